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

# pano_add_library(NAME pano_sensor SRCS a.cc DEPS ... [INTERNAL_HEADERS x.h ...])
# One static library per concept folder, installed and exported as
# panotrack::<concept> with the folder's headers under include/panotrack/<concept>.
# INTERNAL_HEADERS stay out of the installed tree: the toolkit's own code
# (its libraries, programs and tests) includes them, users do not. The
# installed headers are the public API (README, "Layout"); none includes an
# internal one (ctest install/prefix checks).
function(pano_add_library)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;DEPS;PRIVATE_DEPS;INTERNAL_HEADERS" ${ARGN})
  add_library(${ARG_NAME} STATIC ${ARG_SRCS})
  target_include_directories(${ARG_NAME} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/lib>
    $<BUILD_INTERFACE:${PROJECT_BINARY_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_compile_features(${ARG_NAME} PUBLIC cxx_std_17)  # the headers need it too
  target_link_libraries(${ARG_NAME} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  pano_set_warnings(${ARG_NAME})
  pano_install_library(${ARG_NAME})
  # Link order for the pkg-config file: the folder's own libraries it uses.
  set(pano_deps)
  foreach(dep IN LISTS ARG_DEPS ARG_PRIVATE_DEPS)
    if(dep MATCHES "^pano_")
      list(APPEND pano_deps ${dep})
    endif()
  endforeach()
  set_property(TARGET ${ARG_NAME} PROPERTY PANO_LIBRARY_DEPS ${pano_deps})
  set_property(GLOBAL APPEND PROPERTY PANO_LIBRARIES ${ARG_NAME})

  get_filename_component(concept ${CMAKE_CURRENT_SOURCE_DIR} NAME)
  file(GLOB headers CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.h)
  foreach(internal IN LISTS ARG_INTERNAL_HEADERS)
    if(NOT EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${internal})
      message(FATAL_ERROR "${ARG_NAME}: INTERNAL_HEADERS names ${internal}, which does not exist")
    endif()
    list(REMOVE_ITEM headers ${CMAKE_CURRENT_SOURCE_DIR}/${internal})
  endforeach()
  install(FILES ${headers} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/panotrack/${concept} COMPONENT development)
endfunction()

# Installs a static library of the toolkit and adds it to the exported set as
# panotrack::<name without pano_>; the same alias serves in the build tree.
function(pano_install_library target)
  string(REGEX REPLACE "^pano_" "" export_name ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${export_name})
  add_library(panotrack::${export_name} ALIAS ${target})
  install(TARGETS ${target} EXPORT panotrackTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT development)
endfunction()

# pano_add_executable(NAME panoloc SRCS main.cc DEPS ... [SUMMARY "one line"])
# A program of the toolkit: installed to bin/, with a man page made from its
# --help by help2man (SUMMARY is the page's NAME line) when help2man is found.
function(pano_add_executable)
  cmake_parse_arguments(ARG "" "NAME;SUMMARY" "SRCS;DEPS" ${ARGN})
  add_executable(${ARG_NAME} ${ARG_SRCS})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_DEPS})
  pano_set_warnings(${ARG_NAME})
  set_target_properties(${ARG_NAME} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bin)
  install(TARGETS ${ARG_NAME} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
  set_property(GLOBAL APPEND PROPERTY PANO_PROGRAMS ${ARG_NAME})
  pano_add_man_page(${ARG_NAME} "${ARG_SUMMARY}")
endfunction()

# man1/<program>.1 from the built program's --help (help2man runs it at build
# time; the version is the project's, since not every program has --version).
function(pano_add_man_page program summary)
  if(NOT PANO_HELP2MAN)
    return()
  endif()
  set(page ${PROJECT_BINARY_DIR}/man/man1/${program}.1)
  if(NOT summary)
    set(summary "${program} of panotrack")
  endif()
  add_custom_command(OUTPUT ${page}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${PROJECT_BINARY_DIR}/man/man1
    COMMAND ${PANO_HELP2MAN} --no-info --no-discard-stderr --version-string=${PROJECT_VERSION}
            --name=${summary} --output=${page} $<TARGET_FILE:${program}>
    DEPENDS ${program}
    COMMENT "Generating the man page of ${program}"
    VERBATIM)
  add_custom_target(${program}_man ALL DEPENDS ${page})
  install(FILES ${page} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT runtime)
  set_property(GLOBAL APPEND PROPERTY PANO_MAN_TARGETS ${program}_man)
endfunction()

# The toolkit's libraries ordered for a static link line: every library
# before the libraries it uses (a depth-first post-order, reversed).
function(pano_library_link_order out_var)
  get_property(libraries GLOBAL PROPERTY PANO_LIBRARIES)
  set(order)
  set(visited)
  foreach(lib IN LISTS libraries)
    _pano_visit_library(${lib})
  endforeach()
  list(REVERSE order)
  set(${out_var} ${order} PARENT_SCOPE)
endfunction()

# Appends `lib` to `order` after everything it uses (the caller's `order` and `visited`).
function(_pano_visit_library lib)
  if("${lib}" IN_LIST visited)
    return()
  endif()
  list(APPEND visited ${lib})
  get_property(deps TARGET ${lib} PROPERTY PANO_LIBRARY_DEPS)
  foreach(dep IN LISTS deps)
    _pano_visit_library(${dep})
  endforeach()
  list(APPEND order ${lib})
  set(visited ${visited} PARENT_SCOPE)
  set(order ${order} PARENT_SCOPE)
endfunction()

# pano_test_timeout(out seconds): a test's time limit (300 s unless given),
# times PANO_TEST_TIMEOUT_SCALE: a sanitized build runs the same work 3 - 10x
# slower, and its limit must bound a hang, not the instrumentation.
function(pano_test_timeout out seconds)
  if(NOT seconds)
    set(seconds 300)
  endif()
  math(EXPR seconds "${seconds} * ${PANO_TEST_TIMEOUT_SCALE}")
  set(${out} ${seconds} PARENT_SCOPE)
endfunction()

# pano_long_test(NAME COMMAND...): registers a long test (its caller adds the
# label "long"). With PANO_LONG_TESTS off it is registered as one that
# reports itself skipped.
function(pano_long_test name)
  if(PANO_LONG_TESTS)
    add_test(NAME ${name} COMMAND ${ARGN})
  else()
    add_test(NAME ${name} COMMAND sh -c
      "echo '${name}: a long test, skipped (PANO_LONG_TESTS is OFF; configure with -DPANO_LONG_TESTS=ON)'; exit 77")
  endif()
  set_tests_properties(${name} PROPERTIES SKIP_RETURN_CODE 77)
endfunction()

# The environment of every test: the build's programs; panoloc's table cache
# inside the build tree, not in the user's home; OpenMP's threads sleeping
# while they wait (ctest runs tests side by side: a spinning thread takes
# the core another test needs, and changes no result).
set(PANO_TEST_ENVIRONMENT
  "PANO_BIN_DIR=${PROJECT_BINARY_DIR}/bin;XDG_CACHE_HOME=${PROJECT_BINARY_DIR}/test-cache;OMP_WAIT_POLICY=passive")

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
  pano_test_timeout(ARG_TIMEOUT "${ARG_TIMEOUT}")
  set_tests_properties(${ARG_FOLDER}/${ARG_NAME} PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT}
    SKIP_RETURN_CODE 77
    ENVIRONMENT "${PANO_TEST_ENVIRONMENT}")
endfunction()

# pano_add_test_suite(FOLDER sensor SRCS a_test.cc b_test.cc DEPS ... TAGS round_trip jet)
# builds one executable and registers one ctest per Catch tag: "sensor/round_trip"
# runs the cases tagged [round_trip]. A tag that matches no case fails. Tags
# also in LONG_TAGS are long tests (pano_long_test), labelled "long" as well.
# "sensor/every_case_registered" fails where a case carries none of the tags
# (it would never run): it lists them (Catch's exit code is their count).
function(pano_add_test_suite)
  cmake_parse_arguments(ARG "" "FOLDER;TIMEOUT" "SRCS;DEPS;TAGS;LABELS;LONG_TAGS" ${ARGN})
  set(target test_${ARG_FOLDER})
  add_executable(${target} ${ARG_SRCS})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} pano_test_main)
  pano_set_warnings(${target})
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  pano_test_timeout(ARG_TIMEOUT "${ARG_TIMEOUT}")
  foreach(tag ${ARG_TAGS} ${ARG_LONG_TAGS})
    set(labels ${ARG_LABELS})
    if(tag IN_LIST ARG_LONG_TAGS)
      pano_long_test(${ARG_FOLDER}/${tag} ${target} "[${tag}]" --warn NoTests)
      list(APPEND labels long)
    else()
      add_test(NAME ${ARG_FOLDER}/${tag} COMMAND ${target} "[${tag}]" --warn NoTests)
    endif()
    set_tests_properties(${ARG_FOLDER}/${tag} PROPERTIES LABELS "${labels}" TIMEOUT ${ARG_TIMEOUT}
      SKIP_RETURN_CODE 77
      ENVIRONMENT "${PANO_TEST_ENVIRONMENT}")
  endforeach()
  set(unregistered "")
  foreach(tag ${ARG_TAGS} ${ARG_LONG_TAGS})
    string(APPEND unregistered "~[${tag}]")
  endforeach()
  add_test(NAME ${ARG_FOLDER}/every_case_registered COMMAND ${target} "${unregistered}" --list-test-names-only)
  set_tests_properties(${ARG_FOLDER}/every_case_registered PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT 60)
endfunction()
