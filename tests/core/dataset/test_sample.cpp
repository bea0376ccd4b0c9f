// Sample extraction (core/dataset): binning, ground truth, crops, augmentations and the
// deterministic draws a resumed training run relies on.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/dataset/batch_loader.h"
#include "core/dataset/sample.h"
#include "core/dataset/sequence.h"
#include "core/events/formats/png16.h"
#include "core/events/io.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// 100 x 80 sensor; background events along row 10 every ms, a moving object's events at
// (50 + t_ms / 2, 40) (label 3), 0..49 ms.
LabelledSequence synthetic() {
  LabelledSequence s;
  s.name = "synthetic";
  s.events.sensor = {100, 80};
  for (int ms = 0; ms < 50; ++ms) {
    s.events.push_back(ms * 1000 + 100, uint16_t(ms % 100), 10, 1, 0);
    s.events.push_back(ms * 1000 + 200, uint16_t(50 + ms / 2), 40, uint8_t(ms % 2), 1);
  }
  return s;
}

SampleOptions plain() {
  SampleOptions o;
  o.window_us = 10000;
  o.warmup_us = 5000;
  o.crop = 32;
  o.flip_x = o.flip_y = o.polarity_swap = o.drop_max = o.threshold_jitter = o.noise_hz_max = 0;
  return o;
}

// 20-35 ms, a 32 x 48 crop at (40, 5) holding the object and none of the background events.
SampleSpec object_crop() {
  SampleSpec s;
  s.t0 = 20000;
  s.crop_x = 40;
  s.crop_y = 5;
  s.crop_w = 32;
  s.crop_h = 48;
  return s;
}

// Every draw centred on the object, with a small jitter and a 3-pixel filter.
SampleOptions centred_options() {
  SampleOptions o = plain();
  o.centred_fraction = 1;
  o.jitter = 4;
  o.min_fg_pixels = 3;
  return o;
}

// Foreground cells of the window's steps (the warm-up left out).
size_t window_foreground(const Sample& x) {
  size_t fg = 0;
  for (int t = x.warmup_steps; t < x.T; ++t)
    for (int p = 0; p < x.H * x.W; ++p) fg += x.fg[size_t(t) * x.H * x.W + p];
  return fg;
}

TEST(Sample, BinsEventsAndForegroundIntoTheCrop) {
  const LabelledSequence seq = synthetic();
  SampleOptions o = plain();
  SampleSpec s = object_crop();
  Sample x = extract_sample(seq, s, o);
  ASSERT_EQ(x.T, 15);
  EXPECT_EQ(x.warmup_steps, 5);
  ASSERT_EQ(x.H, 48);
  ASSERT_EQ(x.W, 32);
  for (int t = 0; t < 15; ++t) {
    const int ms = 20 + t;
    // Background event at column ms (inside the crop from x = 40) on row 10 -> crop row 5.
    const int bx = ms - 40;
    if (bx >= 0 && bx < 32) {
      EXPECT_EQ(x.input[x.at(t, 1, 5, bx)], 1) << t;
      EXPECT_EQ(x.fg[size_t(t) * 48 * 32 + 5 * 32 + bx], 0);
    }
    const int ox = 50 + ms / 2 - 40, oy = 35, op = ms % 2;
    EXPECT_EQ(x.input[x.at(t, op, oy, ox)], 1) << t;
    EXPECT_EQ(x.fg[size_t(t) * 48 * 32 + size_t(oy) * 32 + ox], 1) << t;
  }
  size_t ones = 0, fg = 0;
  for (auto v : x.input) ones += v;
  for (auto v : x.fg) fg += v;
  EXPECT_EQ(fg, 15u);         // one object event per step
  EXPECT_EQ(ones, 15u + 0u);  // background columns 20..34 lie left of the crop (x < 40)
}

