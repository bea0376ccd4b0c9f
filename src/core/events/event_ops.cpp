#include "core/events/event_ops.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/util/error.h"

namespace spikems {

namespace {

void need_sensor(const EventStream& ev, const char* what) {
  if (!ev.sensor.known())
    fail(what, "", "sensor size unknown; pass --width/--height or use a format that stores it");
}

// Copies the events whose keep[i] is set.
EventStream select(const EventStream& ev, const std::vector<uint8_t>& keep) {
  EventStream out;
  out.sensor = ev.sensor;
  size_t n = size_t(std::count(keep.begin(), keep.end(), uint8_t(1)));
  out.reserve(n);
  if (ev.has_labels()) out.label.reserve(n);
  for (size_t i = 0; i < ev.size(); ++i) {
    if (!keep[i]) continue;
    out.t.push_back(ev.t[i]);
    out.x.push_back(ev.x[i]);
    out.y.push_back(ev.y[i]);
    out.p.push_back(ev.p[i]);
    if (ev.has_labels()) out.label.push_back(ev.label[i]);
  }
  return out;
}

}  // namespace

EventStream remap_events(const EventStream& ev, const BinningConfig& cfg) {
  PixelMap pm(ev.sensor, cfg);
  EventStream out;
  out.sensor = {pm.W, pm.H};
  out.reserve(ev.size());
  for (size_t i = 0; i < ev.size(); ++i) {
    int ox, oy;
    if (!pm.map(ev.x[i], ev.y[i], ox, oy)) continue;
    if (ev.has_labels())
      out.push_back(ev.t[i], uint16_t(ox), uint16_t(oy), ev.p[i], ev.label[i]);
    else
      out.push_back(ev.t[i], uint16_t(ox), uint16_t(oy), ev.p[i]);
  }
  return out;
}

EventStream thin_events(const EventStream& ev, double keep, uint64_t seed) {
  if (!(keep > 0 && keep <= 1))
    fail("thin events", "", "the share of events kept must lie in (0, 1]");
  if (keep == 1) return ev;
  // SplitMix64 of (seed, index): a counter-based draw, no generator state to carry.
  auto draw = [seed](uint64_t i) {
    uint64_t z = seed * 0x9E3779B97F4A7C15ull + (i + 1) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return double((z ^ (z >> 31)) >> 11) * 0x1.0p-53;  // uniform in [0, 1)
  };
  EventStream out;
  out.sensor = ev.sensor;
  out.reserve(size_t(double(ev.size()) * keep * 1.01) + 16);
  for (size_t i = 0; i < ev.size(); ++i) {
    if (draw(i) >= keep) continue;
    if (ev.has_labels())
      out.push_back(ev.t[i], ev.x[i], ev.y[i], ev.p[i], ev.label[i]);
    else
      out.push_back(ev.t[i], ev.x[i], ev.y[i], ev.p[i]);
  }
  return out;
}

BinningConfig centred_crop(SensorSize sensor, double cx, double cy, int w, int h,
                           const BinningConfig& base) {
  if (!sensor.known()) fail("crop", "", "sensor size unknown");
  if (w <= 0 || h <= 0 || w > sensor.width || h > sensor.height)
    fail("crop", "",
         "a " + std::to_string(w) + "x" + std::to_string(h) + " crop does not fit the " +
             std::to_string(sensor.width) + "x" + std::to_string(sensor.height) + " sensor");
  BinningConfig c = base;
  // (cx, cy) in pixel coordinates (as event x, y): the nearest pixel becomes the crop's pixel
  // (w/2, h/2).
  int x0 = int(std::lround(cx)) - w / 2;
  int y0 = int(std::lround(cy)) - h / 2;
  c.crop_x = std::clamp(x0, 0, sensor.width - w);
  c.crop_y = std::clamp(y0, 0, sensor.height - h);
  c.crop_w = w;
  c.crop_h = h;
  return c;
}

bool foreground_centroid(const EventStream& ev, int64_t t0, int64_t t1,
                         const std::vector<uint16_t>& moving_ids, double& cx, double& cy) {
  if (!ev.has_labels()) return false;
  auto [b, e] = ev.time_range(t0, t1);
  double sx = 0, sy = 0;
  size_t n = 0;
  for (size_t i = b; i < e; ++i) {
    uint16_t id = ev.label[i];
    if (id == 0) continue;
    if (!moving_ids.empty() &&
        std::find(moving_ids.begin(), moving_ids.end(), id) == moving_ids.end())
      continue;
    sx += ev.x[i];
    sy += ev.y[i];
    ++n;
  }
  if (n == 0) return false;
  cx = sx / double(n);
  cy = sy / double(n);
  return true;
}

namespace {

void need_known(SensorSize s, const char* what) {
  if (!s.known())
    fail(what, "", "sensor size unknown; pass --width/--height or use a format that stores it");
}

}  // namespace

RefractoryFilter::RefractoryFilter(SensorSize sensor, int64_t period_us)
    : sensor_(sensor), period_(period_us) {
  need_known(sensor, "refractory filter");
  last_.assign(size_t(sensor.width) * size_t(sensor.height), INT64_MIN);
}

EventStream RefractoryFilter::apply(const EventStream& ev) {
  std::vector<uint8_t> keep(ev.size(), 0);
  for (size_t i = 0; i < ev.size(); ++i) {
    if (ev.x[i] >= sensor_.width || ev.y[i] >= sensor_.height) continue;
    size_t k = size_t(ev.y[i]) * size_t(sensor_.width) + ev.x[i];
    if (last_[k] != INT64_MIN && ev.t[i] - last_[k] < period_) continue;
    keep[i] = 1;
    last_[k] = ev.t[i];
  }
  return select(ev, keep);
}

EventStream refractory_filter(const EventStream& ev, int64_t period_us) {
  need_sensor(ev, "refractory filter");
  return RefractoryFilter(ev.sensor, period_us).apply(ev);
}

BackgroundActivityFilter::BackgroundActivityFilter(SensorSize sensor, int64_t dt_us)
    : sensor_(sensor), dt_(dt_us) {
  need_known(sensor, "background-activity filter");
  last_.assign(size_t(sensor.width) * size_t(sensor.height), INT64_MIN);
}

EventStream BackgroundActivityFilter::apply(const EventStream& ev) {
  const int W = sensor_.width, H = sensor_.height;
  std::vector<uint8_t> keep(ev.size(), 0);
  for (size_t i = 0; i < ev.size(); ++i) {
    const int x = ev.x[i], y = ev.y[i];
    if (x >= W || y >= H) continue;
    const int64_t t = ev.t[i];
    bool support = false;
    for (int yy = std::max(0, y - 1); yy <= std::min(H - 1, y + 1) && !support; ++yy)
      for (int xx = std::max(0, x - 1); xx <= std::min(W - 1, x + 1); ++xx) {
        if (xx == x && yy == y) continue;
        int64_t lt = last_[size_t(yy) * size_t(W) + size_t(xx)];
        if (lt != INT64_MIN && t - lt <= dt_) {
          support = true;
          break;
        }
      }
    keep[i] = support;
    last_[size_t(y) * size_t(W) + size_t(x)] = t;
  }
  return select(ev, keep);
}

EventStream background_activity_filter(const EventStream& ev, int64_t dt_us) {
  need_sensor(ev, "background-activity filter");
  return BackgroundActivityFilter(ev.sensor, dt_us).apply(ev);
}

}  // namespace spikems
