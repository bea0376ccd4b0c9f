// From events to the network's input: a binary spike tensor over a time window, and the
// window's ground truth (which pixels saw foreground events).
//
// Conventions (docs/events.md):
// - A window is [t0, t0 + window_us): t0 inclusive, the end exclusive.
// - T = ceil(window_us / step_us) steps; an event at time t goes to step floor((t - t0) / step_us).
// - All events of one polarity at one pixel within a step collapse into one spike (value 1).
// - Geometry: crop first (sensor coordinates), then flip inside the crop, then downsample by an
//   integer factor f (pixel = floor(coord / f)); output size = ceil(crop size / f).
// Events must be in time order (EventStream's promise; readers check it).
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "core/events/event_stream.h"

namespace spikems {

struct BinningConfig {
  int64_t step_us = 1000;                              // simulation step (paper: 1 ms)
  int crop_x = 0, crop_y = 0, crop_w = 0, crop_h = 0;  // crop_w/h = 0: full sensor
  bool flip_x = false, flip_y = false;                 // applied after crop
  int downsample = 1;  // integer factor; applied after crop/flip; pixel = floor(coord/f)
};

// Binary spike tensor, time-major [T, 2, H, W]; channel c = polarity (0 OFF, 1 ON).
struct SpikeTensor {
  int T = 0, C = 2, H = 0, W = 0;
  std::vector<uint8_t> data;
  size_t index(int t, int c, int y, int x) const { return ((size_t(t) * C + c) * H + y) * W + x; }
  uint8_t at(int t, int c, int y, int x) const { return data[index(t, c, y, x)]; }
  size_t count() const;  // number of ones
};

// Output geometry (H, W) after crop/downsample for a sensor size. Throws spikems::Error when
// the crop does not fit the sensor, the sensor is unknown, or the factor/step is not positive.
std::pair<int, int> binned_size(SensorSize sensor, const BinningConfig& cfg);

// Maps a sensor pixel to the output pixel; false when it falls outside the crop.
// (Checked helper for code that bins events one by one, e.g. the streaming runtime.)
struct PixelMap {
  PixelMap(SensorSize sensor, const BinningConfig& cfg);
  int H = 0, W = 0;
  // Output column of sensor column x, or -1 outside the crop (likewise rows).
  int map_x(int x) const {
    int c = x - x0_;
    if (unsigned(c) >= unsigned(cw_)) return -1;
    return (fx_ ? cw_ - 1 - c : c) / f_;
  }
  int map_y(int y) const {
    int c = y - y0_;
    if (unsigned(c) >= unsigned(ch_)) return -1;
    return (fy_ ? ch_ - 1 - c : c) / f_;
  }
  bool map(int x, int y, int& ox, int& oy) const {
    ox = map_x(x);
    oy = map_y(y);
    return ox >= 0 && oy >= 0;
  }

 private:
  int x0_ = 0, y0_ = 0, cw_ = 0, ch_ = 0, f_ = 1;
  bool fx_ = false, fy_ = false;
};

// Window [t0, t0 + window_us): T = ceil(window_us / step_us); events at step
// floor((t - t0)/step_us); all events of one polarity at one pixel within a step collapse into
// one spike.
SpikeTensor bin_events(const EventStream& ev, int64_t t0, int64_t window_us,
                       const BinningConfig& cfg);

// Ground truth for a window (same geometry): fg[y*W+x] = 1 where an event with a label in
// `moving_ids` (empty: any non-zero label) fell in the window; any = pixels with any event.
// A stream without labels gives an all-zero fg.
struct WindowTruth {
  int H = 0, W = 0;
  std::vector<uint8_t> fg, any;
};
WindowTruth window_truth(const EventStream& ev, int64_t t0, int64_t window_us,
                         const BinningConfig& cfg, const std::vector<uint16_t>& moving_ids = {});

}  // namespace spikems
