// Labelling rule, mask frames and the Kalman tracker, on cases whose answers are known.
#include <gtest/gtest.h>

#include <cmath>

#include "core/runtime/dense_reference.h"
#include "core/runtime/event_labeller.h"
#include "core/runtime/kalman_tracker.h"
#include "core/runtime/mask_accumulator.h"
#include "core/runtime/segmenter.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// Output 4x4, one channel... events at (1,1) in step 10; window 3 steps.
TEST(EventLabeller, WindowRuleIsExact) {
  for (int spike_step : {9, 10, 12, 13, 14}) {
    EventLabeller lab(SensorSize{4, 4}, 4, 4, 2, 3);
    EventStream out;
    out.add_zero_labels();
    lab.push(Event{10000, 1, 1, 1, 0}, 10);
    for (int64_t s = 9; s <= 20; ++s) {
      std::vector<uint32_t> spikes;
      if (s == spike_step) spikes.push_back((1 * 4 + 1) * 2 + 1);  // channel 1 at pixel (1,1)
      lab.on_step(s, spikes, out);
      if (s < 13) {
        EXPECT_EQ(out.size(), 0u) << "decided before its window ended";
      }
    }
    ASSERT_EQ(out.size(), 1u);
    const bool want = spike_step >= 10 && spike_step <= 13;
    EXPECT_EQ(out.label[0], want ? 1 : 0) << "spike at step " << spike_step;
    EXPECT_EQ(out.t[0], 10000);
  }
}

// Many steps of random events and output spikes, pushed in uneven batches (the queue grows,
// is compacted, and is emptied): every event comes out once, in order, with the label the
// window rule gives, computed here from the whole spike history.
TEST(EventLabeller, LongRandomStreamMatchesTheRuleFromTheHistory) {
  const int W = 9, H = 7, C = 2, window = 3, shift = 1;  // a 2x downsampled 18x14 sensor
  EventLabeller lab(SensorSize{W, H}, H, W, C, window, shift);
  uint64_t rng = 12345;
  auto next = [&](uint32_t n) {
    rng = rng * 6364136223846793005ull + 1442695040888963407ull;
    return uint32_t(rng >> 33) % n;
  };
  std::vector<std::vector<uint32_t>> spikes_at;  // per step: output neurons
  std::vector<std::pair<Event, int64_t>> pushed;
  EventStream out;
  out.add_zero_labels();
  int64_t t = 0;
  const int steps = 400;
  for (int s = 0; s < steps + window + 1; ++s) {
    // A busy stretch (thousands of events a step: growth) and idle ones (the queue empties).
    const uint32_t n = s >= steps ? 0 : (s / 50) % 2 ? next(3000) : next(4);
    lab.reserve(n);
    for (uint32_t i = 0; i < n; ++i) {
      Event e{t++, uint16_t(next(2 * W)), uint16_t(next(2 * H)), uint8_t(next(2)), 0};
      lab.push_reserved(e.t, e.x, e.y, e.p, s);
      pushed.push_back({e, s});
    }
    std::vector<uint32_t> sp;
    for (uint32_t k = next(12); k > 0; --k) sp.push_back(next(uint32_t(W * H * C)));
    spikes_at.push_back(sp);
    lab.on_step(s, sp, out);
  }
  EXPECT_EQ(lab.pending(), 0u);
  ASSERT_EQ(out.size(), pushed.size());
  uint64_t fg = 0;
  for (size_t i = 0; i < pushed.size(); ++i) {
    const auto& [e, s] = pushed[i];
    const uint32_t pix = lab.out_pixel(e.x >> shift, e.y >> shift);
    bool want = false;
    for (int64_t q = s; q <= s + window; ++q)
      for (uint32_t nrn : spikes_at[size_t(q)]) want |= nrn / C == pix;
    fg += want;
    ASSERT_EQ(out.t[i], e.t) << i;
    ASSERT_EQ(out.x[i], e.x) << i;
    ASSERT_EQ(out.y[i], e.y) << i;
    ASSERT_EQ(out.p[i], e.p) << i;
    ASSERT_EQ(out.label[i], want ? 1 : 0) << "event " << i << " of step " << s;
  }
  EXPECT_EQ(lab.foreground_count(), fg);
  EXPECT_GT(fg, 100u);
  EXPECT_LT(fg, pushed.size());
}

