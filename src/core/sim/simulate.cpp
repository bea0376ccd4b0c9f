#include "core/sim/simulate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>
#include <tuple>

#include "core/events/io.h"
#include "core/sim/event_generator.h"
#include "core/sim/renderer.h"
#include "core/util/atomic_file.h"
#include "core/util/error.h"
#include "core/util/interrupt.h"
#include "core/util/progress.h"
#include "core/util/splitmix.h"

namespace spikems::sim {

namespace {

PoseSample to_sample(int64_t t_us, uint16_t id, const Pose& p) {
  PoseSample s;
  s.t_us = t_us;
  s.id = id;
  s.translation = {p.t.x, p.t.y, p.t.z};
  s.rotation = {p.q.w, p.q.x, p.q.y, p.q.z};
  return s;
}

// Fastest image motion (px/s) around time t: visible static points (from the depth buffer, on a
// coarse grid) reprojected after the camera moves, and points of each moving object (centre
// and +-r along its axes) reprojected after both move. Finite difference over h seconds.
double max_image_speed(const Scene& scene, const Camera& cam, const Frame& f, double t) {
  const double h = 1e-3;
  const Pose c0 = scene.camera.at(t), c1 = scene.camera.at(t + h);
  const Mat3 R0 = c0.q.to_matrix(), R1t = c1.q.to_matrix().transposed();
  double best = 0;
  auto project = [&](const Mat3& Rt, const Vec3& ct, const Vec3& pw, double& u, double& v) {
    Vec3 pc = Rt * (pw - ct);
    if (pc.z < 0.05) return false;
    cam.project(pc, u, v);
    return true;
  };
  const int G = 6;
  for (int gy = 0; gy < G; ++gy)
    for (int gx = 0; gx < G; ++gx) {
      int x = int((gx + 0.5) * cam.width / G), y = int((gy + 0.5) * cam.height / G);
      size_t i = size_t(y) * size_t(cam.width) + size_t(x);
      float z = f.depth[i];
      if (z <= 0 || f.id[i] != 0) continue;
      Vec3 pc{(x - cam.cx) / cam.fx * z, (y - cam.cy) / cam.fy * z, z};
      Vec3 pw = R0 * pc + c0.t;
      double u, v;
      if (project(R1t, c1.t, pw, u, v)) best = std::max(best, std::hypot(u - x, v - y));
    }
  const Mat3 R0t = R0.transposed();
  for (const auto& s : scene.shapes) {
    if (s.id == 0) continue;
    const Pose o0 = s.motion.at(t), o1 = s.motion.at(t + h);
    const double r = std::max({s.half.x, s.half.y, s.half.z});
    const Vec3 pts[7] = {{0, 0, 0},  {r, 0, 0}, {-r, 0, 0}, {0, r, 0},
                         {0, -r, 0}, {0, 0, r}, {0, 0, -r}};
    for (const auto& pl : pts) {
      double u0, v0, u1, v1;
      if (project(R0t, c0.t, o0.apply(pl), u0, v0) && project(R1t, c1.t, o1.apply(pl), u1, v1))
        best = std::max(best, std::hypot(u1 - u0, v1 - v0));
    }
  }
  return best / h;
}

// Largest |dL| over pixels that see the same surface in both samples.
double max_smooth_dlog(const Frame& a, const Frame& b) {
  float mx = 0;
  const size_t n = a.log_intensity.size();
  for (size_t i = 0; i < n; ++i)
    if (a.surface[i] == b.surface[i])
      mx = std::max(mx, std::fabs(a.log_intensity[i] - b.log_intensity[i]));
  return mx;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

Camera camera_from_config(const SimConfig& c) {
  Camera cam = Camera::for_sensor(c.width, c.height);
  if (c.fx > 0) cam.fx = c.fx;
  if (c.fy > 0)
    cam.fy = c.fy;
  else if (c.fx > 0)
    cam.fy = c.fx;
  if (c.cx >= 0) cam.cx = c.cx;
  if (c.cy >= 0) cam.cy = c.cy;
  return cam;
}

Camera draw_camera(const SimConfig& c, uint64_t seed) {
  if (c.sizes.empty() && c.hfov_deg.hi <= 0) return camera_from_config(c);
  std::mt19937_64 rng(splitmix64(seed ^ 0xCA3E7A5Eull));
  // Two draws whatever is set, so that adding one key does not change the other's draw.
  const size_t k = size_t(rng() % std::max<uint64_t>(1, c.sizes.size()));
  const double u = std::uniform_real_distribution<double>(0, 1)(rng);
  SimConfig s = c;
  if (!c.sizes.empty()) std::tie(s.width, s.height) = c.sizes[k];
  Camera cam = camera_from_config(s);
  if (c.hfov_deg.hi > 0) {
    const double fov =
        (c.hfov_deg.lo + u * (c.hfov_deg.hi - c.hfov_deg.lo)) * 3.141592653589793 / 180;
    cam.fx = cam.fy = 0.5 * cam.width / std::tan(0.5 * fov);
  }
  return cam;
}

NoiseParams noise_from_config(const SimConfig& c) {
  NoiseParams n;
  n.threshold = c.threshold;
  n.threshold_sigma = c.threshold_sigma;
  n.refractory_us = c.refractory_us;
  n.leak_hz = c.leak_hz;
  n.shot_hz = c.shot_hz;
  n.hot_pixel_fraction = c.hot_pixel_fraction;
  n.hot_pixel_hz = c.hot_pixel_hz;
  n.random_initial_reference = c.noise == "noisy";
  n.photoreceptor_cutoff_hz = c.photoreceptor_cutoff_hz;
  n.threshold_asymmetry = c.threshold_asymmetry;
  n.photoreceptor_light_dependent = c.photoreceptor_light_dependent;
  n.shot_intensity_factor = c.shot_intensity_factor;
  n.log_eps = c.log_eps;
  n.balanced_initial_reference = c.initial_reference == "balanced";
  return n;
}

uint64_t sequence_seed(uint64_t global_seed, int index) {
  return splitmix64(splitmix64(global_seed) ^ splitmix64(0xC0FFEEull + uint64_t(index)));
}

Recording simulate_scene(const Scene& scene, const Camera& cam, const SimConfig& cfg_in,
                         uint64_t seed, const SimulateOptions& opt, SimStats* stats) {
  // Ranges not yet drawn (a caller that builds its own scene): draw them from this seed.
  SimConfig drawn;
  if (has_sequence_ranges(cfg_in)) {
    std::mt19937_64 rng(splitmix64(seed ^ 0x5E45A7ull));
    drawn = draw_sequence_config(cfg_in, rng);
  }
  const SimConfig& cfg = has_sequence_ranges(cfg_in) ? drawn : cfg_in;
  Recording rec;
  rec.events.sensor = {cam.width, cam.height};
  rec.events.add_zero_labels();
  rec.intrinsics = cam.intrinsics();
  rec.moving_ids = scene.moving_ids();

  Renderer renderer(scene, cam, cfg.log_eps);
  EventGenerator gen(cam.width, cam.height, noise_from_config(cfg), splitmix64(seed ^ 0xE7E7));
  SimStats st;
  Frame prev, cur;

  auto record_sample = [&](int64_t t_us, const Frame& f) {
    if (opt.keep_masks) {
      MaskFrame m;
      m.t_us = t_us;
      m.width = cam.width;
      m.height = cam.height;
      m.ids = f.id;
      rec.masks.push_back(std::move(m));
    }
    double ts = double(t_us) * 1e-6;
    rec.poses.push_back(to_sample(t_us, 0, scene.camera.at(ts)));
    for (const auto& s : scene.shapes)
      if (s.id != 0) rec.poses.push_back(to_sample(t_us, s.id, s.motion.at(ts)));
  };

  // Lighting flicker on the rendered samples: I' = I g(t), g = 1 + depth sin(2 pi f t + phase),
  // so L' = log(eps + (exp(L) - eps) g) (the renderer stays flicker-free).
  const double fl_hz = cfg.flicker_hz.lo, fl_depth = cfg.flicker_depth.lo;
  auto flicker = [&](Frame& f, int64_t t_us) {
    if (fl_hz <= 0 || fl_depth <= 0) return;
    const float g =
        float(1 + fl_depth * std::sin(2 * 3.141592653589793 * fl_hz * double(t_us) * 1e-6 +
                                      cfg.flicker_phase));
    const float eps = float(cfg.log_eps);
    for (float& L : f.log_intensity) L = std::log(eps + std::max(std::exp(L) - eps, 0.f) * g);
  };

  auto t_r = std::chrono::steady_clock::now();
  renderer.render(0.0, prev, opt.render_threads);
  flicker(prev, 0);
  st.render_seconds += seconds_since(t_r);
  ++st.frames_rendered;
  gen.reset(prev.log_intensity.data(), prev.id.data(), 0);
  record_sample(0, prev);

  const int64_t T = cfg.duration_us;
  // The smaller of the ON and OFF thresholds bounds the brightness step.
  const double target =
      cfg.max_dlog_fraction * cfg.threshold * (1 - std::fabs(cfg.threshold_asymmetry));
  int64_t t = 0, dt = cfg.dt_min_us, next_mask = cfg.mask_period_us;
  while (t < T) {
    if (opt.cancel && opt.cancel->load()) break;
    int64_t t1 = std::min({t + dt, next_mask, T});
    t_r = std::chrono::steady_clock::now();
    renderer.render(double(t1) * 1e-6, cur, opt.render_threads);
    flicker(cur, t1);
    auto t_e = std::chrono::steady_clock::now();
    st.render_seconds += std::chrono::duration<double>(t_e - t_r).count();
    ++st.frames_rendered;
    gen.step(cur.log_intensity.data(), cur.id.data(), t1, rec.events, opt.render_threads);
    st.events_seconds += seconds_since(t_e);
    if (t1 == next_mask) {
      record_sample(t1, cur);
      next_mask += cfg.mask_period_us;
    }
    const int64_t used = t1 - t;
    if (opt.fixed_step) {
      dt = cfg.dt_min_us;
    } else {
      double by_dlog = double(used) * target / std::max(max_smooth_dlog(prev, cur), 1e-9);
      double speed = max_image_speed(scene, cam, cur, double(t1) * 1e-6);
      double by_motion = speed > 0 ? cfg.max_displacement_px / speed * 1e6 : 1e18;
      double next = std::min(by_dlog, by_motion);
      dt = int64_t(std::clamp(next, double(cfg.dt_min_us), double(cfg.dt_max_us)));
    }
    std::swap(prev, cur);
    t = t1;
    if (opt.on_progress) opt.on_progress(t);
  }
  st.simulated_us = t;

  nlohmann::json meta;
  meta["generator"] = "spikems simulate";
  meta["preset"] = cfg.name;
  meta["seed"] = seed;
  meta["noise"] = cfg.noise;
  meta["threshold"] = cfg.threshold;
  meta["threshold_sigma"] = cfg.threshold_sigma;
  meta["refractory_us"] = cfg.refractory_us;
  meta["leak_hz"] = cfg.leak_hz;
  meta["shot_hz"] = cfg.shot_hz;
  meta["photoreceptor_cutoff_hz"] = cfg.photoreceptor_cutoff_hz;
  // The sensor and lighting this sequence drew (docs/simulator.md, "Sensor randomisation").
  meta["threshold_asymmetry"] = cfg.threshold_asymmetry;
  meta["threshold_on"] = cfg.threshold * (1 + cfg.threshold_asymmetry);
  meta["threshold_off"] = cfg.threshold * (1 - cfg.threshold_asymmetry);
  meta["hot_pixel_fraction"] = cfg.hot_pixel_fraction;
  meta["hot_pixel_hz"] = cfg.hot_pixel_hz;
  meta["photoreceptor_light_dependent"] = cfg.photoreceptor_light_dependent;
  meta["shot_intensity_factor"] = cfg.shot_intensity_factor;
  meta["initial_reference"] = cfg.initial_reference;
  meta["flicker"] = {{"hz", fl_hz}, {"depth", fl_depth}, {"phase", cfg.flicker_phase}};
  meta["duration_us"] = t;
  meta["mask_period_us"] = cfg.mask_period_us;
  meta["frames_rendered"] = st.frames_rendered;
  meta["label_policy"] =
      "id at the pixel in the rendered sample nearer to the crossing time; object id when one "
      "of the two samples shows background; noise events 0";
  meta["pose_convention"] =
      "camera/object to world; world = initial camera frame (x right, y down, z forward)";
  meta["camera_motion"] = scene.camera_motion;
  meta["objects"] = scene.describe();
  rec.metadata_json = meta.dump();
  if (stats) *stats = st;
  return rec;
}

Recording simulate_sequence(const SimConfig& cfg, uint64_t seed, const SimulateOptions& opt,
                            SimStats* stats) {
  std::mt19937_64 rng(seed);
  Camera cam = draw_camera(cfg, seed);
  Scene scene = make_random_scene(cfg, cam, rng);
  // Sensor and flicker after the scene, from the same generator (the scene's draws unchanged).
  const SimConfig seq = draw_sequence_config(cfg, rng);
  return simulate_scene(scene, cam, seq, seed, opt, stats);
}

DatasetSummary simulate_dataset(const SimConfig& cfg, const DatasetOptions& opt) {
  namespace fs = std::filesystem;
  if (opt.sequences < 1) fail("--sequences", "", "must be at least 1");
  if (!find_format(opt.format))
    fail(opt.out_dir, "",
         "output format '" + opt.format + "' is not in this build (see `spikems formats`)");
  std::error_code ec;
  fs::create_directories(opt.out_dir, ec);
  if (ec || !fs::is_directory(opt.out_dir))
    fail(opt.out_dir, "", "cannot create the output folder: " + ec.message());
  {
    // Writable? (fail now rather than after minutes of simulation)
    std::string probe = (fs::path(opt.out_dir) / ".spikems_write_test").string();
    std::FILE* f = std::fopen(probe.c_str(), "wb");
    if (!f) fail(opt.out_dir, "", "output folder is not writable");
    std::fclose(f);
    fs::remove(probe, ec);
  }

  const int workers = std::max(1, std::min(opt.threads, opt.sequences));
  const int render_threads = std::max(1, opt.threads / workers);
  std::atomic<int> next{0};
  std::atomic<bool> cancel{false};
  std::atomic<int64_t> done_us{0};
  std::mutex mu;
  std::vector<nlohmann::json> entries(size_t(opt.sequences));
  std::vector<bool> written(size_t(opt.sequences), false);
  std::string first_error;
  DatasetSummary summary;

  auto worker = [&] {
    while (!cancel.load()) {
      int i = next.fetch_add(1);
      if (i >= opt.sequences) break;
      try {
        SimulateOptions so;
        so.render_threads = render_threads;
        so.cancel = &cancel;
        int64_t last = 0;
        so.on_progress = [&](int64_t t) {
          done_us.fetch_add(t - last);
          last = t;
          if (interrupted()) cancel.store(true);
        };
        uint64_t seed = sequence_seed(opt.seed, i);
        Recording rec = simulate_sequence(cfg, seed, so);
        if (cancel.load()) break;
        char name[32];
        std::snprintf(name, sizeof name, "seq_%04d.h5", i);
        {
          // The HDF5 C library (serial build) is not thread-safe: one writer at a time.
          static std::mutex write_mu;
          std::lock_guard<std::mutex> lk(write_mu);
          write_recording((fs::path(opt.out_dir) / name).string(), rec, {}, opt.format);
        }
        nlohmann::json e;
        e["file"] = name;
        e["index"] = i;
        e["seed"] = seed;
        e["events"] = rec.events.size();
        e["sensor"] = {rec.events.sensor.width, rec.events.sensor.height};
        if (rec.intrinsics) e["fx"] = rec.intrinsics->fx;
        e["duration_us"] = cfg.duration_us;
        e["mask_frames"] = rec.masks.size();
        e["objects"] = rec.moving_ids.size();
        std::lock_guard<std::mutex> lk(mu);
        entries[size_t(i)] = e;
        written[size_t(i)] = true;
        summary.events += rec.events.size();
      } catch (const std::exception& ex) {
        std::lock_guard<std::mutex> lk(mu);
        if (first_error.empty()) first_error = ex.what();
        cancel.store(true);
      }
    }
  };

  ProgressBar bar("simulate", uint64_t(cfg.duration_us / 1000) * uint64_t(opt.sequences), "ms",
                  opt.progress);
  std::vector<std::thread> pool;
  for (int k = 0; k < workers; ++k) pool.emplace_back(worker);
  std::atomic<bool> all_done{false};
  std::thread watcher([&] {
    while (!all_done.load()) {
      bar.update(uint64_t(done_us.load() / 1000));
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
  for (auto& th : pool) th.join();
  all_done.store(true);
  watcher.join();
  bar.update(uint64_t(done_us.load() / 1000));
  bar.finish();
  if (!first_error.empty()) throw Error(first_error);
  summary.interrupted = cancel.load();

  // Splits: a seeded shuffle of the indices; val first, then test, the rest train.
  std::vector<int> order(size_t(opt.sequences));
  for (int i = 0; i < opt.sequences; ++i) order[size_t(i)] = i;
  uint64_t s = splitmix64(opt.seed ^ 0x5EED5EEDull);
  for (int i = opt.sequences - 1; i > 0; --i) {
    s = splitmix64(s);
    std::swap(order[size_t(i)], order[size_t(s % uint64_t(i + 1))]);
  }
  const int n_val = int(std::lround(cfg.val_fraction * opt.sequences));
  const int n_test =
      std::min(opt.sequences - n_val, int(std::lround(cfg.test_fraction * opt.sequences)));
  nlohmann::json manifest;
  manifest["generator"] = "spikems simulate";
  manifest["preset"] = cfg.name;
  manifest["config"] = opt.config_source;
  manifest["seed"] = opt.seed;
  manifest["noise"] = cfg.noise;
  // One size, or (with [sensor] sizes) the list of the sizes the sequences got.
  {
    std::vector<std::pair<int, int>> seen;
    for (int i = 0; i < opt.sequences; ++i)
      if (written[size_t(i)]) {
        std::pair<int, int> wh{entries[size_t(i)]["sensor"][0], entries[size_t(i)]["sensor"][1]};
        if (std::find(seen.begin(), seen.end(), wh) == seen.end()) seen.push_back(wh);
      }
    std::sort(seen.begin(), seen.end());
    if (seen.size() > 1) {
      manifest["sensor"] = nlohmann::json::array();
      for (auto [w, h] : seen) manifest["sensor"].push_back({w, h});
    } else {
      manifest["sensor"] = seen.empty() ? nlohmann::json::array({cfg.width, cfg.height})
                                        : nlohmann::json::array({seen[0].first, seen[0].second});
    }
  }
  manifest["duration_us"] = cfg.duration_us;
  manifest["format"] = opt.format;
  manifest["interrupted"] = summary.interrupted;
  nlohmann::json splits = {{"train", nlohmann::json::array()},
                           {"val", nlohmann::json::array()},
                           {"test", nlohmann::json::array()}};
  nlohmann::json seqs = nlohmann::json::array();
  for (int k = 0; k < opt.sequences; ++k) {
    int i = order[size_t(k)];
    if (!written[size_t(i)]) continue;
    const char* split = k < n_val ? "val" : k < n_val + n_test ? "test" : "train";
    entries[size_t(i)]["split"] = split;
    splits[split].push_back(entries[size_t(i)]["file"]);
  }
  for (int i = 0; i < opt.sequences; ++i)
    if (written[size_t(i)]) {
      seqs.push_back(entries[size_t(i)]);
      ++summary.sequences_written;
    }
  for (auto& [k, v] : splits.items()) {
    std::vector<std::string> names = v.get<std::vector<std::string>>();
    std::sort(names.begin(), names.end());
    v = names;
  }
  manifest["splits"] = splits;
  manifest["sequences"] = seqs;
  write_file_atomic((fs::path(opt.out_dir) / "manifest.json").string(), manifest.dump(2) + "\n");
  return summary;
}

}  // namespace spikems::sim
