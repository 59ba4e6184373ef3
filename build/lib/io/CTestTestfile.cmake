# CMake generated Testfile for 
# Source directory: /work/main/lib/io
# Build directory: /work/main/build/lib/io
# 
# This file includes the relevant testing commands required for 
# testing this directory and lists subdirectories to be tested as well.
