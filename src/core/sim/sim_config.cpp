#include "core/sim/sim_config.h"

#include <toml++/toml.h>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

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
    s.check_unknown();
  }
  {
    auto s = sec("time");
    double dur = double(c.duration_us) * 1e-6;
    s.num("duration_s", dur);
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
    s.num("threshold", c.threshold);
    s.num("threshold_sigma", c.threshold_sigma);
    s.integer("refractory_us", c.refractory_us);
    s.num("leak_hz", c.leak_hz);
    s.num("shot_hz", c.shot_hz);
    s.num("hot_pixel_fraction", c.hot_pixel_fraction);
    s.num("hot_pixel_hz", c.hot_pixel_hz);
    s.num("log_eps", c.log_eps);
    s.num("photoreceptor_cutoff_hz", c.photoreceptor_cutoff_hz);
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
    s.range("illumination", c.illumination);
    s.range("ambient", c.ambient);
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
    s.check_unknown();
  }
  {
    auto s = sec("occluder");
    s.boolean("net", c.net);
    s.range("depth", c.net_depth);
    s.range("spacing", c.net_spacing);
    s.range("bar", c.net_bar);
    s.check_unknown();
  }
  {
    auto s = sec("camera");
    s.range("speed", c.camera_speed);
    s.range("angular_speed", c.camera_angular_speed);
    s.range("frequency_hz", c.camera_frequency_hz);
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
}

void validate_sim_config(const SimConfig& c, const std::string& src) {
  auto need = [&](bool ok, const char* key, const std::string& why) {
    if (!ok) fail(src, key, why);
  };
  need(c.width >= 8 && c.width <= 4096 && c.height >= 8 && c.height <= 4096, "[sensor]",
       "width and height must be within 8..4096");
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
  need(c.hot_pixel_fraction >= 0 && c.hot_pixel_fraction <= 1, "[events] hot_pixel_fraction",
       "must be in [0, 1]");
  need(c.log_eps > 0, "[events] log_eps", "must be > 0");
  need(c.photoreceptor_cutoff_hz >= 0, "[events] photoreceptor_cutoff_hz", "must be >= 0");
  need(c.background == "room" || c.background == "planes", "[scene] background",
       "use room or planes");
  need(c.planes >= 1 && c.planes <= 16, "[scene] planes", "must be in 1..16");
  need(c.room_width.lo > 0 && c.room_height.lo > 0 && c.room_depth.lo > 0, "[scene] room_*",
       "must be positive");
  need(c.plane_depth.lo > 0.05, "[scene] plane_depth", "must be > 0.05 m");
  need(c.texture_frequency.lo >= 1, "[scene] texture_frequency", "must be >= 1");
  need(c.texture_tile_m.lo > 0, "[scene] texture_tile_m", "must be positive");
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