TEST(EventLabeller, PixelsBeyondASmallerOutputTakeTheNearestOutputPixel) {
  EventLabeller lab(SensorSize{6, 5}, 3, 4, 1, 0);
  EXPECT_EQ(lab.out_pixel(5, 4), uint32_t(2 * 4 + 3));
  EXPECT_EQ(lab.out_pixel(2, 1), uint32_t(1 * 4 + 2));
}

TEST(MaskAccumulator, FramesCoverConsecutiveWindows) {
  MaskAccumulator m(SensorSize{5, 4}, 3, 4, 2, 1000, 10000);  // output smaller than the sensor
  std::vector<PredictionFrame> frames;
  m.add_event(4, 3);
  m.add_spikes(2000, {uint32_t((2 * 4 + 3) * 2 + 0)});  // output pixel (3, 2), the corner
  m.close_until(11000, frames);                         // first window [1000, 11000) ends
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].t0_us, 1000);
  EXPECT_EQ(frames[0].t1_us, 11000);
  // Sensor pixels with x >= 3 or y >= 2 map to the nearest output pixel.
  EXPECT_EQ(frames[0].foreground[3 * 5 + 4], 1);
  EXPECT_EQ(frames[0].foreground[2 * 5 + 3], 1);
  EXPECT_EQ(frames[0].foreground[0], 0);
  EXPECT_EQ(frames[0].foreground_pixels(), 4u);  // (3..4) x (2..3)
  EXPECT_EQ(frames[0].events[3 * 5 + 4], 1);
  m.close_until(31000, frames);  // two more (empty) windows
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[2].index, 2);
  EXPECT_EQ(frames[2].foreground_pixels(), 0u);
}

TEST(KalmanTracker, ComponentsAndDilation) {
  std::vector<uint8_t> m(10 * 8, 0);
  m[1 * 10 + 1] = m[2 * 10 + 2] = 1;  // diagonal neighbours: one 8-connected component
  m[6 * 10 + 8] = 1;
  auto c = connected_components(m, 10, 8, 1);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].area, 2);
  EXPECT_DOUBLE_EQ(c[0].cx, 1.5);
  EXPECT_EQ(connected_components(m, 10, 8, 2).size(), 1u);
  auto d = dilate(m, 10, 8, 1);
  EXPECT_EQ(connected_components(d, 10, 8, 1)[0].area, 14);  // two 3x3 squares sharing 2x2
}

// A 6x6 blob moving +3 px per 10 ms frame in x and -1 in y: 300 and -100 px/s.
TEST(KalmanTracker, EstimatesConstantVelocityWithStableIds) {
  TrackerOptions opt;
  opt.dilate_radius = 0;
  opt.min_area = 4;
  KalmanTracker tr(opt);
  const int W = 120, H = 60;
  std::vector<TrackedBox> last;
  for (int f = 0; f < 20; ++f) {
    std::vector<uint8_t> m(W * H, 0);
    int x0 = 10 + 3 * f, y0 = 40 - f;
    for (int y = y0; y < y0 + 6; ++y)
      for (int x = x0; x < x0 + 6; ++x) m[y * W + x] = 1;
    for (int y = 5; y < 9; ++y)  // a static second object
      for (int x = 100; x < 104; ++x) m[y * W + x] = 1;
    last = tr.update(10000 * (f + 1), m, W, H);
    if (f >= 1) {
      ASSERT_EQ(last.size(), 2u) << "frame " << f;
    }
  }
  const TrackedBox& mv = last[0].x0 < 90 ? last[0] : last[1];
  const TrackedBox& st = last[0].x0 < 90 ? last[1] : last[0];
  EXPECT_NEAR(mv.vx, 300, 10);
  EXPECT_NEAR(mv.vy, -100, 10);
  EXPECT_NEAR(mv.x0, 10 + 3 * 19 - 0.5, 1.0);  // centroid +- half the box
  EXPECT_NEAR(st.vx, 0, 1);
  EXPECT_NE(mv.id, st.id);
  EXPECT_EQ(tr.live_tracks(), 2u);
}

