file(REMOVE_RECURSE
  "CMakeFiles/pano_sensor.dir/sensor.cc.o"
  "CMakeFiles/pano_sensor.dir/sensor.cc.o.d"
  "libpano_sensor.a"
  "libpano_sensor.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/pano_sensor.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
