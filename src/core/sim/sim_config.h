// Every parameter of the simulator, read from TOML (configs/sim/*.toml; the presets are the
// same files compiled in). Ranges are sampled per sequence from the sequence's own seed.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace spikems::sim {

struct Range {
  double lo = 0, hi = 0;
};

struct SimConfig {
  std::string name = "custom";
  // [sensor] pinhole intrinsics; fx <= 0 derives them from the DAVIS346 defaults scaled to
  // the sensor width (fx = fy = 0.65 * width, principal point at the centre).
  int width = 346, height = 260;
  double fx = 0, fy = 0, cx = -1, cy = -1;
  // Per-sequence cameras (draw_camera in simulate.h), so that a dataset spans the sensors and
  // lenses of real cameras: `sizes` lists [width, height] pairs, one drawn uniformly per
  // sequence (empty: width x height); `hfov_deg` a horizontal field of view drawn per sequence,
  // fx = fy = (width / 2) / tan(hfov / 2) ({0, 0}: fx, fy as above).
  std::vector<std::pair<int, int>> sizes;
  Range hfov_deg{0, 0};

  // [time]
  int64_t duration_us = 2'000'000;
  int64_t dt_min_us = 100;  // adaptive step bounds
  int64_t dt_max_us = 1000;
  double max_dlog_fraction = 1.0 / 3;  // target max |dL| per step on one surface, x C
  double max_displacement_px = 0.5;    // target max image motion per step (occlusion edges)
  int64_t mask_period_us = 1000;       // mask frames and poses

  // [events] (v2e-like non-idealities; `noise = "clean"` zeroes them)
  std::string noise = "noisy";
  double threshold = 0.2;         // C (log units), ON and OFF
  double threshold_sigma = 0.03;  // per-pixel mismatch (std, log units)
  int64_t refractory_us = 500;
  double leak_hz = 0.01;          // per-pixel leak event rate
  double shot_hz = 0.001;         // per-pixel shot-noise rate (each polarity half)
  double hot_pixel_fraction = 0;  // share of pixels that fire ON events at hot_pixel_hz
  double hot_pixel_hz = 50;
  double log_eps = 0.01;                       // L = log(eps + I), I in [0, 1]
  double photoreceptor_cutoff_hz = 0;          // pixel bandwidth (first-order low-pass; 0 = off)
  double threshold_asymmetry = 0;              // C_on = C (1 + a), C_off = C (1 - a)
  bool photoreceptor_light_dependent = false;  // cutoff x (I + 20/255) / (1 + 20/255) (v2e)
  // Random reset state (noisy): "on_side" L - ref in [0, C_on), "balanced" (-C_off, C_on).
  std::string initial_reference = "on_side";
  double shot_intensity_factor = 1;  // shot rate x (1 + (k - 1) I): k < 1 = more noise in the dark
  // [events] keys given as [lo, hi] (any of kDrawnEventKeys): drawn per sequence by
  // draw_sequence_config into the scalars above, which hold the midpoint meanwhile.
  std::vector<std::pair<std::string, Range>> event_ranges;

  // [scene]
  std::string background = "room";  // "room" (textured box) or "planes" (planes at depths)
  Range room_width{4, 8}, room_height{2.5, 4}, room_depth{5, 10};
  int planes = 3;
  Range plane_depth{1.5, 8};
  // Kind names (texture.h) and "dir:PATH" entries (PNG folders, image_texture.h); a preset
  // file's `textures = "PATH"` is {"dir:PATH"}. Relative paths are resolved at parsing.
  std::vector<std::string> textures{"noise", "stripes", "checkers",    "grid",
                                    "blobs", "natural", "dead_leaves", "gradient"};
  Range texture_frequency{2, 10};
  Range log_contrast{0.8, 2.5};
  Range texture_tile_m{0.5, 2.0};  // size of one texture tile in metres
  // Share of each background texture (room walls, planes) made flat by patches (texture.h,
  // apply_flat_patches), drawn per surface from its texture's seed: {0, 0} = none, and the
  // scene is otherwise unchanged by it (no draws from the sequence's generator).
  Range flat_patches{0, 0};
  Range illumination{0.4, 1.0};
  Range ambient{0.3, 0.7};
  // Lighting flicker: intensity x (1 + depth sin(2 pi f t + phase)), applied to the rendered
  // log intensity (simulate.cpp); f, depth drawn per sequence, phase uniform in [0, 2 pi).
  Range flicker_hz{0, 0}, flicker_depth{0, 0};
  double flicker_phase = 0;  // radians; set by draw_sequence_config

