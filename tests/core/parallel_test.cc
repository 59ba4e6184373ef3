// Parallel loops: every index once, the lowest index's exception, nesting,
// and the threads of ParallelForOnOwnThreads gone with the loop.
#include <catch2/catch.hpp>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "expect_error.h"
#include "panotrack/core/parallel.h"
#include "test_skip.h"

#ifdef __linux__
#include <dirent.h>
#include <sched.h>
#endif

namespace pano {
namespace {

#ifdef __linux__
// Threads of this process now (entries of /proc/self/task).
int ProcessThreads() {
  int n = 0;
  if (DIR* d = opendir("/proc/self/task")) {
    while (const dirent* e = readdir(d)) n += e->d_name[0] != '.';
    closedir(d);
  }
  return n;
}
#endif

TEST_CASE("parallel_loop: own threads run every index once, on at most the threads asked for", "[parallel_loop]") {
  for (int chunk : {1, 3, 16}) {
    std::vector<std::atomic<int>> runs(101);
    std::mutex m;
    std::set<std::thread::id> ids;
    bool nested = true;
    ParallelForOnOwnThreads(
        101,
        [&](int k) {
          ++runs[static_cast<size_t>(k)];
          std::lock_guard<std::mutex> lock(m);
          ids.insert(std::this_thread::get_id());
          nested = nested && InParallelRegion();
          std::this_thread::sleep_for(std::chrono::microseconds(50));
        },
        3, chunk);
    for (const std::atomic<int>& r : runs) CHECK(r.load() == 1);
    CHECK(ids.size() <= 3);
    CHECK(nested);  // a loop inside runs on its thread alone
  }
  CHECK_FALSE(InParallelRegion());  // the flag does not outlive the loop
  int calls = 0;
  ParallelForOnOwnThreads(0, [&](int) { ++calls; }, 4);
  CHECK(calls == 0);
}

TEST_CASE("parallel_loop: the lowest index's exception, whatever the threads", "[parallel_loop]") {
  for (int threads : {1, 4}) {
    std::atomic<int> done{0};
    try {
      ParallelForOnOwnThreads(
          40,
          [&](int k) {
            ++done;
            if (k == 7 || k == 30) throw std::runtime_error("index " + std::to_string(k));
          },
          threads);
      FAIL("no exception");
    } catch (const std::runtime_error& e) {
      CHECK(std::string(e.what()) == "index 7");
    }
    CHECK(done.load() == 40);  // the other indices still ran
  }
}

TEST_CASE("parallel_loop: nested in a loop it runs on the caller's thread", "[parallel_loop]") {
  std::atomic<int> foreign{0};
  ParallelForOnOwnThreads(
      4,
      [&](int) {
        const std::thread::id outer = std::this_thread::get_id();
        ParallelForOnOwnThreads(
            8, [&](int) { foreign += std::this_thread::get_id() != outer; }, 4);
      },
      4);
  CHECK(foreign.load() == 0);
}

TEST_CASE("parallel_loop: no thread outlives the loop; they start on the caller's policy", "[parallel_loop]") {
#ifndef __linux__
  return test::Skip("threads counted and policies read from Linux's /proc and sched(7)");
#else
  // On a thread of its own at idle priority, so that nothing leaks into the
  // test runner's thread.
  int before = 0, after = 0, during = 0;
  std::vector<int> policies;
  bool refused = false;
  std::thread t([&] {
    const sched_param param{};
    refused = sched_setscheduler(0, SCHED_IDLE, &param) != 0;
    if (refused) return;
    std::mutex m;
    // Threads joined before (earlier tests) may linger in /proc for a moment.
    for (int i = 0; i < 200 && before != ProcessThreads(); ++i) {
      before = ProcessThreads();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ParallelForOnOwnThreads(
        3,
        [&](int) {
          std::lock_guard<std::mutex> lock(m);
          policies.push_back(sched_getscheduler(0));
          during = std::max(during, ProcessThreads());
          std::this_thread::sleep_for(std::chrono::milliseconds(2));
        },
        3);
    // A joined thread may linger in /proc for a moment after its exit.
    for (int i = 0; i < 1000 && (after = ProcessThreads()) > before; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  });
  t.join();
  if (refused) return test::Skip("this system refuses SCHED_IDLE");
  CHECK(policies == std::vector<int>(3, SCHED_IDLE));
  CHECK(during > before);  // helpers were started ...
  CHECK(after <= before);  // ... and are gone
#endif
}

TEST_CASE("thread counts are bounded: absurd ones refused naming the option, none above kMaxThreads",
          "[thread_bounds]") {
  CHECK_NOTHROW(CheckThreadCount(0, "--threads"));
  CHECK_NOTHROW(CheckThreadCount(kMaxThreads, "--threads"));
  CHECK(test::ErrorOf([] { CheckThreadCount(100000, "--threads"); }) ==
        "--threads: expected 0 (every core) or 1..1024, got 100000");
  CHECK(test::ErrorOf([] { CheckThreadCount(-1, "-j/--jobs"); }) ==
        "-j/--jobs: expected 0 (every core) or 1..1024, got -1");
  CHECK(ThreadCount(100000) == kMaxThreads);
  CHECK(ThreadCount(3) == 3);
}

}  // namespace
}  // namespace pano
