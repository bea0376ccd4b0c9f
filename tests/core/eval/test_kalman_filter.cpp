// The Kalman filter over short windows (`spikems eval --kalman`): a synthetic constant-velocity
// blob with noisy detections (pixels dropped, spurious pixels, whole windows missed).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/eval/kalman_filter.h"
#include "core/eval/window_scorer.h"
#include "core/util/error.h"

namespace spikems {
namespace {

constexpr int kW = 160, kH = 60, kSide = 10;
constexpr int64_t kWin = 3000;         // 3 ms windows
constexpr double kVx = 1000, kVy = 0;  // px/s: 3 px per window

// Blob of window k: a kSide square whose left edge moves at kVx from x = 10.
int blob_x(int64_t k) {
  return 10 + int(std::lround(kVx * double(k * kWin) * 1e-6));
}

TEST(KalmanFilter, ConvergesToTheBlobsVelocityAndBeatsTheNoisyInput) {
  std::mt19937 rng(11);
  std::bernoulli_distribution keep(0.4);  // a detection holds 40 % of the blob's pixels
  EventStream ev;
  ev.sensor = SensorSize{kW, kH};
  std::vector<PredictionFrame> frames;
  const int64_t windows = 40;
  for (int64_t k = 0; k < windows; ++k) {
    const int64_t t0 = k * kWin;
    const int x0 = blob_x(k), y0 = 25;
    // Events: every blob pixel moving, 20 background events anywhere, in time order.
    std::vector<std::pair<int, int>> bg;
    for (int i = 0; i < 20; ++i) bg.push_back({int(rng() % kW), int(rng() % kH)});
    for (int y = y0; y < y0 + kSide; ++y)
      for (int x = x0; x < x0 + kSide; ++x) ev.push_back(t0, uint16_t(x), uint16_t(y), 1, 1);
    for (auto [x, y] : bg) ev.push_back(t0 + 200, uint16_t(x), uint16_t(y), 0, 0);
    // The noisy detection: some blob pixels, 2 spurious pixels; every 4th window none at all.
    PredictionFrame f;
    f.t0_us = t0;
    f.t1_us = t0 + kWin;
    f.index = int(k);
    f.width = kW;
    f.height = kH;
    f.foreground.assign(size_t(kW * kH), 0);
    if (k % 4 != 3) {
      for (int y = y0; y < y0 + kSide; ++y)
        for (int x = x0; x < x0 + kSide; ++x)
          if (keep(rng)) f.foreground[size_t(y * kW + x)] = 1;
      for (int i = 0; i < 2; ++i) f.foreground[size_t(rng() % (kW * kH))] = 1;
    }
    frames.push_back(std::move(f));
  }
  ev.push_back(windows * kWin, 0, 0, 0, 0);  // the data goes on past the last window

  auto filter = std::make_shared<KalmanWindowFilter>(kW, kH);
  WindowScorer scorer(ev.sensor, {kWin}, {{kWin, filter}});
  scorer.add_events(ev);
  for (const auto& f : frames) scorer.add_frame(f);
  scorer.finish(windows * kWin + 1);
  const auto& plain = scorer.scores()[0];
  const auto& filtered = scorer.scores()[1];
  ASSERT_EQ(plain.windows(), size_t(windows));
  ASSERT_EQ(filtered.windows(), size_t(windows));

  // Velocity after 40 windows (the last one is a detection): within 10 % of 1000 px/s in x,
  // within 100 px/s of 0 in y.
  // (A pair of spurious pixels may make a short-lived track too: take the blob's, the largest.)
  ASSERT_GE(filter->boxes().size(), 1u);
  TrackedBox b = filter->boxes()[0];
  for (const auto& o : filter->boxes())
    if ((o.x1 - o.x0) * (o.y1 - o.y0) > (b.x1 - b.x0) * (b.y1 - b.y0)) b = o;
  EXPECT_NEAR(b.vx, kVx, 0.1 * kVx);
  EXPECT_NEAR(b.vy, kVy, 100);
  // The box sits on the blob: centre within 2 px.
  EXPECT_NEAR((b.x0 + b.x1) / 2, blob_x(windows - 1) + (kSide - 1) / 2.0, 2.0);

  // Input IoU: about 0.4 in detected windows, 0 in missed ones (mean about 0.3). Filtered:
  // the blob's events inside the tracked box, also through the missed windows.
  EXPECT_LT(plain.mean_iou(), 0.4);
  EXPECT_GT(filtered.mean_iou(), 0.8);
  EXPECT_GT(filtered.mean_iou(), plain.mean_iou() + 0.4);
  // Windows after the first two (the track is confirmed on its second detection) are all
  // detections.
  size_t good = 0;
  for (size_t i = 2; i < filtered.ious().size(); ++i) good += filtered.ious()[i] > 0.7;
  EXPECT_EQ(good, filtered.ious().size() - 2);
}

TEST(KalmanFilter, WithoutPredictionsNothingIsClaimed) {
  KalmanWindowFilter f(8, 4);
  std::vector<uint8_t> p(32, 0), e(32, 1);
  for (int k = 0; k < 5; ++k) {
    f.apply(k * 1000, (k + 1) * 1000, p, e);
    EXPECT_EQ(std::count(p.begin(), p.end(), 1), 0);
  }
  std::vector<uint8_t> wrong(31, 0);
  EXPECT_THROW(f.apply(5000, 6000, wrong, e), Error);
}

}  // namespace
}  // namespace spikems
