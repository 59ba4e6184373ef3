// An OpenMP loop that lets exceptions out: each iteration's exception is
// caught (one escaping an OpenMP region would end the program) and the one
// of the lowest index is rethrown after the loop, whatever the thread count.
#pragma once

#include <exception>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace pano {

// body(k) for k in [0, n), in parallel (dynamic schedule) when `parallel`, on
// `num_threads` threads (0: OpenMP's default team size). Includers compile
// with OpenMP (without it the loop runs serially).
template <typename Body>
void ParallelFor(int n, Body&& body, bool parallel = true, int num_threads = 0) {
  std::vector<std::exception_ptr> errors(n > 0 ? static_cast<size_t>(n) : 0);
#ifdef _OPENMP
  [[maybe_unused]] const int threads = num_threads > 0 ? num_threads : omp_get_max_threads();
#else
  [[maybe_unused]] const int threads = 1;
#endif
#pragma omp parallel for schedule(dynamic) num_threads(threads) if (parallel && n > 1 && threads > 1)
  for (int k = 0; k < n; ++k) {
    try {
      body(k);
    } catch (...) {
      errors[static_cast<size_t>(k)] = std::current_exception();
    }
  }
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace pano
