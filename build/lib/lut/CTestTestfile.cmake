# CMake generated Testfile for 
# Source directory: /work/main/lib/lut
# Build directory: /work/main/build/lib/lut
# 
# This file includes the relevant testing commands required for 
# testing this directory and lists subdirectories to be tested as well.
