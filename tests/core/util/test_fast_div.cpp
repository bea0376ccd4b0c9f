// FastDiv against the hardware division: every small case, the extremes, and random pairs.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>

#include "core/util/fast_div.h"

namespace spikems {
namespace {

TEST(FastDiv, SmallDivisorsAndNumeratorsExhaustive) {
  for (uint32_t d = 1; d <= 700; ++d) {
    const FastDiv f(d);
    EXPECT_EQ(f.divisor(), d);
    for (uint32_t n = 0; n < 200000; n += 7) ASSERT_EQ(f(n), n / d) << n << " / " << d;
  }
}

TEST(FastDiv, Extremes) {
  const uint32_t big = 0xffffffffu;
  for (uint32_t d :
       {1u, 2u, 3u, 7u, 346u, 65535u, 65536u, 0x7fffffffu, 0x80000000u, big - 1, big}) {
    const FastDiv f(d);
    for (uint32_t n : {0u, 1u, d - 1, d, d + 1, big / 2, big - 1, big}) {
      ASSERT_EQ(f(n), n / d) << n << " / " << d;
    }
  }
}

TEST(FastDiv, RandomPairs) {
  std::mt19937 rng(5);
  for (int i = 0; i < 2000000; ++i) {
    const uint32_t d = std::max<uint32_t>(1, rng() >> (rng() % 32));
    const uint32_t n = rng();
    ASSERT_EQ(FastDiv(d)(n), n / d) << n << " / " << d;
  }
}

}  // namespace
}  // namespace spikems
