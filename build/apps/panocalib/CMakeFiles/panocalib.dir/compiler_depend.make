# Empty compiler generated dependencies file for panocalib.
# This may be replaced when dependencies are built.
