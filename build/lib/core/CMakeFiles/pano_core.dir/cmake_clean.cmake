file(REMOVE_RECURSE
  "CMakeFiles/pano_core.dir/atomic_file.cc.o"
  "CMakeFiles/pano_core.dir/atomic_file.cc.o.d"
  "libpano_core.a"
  "libpano_core.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/pano_core.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
