# panocalib calibration against OpenCV's omnidir (Mei's model) on the same
# detected corners: a plain program (not Google Benchmark), run by
# tools/bench_calibration.sh, whose figures BENCHMARKS.md quotes.
if(TARGET pano_calibrate AND TARGET opencv_ccalib)
  add_executable(calibrate_compare ${CMAKE_CURRENT_LIST_DIR}/calibrate_compare.cc)
  target_link_libraries(calibrate_compare PRIVATE pano_pipeline pano_calibrate pano_io opencv_ccalib)
  pano_set_warnings(calibrate_compare)
  set_target_properties(calibrate_compare PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bin)
endif()
# The peer's side of tools/compare_omnidir.sh (system-level cross-validation).
if(TARGET pano_calibrate AND TARGET opencv_ccalib)
  add_executable(omnidir_cv ${CMAKE_CURRENT_LIST_DIR}/omnidir_cv.cc)
  target_link_libraries(omnidir_cv PRIVATE pano_pipeline pano_calibrate pano_io opencv_ccalib
                                   nlohmann_json::nlohmann_json)
  pano_set_warnings(omnidir_cv)
  set_target_properties(omnidir_cv PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bin)
endif()
