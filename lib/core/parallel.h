// An OpenMP loop that lets exceptions out: each iteration's exception is
// caught (one escaping an OpenMP region would end the program) and the one
// of the lowest index is rethrown after the loop, whatever the thread count.
#pragma once

#include <exception>
#include <vector>

namespace pano {

// body(k) for k in [0, n), in parallel (dynamic schedule) when `parallel`.
// Includers compile with OpenMP (without it the loop runs serially).
template <typename Body>
void ParallelFor(int n, Body&& body, bool parallel = true) {
  std::vector<std::exception_ptr> errors(n > 0 ? static_cast<size_t>(n) : 0);
#pragma omp parallel for schedule(dynamic) if (parallel && n > 1)
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
