# Empty compiler generated dependencies file for bench_lut.
# This may be replaced when dependencies are built.
