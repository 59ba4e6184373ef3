# The decode-only floor of panoloc runs (a plain program: it times whole
# inputs given on its command line).
add_executable(bench_decode decode_bench.cc)
target_link_libraries(bench_decode PRIVATE pano_video CLI11::CLI11)
pano_set_warnings(bench_decode)
set_target_properties(bench_decode PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bin)
