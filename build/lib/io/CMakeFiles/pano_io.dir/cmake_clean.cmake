file(REMOVE_RECURSE
  "CMakeFiles/pano_io.dir/calibration.cc.o"
  "CMakeFiles/pano_io.dir/calibration.cc.o.d"
  "CMakeFiles/pano_io.dir/map.cc.o"
  "CMakeFiles/pano_io.dir/map.cc.o.d"
  "CMakeFiles/pano_io.dir/pose_csv.cc.o"
  "CMakeFiles/pano_io.dir/pose_csv.cc.o.d"
  "CMakeFiles/pano_io.dir/targets.cc.o"
  "CMakeFiles/pano_io.dir/targets.cc.o.d"
  "CMakeFiles/pano_io.dir/yaml_util.cc.o"
  "CMakeFiles/pano_io.dir/yaml_util.cc.o.d"
  "libpano_io.a"
  "libpano_io.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/pano_io.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
