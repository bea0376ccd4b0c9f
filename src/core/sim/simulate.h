// The sequence driver: renders a scene at adaptive time steps, turns the samples into events,
// keeps mask frames and poses at a fixed period, and (for datasets) runs many sequences in
// parallel, one file per sequence plus a manifest with train/val/test splits.
//
// Adaptive stepping, two bounds on the next step, the smaller wins, clamped to
// [dt_min, dt_max] and cut at the next mask time (so mask frames come from the very renderings
// that made the events):
//  - brightness: dt * (f * C) / max|dL|, f = max_dlog_fraction, the max taken over pixels that
//    see the same surface in both samples (within a surface L varies smoothly);
//  - motion: max_displacement_px / (fastest image motion), measured by reprojecting visible
//    background points and object points over a short interval. Occlusion edges are
//    discontinuities in L; with steps of <= 0.5 px of motion, linear interpolation across the
//    step spreads their events over the time the edge takes to cross part of a pixel, much
//    as a real pixel integrates over its area.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/events/recording.h"
#include "core/sim/camera.h"
#include "core/sim/scene.h"
#include "core/sim/sensor_noise.h"
#include "core/sim/sim_config.h"

namespace spikems::sim {

struct SimulateOptions {
  int render_threads = 1;
  bool fixed_step = false;  // baseline: every step is dt_min (no adaptation)
  bool keep_masks = true;
  // Called after each step with the simulated time reached (us); may be empty.
  std::function<void(int64_t)> on_progress;
  const std::atomic<bool>* cancel = nullptr;  // stops early when set (the recording is cut)
};

struct SimStats {
  int64_t frames_rendered = 0;
  int64_t simulated_us = 0;
  double render_seconds = 0, events_seconds = 0;
};

Camera camera_from_config(const SimConfig& c);
// The camera of the sequence with `seed`: camera_from_config, or where [sensor] sizes or
// hfov_deg are set, a size and a field of view drawn from the seed's own generator (so the
// scene's, sensor's and motions' draws are those of a fixed camera).
Camera draw_camera(const SimConfig& c, uint64_t seed);
NoiseParams noise_from_config(const SimConfig& c);
// Seed of sequence `index` of a dataset made with `global_seed` (independent of threads).
uint64_t sequence_seed(uint64_t global_seed, int index);

// Simulates one given scene (tests build their own scenes).
Recording simulate_scene(const Scene& scene, const Camera& cam, const SimConfig& cfg, uint64_t seed,
                         const SimulateOptions& opt = {}, SimStats* stats = nullptr);
// Draws a random scene from cfg with `seed`, then simulates it.
Recording simulate_sequence(const SimConfig& cfg, uint64_t seed, const SimulateOptions& opt = {},
                            SimStats* stats = nullptr);

struct DatasetOptions {
  std::string out_dir;
  int sequences = 1;
  int threads = 1;
  uint64_t seed = 1;
  std::string format = "spikems-h5";
  bool progress = true;
  std::string config_source;  // where the config came from (manifest)
};

struct DatasetSummary {
  int sequences_written = 0;
  uint64_t events = 0;
  bool interrupted = false;
};

// Writes seq_XXXX.h5 files and manifest.json into out_dir (created if needed).
DatasetSummary simulate_dataset(const SimConfig& cfg, const DatasetOptions& opt);

}  // namespace spikems::sim
