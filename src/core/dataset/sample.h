// Training and validation samples: a crop of a labelled sequence over [t0, t0 + warm-up +
// window), binned into binary spikes as the network sees them (events/binning.h conventions),
// with the per-step foreground events as ground truth. No LibTorch: evaluation and tools reuse
// it; the trainer turns a Sample into tensors.
//
// Warm-up: the first `warmup_us` of a sample feed the network but carry no loss, so that the
// window is scored with the neuron state of a running stream (docs/training.md: a network of
// 6 layers answers 6 steps late, and its slowest kernels (tau_s = 4 ms) need ~10 ms to rise).
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "core/dataset/sequence.h"

namespace spikems {

struct SampleOptions {
  int64_t step_us = 1000;     // simulation step (paper: 1 ms)
  int64_t window_us = 10000;  // the part the loss sees (paper: Δt_train = 10 ms)
  int64_t warmup_us = 10000;  // input before the window, no loss
  int crop = 128;             // square crop side (px); 0 = the whole sensor
  // Share of crops centred on a moving object (the authors' choice); the rest are placed at
  // random and teach the network to stay silent on ego-motion alone.
  double centred_fraction = 0.75;
  int jitter = 24;  // px, uniform offset of a centred crop's centre
  // The authors' filters, applied to centred crops: at least this many foreground pixels in
  // the window, and at most this ratio of background to foreground event pixels (0: off).
  int min_fg_pixels = 30;
  double max_bg_fg_ratio = 0;
  int max_tries = 20;  // draws before a centred sample falls back to a random crop
  // Augmentations that respect event geometry.
  double flip_x = 0.5, flip_y = 0.5;  // probabilities
  double polarity_swap = 0.5;         // probability (reverses every brightness change)
  double drop_max = 0.2;              // each sample drops a fraction U(0, drop_max) of events
  // Contrast-threshold jitter: per sample and polarity, a threshold scale s ~ U(1, 1 + j);
  // an event survives with probability 1/s (a higher threshold fires 1/s as often).
  double threshold_jitter = 0.3;
  double noise_hz_max = 2.0;  // added background noise events, U(0, max) Hz per pixel
  // Playback speed: per sample a factor v, log-uniform in [1/speed_max, speed_max], by which the
  // recording is sped up (the sample's steps cover v times as much of it). Camera and objects
  // speed up together, so their relative motion is kept while event rates change: the network
  // cannot take a high local event rate for object motion. 1: off.
  double speed_max = 1.0;
};

struct Sample {
  int T = 0, warmup_steps = 0, H = 0, W = 0;
  std::vector<uint8_t> input;  // [T, 2, H, W] binary spikes, channel = polarity (0 OFF, 1 ON)
  std::vector<uint8_t> fg;     // [T, H, W] 1 where a moving-object event fell in that step
  bool centred = false;        // crop centred on a moving object
  size_t at(int t, int c, int y, int x) const { return ((size_t(t) * 2 + c) * H + y) * W + x; }
};

// Where and how a sample is cut (drawn by draw_sample, or given by hand in tests).
struct SampleSpec {
  size_t sequence = 0;
  int64_t t0 = 0;  // start of the warm-up (µs)
  int crop_x = 0, crop_y = 0, crop_w = 0, crop_h = 0;
  bool flip_x = false, flip_y = false, swap_polarity = false;
  double keep[2] = {1, 1};  // per polarity (OFF, ON): probability an event is kept
  double noise_hz = 0;
  double speed = 1;   // playback speed: step k holds the recording's [t0 + k v step, + v step)
  uint64_t seed = 0;  // for the event drop and noise draws
  bool centred = false;
};

// Cuts the sample `s` describes. Throws Error when the crop leaves the sensor, T = 0 or the
// speed is not positive.
Sample extract_sample(const LabelledSequence& seq, const SampleSpec& s, const SampleOptions& o);

// Draws a sample spec: a sequence (by `weights`, one per sequence), a time, a crop (centred on
// a random foreground event of the window with jitter, or random), augmentations; applies the
// filters. Deterministic for a given rng state.
SampleSpec draw_sample(const std::vector<const LabelledSequence*>& seqs,
                       const std::vector<double>& weights, const SampleOptions& o,
                       std::mt19937_64& rng);

// Steps of a sample and its window.
int sample_steps(const SampleOptions& o);
int warmup_steps(const SampleOptions& o);

// A seed for item `index` of stream `stream` under `seed` (splitmix64): samples are drawn from
// (seed, step, index) alone, so a resumed run sees exactly the samples a straight run sees.
uint64_t mix_seed(uint64_t seed, uint64_t stream, uint64_t index);

}  // namespace spikems
