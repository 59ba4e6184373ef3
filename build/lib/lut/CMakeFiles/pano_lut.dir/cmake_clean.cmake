file(REMOVE_RECURSE
  "CMakeFiles/pano_lut.dir/radius_table.cc.o"
  "CMakeFiles/pano_lut.dir/radius_table.cc.o.d"
  "libpano_lut.a"
  "libpano_lut.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/pano_lut.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
