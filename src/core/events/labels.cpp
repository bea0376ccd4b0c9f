#include "core/events/labels.h"

#include <algorithm>
#include <numeric>
#include <string>

#include "core/util/error.h"

namespace spikems {

MaskFrame filter_mask_ids(const MaskFrame& mask, const std::vector<uint16_t>& moving_ids) {
  MaskFrame out = mask;
  if (moving_ids.empty()) return out;
  std::vector<uint8_t> keep(65536, 0);
  for (uint16_t id : moving_ids) keep[id] = 1;
  for (auto& v : out.ids)
    if (!keep[v]) v = 0;
  return out;
}

MaskFrame dilate_mask(const MaskFrame& mask, int size) {
  if (size < 0 || (size > 1 && size % 2 == 0))
    fail("mask dilation", "",
         "size must be odd (e.g. 3, 5) or 0/1 for none; got " + std::to_string(size));
  MaskFrame out = mask;
  if (size <= 1) return out;
  const int r = size / 2, W = mask.width, H = mask.height;
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      if (mask.at(x, y) != 0) continue;
      int best_d = INT32_MAX;
      uint16_t best = 0;
      for (int yy = std::max(0, y - r); yy <= std::min(H - 1, y + r); ++yy) {
        for (int xx = std::max(0, x - r); xx <= std::min(W - 1, x + r); ++xx) {
          uint16_t id = mask.at(xx, yy);
          if (id == 0) continue;
          int d = (xx - x) * (xx - x) + (yy - y) * (yy - y);
          if (d < best_d || (d == best_d && id < best)) {
            best_d = d;
            best = id;
          }
        }
      }
      out.ids[size_t(y) * size_t(W) + size_t(x)] = best;
    }
  }
  return out;
}

void label_from_masks(EventStream& ev, const std::vector<MaskFrame>& masks,
                      const LabelOptions& opt) {
  const std::string src = "labelling";
  if (masks.empty()) fail(src, "", "no mask frames to label the events from");
  if (opt.dilation < 0 || (opt.dilation > 1 && opt.dilation % 2 == 0))
    fail(
        src, "",
        "dilation must be odd (e.g. 5 for 5x5) or 0 for none; got " + std::to_string(opt.dilation));
  for (size_t i = 0; i < masks.size(); ++i) {
    const auto& m = masks[i];
    if (m.width <= 0 || m.height <= 0 || m.ids.size() != size_t(m.width) * size_t(m.height))
      fail(src, "mask frame " + std::to_string(i), "size and pixel count disagree");
    if (ev.sensor.known() && (m.width != ev.sensor.width || m.height != ev.sensor.height))
      fail(src, "mask frame " + std::to_string(i),
           "mask is " + std::to_string(m.width) + "x" + std::to_string(m.height) +
               " but the sensor is " + std::to_string(ev.sensor.width) + "x" +
               std::to_string(ev.sensor.height));
  }
  // Frames in time order (stable: equal times keep their order).
  std::vector<size_t> order(masks.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return masks[a].t_us < masks[b].t_us; });
  std::vector<int64_t> times(order.size());
  for (size_t i = 0; i < order.size(); ++i) times[i] = masks[order[i]].t_us;

  ev.label.assign(ev.size(), 0);
  // Events are usually in time order, so each frame serves one run of events: prepare
  // (filter + dilate) one frame at a time.
  size_t cached = SIZE_MAX;
  MaskFrame prepared;
  for (size_t i = 0; i < ev.size(); ++i) {
    int64_t t = ev.t[i];
    size_t k = size_t(std::lower_bound(times.begin(), times.end(), t) - times.begin());
    size_t best;
    if (k == 0)
      best = 0;
    else if (k == times.size())
      best = k - 1;
    else
      best = (t - times[k - 1] <= times[k] - t) ? k - 1 : k;  // tie: the earlier frame
    int64_t gap = t > times[best] ? t - times[best] : times[best] - t;
    if (opt.max_gap_us >= 0 && gap > opt.max_gap_us) continue;
    if (best != cached) {
      prepared = dilate_mask(filter_mask_ids(masks[order[best]], opt.moving_ids), opt.dilation);
      cached = best;
    }
    if (ev.x[i] >= prepared.width || ev.y[i] >= prepared.height) continue;
    ev.label[i] = prepared.at(ev.x[i], ev.y[i]);
  }
}

}  // namespace spikems
