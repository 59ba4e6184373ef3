// The consumer's priority follows its lag, with hysteresis, and is restored.
#include <catch2/catch.hpp>

#include <thread>
#include <vector>

#include "panotrack/core/error.h"
#include "panotrack/core/thread_priority.h"
#include "test_skip.h"

#ifdef __linux__
#include <sched.h>
#endif
#ifdef _OPENMP
#include <omp.h>
#endif

namespace pano {
namespace {

#ifdef __linux__
int Policy() { return sched_getscheduler(0); }

// Runs `body` on a thread of its own, so that no policy leaks into the test
// runner's thread; returns what it threw, if anything.
template <typename Body>
void OnOwnThread(Body body) {
  std::exception_ptr error;
  std::thread t([&] {
    try {
      body();
    } catch (...) {
      error = std::current_exception();
    }
  });
  t.join();
  if (error) std::rethrow_exception(error);
}
#endif

TEST_CASE("lag_priority: idle while keeping up, normal from the threshold, restored at the end",
          "[lag_priority]") {
#ifndef __linux__
  return test::Skip("scheduling policies are Linux's");
#else
  bool refused = false;
  OnOwnThread([&] {
    {
      LagPriority priority(1, 4);
      CHECK_FALSE(priority.idle());
      priority.Update(2);  // above idle_at_most: stays normal
      CHECK_FALSE(priority.idle());
      CHECK(Policy() == SCHED_OTHER);
      priority.Update(1);
      if (!priority.idle()) {
        refused = true;  // a sandbox that forbids sched_setscheduler
        CHECK(Policy() == SCHED_OTHER);
        return;
      }
      CHECK(Policy() == SCHED_IDLE);
      priority.Update(3);  // below normal_from: stays idle
      CHECK(Policy() == SCHED_IDLE);
      priority.Update(4);
      CHECK_FALSE(priority.idle());
      CHECK(Policy() == SCHED_OTHER);
      priority.Update(2);  // between the two: stays normal
      CHECK(Policy() == SCHED_OTHER);
      priority.Update(0);
      CHECK(Policy() == SCHED_IDLE);
      CHECK(priority.switches() == 3);
    }
    CHECK(Policy() == SCHED_OTHER);  // the destructor's
  });
  if (refused) return test::Skip("this system refuses SCHED_IDLE");
#endif
}

TEST_CASE("lag_priority: a policy set by the user is left alone; bad thresholds refused", "[lag_priority]") {
  CHECK_THROWS_AS(LagPriority(2, 2), Error);
  CHECK_THROWS_AS(LagPriority(-1, 2), Error);
#ifdef __linux__
  OnOwnThread([] {
    const sched_param param{};
    if (sched_setscheduler(0, SCHED_BATCH, &param) != 0) return;  // refused: nothing to check
    {
      LagPriority priority(0, 4);
      priority.Update(0);
      CHECK_FALSE(priority.idle());
      CHECK(Policy() == SCHED_BATCH);
    }
    CHECK(Policy() == SCHED_BATCH);
  });
#endif
}

TEST_CASE("worker threads: started on the caller's policy, idle or normal", "[worker_threads]") {
#if !defined(__linux__) || !defined(_OPENMP)
  return test::Skip("scheduling policies are Linux's; worker threads OpenMP's");
#else
  // The policies of a two-thread loop's threads; empty where OpenMP gave
  // the loop fewer threads (OMP_THREAD_LIMIT, OMP_DYNAMIC).
  auto loop_policies = [] {
    std::vector<int> policy(2, -1);
    int team = 0;
#pragma omp parallel num_threads(2)
    {
#pragma omp single
      team = omp_get_num_threads();
      if (omp_get_thread_num() < 2) policy[static_cast<size_t>(omp_get_thread_num())] = Policy();
    }
    return team == 2 ? policy : std::vector<int>();
  };
  bool refused = false;
  std::vector<int> while_idle, normal_again;
  OnOwnThread([&] {
    LagPriority priority(0, 4);
    priority.Update(0);
    refused = !priority.idle();
    if (refused) return;
    StartWorkerThreads(2);  // the worker starts idle
    while_idle = loop_policies();
    priority.Update(4);
    StartWorkerThreads(2);  // the same worker, normal again
    normal_again = loop_policies();
  });
  if (refused) return test::Skip("this system refuses SCHED_IDLE");
  if (while_idle.empty() || normal_again.empty()) return test::Skip("OpenMP gave a loop fewer than two threads");
  CHECK(while_idle == std::vector<int>{SCHED_IDLE, SCHED_IDLE});
  CHECK(normal_again == std::vector<int>{SCHED_OTHER, SCHED_OTHER});
#endif
}

}  // namespace
}  // namespace pano