TEST(Sample, FlipsAndPolaritySwapRespectGeometry) {
  const LabelledSequence seq = synthetic();
  SampleOptions o = plain();
  SampleSpec s = object_crop();
  Sample a = extract_sample(seq, s, o);
  s.flip_x = s.flip_y = s.swap_polarity = true;
  Sample b = extract_sample(seq, s, o);
  for (int t = 0; t < a.T; ++t)
    for (int c = 0; c < 2; ++c)
      for (int y = 0; y < a.H; ++y)
        for (int x = 0; x < a.W; ++x) {
          ASSERT_EQ(a.input[a.at(t, c, y, x)], b.input[b.at(t, 1 - c, a.H - 1 - y, a.W - 1 - x)]);
          ASSERT_EQ(a.fg[(size_t(t) * a.H + y) * a.W + x],
                    b.fg[(size_t(t) * a.H + (a.H - 1 - y)) * a.W + (a.W - 1 - x)]);
        }
}

TEST(Sample, DropKeepsTheExpectedShareAndNoiseAddsBackgroundOnly) {
  LabelledSequence seq;
  seq.name = "dense";
  seq.events.sensor = {64, 64};
  for (int ms = 0; ms < 20; ++ms)
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x)
        seq.events.push_back(ms * 1000 + 10, uint16_t(x), uint16_t(y), 1, 0);
  SampleOptions o = plain();
  o.warmup_us = 0;
  SampleSpec s;
  s.crop_w = s.crop_h = 64;
  s.keep[1] = 0.25;
  s.seed = 7;
  Sample x = extract_sample(seq, s, o);
  double n = 0;
  for (auto v : x.input) n += v;
  EXPECT_NEAR(n / (10 * 64 * 64), 0.25, 0.02);
  s.keep[1] = 0;  // every event dropped: only noise is left, none of it foreground
  s.noise_hz = 1000;
  x = extract_sample(seq, s, o);
  n = 0;
  for (auto v : x.input) n += v;
  // Poisson mean 1000 Hz * 4096 px * 10 ms = 40960 draws, some colliding on one bin.
  const double cells = 10.0 * 2 * 64 * 64, expect = cells * (1 - std::exp(-40960.0 / cells));
  EXPECT_NEAR(n, expect, 4 * std::sqrt(expect));
  for (auto v : x.fg) ASSERT_EQ(v, 0);
}

TEST(Sample, CentredDrawsContainTheObjectAndAreDeterministic) {
  const LabelledSequence seq = synthetic();
  SampleOptions o = centred_options();
  std::vector<const LabelledSequence*> seqs{&seq};
  for (int i = 0; i < 20; ++i) {
    std::mt19937_64 r1(mix_seed(5, 9, uint64_t(i))), r2(mix_seed(5, 9, uint64_t(i)));
    SampleSpec a = draw_sample(seqs, {1.0}, o, r1), b = draw_sample(seqs, {1.0}, o, r2);
    EXPECT_EQ(a.t0, b.t0);
    EXPECT_EQ(a.crop_x, b.crop_x);
    EXPECT_EQ(a.seed, b.seed);
    ASSERT_TRUE(a.centred);
    EXPECT_GE(window_foreground(extract_sample(seq, a, o)), 3u);
  }
  // A filter nothing can pass falls back to a random crop.
  o.min_fg_pixels = 1000;
  std::mt19937_64 r(1);
  EXPECT_FALSE(draw_sample(seqs, {1.0}, o, r).centred);
}

