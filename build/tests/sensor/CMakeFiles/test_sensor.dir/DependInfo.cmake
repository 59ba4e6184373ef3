
# Consider dependencies only in project.
set(CMAKE_DEPENDS_IN_PROJECT_ONLY OFF)

# The set of languages for which implicit dependencies are needed:
set(CMAKE_DEPENDS_LANGUAGES
  )

# The set of dependency files which are needed:
set(CMAKE_DEPENDS_DEPENDENCY_FILES
  "/work/main/tests/sensor/geometry_test.cc" "tests/sensor/CMakeFiles/test_sensor.dir/geometry_test.cc.o" "gcc" "tests/sensor/CMakeFiles/test_sensor.dir/geometry_test.cc.o.d"
  "/work/main/tests/sensor/jet_test.cc" "tests/sensor/CMakeFiles/test_sensor.dir/jet_test.cc.o" "gcc" "tests/sensor/CMakeFiles/test_sensor.dir/jet_test.cc.o.d"
  "/work/main/tests/sensor/round_trip_test.cc" "tests/sensor/CMakeFiles/test_sensor.dir/round_trip_test.cc.o" "gcc" "tests/sensor/CMakeFiles/test_sensor.dir/round_trip_test.cc.o.d"
  )

# Targets to which this target links.
set(CMAKE_TARGET_LINKED_INFO_FILES
  "/work/main/build/lib/sensor/CMakeFiles/pano_sensor.dir/DependInfo.cmake"
  "/work/main/build/tests/CMakeFiles/pano_test_main.dir/DependInfo.cmake"
  "/work/main/build/lib/core/CMakeFiles/pano_core.dir/DependInfo.cmake"
  )

# Fortran module output directory.
set(CMAKE_Fortran_TARGET_MODULE_DIR "")
