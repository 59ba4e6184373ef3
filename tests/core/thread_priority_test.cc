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

}  // namespace
}  // namespace pano
