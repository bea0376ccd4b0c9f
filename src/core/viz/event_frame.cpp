#include "core/viz/event_frame.h"

#include <string>

#include "core/util/error.h"

namespace spikems {

Rgb label_color(uint16_t id) {
  static constexpr Rgb palette[] = {{255, 140, 0},  {0, 160, 160}, {200, 160, 0}, {120, 70, 20},
                                    {255, 90, 180}, {90, 90, 90},  {0, 110, 60},  {150, 110, 255}};
  return palette[(id + 7) % 8];
}

namespace {

void put(Image& img, int x, int y, Rgb c) {
  img.set(x, y, c.r, c.g, c.b);
}

// Draws the region borders of `m` on an image enlarged `scale` times: for each region pixel,
// a 1-pixel line along every side that faces a pixel outside the region. At scale 1 this is
// the contour pixel itself; at larger scales the inside of the block keeps its event colour.
void draw_outline(Image& img, const MaskFrame& m, int scale) {
  if (m.width * scale != img.width || m.height * scale != img.height)
    fail("render", "",
         "mask is " + std::to_string(m.width) + "x" + std::to_string(m.height) +
             " but the frame is " + std::to_string(img.width / scale) + "x" +
             std::to_string(img.height / scale));
  const int W = m.width, H = m.height, s = scale;
  auto in = [&](int x, int y) { return m.ids[size_t(y) * size_t(W) + size_t(x)] != 0; };
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (!in(x, y)) continue;
      int bx = x * s, by = y * s;
      if (x > 0 && !in(x - 1, y))
        for (int k = 0; k < s; ++k) put(img, bx, by + k, kOutlineColor);
      if (x + 1 < W && !in(x + 1, y))
        for (int k = 0; k < s; ++k) put(img, bx + s - 1, by + k, kOutlineColor);
      if (y > 0 && !in(x, y - 1))
        for (int k = 0; k < s; ++k) put(img, bx + k, by, kOutlineColor);
      if (y + 1 < H && !in(x, y + 1))
        for (int k = 0; k < s; ++k) put(img, bx + k, by + s - 1, kOutlineColor);
    }
}

}  // namespace

std::vector<uint8_t> mask_contour(const std::vector<uint16_t>& ids, int w, int h) {
  std::vector<uint8_t> c(size_t(w) * size_t(h), 0);
  auto in = [&](int x, int y) { return ids[size_t(y) * size_t(w) + size_t(x)] != 0; };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!in(x, y)) continue;
      bool edge = (x > 0 && !in(x - 1, y)) || (x + 1 < w && !in(x + 1, y)) ||
                  (y > 0 && !in(x, y - 1)) || (y + 1 < h && !in(x, y + 1));
      c[size_t(y) * size_t(w) + size_t(x)] = edge;
    }
  return c;
}

Image render_events(const EventStream& ev, int64_t t0, int64_t t1, SensorSize sensor,
                    const MaskFrame* mask, const RenderOptions& opt) {
  if (!sensor.known()) sensor = ev.sensor;
  if (!sensor.known()) fail("render", "", "sensor size unknown; pass --width and --height");
  Image img(sensor.width, sensor.height);
  // Bit 0: ON seen, bit 1: OFF seen; label of the last labelled event at the pixel.
  std::vector<uint8_t> seen(size_t(sensor.width) * size_t(sensor.height), 0);
  std::vector<uint16_t> lab(opt.show_labels ? seen.size() : 0, 0);
  auto [b, e] = ev.time_range(t0, t1);
  for (size_t i = b; i < e; ++i) {
    if (ev.x[i] >= sensor.width || ev.y[i] >= sensor.height) continue;
    size_t k = size_t(ev.y[i]) * size_t(sensor.width) + ev.x[i];
    seen[k] |= ev.p[i] ? 1 : 2;
    if (opt.show_labels && ev.has_labels() && ev.label[i] != 0) lab[k] = ev.label[i];
  }
  for (int y = 0; y < sensor.height; ++y)
    for (int x = 0; x < sensor.width; ++x) {
      size_t k = size_t(y) * size_t(sensor.width) + size_t(x);
      if (!seen[k]) continue;
      if (opt.show_labels && lab[k])
        put(img, x, y, label_color(lab[k]));
      else
        put(img, x, y, seen[k] == 1 ? kOnColor : seen[k] == 2 ? kOffColor : kBothColor);
    }
  img = upscale(img, opt.scale);
  if (mask && opt.outline_mask) draw_outline(img, *mask, opt.scale);
  return img;
}

Image render_mask(const std::vector<uint8_t>& mask, int w, int h, const MaskFrame* truth,
                  const RenderOptions& opt) {
  if (mask.size() != size_t(w) * size_t(h)) fail("render", "", "mask size does not match w x h");
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (mask[size_t(y) * size_t(w) + size_t(x)]) put(img, x, y, kMaskColor);
  img = upscale(img, opt.scale);
  if (truth && opt.outline_mask) draw_outline(img, *truth, opt.scale);
  return img;
}

Image render_comparison(const std::vector<uint8_t>& predicted, const std::vector<uint8_t>& truth,
                        int w, int h, int scale) {
  size_t n = size_t(w) * size_t(h);
  if (predicted.size() != n || truth.size() != n)
    fail("render", "", "prediction and truth sizes do not match w x h");
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      size_t k = size_t(y) * size_t(w) + size_t(x);
      bool p = predicted[k] != 0, g = truth[k] != 0;
      if (p && g)
        put(img, x, y, kTruePositive);
      else if (p)
        put(img, x, y, kFalsePositive);
      else if (g)
        put(img, x, y, kFalseNegative);
    }
  return upscale(img, scale);
}

Image render_spikes(const SpikeTensor& s, int scale) {
  Image img(s.W, s.H);
  for (int y = 0; y < s.H; ++y)
    for (int x = 0; x < s.W; ++x) {
      bool on = false, off = false;
      for (int t = 0; t < s.T; ++t) {
        on |= s.at(t, 1, y, x) != 0;
        off |= s.at(t, 0, y, x) != 0;
      }
      if (on || off) put(img, x, y, on && off ? kBothColor : on ? kOnColor : kOffColor);
    }
  return upscale(img, scale);
}

}  // namespace spikems
