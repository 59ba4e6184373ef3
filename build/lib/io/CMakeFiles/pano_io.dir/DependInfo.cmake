
# Consider dependencies only in project.
set(CMAKE_DEPENDS_IN_PROJECT_ONLY OFF)

# The set of languages for which implicit dependencies are needed:
set(CMAKE_DEPENDS_LANGUAGES
  )

# The set of dependency files which are needed:
set(CMAKE_DEPENDS_DEPENDENCY_FILES
  "/work/main/lib/io/calibration.cc" "lib/io/CMakeFiles/pano_io.dir/calibration.cc.o" "gcc" "lib/io/CMakeFiles/pano_io.dir/calibration.cc.o.d"
  "/work/main/lib/io/map.cc" "lib/io/CMakeFiles/pano_io.dir/map.cc.o" "gcc" "lib/io/CMakeFiles/pano_io.dir/map.cc.o.d"
  "/work/main/lib/io/pose_csv.cc" "lib/io/CMakeFiles/pano_io.dir/pose_csv.cc.o" "gcc" "lib/io/CMakeFiles/pano_io.dir/pose_csv.cc.o.d"
  "/work/main/lib/io/targets.cc" "lib/io/CMakeFiles/pano_io.dir/targets.cc.o" "gcc" "lib/io/CMakeFiles/pano_io.dir/targets.cc.o.d"
  "/work/main/lib/io/yaml_util.cc" "lib/io/CMakeFiles/pano_io.dir/yaml_util.cc.o" "gcc" "lib/io/CMakeFiles/pano_io.dir/yaml_util.cc.o.d"
  )

# Targets to which this target links.
set(CMAKE_TARGET_LINKED_INFO_FILES
  "/work/main/build/lib/core/CMakeFiles/pano_core.dir/DependInfo.cmake"
  "/work/main/build/lib/sensor/CMakeFiles/pano_sensor.dir/DependInfo.cmake"
  )

# Fortran module output directory.
set(CMAKE_Fortran_TARGET_MODULE_DIR "")