// At playback speed v each step holds v steps' worth of the recording: an event at t falls in
// step floor((t - t0) / (v step)).
TEST(Sample, PlaybackSpeedMapsTheRecordingOntoTheSteps) {
  const LabelledSequence seq = synthetic();
  SampleOptions o = plain();
  SampleSpec s;
  s.t0 = 0;
  s.crop_x = s.crop_y = 0;
  s.crop_w = 100;
  s.crop_h = 80;
  for (double v : {2.0, 0.5}) {
    s.speed = v;
    const Sample x = extract_sample(seq, s, o);
    ASSERT_EQ(x.T, 15);
    size_t bg = 0, fg = 0;
    for (int ms = 0; ms < 50; ++ms) {
      const int64_t tb = ms * 1000 + 100, to = ms * 1000 + 200;
      const bool in = double(to) < 15 * 1000 * v;  // both events of this ms in the sample
      if (!in) continue;
      const int stb = int(double(tb) / (1000 * v)), sto = int(double(to) / (1000 * v));
      EXPECT_EQ(x.input[x.at(stb, 1, 10, ms % 100)], 1) << "v " << v << " ms " << ms;
      EXPECT_EQ(x.input[x.at(sto, ms % 2, 40, 50 + ms / 2)], 1) << "v " << v << " ms " << ms;
      EXPECT_EQ(x.fg[(size_t(sto) * 80 + 40) * 100 + size_t(50 + ms / 2)], 1);
      ++bg;
      ++fg;
    }
    size_t ones = 0, fgs = 0;
    for (auto b : x.input) ones += b;
    for (auto b : x.fg) fgs += b;
    EXPECT_EQ(bg, v == 2 ? 30u : 8u);  // 30 ms of the recording, or 7.5 ms
    // Every event its own input cell (the object's two events of a 2 ms step differ in
    // polarity); at 2x the object's pixel 50 + ms / 2 is one foreground cell per step.
    EXPECT_EQ(ones, 2 * bg);
    EXPECT_EQ(fgs, v == 2 ? 15u : fg);
  }
  s.speed = 0;
  EXPECT_THROW(extract_sample(seq, s, o), Error);
}

TEST(Sample, PlaybackSpeedsAreLogUniformAndDrawnOnlyWhenOn) {
  const LabelledSequence seq = synthetic();
  std::vector<const LabelledSequence*> seqs{&seq};
  SampleOptions o = centred_options();
  double log_sum = 0;
  int faster = 0;
  const int n = 400;
  o.speed_max = 2;
  for (int i = 0; i < n; ++i) {
    std::mt19937_64 r(mix_seed(3, 1, uint64_t(i)));
    const SampleSpec a = draw_sample(seqs, {1.0}, o, r);
    ASSERT_GE(a.speed, 0.5);
    ASSERT_LE(a.speed, 2.0);
    log_sum += std::log(a.speed);
    faster += a.speed > 1;
    // Placed on the recording's time scale: the centred window still holds the object, and
    // the sample ends inside the recording.
    if (a.centred) EXPECT_GE(window_foreground(extract_sample(seq, a, o)), 3u) << a.speed;
  }
  // log v ~ U(-ln 2, ln 2): mean 0, sd ln 2 / sqrt 3 per draw.
  EXPECT_NEAR(log_sum / n, 0.0, 4 * std::log(2.0) / std::sqrt(3.0 * n));
  EXPECT_NEAR(double(faster) / n, 0.5, 4 * 0.5 / std::sqrt(double(n)));
  // Off (1): every speed is 1.
  o.speed_max = 1;
  for (int i = 0; i < 20; ++i) {
    std::mt19937_64 r(mix_seed(3, 1, uint64_t(i)));
    EXPECT_EQ(draw_sample(seqs, {1.0}, o, r).speed, 1.0);
  }
  o.speed_max = 0.5;
  std::mt19937_64 r(1);
  EXPECT_THROW(draw_sample(seqs, {1.0}, o, r), Error);
}

TEST(Sample, BadCropIsAnError) {
  const LabelledSequence seq = synthetic();
  SampleSpec s;
  s.crop_x = 90;
  s.crop_w = s.crop_h = 32;
  EXPECT_THROW(extract_sample(seq, s, plain()), Error);
  SampleOptions o = plain();
  o.crop = 128;  // larger than the 100 x 80 sensor
  std::vector<const LabelledSequence*> seqs{&seq};
  std::mt19937_64 r(1);
  EXPECT_THROW(draw_sample(seqs, {1.0}, o, r), Error);
}