  // [objects]
  int objects_min = 1, objects_max = 3;
  std::vector<std::string> shapes{"sphere", "ellipsoid", "box", "disc", "rect", "star"};
  Range object_size{0.1, 0.35};  // radius / half-extent (m)
  Range object_depth{1.0, 3.5};  // distance in front of the camera at mid-sequence (m)
  Range object_speed{0.3, 2.0};  // m/s
  Range object_spin{0.0, 3.0};   // rad/s
  // Motion kinds, one drawn per object: linear (drift + sway), curved (arc), ballistic (drift
  // + gravity), spin (spinning in place, small drift).
  std::vector<std::string> object_motion{"linear"};
  // Static look-alikes: objects drawn from the same shapes/sizes/depths/textures, world-fixed,
  // labelled background (id 0), so that a network learns motion rather than object-ness.
  int static_min = 0, static_max = 0;

  // [occluder]
  bool net = false;
  Range net_depth{0.4, 0.8};
  Range net_spacing{0.04, 0.08};  // m between bars
  Range net_bar{0.004, 0.01};     // bar width (m)
  // Occluder kinds, one drawn per sequence: none, net (grid), bars (parallel bars, random
  // angle; spacing/bar as the net), foliage (leaves: thresholded low-frequency noise).
  // `net = true` means kind = ["net"].
  std::vector<std::string> occluder_kinds{"none"};
  Range leaf_size{0.02, 0.06};  // foliage: feature size of the leaf mask (m)
  Range leaf_cover{0.4, 0.7};   // foliage: fraction of the plane covered by leaves

  // [camera]
  Range camera_speed{0.0, 0.6};          // m/s (peak of the sinusoid sum, per axis scale)
  Range camera_angular_speed{0.0, 1.0};  // rad/s
  Range camera_frequency_hz{0.2, 1.5};
  // Camera motion kinds, one drawn per sequence: handheld (6-DoF sinusoids), translate (no
  // rotation), rotate (no translation), shake (6-DoF at shake_frequency_hz, same peak speeds).
  std::vector<std::string> camera_motion{"handheld"};
  Range shake_frequency_hz{3.0, 10.0};

  // [output]
  double val_fraction = 0.1, test_fraction = 0.1;
};

// Parses TOML text; every key is optional (defaults above); unknown keys are errors. Relative
// texture folders are taken from base_dir (load_sim_config: the file's folder; empty: the
// current folder, as for the compiled-in presets).
SimConfig parse_sim_config(const std::string& toml_text, const std::string& source,
                           const std::string& base_dir = "");
SimConfig load_sim_config(const std::string& path);
// "clean" zeroes mismatch, refractory, leak, shot noise and hot pixels; "noisy" keeps them.
void apply_noise_setting(SimConfig& c, const std::string& setting);
// Throws spikems::Error naming `source` for out-of-range values.
void validate_sim_config(const SimConfig& c, const std::string& source);

// The [events] keys that accept [lo, hi], in the order they are drawn.
inline constexpr const char* kDrawnEventKeys[] = {
    "threshold", "threshold_sigma", "threshold_asymmetry", "refractory_us",
    "leak_hz",   "shot_hz",         "hot_pixel_fraction",  "photoreceptor_cutoff_hz"};
// The per-sequence sensor and lighting: one uniform draw from rng per kDrawnEventKeys entry
// (whether a range or fixed, so one key's range does not shift the others), then flicker_hz,
// flicker_depth and the flicker phase. Returns c with every such range collapsed to its draw
// (event_ranges empty, flicker_hz.lo == .hi, flicker_depth.lo == .hi).
SimConfig draw_sequence_config(const SimConfig& c, std::mt19937_64& rng);
// True when c still holds [events] ranges or a flicker range (draw_sequence_config not applied).
bool has_sequence_ranges(const SimConfig& c);

}  // namespace spikems::sim
