# Empty compiler generated dependencies file for test_sensor.
# This may be replaced when dependencies are built.
