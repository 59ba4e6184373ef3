# Empty compiler generated dependencies file for pano_test_main.
# This may be replaced when dependencies are built.
