# Empty dependencies file for pano_io.
# This may be replaced when dependencies are built.
