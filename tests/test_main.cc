// Catch2 main for every test executable. A case that cannot run here (no GPU,
// no shared data) calls pano::test::Skip(); the executable then exits with
// kSkipReturnCode when nothing failed, which ctest reports as skipped.
// Scratch folders (test_paths.h) are removed after a run without failures.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>

#include <atomic>
#include <cstdio>

#include "test_paths.h"
#include "test_skip.h"

namespace pano::test {

namespace {
std::atomic<int> g_skipped{0};
}

void Skip(const std::string& reason) {
  ++g_skipped;
  std::printf("SKIPPED: %s\n", reason.c_str());
  std::fflush(stdout);
}

}  // namespace pano::test

int main(int argc, char* argv[]) {
  const int failed = Catch::Session().run(argc, argv);
  // Scratch folders stay behind only when something failed.
  if (failed == 0) pano::test::RemoveScratchDirs();
  if (failed == 0 && pano::test::g_skipped > 0) return pano::test::kSkipReturnCode;
  return failed;
}
