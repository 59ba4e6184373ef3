// Thread counts and OpenMP loops that let exceptions out. Each loop takes
// its thread count from its caller's options (a num_threads clause), never
// from a process-wide setting, and catches every iteration's exception (one
// escaping an OpenMP region would end the program); the one of the lowest
// index is rethrown after the loop, whatever the thread count.
#pragma once

#include <algorithm>
#include <exception>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace pano {

// `requested` threads; 0 (or less): OpenMP's default, every core unless
// OMP_NUM_THREADS says otherwise.
inline int ThreadCount(int requested) {
#ifdef _OPENMP
  return requested > 0 ? requested : std::max(1, omp_get_max_threads());
#else
  return requested > 0 ? requested : 1;
#endif
}

// Whether the caller runs on a thread of an active parallel region: a loop
// nested there runs on that thread alone.
inline bool InParallelRegion() {
#ifdef _OPENMP
  return omp_in_parallel() != 0;
#else
  return false;
#endif
}

// After a loop: rethrows the exception of the lowest index, if any, so the
// error is the same whatever the thread count.
inline void RethrowFirst(const std::vector<std::exception_ptr>& errors) {
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

// body(k) for k in [0, n), in parallel (dynamic schedule) when `parallel`, on
// `num_threads` threads (0: OpenMP's default team size). Includers compile
// with OpenMP (without it the loop runs serially).
template <typename Body>
void ParallelFor(int n, Body&& body, bool parallel = true, int num_threads = 0) {
  std::vector<std::exception_ptr> errors(n > 0 ? static_cast<size_t>(n) : 0);
  [[maybe_unused]] const int threads = ThreadCount(num_threads);
#pragma omp parallel for schedule(dynamic) num_threads(threads) if (parallel && n > 1 && threads > 1)
  for (int k = 0; k < n; ++k) {
    try {
      body(k);
    } catch (...) {
      errors[static_cast<size_t>(k)] = std::current_exception();
    }
  }
  RethrowFirst(errors);
}

}  // namespace pano
