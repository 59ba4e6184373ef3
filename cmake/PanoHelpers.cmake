# Helpers in the spirit of COLMAP's CMakeHelper: one small target per concept,
# tests named <folder>/<name>.

# Locals shadowing locals: GCC's -Wshadow=local; clang has no such option
# (an unknown one fails -Werror), its -Wshadow leaves class members alone.
if(CMAKE_CXX_COMPILER_ID MATCHES "Clang")
  set(PANO_WARNING_FLAGS -Wall -Wextra -Wpedantic -Wshadow -Wno-unknown-pragmas)
else()
  set(PANO_WARNING_FLAGS -Wall -Wextra -Wpedantic -Wshadow=local -Wno-unknown-pragmas)
endif()

# Adds every immediate subdirectory of DIR (relative to the calling folder;
# "." for the folder itself) that has a CMakeLists.txt, in sorted order so
# that the configuration does not depend on the file system's listing order.
function(pano_add_subdirectories dir)
  get_filename_component(base ${CMAKE_CURRENT_SOURCE_DIR}/${dir} ABSOLUTE)
  file(GLOB children LIST_DIRECTORIES true RELATIVE ${base} ${base}/*)
  list(SORT children)
  foreach(child IN LISTS children)
    if(EXISTS ${base}/${child}/CMakeLists.txt)
      add_subdirectory(${base}/${child})
    endif()
  endforeach()
endfunction()

function(pano_set_warnings target)
  target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:${PANO_WARNING_FLAGS}>)
  if(PANO_WERROR)
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Werror>)
  endif()
endfunction()

# pano_add_library(NAME pano_sensor SRCS a.cc DEPS ...)
function(pano_add_library)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${ARG_NAME} STATIC ${ARG_SRCS})
  target_include_directories(${ARG_NAME} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/lib>
    $<BUILD_INTERFACE:${PROJECT_BINARY_DIR}/include>)
  target_link_libraries(${ARG_NAME} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  pano_set_warnings(${ARG_NAME})
endfunction()

# pano_add_executable(NAME panoloc SRCS main.cc DEPS ...)
function(pano_add_executable)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;DEPS" ${ARGN})
  add_executable(${ARG_NAME} ${ARG_SRCS})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_DEPS})
  pano_set_warnings(${ARG_NAME})
  set_target_properties(${ARG_NAME} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bin)
endfunction()

# pano_add_test(FOLDER sensor NAME round_trip SRCS round_trip_test.cc DEPS ...)
# registers the ctest "sensor/round_trip". LABELS default to "unit".
function(pano_add_test)
  cmake_parse_arguments(ARG "" "FOLDER;NAME;TIMEOUT" "SRCS;DEPS;LABELS;ARGS" ${ARGN})
  set(target test_${ARG_FOLDER}_${ARG_NAME})
  add_executable(${target} ${ARG_SRCS})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} pano_test_main)
  pano_set_warnings(${target})
  add_test(NAME ${ARG_FOLDER}/${ARG_NAME} COMMAND ${target} ${ARG_ARGS})
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  set_tests_properties(${ARG_FOLDER}/${ARG_NAME} PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT}
    SKIP_RETURN_CODE 77 ENVIRONMENT "PANO_BIN_DIR=${PROJECT_BINARY_DIR}/bin")
endfunction()

# pano_add_test_suite(FOLDER sensor SRCS a_test.cc b_test.cc DEPS ... TAGS round_trip jet)
# builds one executable and registers one ctest per Catch tag: "sensor/round_trip"
# runs the cases tagged [round_trip]. A tag that matches no case fails.
function(pano_add_test_suite)
  cmake_parse_arguments(ARG "" "FOLDER;TIMEOUT" "SRCS;DEPS;TAGS;LABELS" ${ARGN})
  set(target test_${ARG_FOLDER})
  add_executable(${target} ${ARG_SRCS})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} pano_test_main)
  pano_set_warnings(${target})
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  foreach(tag ${ARG_TAGS})
    add_test(NAME ${ARG_FOLDER}/${tag} COMMAND ${target} "[${tag}]" --warn NoTests)
    set_tests_properties(${ARG_FOLDER}/${tag} PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT}
      SKIP_RETURN_CODE 77 ENVIRONMENT "PANO_BIN_DIR=${PROJECT_BINARY_DIR}/bin")
  endforeach()
endfunction()
