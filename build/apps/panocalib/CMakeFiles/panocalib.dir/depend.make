# Empty dependencies file for panocalib.
# This may be replaced when dependencies are built.
