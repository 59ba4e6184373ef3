file(REMOVE_RECURSE
  "CMakeFiles/pano_test_main.dir/test_main.cc.o"
  "CMakeFiles/pano_test_main.dir/test_main.cc.o.d"
  "libpano_test_main.a"
  "libpano_test_main.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/pano_test_main.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
