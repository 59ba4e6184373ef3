# Empty dependencies file for pano_lut.
# This may be replaced when dependencies are built.
