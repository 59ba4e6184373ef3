// Thread counts and exceptions of the tracking code's OpenMP loops (PH tables
// and lib/track). Each loop takes its thread count from its caller's options
// (a num_threads clause) and catches every iteration's exception: one
// escaping an OpenMP region would end the program.
#pragma once

#include <omp.h>

#include <algorithm>
#include <exception>
#include <vector>

namespace pano {

// `requested` threads; 0 (or less): OpenMP's default, every core unless
// OMP_NUM_THREADS says otherwise.
inline int ThreadCount(int requested) {
  return requested > 0 ? requested : std::max(1, omp_get_max_threads());
}

// After the loop: rethrows the exception of the lowest index, if any, so the
// error is the same whatever the thread count.
inline void RethrowFirst(const std::vector<std::exception_ptr>& errors) {
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace pano
