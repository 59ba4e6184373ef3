# CMake generated Testfile for 
# Source directory: /work/main/tests/sensor
# Build directory: /work/main/build/tests/sensor
# 
# This file includes the relevant testing commands required for 
# testing this directory and lists subdirectories to be tested as well.
add_test([=[sensor/round_trip]=] "/work/main/build/tests/sensor/test_sensor" "[round_trip]" "--warn" "NoTests")
set_tests_properties([=[sensor/round_trip]=] PROPERTIES  ENVIRONMENT "PANO_BIN_DIR=/work/main/build/bin" LABELS "unit" TIMEOUT "300" _BACKTRACE_TRIPLES "/work/main/cmake/PanoHelpers.cmake;79;add_test;/work/main/tests/sensor/CMakeLists.txt;1;pano_add_test_suite;/work/main/tests/sensor/CMakeLists.txt;0;")
add_test([=[sensor/limb]=] "/work/main/build/tests/sensor/test_sensor" "[limb]" "--warn" "NoTests")
set_tests_properties([=[sensor/limb]=] PROPERTIES  ENVIRONMENT "PANO_BIN_DIR=/work/main/build/bin" LABELS "unit" TIMEOUT "300" _BACKTRACE_TRIPLES "/work/main/cmake/PanoHelpers.cmake;79;add_test;/work/main/tests/sensor/CMakeLists.txt;1;pano_add_test_suite;/work/main/tests/sensor/CMakeLists.txt;0;")
add_test([=[sensor/hand_value]=] "/work/main/build/tests/sensor/test_sensor" "[hand_value]" "--warn" "NoTests")
set_tests_properties([=[sensor/hand_value]=] PROPERTIES  ENVIRONMENT "PANO_BIN_DIR=/work/main/build/bin" LABELS "unit" TIMEOUT "300" _BACKTRACE_TRIPLES "/work/main/cmake/PanoHelpers.cmake;79;add_test;/work/main/tests/sensor/CMakeLists.txt;1;pano_add_test_suite;/work/main/tests/sensor/CMakeLists.txt;0;")
add_test([=[sensor/visibility]=] "/work/main/build/tests/sensor/test_sensor" "[visibility]" "--warn" "NoTests")
set_tests_properties([=[sensor/visibility]=] PROPERTIES  ENVIRONMENT "PANO_BIN_DIR=/work/main/build/bin" LABELS "unit" TIMEOUT "300" _BACKTRACE_TRIPLES "/work/main/cmake/PanoHelpers.cmake;79;add_test;/work/main/tests/sensor/CMakeLists.txt;1;pano_add_test_suite;/work/main/tests/sensor/CMakeLists.txt;0;")
add_test([=[sensor/jet]=] "/work/main/build/tests/sensor/test_sensor" "[jet]" "--warn" "NoTests")
set_tests_properties([=[sensor/jet]=] PROPERTIES  ENVIRONMENT "PANO_BIN_DIR=/work/main/build/bin" LABELS "unit" TIMEOUT "300" _BACKTRACE_TRIPLES "/work/main/cmake/PanoHelpers.cmake;79;add_test;/work/main/tests/sensor/CMakeLists.txt;1;pano_add_test_suite;/work/main/tests/sensor/CMakeLists.txt;0;")
add_test([=[sensor/frames]=] "/work/main/build/tests/sensor/test_sensor" "[frames]" "--warn" "NoTests")
set_tests_properties([=[sensor/frames]=] PROPERTIES  ENVIRONMENT "PANO_BIN_DIR=/work/main/build/bin" LABELS "unit" TIMEOUT "300" _BACKTRACE_TRIPLES "/work/main/cmake/PanoHelpers.cmake;79;add_test;/work/main/tests/sensor/CMakeLists.txt;1;pano_add_test_suite;/work/main/tests/sensor/CMakeLists.txt;0;")
