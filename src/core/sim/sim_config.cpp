#include "core/sim/sim_config.h"

#include <toml++/toml.h>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <tuple>

#include "core/sim/image_texture.h"
#include "core/sim/texture.h"
#include "core/util/error.h"

namespace spikems::sim {

namespace {

// Reads the keys of one [section], remembering which it knew, so that typos are reported.
class Section {
 public:
  Section(const toml::table* t, std::string name, std::string source)
      : t_(t), name_(std::move(name)), source_(std::move(source)) {}

  void num(const char* key, double& out) {
    if (auto* n = get(key)) {
      if (auto v = n->value<double>())
        out = *v;
      else
        bad(key, "a number");
    }
  }
  void integer(const char* key, int64_t& out) {
    if (auto* n = get(key)) {
      if (auto v = n->value<int64_t>())
        out = *v;
      else
        bad(key, "an integer");
    }
  }
  void integer(const char* key, int& out) {
    int64_t v = out;
    integer(key, v);
    if (v < -2147483647 || v > 2147483647) bad(key, "an integer of reasonable size");
    out = int(v);
  }
  void boolean(const char* key, bool& out) {
    if (auto* n = get(key)) {
      if (auto v = n->value<bool>())
        out = *v;
      else
        bad(key, "true or false");
    }
  }
  void str(const char* key, std::string& out) {
    if (auto* n = get(key)) {
      if (auto v = n->value<std::string>())
        out = *v;
      else
        bad(key, "a string");
    }
  }
  void range(const char* key, Range& out) {
    if (auto* n = get(key)) {
      auto* a = n->as_array();
      if (!a || a->size() != 2 || !(*a)[0].value<double>() || !(*a)[1].value<double>())
        bad(key, "[low, high]");
      out.lo = *(*a)[0].value<double>();
      out.hi = *(*a)[1].value<double>();
      if (out.lo > out.hi) bad(key, "[low, high] with low <= high");
    }
  }
  // A number, or [low, high] recorded in ranges (out = midpoint meanwhile).
  void num_or_range(const char* key, double& out,
                    std::vector<std::pair<std::string, Range>>& ranges) {
    if (auto* n = get(key)) {
      if (n->is_array()) {
        Range r;
        range(key, r);
        ranges.emplace_back(key, r);
        out = 0.5 * (r.lo + r.hi);
      } else if (auto v = n->value<double>()) {
        out = *v;
      } else {
        bad(key, "a number or [low, high]");
      }
    }
  }
  // [low, high], or a number x meaning [x, x].
  void range_or_num(const char* key, Range& out) {
    if (auto* n = get(key)) {
      if (n->is_array()) {
        range(key, out);
      } else if (auto v = n->value<double>()) {
        out = {*v, *v};
      } else {
        bad(key, "a number or [low, high]");
      }
    }
  }
  void strings(const char* key, std::vector<std::string>& out) {
    if (auto* n = get(key)) {
      auto* a = n->as_array();
      if (!a || a->empty()) bad(key, "a non-empty list of strings");
      out.clear();
      for (auto& e : *a) {
        auto v = e.value<std::string>();
        if (!v) bad(key, "a list of strings");
        out.push_back(*v);
      }
    }
  }
  // A non-empty list of [width, height] pairs of integers.
  void sizes(const char* key, std::vector<std::pair<int, int>>& out) {
    auto* n = get(key);
    if (!n) return;
    auto* a = n->as_array();
    if (!a || a->empty()) bad(key, "a non-empty list of [width, height] pairs");
    out.clear();
    for (auto& e : *a) {
      auto* p = e.as_array();
      if (!p || p->size() != 2 || !(*p)[0].value<int64_t>() || !(*p)[1].value<int64_t>())
        bad(key, "a list of [width, height] pairs of integers");
      const int64_t w = *(*p)[0].value<int64_t>(), h = *(*p)[1].value<int64_t>();
      if (w < 8 || w > 4096 || h < 8 || h > 4096) bad(key, "sizes within 8..4096");
      out.emplace_back(int(w), int(h));
    }
  }
  // `textures`: a list of kind names and "dir:PATH" entries, or one string PATH (= "dir:PATH").
  // Relative paths are taken from base_dir (the config file's folder; empty: current folder).
  void textures(const char* key, std::vector<std::string>& out, const std::string& base_dir) {
    auto* n = get(key);
    if (!n) return;
    const std::string prefix = kTextureDirPrefix;
    auto resolve = [&](const std::string& path) {
      if (path.empty()) bad(key, "a non-empty folder path");
      std::filesystem::path p(path);
      if (p.is_relative() && !base_dir.empty()) p = std::filesystem::path(base_dir) / p;
      return prefix + p.lexically_normal().string();
    };
    if (auto v = n->value<std::string>()) {
      out = {resolve(*v)};
      return;
    }
    strings(key, out);
    for (auto& e : out)
      if (e.rfind(prefix, 0) == 0) e = resolve(e.substr(prefix.size()));
  }
  void check_unknown() const {
    if (!t_) return;
    for (auto&& [k, v] : *t_)
      if (!known_.count(std::string(k.str())))
        fail(source_, "[" + name_ + "]",
             "unknown key '" + std::string(k.str()) + "' (see docs/simulator.md for every key)");
  }