// The pipeline end to end on an identity-like model: a 1x1 conv passing OFF events through.
TEST(Segmenter, DefaultBlockIsAboutFortyMillisecondsOrTwentyWithThreads) {
  EXPECT_EQ(default_block_steps(1.0, 1), 16);  // 40 steps, capped
  EXPECT_EQ(default_block_steps(2.0, 1), 16);  // 20, capped: the older models' 16 stays
  EXPECT_EQ(default_block_steps(5.0, 1), 8);
  EXPECT_EQ(default_block_steps(10.0, 1), 4);
  EXPECT_EQ(default_block_steps(50.0, 1), 1);  // never below one step
  EXPECT_EQ(default_block_steps(1.0, 2), 16);
  EXPECT_EQ(default_block_steps(2.0, 2), 10);
  EXPECT_EQ(default_block_steps(5.0, 4), 4);
  EXPECT_EQ(default_block_steps(10.0, 2), 2);
  EXPECT_EQ(default_block_steps(0.0, 1), 16);  // no step known: the former default
}

TEST(Segmenter, LabelsFollowTheOutputSpikes) {
  ModelSpec m;
  LayerSpec l;
  l.in_channels = 2;
  l.out_channels = 2;
  l.kernel = 1;
  l.stride = 1;
  l.weight = {1.f, 0.f, 0.f, 0.f};  // out 0 <- in 0 (OFF); ON events reach nothing
  m.layers = {l};
  fill_fir_kernels(m);
  Segmenter seg(m, SensorSize{8, 6}, SegmenterOptions{});
  EventStream ev;
  for (int i = 0; i < 50; ++i)
    ev.push_back(1000 * i + 7, uint16_t(i % 8), uint16_t(i % 6), uint8_t(i % 2));
  seg.push(ev.slice_index(0, 20));
  seg.push(ev.slice_index(20, 50));
  seg.finish();
  const auto& out = seg.labelled();
  ASSERT_EQ(out.size(), 50u);
  for (size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out.t[i], ev.t[i]);
    EXPECT_EQ(out.label[i], ev.p[i] == 0 ? 1 : 0) << i;
  }
  EXPECT_EQ(seg.network().stats()[0].synops, 50u * 2);  // 50 input spikes, 2 outputs each
  // Each OFF event (pixels revisit only after 24 steps, beyond the 16-step kernel) makes the
  // same burst as a lone spike in the dense reference.
  DenseTensor one(20, 2, 1, 1);
  one.at(0, 0, 0, 0) = 1;
  const double burst = dense_layer_forward(m.layers[0], 1.0, one).spikes.sum();
  EXPECT_GE(burst, 2);
  EXPECT_EQ(double(seg.network().stats()[0].out_spikes), 25 * burst);
  // Going back in time is an error naming the event.
  EventStream back;
  back.push_back(0, 1, 1, 1);
  Segmenter s2(m, SensorSize{8, 6}, SegmenterOptions{});
  s2.push(ev);
  EXPECT_THROW(s2.push(back), Error);
  // A model made for another sensor is refused.
  m.input_width = 16;
  m.input_height = 12;
  EXPECT_THROW(Segmenter(m, SensorSize{8, 6}, SegmenterOptions{}), Error);
}

}  // namespace
}  // namespace spikems
