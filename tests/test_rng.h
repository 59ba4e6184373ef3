// Reproducible randomness for tests (after PoseLib's tests/test_rng.h): each
// test seeds its own generator, from PANO_TEST_SEED when set, and the seed is
// reported with any failure so that a failing run can be replayed.
#pragma once

#include <catch2/catch.hpp>

#include <cstdint>
#include <cstdlib>
#include <random>
#include <string>

namespace pano::test {

inline uint64_t TestSeed(uint64_t fallback) {
  if (const char* s = std::getenv("PANO_TEST_SEED")) return std::strtoull(s, nullptr, 10);
  return fallback;
}

}  // namespace pano::test

// Declares `rng` seeded for this test and prints the seed on failure.
#define PANO_SEEDED_RNG(default_seed)                                   \
  const uint64_t pano_test_seed = ::pano::test::TestSeed(default_seed); \
  INFO("seed " << pano_test_seed << " (set PANO_TEST_SEED to replay)"); \
  std::mt19937_64 rng(pano_test_seed)