 private:
  const toml::node* get(const char* key) {
    known_.insert(key);
    return t_ ? t_->get(key) : nullptr;
  }
  [[noreturn]] void bad(const char* key, const char* what) const {
    fail(source_, "[" + name_ + "] " + key, std::string("expected ") + what);
  }
  const toml::table* t_;
  std::string name_, source_;
  std::set<std::string> known_;
};

}  // namespace

SimConfig parse_sim_config(const std::string& text, const std::string& source,
                           const std::string& base_dir) {
  toml::table root;
  try {
    root = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    fail(source, "line " + std::to_string(e.source().begin.line),
         std::string(e.description()) + " (not valid TOML)");
  }
  SimConfig c;
  static const std::set<std::string> sections{"preset",  "sensor",   "time",   "events", "scene",
                                              "objects", "occluder", "camera", "output"};
  for (auto&& [k, v] : root) {
    if (!sections.count(std::string(k.str())) || !v.is_table())
      fail(source, "",
           "unknown section or key '" + std::string(k.str()) +
               "' at top level (sections: preset sensor time events scene objects "
               "occluder camera output)");
  }
  auto sec = [&](const char* n) { return Section(root[n].as_table(), n, source); };
  {
    auto s = sec("preset");
    s.str("name", c.name);
    s.check_unknown();
  }
  {
    auto s = sec("sensor");
    s.integer("width", c.width);
    s.integer("height", c.height);
    s.num("fx", c.fx);
    s.num("fy", c.fy);
    s.num("cx", c.cx);
    s.num("cy", c.cy);
    s.sizes("sizes", c.sizes);
    s.range_or_num("hfov_deg", c.hfov_deg);
    s.check_unknown();
  }
  {
    auto s = sec("time");
    double dur = double(c.duration_us) * 1e-6;
    s.num("duration_s", dur);
    // Checked before the conversion: llround of 1e300 or NaN is undefined.
    if (!(dur > 0 && dur <= 1e6)) fail(source, "[time] duration_s", "must be within (0, 10^6] s");
    c.duration_us = int64_t(std::llround(dur * 1e6));
    s.integer("dt_min_us", c.dt_min_us);
    s.integer("dt_max_us", c.dt_max_us);
    s.num("max_dlog_fraction", c.max_dlog_fraction);
    s.num("max_displacement_px", c.max_displacement_px);
    s.integer("mask_period_us", c.mask_period_us);
    s.check_unknown();
  }
  {
    auto s = sec("events");
    s.str("noise", c.noise);
    auto& rs = c.event_ranges;
    s.num_or_range("threshold", c.threshold, rs);
    s.num_or_range("threshold_sigma", c.threshold_sigma, rs);
    double refr = double(c.refractory_us);
    s.num_or_range("refractory_us", refr, rs);
    c.refractory_us = int64_t(std::llround(refr));
    s.num_or_range("leak_hz", c.leak_hz, rs);
    s.num_or_range("shot_hz", c.shot_hz, rs);
    s.num_or_range("hot_pixel_fraction", c.hot_pixel_fraction, rs);
    s.num("hot_pixel_hz", c.hot_pixel_hz);
    s.num("log_eps", c.log_eps);
    s.num_or_range("photoreceptor_cutoff_hz", c.photoreceptor_cutoff_hz, rs);
    s.num_or_range("threshold_asymmetry", c.threshold_asymmetry, rs);
    s.boolean("photoreceptor_light_dependent", c.photoreceptor_light_dependent);
    s.num("shot_intensity_factor", c.shot_intensity_factor);
    s.str("initial_reference", c.initial_reference);
    s.check_unknown();
  }
  {
    auto s = sec("scene");
    s.str("background", c.background);
    s.range("room_width", c.room_width);
    s.range("room_height", c.room_height);
    s.range("room_depth", c.room_depth);
    s.integer("planes", c.planes);
    s.range("plane_depth", c.plane_depth);
    s.textures("textures", c.textures, base_dir);
    s.range("texture_frequency", c.texture_frequency);
    s.range("log_contrast", c.log_contrast);
    s.range("texture_tile_m", c.texture_tile_m);
    s.range("flat_patches", c.flat_patches);
    s.range("illumination", c.illumination);
    s.range("ambient", c.ambient);
    s.range_or_num("flicker_hz", c.flicker_hz);
    s.range_or_num("flicker_depth", c.flicker_depth);
    s.check_unknown();
  }
  {
    auto s = sec("objects");
    s.integer("min", c.objects_min);
    s.integer("max", c.objects_max);
    s.strings("shapes", c.shapes);
    s.range("size", c.object_size);
    s.range("depth", c.object_depth);
    s.range("speed", c.object_speed);
    s.range("spin", c.object_spin);
    s.strings("motion", c.object_motion);
    s.integer("static_min", c.static_min);
    s.integer("static_max", c.static_max);
    s.check_unknown();
  }
  {
    auto s = sec("occluder");
    s.boolean("net", c.net);
    s.range("depth", c.net_depth);
    s.range("spacing", c.net_spacing);
    s.range("bar", c.net_bar);
    s.strings("kind", c.occluder_kinds);
    s.range("leaf_size", c.leaf_size);
    s.range("leaf_cover", c.leaf_cover);
    s.check_unknown();
    const auto* t = root["occluder"].as_table();
    if (c.net && t && t->contains("kind"))
      fail(source, "[occluder] net", "give either net = true or kind = [...], not both");
    if (c.net) c.occluder_kinds = {"net"};
  }
  {
    auto s = sec("camera");
    s.range("speed", c.camera_speed);
    s.range("angular_speed", c.camera_angular_speed);
    s.range("frequency_hz", c.camera_frequency_hz);
    s.strings("motion", c.camera_motion);
    s.range("shake_frequency_hz", c.shake_frequency_hz);
    s.check_unknown();
  }
  {
    auto s = sec("output");
    s.num("val_fraction", c.val_fraction);
    s.num("test_fraction", c.test_fraction);
    s.check_unknown();
  }
  validate_sim_config(c, source);
  return c;
}

SimConfig load_sim_config(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail(path, "", "cannot open the simulator config (check the path)");
  std::stringstream ss;
  ss << f.rdbuf();
  return parse_sim_config(ss.str(), path, std::filesystem::path(path).parent_path().string());
}

void apply_noise_setting(SimConfig& c, const std::string& setting) {
  if (setting == "noisy") {
    c.noise = "noisy";
    return;
  }
  if (setting != "clean") fail("--noise", "", "'" + setting + "': use clean or noisy");
  c.noise = "clean";
  c.threshold_sigma = 0;
  c.refractory_us = 0;
  c.leak_hz = 0;
  c.shot_hz = 0;
  c.hot_pixel_fraction = 0;
  c.photoreceptor_cutoff_hz = 0;
  std::erase_if(c.event_ranges, [](const auto& kv) {
    return kv.first != "threshold" && kv.first != "threshold_asymmetry";
  });
}

namespace {

void set_event_key(SimConfig& c, const std::string& k, double v) {
  if (k == "threshold")
    c.threshold = v;
  else if (k == "threshold_sigma")
    c.threshold_sigma = v;
  else if (k == "threshold_asymmetry")
    c.threshold_asymmetry = v;
  else if (k == "refractory_us")
    c.refractory_us = int64_t(std::llround(v));
  else if (k == "leak_hz")
    c.leak_hz = v;
  else if (k == "shot_hz")
    c.shot_hz = v;
  else if (k == "hot_pixel_fraction")
    c.hot_pixel_fraction = v;
  else if (k == "photoreceptor_cutoff_hz")
    c.photoreceptor_cutoff_hz = v;
  else
    fail("[events] " + k, "", "does not accept [low, high]");
}

const Range* find_range(const SimConfig& c, const std::string& k) {
  for (const auto& [name, r] : c.event_ranges)
    if (name == k) return &r;
  return nullptr;
}

}  // namespace

bool has_sequence_ranges(const SimConfig& c) {
  return !c.event_ranges.empty() || c.flicker_hz.lo != c.flicker_hz.hi ||
         c.flicker_depth.lo != c.flicker_depth.hi;
}

SimConfig draw_sequence_config(const SimConfig& c, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(0, 1);
  SimConfig out = c;
  for (const char* k : kDrawnEventKeys) {
    const double u = U(rng);  // drawn for fixed keys too: the order never shifts
    if (const Range* r = find_range(c, k)) set_event_key(out, k, r->lo + (r->hi - r->lo) * u);
  }
  out.event_ranges.clear();
  const double f = c.flicker_hz.lo + (c.flicker_hz.hi - c.flicker_hz.lo) * U(rng);
  const double d = c.flicker_depth.lo + (c.flicker_depth.hi - c.flicker_depth.lo) * U(rng);
  out.flicker_hz = {f, f};
  out.flicker_depth = {d, d};
  out.flicker_phase = 2 * 3.141592653589793 * U(rng);
  return out;
}

void validate_sim_config(const SimConfig& c, const std::string& src) {
  if (!c.event_ranges.empty()) {
    // Each range end must be valid with the other keys as they are, and mismatch must stay
    // below the smallest threshold.
    SimConfig base = c;
    base.event_ranges.clear();
    for (const auto& [k, r] : c.event_ranges)
      for (double v : {r.lo, r.hi}) {
        SimConfig e = base;
        set_event_key(e, k, v);
        validate_sim_config(e, src);
      }
    const Range* t = find_range(c, "threshold");
    const Range* sg = find_range(c, "threshold_sigma");
    SimConfig worst = base;
    worst.threshold = t ? t->lo : c.threshold;
    worst.threshold_sigma = sg ? sg->hi : c.threshold_sigma;
    validate_sim_config(worst, src);
    validate_sim_config(base, src);
    return;
  }
  auto need = [&](bool ok, const char* key, const std::string& why) {
    if (!ok) fail(src, key, why);
  };
  need(c.width >= 8 && c.width <= 4096 && c.height >= 8 && c.height <= 4096, "[sensor]",
       "width and height must be within 8..4096");
  need(c.hfov_deg.hi == 0 || (c.hfov_deg.lo >= 10 && c.hfov_deg.hi <= 170), "[sensor] hfov_deg",
       "must be within [10, 170] degrees (or 0: fx, fy as given)");
  need(c.hfov_deg.hi == 0 || (c.fx <= 0 && c.fy <= 0), "[sensor] hfov_deg",
       "sets the focal length: remove fx and fy, or hfov_deg");
  need(c.sizes.empty() || (c.cx < 0 && c.cy < 0), "[sensor] sizes",
       "each size has its own image centre: remove cx and cy, or sizes");
  for (const auto& [w, h] : c.sizes)
    need(w >= 8 && w <= 4096 && h >= 8 && h <= 4096, "[sensor] sizes",
         "each width and height must be within 8..4096");
  need(c.duration_us > 0, "[time] duration_s", "must be positive");
  need(c.dt_min_us >= 1 && c.dt_max_us >= c.dt_min_us, "[time] dt_min_us/dt_max_us",
       "need 1 <= dt_min_us <= dt_max_us");
  need(c.max_dlog_fraction > 0 && c.max_dlog_fraction <= 1, "[time] max_dlog_fraction",
       "must be in (0, 1]");
  need(c.max_displacement_px > 0, "[time] max_displacement_px", "must be positive");
  need(c.mask_period_us >= 100, "[time] mask_period_us", "must be >= 100");
  need(c.noise == "clean" || c.noise == "noisy", "[events] noise", "use clean or noisy");
  need(c.threshold >= 0.01 && c.threshold <= 5, "[events] threshold", "must be in [0.01, 5]");
  need(c.threshold_sigma >= 0 && c.threshold_sigma < c.threshold, "[events] threshold_sigma",
       "must be in [0, threshold)");
  need(c.refractory_us >= 0, "[events] refractory_us", "must be >= 0");
  need(c.leak_hz >= 0 && c.shot_hz >= 0 && c.hot_pixel_hz >= 0, "[events]", "rates must be >= 0");
  // Noise rates are per pixel: a real sensor leaks ~0.1 Hz and shows ~0.1-5 Hz of shot noise
  // in the dark, and a hot pixel fires up to a few kHz (v2e's defaults and ranges). Far larger
  // rates are typing errors that would run for hours (1e9 Hz: 5 ms of a 64x48 scene in 73 s).
  need(c.leak_hz <= 100, "[events] leak_hz", "must be within [0, 100] Hz per pixel");
  need(c.shot_hz <= 100, "[events] shot_hz", "must be within [0, 100] Hz per pixel");
  need(c.hot_pixel_hz <= 1e4, "[events] hot_pixel_hz", "must be within [0, 10000] Hz");
  {  // and within the caps, the noise of a whole sequence must stay a stream, not a flood
    double pixels = double(c.width) * c.height;
    for (const auto& [w, h] : c.sizes) pixels = std::max(pixels, double(w) * h);
    const double per_pixel_hz = c.leak_hz + c.shot_hz + c.hot_pixel_fraction * c.hot_pixel_hz;
    const double noise_events = per_pixel_hz * pixels * (double(c.duration_us) * 1e-6);
    char n[32];
    std::snprintf(n, sizeof n, "%.3g", noise_events);
    need(noise_events <= 1e9, "[events]",
         std::string("the noise rates would give ~") + n +
             " noise events per sequence (more than 10^9: rates x pixels x duration); lower "
             "leak_hz, shot_hz or hot pixels, the sensor size or the duration");
  }
  need(c.hot_pixel_fraction >= 0 && c.hot_pixel_fraction <= 1, "[events] hot_pixel_fraction",
       "must be in [0, 1]");
  need(c.log_eps > 0, "[events] log_eps", "must be > 0");
  need(c.photoreceptor_cutoff_hz >= 0, "[events] photoreceptor_cutoff_hz", "must be >= 0");
  need(c.threshold_asymmetry >= -0.9 && c.threshold_asymmetry <= 0.9,
       "[events] threshold_asymmetry", "must be in [-0.9, 0.9]");
  need(c.initial_reference == "on_side" || c.initial_reference == "balanced",
       "[events] initial_reference", "use on_side or balanced");
  need(c.shot_intensity_factor >= 0 && c.shot_intensity_factor <= 1,
       "[events] shot_intensity_factor", "must be in [0, 1]");
  need(c.flicker_hz.lo >= 0 && c.flicker_hz.hi <= 1e4, "[scene] flicker_hz",
       "must be within [0, 10000] Hz");
  need(c.flicker_depth.lo >= 0 && c.flicker_depth.hi < 1, "[scene] flicker_depth",
       "must be within [0, 1)");
  need(c.background == "room" || c.background == "planes", "[scene] background",
       "use room or planes");
  need(c.planes >= 1 && c.planes <= 16, "[scene] planes", "must be in 1..16");
  need(c.room_width.lo > 0 && c.room_height.lo > 0 && c.room_depth.lo > 0, "[scene] room_*",
       "must be positive");
  // Lengths, speeds and frequencies of a scene seen by a camera: each range finite and below a
  // bound no scene needs (a room of 10^300 m overflowed the geometry to inf and NaN).
  for (const auto& [r, key, max] :
       std::initializer_list<std::tuple<const Range&, const char*, double>>{
           {c.room_width, "[scene] room_width", 1e4},
           {c.room_height, "[scene] room_height", 1e4},
           {c.room_depth, "[scene] room_depth", 1e4},
           {c.plane_depth, "[scene] plane_depth", 1e4},
           {c.texture_frequency, "[scene] texture_frequency", 1e4},
           {c.log_contrast, "[scene] log_contrast", 100},
           {c.texture_tile_m, "[scene] texture_tile_m", 1e4},
           {c.illumination, "[scene] illumination", 1e4},
           {c.object_size, "[objects] size", 1e3},
           {c.object_depth, "[objects] depth", 1e4},
           {c.object_speed, "[objects] speed", 1e3},
           {c.object_spin, "[objects] spin", 1e3},
           {c.net_depth, "[occluder] net_depth", 1e4},
           {c.net_spacing, "[occluder] net_spacing", 1e3},
           {c.leaf_size, "[occluder] leaf_size", 1e3},
           {c.camera_speed, "[camera] speed", 1e3},
           {c.camera_angular_speed, "[camera] angular_speed", 1e3},
           {c.camera_frequency_hz, "[camera] frequency_hz", 1e4},
           {c.shake_frequency_hz, "[camera] shake_frequency_hz", 1e4}})
    need(std::isfinite(r.lo) && std::isfinite(r.hi) && r.hi <= max, key,
         "must be at most " + std::to_string(int64_t(max)));
  need(c.plane_depth.lo > 0.05, "[scene] plane_depth", "must be > 0.05 m");
  need(c.texture_frequency.lo >= 1, "[scene] texture_frequency", "must be >= 1");
  need(c.texture_tile_m.lo > 0, "[scene] texture_tile_m", "must be positive");
  need(c.flat_patches.lo >= 0 && c.flat_patches.hi <= 0.9, "[scene] flat_patches",
       "must be within [0, 0.9] (a share of the tile)");
  need(c.illumination.lo > 0, "[scene] illumination", "must be positive");
  need(c.ambient.lo >= 0 && c.ambient.hi <= 1, "[scene] ambient", "must be within [0, 1]");
  need(c.objects_min >= 0 && c.objects_max >= c.objects_min && c.objects_max <= 64,
       "[objects] min/max", "need 0 <= min <= max <= 64");
  need(c.object_size.lo > 0, "[objects] size", "must be positive");
  need(c.object_depth.lo > 0.1, "[objects] depth", "must be > 0.1 m");
  need(c.object_speed.lo >= 0 && c.object_spin.lo >= 0, "[objects] speed/spin", "must be >= 0");
  need(c.net_depth.lo > 0.05 && c.net_spacing.lo > 0 && c.net_bar.lo > 0 &&
           c.net_bar.hi < c.net_spacing.lo,
       "[occluder]", "need depth > 0.05, spacing > 0, 0 < bar < spacing");
  need(c.camera_speed.lo >= 0 && c.camera_angular_speed.lo >= 0 && c.camera_frequency_hz.lo > 0,
       "[camera]", "speeds must be >= 0 and frequencies > 0");
  need(c.val_fraction >= 0 && c.test_fraction >= 0 && c.val_fraction + c.test_fraction <= 1,
       "[output]", "need val_fraction, test_fraction >= 0 with sum <= 1");
  for (const auto& s : c.shapes)
    need(s == "sphere" || s == "ellipsoid" || s == "box" || s == "disc" || s == "rect" ||
             s == "star",
         "[objects] shapes", "unknown shape '" + s + "' (sphere ellipsoid box disc rect star)");
  need(c.static_min >= 0 && c.static_max >= c.static_min && c.static_max <= 64,
       "[objects] static_min/static_max", "need 0 <= static_min <= static_max <= 64");
  need(c.leaf_size.lo > 0, "[occluder] leaf_size", "must be positive");
  need(c.leaf_cover.lo > 0 && c.leaf_cover.hi < 1, "[occluder] leaf_cover",
       "must be within (0, 1)");
  need(c.shake_frequency_hz.lo > 0, "[camera] shake_frequency_hz", "must be > 0");
  auto one_of = [&](const std::vector<std::string>& list, const char* key,
                    const std::vector<std::string>& names) {
    std::string all;
    for (const auto& n : names) all += (all.empty() ? "" : " ") + n;
    need(!list.empty(), key, "must list at least one of: " + all);
    for (const auto& v : list)
      need(std::find(names.begin(), names.end(), v) != names.end(), key,
           "unknown kind '" + v + "' (" + all + ")");
  };
  one_of(c.object_motion, "[objects] motion", {"linear", "curved", "ballistic", "spin"});
  one_of(c.camera_motion, "[camera] motion", {"handheld", "translate", "rotate", "shake", "glide"});
  one_of(c.occluder_kinds, "[occluder] kind", {"none", "net", "bars", "foliage"});
  need(!c.textures.empty(), "[scene] textures", "must not be empty");
  const std::string prefix = kTextureDirPrefix;
  for (const auto& t : c.textures) {
    if (t.rfind(prefix, 0) == 0) {
      try {
        image_texture_files(t.substr(prefix.size()));  // folder exists, holds readable PNGs
      } catch (const Error& e) {
        fail(src, "[scene] textures", e.what());
      }
      continue;
    }
    need(is_texture_kind_name(t), "[scene] textures",
         "unknown texture '" + t + "' (" + texture_kind_names() + ", or dir:PATH)");
  }
}

}  // namespace spikems::sim
