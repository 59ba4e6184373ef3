# Installation of the toolkit: the umbrella target, data and documentation,
# the CMake package (find_package(panotrack CONFIG)) and the pkg-config file.
# Included by the top-level CMakeLists.txt after the libraries and programs;
# each library and program installs itself (PanoHelpers.cmake).
include(CMakePackageConfigHelpers)

# panotrack::panotrack: every library of the toolkit.
get_property(pano_libraries GLOBAL PROPERTY PANO_LIBRARIES)
add_library(panotrack INTERFACE)
target_link_libraries(panotrack INTERFACE ${pano_libraries})
set_target_properties(panotrack PROPERTIES EXPORT_NAME panotrack)
add_library(panotrack::panotrack ALIAS panotrack)
install(TARGETS panotrack EXPORT panotrackTargets)

install(FILES ${PROJECT_BINARY_DIR}/include/panotrack/config.h
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/panotrack COMPONENT development)
install(DIRECTORY calib/ DESTINATION ${CMAKE_INSTALL_DATADIR}/panotrack/calib COMPONENT runtime)
install(DIRECTORY docs DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT runtime)
install(FILES README.md LICENSE CHANGELOG.md DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT runtime)

# Everything the install step copies, for whoever must build it first
# (the install tests).
get_property(pano_programs GLOBAL PROPERTY PANO_PROGRAMS)
get_property(pano_man_targets GLOBAL PROPERTY PANO_MAN_TARGETS)
add_custom_target(pano_installable)
add_dependencies(pano_installable ${pano_libraries} ${pano_programs} ${pano_man_targets})

# The CMake package.
set(PANO_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/panotrack)
set(PANO_OPENCV_COMPONENTS ${PANO_OPENCV_MODULES})
install(EXPORT panotrackTargets NAMESPACE panotrack:: FILE panotrackTargets.cmake
  DESTINATION ${PANO_CMAKE_DIR} COMPONENT development)
if(PANO_WITH_CUDA)
  # A hint for the consumer's FindCUDAToolkit: where the build found it.
  get_filename_component(PANO_CUDA_ROOT ${CUDAToolkit_BIN_DIR} DIRECTORY)
endif()
configure_package_config_file(cmake/panotrackConfig.cmake.in
  ${PROJECT_BINARY_DIR}/panotrackConfig.cmake INSTALL_DESTINATION ${PANO_CMAKE_DIR}
  PATH_VARS CMAKE_INSTALL_DATADIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/panotrackConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/panotrackConfig.cmake ${PROJECT_BINARY_DIR}/panotrackConfigVersion.cmake
  DESTINATION ${PANO_CMAKE_DIR} COMPONENT development)

# The pkg-config file. The libraries are static only, so whatever they link
# is in Requires/Libs (not .private): `pkg-config --libs panotrack` alone must
# give a working link line. The prefix is found from the file's own place,
# so that `cmake --install --prefix` and the .deb need no rewriting.
pano_library_link_order(pano_link_order)
set(PANO_PC_LIBS "-L\${libdir}")
foreach(lib IN LISTS pano_link_order)
  string(APPEND PANO_PC_LIBS " -l${lib}")
endforeach()
# Ceres has no .pc file; its shared library carries its own dependencies
# but its headers call glog.
set(PANO_PC_REQUIRES "opencv4 eigen3 yaml-cpp libglog")
if(PANO_WITH_FFMPEG)
  string(APPEND PANO_PC_REQUIRES " libavformat libavcodec libavutil")
endif()
string(APPEND PANO_PC_LIBS " -lceres")
if(PANO_WITH_CUDA)
  get_filename_component(cudart_dir ${CUDA_cudart_LIBRARY} DIRECTORY)
  string(APPEND PANO_PC_LIBS " -L${cudart_dir} -lcudart")
endif()
string(APPEND PANO_PC_LIBS " ${OpenMP_CXX_FLAGS} -pthread")
set(PANO_PC_CFLAGS "-I\${includedir} ${OpenMP_CXX_FLAGS}")
set(pc_dir ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
if(IS_ABSOLUTE "${pc_dir}")
  set(PANO_PC_PREFIX "${CMAKE_INSTALL_PREFIX}")
else()
  file(RELATIVE_PATH up /root/${pc_dir} /root)
  string(REGEX REPLACE "/$" "" up "${up}")
  set(PANO_PC_PREFIX "\${pcfiledir}/${up}")
endif()
configure_file(cmake/panotrack.pc.in ${PROJECT_BINARY_DIR}/panotrack.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/panotrack.pc DESTINATION ${pc_dir} COMPONENT development)
