// Skipping a test case that cannot run on this machine: call Skip(reason) and
// return from the case. ctest shows the test as skipped (SKIP_RETURN_CODE),
// never as passed.
#pragma once

#include <string>

namespace pano::test {

constexpr int kSkipReturnCode = 77;
void Skip(const std::string& reason);

}  // namespace pano::test
