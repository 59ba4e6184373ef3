file(REMOVE_RECURSE
  "../../bin/panocalib"
  "../../bin/panocalib.pdb"
  "CMakeFiles/panocalib.dir/main.cc.o"
  "CMakeFiles/panocalib.dir/main.cc.o.d"
  "CMakeFiles/panocalib.dir/project_command.cc.o"
  "CMakeFiles/panocalib.dir/project_command.cc.o.d"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/panocalib.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
