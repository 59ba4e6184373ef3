# Empty dependencies file for pano_core.
# This may be replaced when dependencies are built.
