# Default CUDA architectures, derived from the toolkit as Ceres does rather
# than fixed: native code (SASS) for the oldest architecture of each major
# generation the installed nvcc supports (it runs on every newer minor of
# that generation), plus PTX of the newest generation, which the driver compiles for
# GPUs newer than the toolkit. CMAKE_CUDA_ARCHITECTURES, when given, wins.
function(pano_default_cuda_architectures nvcc out_var)
  execute_process(COMMAND ${nvcc} --list-gpu-arch OUTPUT_VARIABLE listed RESULT_VARIABLE rc ERROR_QUIET)
  set(archs)
  if(rc EQUAL 0)
    string(REGEX MATCHALL "compute_[0-9]+" computes "${listed}")
    foreach(c IN LISTS computes)
      string(REPLACE "compute_" "" n "${c}")
      list(APPEND archs ${n})
    endforeach()
  endif()
  if(NOT archs)
    # nvcc before CUDA 11 cannot list its architectures: let CMake choose.
    set(${out_var} all-major PARENT_SCOPE)
    return()
  endif()
  list(REMOVE_DUPLICATES archs)
  list(SORT archs COMPARE NATURAL)
  set(chosen)
  set(last_major -1)
  foreach(a IN LISTS archs)
    math(EXPR major "${a} / 10")
    if(NOT major EQUAL last_major)
      list(APPEND chosen ${a}-real)
      set(last_major ${major})
    endif()
  endforeach()
  # The newest generation's entry gets PTX as well ("120": real and virtual).
  list(POP_BACK chosen newest)
  string(REPLACE "-real" "" newest "${newest}")
  list(APPEND chosen ${newest})
  set(${out_var} "${chosen}" PARENT_SCOPE)
endfunction()
