file(REMOVE_RECURSE
  "CMakeFiles/test_sensor.dir/geometry_test.cc.o"
  "CMakeFiles/test_sensor.dir/geometry_test.cc.o.d"
  "CMakeFiles/test_sensor.dir/jet_test.cc.o"
  "CMakeFiles/test_sensor.dir/jet_test.cc.o.d"
  "CMakeFiles/test_sensor.dir/round_trip_test.cc.o"
  "CMakeFiles/test_sensor.dir/round_trip_test.cc.o.d"
  "test_sensor"
  "test_sensor.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_sensor.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
