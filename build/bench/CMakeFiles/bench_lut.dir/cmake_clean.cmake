file(REMOVE_RECURSE
  "../bin/bench_lut"
  "../bin/bench_lut.pdb"
  "CMakeFiles/bench_lut.dir/lut_bench.cc.o"
  "CMakeFiles/bench_lut.dir/lut_bench.cc.o.d"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/bench_lut.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