TEST(BatchLoader, BackgroundBatchesEqualBatchesMadeInPlaceFromAnyStartStep) {
  const LabelledSequence seq = synthetic();
  std::vector<const LabelledSequence*> seqs{&seq};
  SampleOptions o = plain();
  o.flip_x = 0.5;
  o.noise_hz_max = 50;
  BatchLoader loader(seqs, {1.0}, o, 3, 42, 5, 2, 2);
  for (int64_t step = 5; step < 12; ++step) {
    Batch b = loader.next();
    Batch ref = BatchLoader::make(seqs, {1.0}, o, 3, 42, step);
    ASSERT_EQ(b.step, step);
    ASSERT_EQ(b.samples.size(), 3u);
    for (size_t j = 0; j < 3; ++j) {
      EXPECT_EQ(b.samples[j].input, ref.samples[j].input);
      EXPECT_EQ(b.samples[j].fg, ref.samples[j].fg);
    }
  }
}

// A data-parallel rank's share of a global batch is the same samples the whole batch holds.
TEST(BatchLoader, ShardsAreSlicesOfTheGlobalBatch) {
  const LabelledSequence seq = synthetic();
  std::vector<const LabelledSequence*> seqs{&seq};
  SampleOptions o = plain();
  o.flip_x = 0.5;
  o.noise_hz_max = 50;
  BatchLoader loader(seqs, {1.0}, o, 2, 42, 3, 2, 1, 2);  // samples 2, 3 of a batch of 4
  for (int64_t step = 3; step < 6; ++step) {
    Batch whole = BatchLoader::make(seqs, {1.0}, o, 4, 42, step);
    Batch shard = loader.next();
    ASSERT_EQ(shard.samples.size(), 2u);
    for (size_t j = 0; j < 2; ++j) {
      EXPECT_EQ(shard.samples[j].input, whole.samples[2 + j].input);
      EXPECT_EQ(shard.samples[j].fg, whole.samples[2 + j].fg);
    }
    // and differ from the first half (the test could not pass with an ignored offset)
    EXPECT_NE(shard.samples[0].input, whole.samples[0].input);
  }
}

// Whole-sensor batches of sequences from two sensor sizes hold one size each; each sequence
// keeps the share of samples its weight gives; a rank's shard is still its slice of the
// global batch; crops (any size fits) and validation sets mix, the latter ordered by size.
TEST(BatchLoader, WholeSensorBatchesHoldOneSensorSize) {
  LabelledSequence big = synthetic(), small = synthetic(), big2 = synthetic();
  small.events.sensor = {80, 48};  // every event of synthetic() fits 80 x 48 too
  std::vector<const LabelledSequence*> seqs{&big, &small, &big2};
  const std::vector<double> w{0.5, 0.3, 0.2};
  SampleOptions o = plain();
  o.crop = 0;
  std::vector<double> share(3, 0);
  const int steps = 400;
  for (int64_t step = 0; step < steps; ++step) {
    Batch b = BatchLoader::make(seqs, w, o, 4, 7, step);
    ASSERT_EQ(b.samples.size(), 4u);
    for (const Sample& x : b.samples) {
      EXPECT_EQ(x.W, b.samples[0].W) << "step " << step;
      EXPECT_EQ(x.H, b.samples[0].H) << "step " << step;
      // Which sequence: the small one by its size; the two big ones share 100 x 80.
      share[x.W == 80 ? 1 : 0] += 1.0 / (4 * steps);
    }
    if (step < 5) {  // shard = slice
      Batch shard = BatchLoader::make(seqs, w, o, 2, 7, step, 2);
      for (size_t j = 0; j < 2; ++j) EXPECT_EQ(shard.samples[j].input, b.samples[2 + j].input);
    }
  }
  // 1,600 samples in 400 groups of 4 (sd of a group share ~ sqrt(.21 / 400) = 0.023).
  EXPECT_NEAR(share[1], 0.3, 0.08);
  EXPECT_NEAR(share[0], 0.7, 0.08);
  // Crops fit both sensors: batches mix them.
  o.crop = 32;
  for (int64_t step = 0; step < 50; ++step) {
    Batch b = BatchLoader::make(seqs, w, o, 4, 7, step);
    for (const Sample& x : b.samples) EXPECT_EQ(x.W, 32);
  }
  // Validation: ordered by size.
  o.crop = 0;
  const auto val = validation_samples(seqs, o, 30, 3);
  int changes = 0;
  for (size_t i = 1; i < val.size(); ++i) changes += val[i].W != val[i - 1].W;
  EXPECT_EQ(changes, 1);
}

