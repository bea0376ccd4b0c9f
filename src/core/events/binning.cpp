#include "core/events/binning.h"

#include <algorithm>
#include <numeric>
#include <string>

#include "core/util/error.h"

namespace spikems {

size_t SpikeTensor::count() const {
  return size_t(std::count_if(data.begin(), data.end(), [](uint8_t v) { return v != 0; }));
}

namespace {

struct Crop {
  int x, y, w, h;
};

Crop resolve_crop(SensorSize sensor, const BinningConfig& cfg) {
  const std::string src = "binning";
  if (cfg.step_us <= 0)
    fail(src, "", "step_us must be positive (got " + std::to_string(cfg.step_us) + ")");
  if (cfg.downsample < 1)
    fail(src, "", "downsample factor must be >= 1 (got " + std::to_string(cfg.downsample) + ")");
  if (!sensor.known())
    fail(src, "", "sensor size unknown; pass --width/--height or use a format that stores it");
  Crop c{cfg.crop_x, cfg.crop_y, cfg.crop_w, cfg.crop_h};
  if (c.w == 0 && c.h == 0) {
    if (c.x != 0 || c.y != 0) fail(src, "", "a crop offset needs a crop size");
    c.w = sensor.width;
    c.h = sensor.height;
  }
  if (c.x < 0 || c.y < 0 || c.w <= 0 || c.h <= 0 || c.x + c.w > sensor.width ||
      c.y + c.h > sensor.height)
    fail(src, "",
         "crop " + std::to_string(c.w) + "x" + std::to_string(c.h) + "+" + std::to_string(c.x) +
             "+" + std::to_string(c.y) + " does not fit the " + std::to_string(sensor.width) + "x" +
             std::to_string(sensor.height) + " sensor");
  return c;
}

// Per-axis lookup tables of a PixelMap: output column per sensor column and output row offset
// (row * W) per sensor row, -1 outside the crop.
struct AxisTables {
  std::vector<int32_t> xo, yo;
  AxisTables(SensorSize sensor, const PixelMap& pm)
      : xo(size_t(sensor.width), -1), yo(size_t(sensor.height), -1) {
    for (int x = 0; x < sensor.width; ++x) xo[size_t(x)] = pm.map_x(x);
    for (int y = 0; y < sensor.height; ++y) {
      int oy = pm.map_y(y);
      yo[size_t(y)] = oy < 0 ? -1 : oy * pm.W;
    }
  }
  // Output offset y*W + x of a sensor pixel, or -1 (outside the crop or the sensor).
  int32_t offset(uint16_t x, uint16_t y) const {
    if (x >= xo.size() || y >= yo.size()) return -1;
    int32_t ox = xo[x], oy = yo[y];
    return (ox | oy) < 0 ? -1 : oy + ox;
  }
};

}  // namespace

std::pair<int, int> binned_size(SensorSize sensor, const BinningConfig& cfg) {
  Crop c = resolve_crop(sensor, cfg);
  int f = cfg.downsample;
  return {(c.h + f - 1) / f, (c.w + f - 1) / f};
}

PixelMap::PixelMap(SensorSize sensor, const BinningConfig& cfg) {
  Crop c = resolve_crop(sensor, cfg);
  x0_ = c.x;
  y0_ = c.y;
  cw_ = c.w;
  ch_ = c.h;
  f_ = cfg.downsample;
  fx_ = cfg.flip_x;
  fy_ = cfg.flip_y;
  H = (c.h + f_ - 1) / f_;
  W = (c.w + f_ - 1) / f_;
}

SpikeTensor bin_events(const EventStream& ev, int64_t t0, int64_t window_us,
                       const BinningConfig& cfg) {
  if (window_us < 0)
    fail("binning", "",
         "window length must not be negative (got " + std::to_string(window_us) + " us)");
  PixelMap pm(ev.sensor, cfg);
  SpikeTensor s;
  s.H = pm.H;
  s.W = pm.W;
  s.T = int((window_us + cfg.step_us - 1) / cfg.step_us);
  s.data.assign(size_t(s.T) * 2 * size_t(s.H) * size_t(s.W), 0);
  auto [b, e] = ev.time_range(t0, t0 + window_us);
  const size_t plane = size_t(s.H) * size_t(s.W);
  // Per-axis lookup tables (crop, flip, downsample folded in) and a walk over step boundaries
  // instead of a division per event: the inner loop is loads and a store.
  const AxisTables tab(ev.sensor, pm);
  const int64_t* t = ev.t.data();
  const uint16_t* xs = ev.x.data();
  const uint16_t* ys = ev.y.data();
  const uint8_t* ps = ev.p.data();
  size_t i = b;
  for (int step = 0; step < s.T && i < e; ++step) {
    const int64_t step_end = t0 + int64_t(step + 1) * cfg.step_us;
    uint8_t* base = s.data.data() + size_t(step) * 2 * plane;
    for (; i < e && t[i] < step_end; ++i) {
      int32_t k = tab.offset(xs[i], ys[i]);
      if (k >= 0) base[ps[i] * plane + size_t(k)] = 1;
    }
  }
  return s;
}

WindowTruth window_truth(const EventStream& ev, int64_t t0, int64_t window_us,
                         const BinningConfig& cfg, const std::vector<uint16_t>& moving_ids) {
  PixelMap pm(ev.sensor, cfg);
  WindowTruth w;
  w.H = pm.H;
  w.W = pm.W;
  w.fg.assign(size_t(w.H) * size_t(w.W), 0);
  w.any.assign(w.fg.size(), 0);
  auto [b, e] = ev.time_range(t0, t0 + std::max<int64_t>(window_us, 0));
  // Lookup table over all uint16 ids: which ones count as foreground.
  std::vector<uint8_t> is_fg(65536, moving_ids.empty() ? 1 : 0);
  is_fg[0] = 0;
  for (uint16_t id : moving_ids)
    if (id != 0) is_fg[id] = 1;
  const AxisTables tab(ev.sensor, pm);
  const bool labelled = ev.has_labels();
  for (size_t i = b; i < e; ++i) {
    int32_t k = tab.offset(ev.x[i], ev.y[i]);
    if (k < 0) continue;
    w.any[size_t(k)] = 1;
    if (labelled && is_fg[ev.label[i]]) w.fg[size_t(k)] = 1;
  }
  return w;
}

}  // namespace spikems
