# CMake generated Testfile for 
# Source directory: /work/main/apps/panocalib
# Build directory: /work/main/build/apps/panocalib
# 
# This file includes the relevant testing commands required for 
# testing this directory and lists subdirectories to be tested as well.