TEST(Dataset, LoadsASimulatorStyleFolderBySplitAndRefusesUnlabelledData) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "spikems_dataset_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  Recording rec;
  rec.events = synthetic().events;
  for (auto& l : rec.events.label) l = l ? 3 : 0;
  write_recording((dir / "a.h5").string(), rec);
  write_recording((dir / "b.h5").string(), rec);
  {
    std::ofstream m(dir / "manifest.json");
    m << R"({"splits": {"train": ["b.h5", "a.h5"], "val": [], "test": ["a.h5"]}})";
  }
  auto files = sequence_files({dir.string(), "train"});
  ASSERT_EQ(files.size(), 2u);
  EXPECT_EQ(fs::path(files[0]).filename(), "a.h5");
  EXPECT_THROW(sequence_files({dir.string(), "val"}), Error);      // empty split
  EXPECT_THROW(sequence_files({dir.string(), "bogus"}), Error);    // unknown split
  EXPECT_THROW(sequence_files({(dir / "none").string()}), Error);  // missing
  LabelledSequence s = load_sequence(files[0]);
  ASSERT_EQ(s.events.size(), 100u);
  for (size_t i = 0; i < s.events.size(); ++i)
    EXPECT_EQ(s.events.label[i], i % 2 ? 1 : 0);  // object id 3 -> 1
  Recording bare;
  bare.events = synthetic().events;
  bare.events.label.clear();
  write_recording((dir / "bare.h5").string(), bare);
  EXPECT_THROW(load_sequence((dir / "bare.h5").string()), Error);
  fs::remove_all(dir);
}

// An EV-IMO txt folder (no labels, mask frames): events take the id of the nearest mask frame,
// dilated by the source's mask_dilation (5x5 by default, as the SpikeMS authors), then 0/1.
TEST(Dataset, EvimoFolderIsLabelledFromDilatedMasks) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "spikems_dataset_evimo_test";
  fs::remove_all(dir);
  fs::create_directories(dir / "img");
  std::ofstream(dir / "events.txt") << "0.100000 1 2 1\n0.200000 5 3 0\n0.350000 6 4 1\n";
  std::ofstream(dir / "meta.txt") << "{'frames': [{'id': 7, 'ts': 0.15}, {'id': 8, 'ts': 0.30}]}";
  for (int id : {7, 8}) {
    Image16 img;
    img.width = 8;
    img.height = 6;
    img.channels = 3;
    img.data.assign(8 * 6 * 3, 0);
    img.data[(2 * 8 + 5) * 3 + 0] = 2000;  // object 2 at (5, 2) (R = BGR channel 2)
    write_png16((dir / "img" / ("depth_mask_" + std::to_string(id) + ".png")).string(), img);
  }
  DatasetSource src{dir.string()};
  ASSERT_EQ(sequence_files(src), std::vector<std::string>{dir.string()});  // one recording
  LabelledSequence s = load_sequences(src).at(0);
  EXPECT_EQ(s.events.label, (std::vector<uint16_t>{0, 1, 1}));  // (1,2) lies outside 3..7
  s = load_sequence(dir.string(), 1);                           // no dilation
  EXPECT_EQ(s.events.label, (std::vector<uint16_t>{0, 0, 0}));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace spikems
