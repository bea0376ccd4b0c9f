// to_tensors: samples of different sizes (whole sensors of several cameras) share a batch,
// each at the top-left of the batch's largest size, and score as they do alone.
#include <gtest/gtest.h>

#include <random>

#include "core/util/error.h"
#include "train/trainer/batch_tensors.h"

using namespace spikems;
using namespace spikems::train;

namespace {

Sample random_sample(int T, int warm, int H, int W, uint64_t seed) {
  Sample s;
  s.T = T;
  s.warmup_steps = warm;
  s.H = H;
  s.W = W;
  std::mt19937_64 rng(seed);
  s.input.resize(size_t(T) * 2 * size_t(H) * size_t(W));
  s.fg.resize(size_t(T) * size_t(H) * size_t(W));
  for (auto& v : s.input) v = rng() % 5 == 0;
  for (auto& v : s.fg) v = rng() % 7 == 0;
  return s;
}

}  // namespace

TEST(BatchTensors, MixedSizesArePlacedTopLeftAndScoreAsAlone) {
  const Sample a = random_sample(4, 1, 6, 9, 1), b = random_sample(4, 1, 8, 5, 2);
  const BatchTensors t = to_tensors({a, b}, 0.5, torch::kCPU);
  ASSERT_EQ(t.input.sizes(), (std::vector<int64_t>{4, 2, 2, 8, 9}));
  ASSERT_EQ(t.fg.sizes(), (std::vector<int64_t>{4, 2, 8, 9}));
  EXPECT_EQ(t.warmup_steps, 1);
  for (int k = 0; k < 2; ++k) {
    const Sample& s = k == 0 ? a : b;
    for (int tt = 0; tt < 4; ++tt)
      for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 9; ++x) {
          const bool inside = y < s.H && x < s.W;
          for (int c = 0; c < 2; ++c) {
            const float want = inside ? float(s.input[s.at(tt, c, y, x)]) / 0.5f : 0.f;
            ASSERT_EQ(t.input[tt][k][c][y][x].item<float>(), want) << k << tt << c << y << x;
          }
          const float g = inside ? float(s.fg[(size_t(tt) * s.H + y) * s.W + x]) : 0.f;
          ASSERT_EQ(t.fg[tt][k][y][x].item<float>(), g);
        }
  }
  // Window counts of a padded sample equal those of the sample alone (an output equal to the
  // input: P = pixels with input spikes; the padding has none and no foreground).
  auto counts = [](const BatchTensors& bt) {
    return window_counts(bt.input.slice(0, 1), bt.fg.slice(0, 1));
  };
  const auto both = counts(t), alone_a = counts(to_tensors({a}, 0.5, torch::kCPU)),
             alone_b = counts(to_tensors({b}, 0.5, torch::kCPU));
  ASSERT_EQ(both.size(), 2u);
  for (auto [x, y] : {std::pair{both[0], alone_a[0]}, std::pair{both[1], alone_b[0]}}) {
    EXPECT_EQ(x.intersection, y.intersection);
    EXPECT_EQ(x.predicted, y.predicted);
    EXPECT_EQ(x.truth, y.truth);
  }
}

TEST(BatchTensors, SameSizeBatchIsCopiedAsIs) {
  const Sample a = random_sample(3, 0, 5, 7, 3), b = random_sample(3, 0, 5, 7, 4);
  const BatchTensors t = to_tensors({a, b}, 1.0, torch::kCPU);
  ASSERT_EQ(t.input.sizes(), (std::vector<int64_t>{3, 2, 2, 5, 7}));
  const auto in = t.input.permute({1, 0, 2, 3, 4}).contiguous().to(torch::kUInt8);
  EXPECT_EQ(0, std::memcmp(in[1].data_ptr<uint8_t>(), b.input.data(), b.input.size()));
}

TEST(BatchTensors, LengthsMustAgree) {
  const Sample a = random_sample(4, 1, 6, 9, 1);
  Sample b = random_sample(5, 1, 6, 9, 2), c = random_sample(4, 2, 6, 9, 3);
  EXPECT_THROW(to_tensors({a, b}, 1.0, torch::kCPU), Error);
  EXPECT_THROW(to_tensors({a, c}, 1.0, torch::kCPU), Error);
  Sample d = a;
  d.fg.pop_back();
  EXPECT_THROW(to_tensors({a, d}, 1.0, torch::kCPU), Error);
  EXPECT_THROW(to_tensors({}, 1.0, torch::kCPU), Error);
}
