// The fast float helpers of the per-pixel loops against the std functions.
#include <gtest/gtest.h>

#include <cmath>

#include "core/sim/fast_math.h"

using namespace spikems::sim;

TEST(SimFastMath, LogAndFloorMatchStd) {
  double worst = 0;
  for (int k = 0; k < 200000; ++k) {
    float x = std::exp(-12.0f + 24.0f * float(k) / 200000.0f);  // 6e-6 .. 1.6e5
    worst = std::max(worst, double(std::fabs(fast_log2(x) - std::log2(x))));
    EXPECT_NEAR(fast_log(x), std::log(x), 1e-5) << x;
  }
  EXPECT_LT(worst, 1e-5);
  for (float x : {-3.5f, -3.0f, -0.25f, 0.0f, 0.25f, 2.0f, 2.999f, -1e6f, 123456.7f})
    EXPECT_EQ(fast_floor(x), std::floor(x)) << x;
}
