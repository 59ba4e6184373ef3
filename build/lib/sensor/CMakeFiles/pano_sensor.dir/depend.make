# Empty dependencies file for pano_sensor.
# This may be replaced when dependencies are built.
