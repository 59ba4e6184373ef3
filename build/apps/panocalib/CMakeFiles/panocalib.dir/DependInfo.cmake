
# Consider dependencies only in project.
set(CMAKE_DEPENDS_IN_PROJECT_ONLY OFF)

# The set of languages for which implicit dependencies are needed:
set(CMAKE_DEPENDS_LANGUAGES
  )

# The set of dependency files which are needed:
set(CMAKE_DEPENDS_DEPENDENCY_FILES
  "/work/main/apps/panocalib/main.cc" "apps/panocalib/CMakeFiles/panocalib.dir/main.cc.o" "gcc" "apps/panocalib/CMakeFiles/panocalib.dir/main.cc.o.d"
  "/work/main/apps/panocalib/project_command.cc" "apps/panocalib/CMakeFiles/panocalib.dir/project_command.cc.o" "gcc" "apps/panocalib/CMakeFiles/panocalib.dir/project_command.cc.o.d"
  )

# Targets to which this target links.
set(CMAKE_TARGET_LINKED_INFO_FILES
  "/work/main/build/lib/io/CMakeFiles/pano_io.dir/DependInfo.cmake"
  "/work/main/build/lib/lut/CMakeFiles/pano_lut.dir/DependInfo.cmake"
  "/work/main/build/lib/sensor/CMakeFiles/pano_sensor.dir/DependInfo.cmake"
  "/work/main/build/lib/core/CMakeFiles/pano_core.dir/DependInfo.cmake"
  )

# Fortran module output directory.
set(CMAKE_Fortran_TARGET_MODULE_DIR "")
