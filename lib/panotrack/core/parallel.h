// Thread counts and parallel loops that let exceptions out. Each loop takes
// its thread count from its caller's options (a num_threads clause), never
// from a process-wide setting, and catches every iteration's exception (one
// escaping an OpenMP region would end the program); the one of the lowest
// index is rethrown after the loop, whatever the thread count.
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <string>
#include <thread>
#include <vector>

#include "panotrack/core/error.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace pano {

namespace internal {
// Set on the threads of a ParallelForOnOwnThreads loop while they run it.
inline thread_local bool in_own_threads_loop = false;
}  // namespace internal

// The most threads any option may ask for: more than the cores of any
// machine the programs run on, few enough that their stacks and per-thread
// buffers fit in memory (100000 threads end the process in libgomp or by
// the kernel's hand).
constexpr int kMaxThreads = 1024;

// Throws pano::Error "<option>: expected 0 (every core) or 1..1024, got N"
// for a thread count no run may have.
inline void CheckThreadCount(int requested, const std::string& option) {
  if (requested < 0 || requested > kMaxThreads)
    throw Error(option + ": expected 0 (every core) or 1.." + std::to_string(kMaxThreads) + ", got " +
                std::to_string(requested));
}

// `requested` threads, at most kMaxThreads; 0 (or less): OpenMP's default,
// every core unless OMP_NUM_THREADS says otherwise. On a thread of a
// ParallelForOnOwnThreads loop, 1: a loop nested there runs on that thread,
// as OpenMP runs a nested region.
inline int ThreadCount(int requested) {
  if (internal::in_own_threads_loop) return 1;
  if (requested > 0) return std::min(requested, kMaxThreads);
#ifdef _OPENMP
  return std::clamp(omp_get_max_threads(), 1, kMaxThreads);
#else
  return 1;
#endif
}

// Whether the caller runs on a thread of an active parallel region (an
// OpenMP one or a ParallelForOnOwnThreads loop): a loop nested there runs on
// that thread alone.
inline bool InParallelRegion() {
  if (internal::in_own_threads_loop) return true;
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

// body(k) for k in [0, n) on `num_threads` threads (0: ThreadCount's
// default): the caller and threads started for this loop alone, joined at
// its end, each taking the next `chunk` indices whenever it is free. For
// loops that run now and then beside other busy threads (a room-wide search
// beside the video decoder): OpenMP's workers stay after a loop and, by
// libgomp's default wait policy, spin for a few milliseconds on the cores
// the others need. The threads start on the caller's scheduling policy (the
// pthreads default, inherited). Nested in a parallel region it runs on the
// calling thread. Needs no OpenMP.
template <typename Body>
void ParallelForOnOwnThreads(int n, Body&& body, int num_threads = 0, int chunk = 1) {
  std::vector<std::exception_ptr> errors(n > 0 ? static_cast<size_t>(n) : 0);
  chunk = std::max(1, chunk);
  std::atomic<int> next{0};
  auto work = [&] {
    const bool outer = internal::in_own_threads_loop;
    internal::in_own_threads_loop = true;
    for (int begin; (begin = next.fetch_add(chunk)) < n;)
      for (int k = begin; k < std::min(n, begin + chunk); ++k) {
        try {
          body(k);
        } catch (...) {
          errors[static_cast<size_t>(k)] = std::current_exception();
        }
      }
    internal::in_own_threads_loop = outer;
  };
  const int threads = InParallelRegion() ? 1 : std::min(ThreadCount(num_threads), (std::max(n, 0) + chunk - 1) / chunk);
  std::vector<std::thread> helpers;
  helpers.reserve(static_cast<size_t>(std::max(0, threads - 1)));  // no reallocation once threads run
  for (int t = 1; t < threads; ++t) {
    try {
      helpers.emplace_back(work);
    } catch (...) {  // std::system_error, or std::bad_alloc for the thread's state
      break;           // no more threads to be had: the ones started (and the caller) do the rest
    }
  }
  work();
  for (std::thread& h : helpers) h.join();
  RethrowFirst(errors);
}

}  // namespace pano
