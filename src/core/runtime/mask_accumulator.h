// Mask frames from the output spikes, for any window length: frame k covers
// [origin + k*window, origin + (k+1)*window) and holds, per sensor pixel, whether the network
// predicted foreground there (an output spike at a step whose start time lies in the window;
// pixel mapping as in event_labeller.h) and how many input events fell there.
#pragma once

#include <cstdint>
#include <vector>

#include "core/events/event_stream.h"

namespace spikems {

struct PredictionFrame {
  int64_t t0_us = 0, t1_us = 0;
  int index = 0;
  int width = 0, height = 0;
  // Pixel (x, y) covers sensor pixels [x*scale, (x+1)*scale) x [y*scale, (y+1)*scale): > 1 when
  // the network sees the sensor downsampled (SegmenterOptions::downsample).
  int scale = 1;
  std::vector<uint8_t> foreground;  // [y*width + x], 0/1
  std::vector<uint16_t> events;     // input events per pixel (saturating)
  size_t foreground_pixels() const;
};

class MaskAccumulator {
 public:
  // `sensor`: the grid the network sees; scale > 1 when that is the sensor downsampled
  // (PredictionFrame::scale).
  MaskAccumulator(SensorSize sensor, int out_height, int out_width, int out_channels,
                  int64_t origin_us, int64_t window_us, int scale = 1);
  void add_event(int x, int y);
  // Output spikes of the step starting at t_us.
  void add_spikes(int64_t t_us, const std::vector<uint32_t>& spikes);
  // Moves to `out` every frame that ends at or before t_us (nothing more can fall in it).
  void close_until(int64_t t_us, std::vector<PredictionFrame>& out);
  // The frame in progress (end of stream), if it saw anything or none was emitted yet.
  void flush(std::vector<PredictionFrame>& out);

 private:
  void start(int64_t index);
  void emit(std::vector<PredictionFrame>& out);
  SensorSize sensor_;
  int oh_, ow_, oc_, scale_;
  int64_t origin_, window_;
  int64_t index_ = 0;
  bool dirty_ = false;
  std::vector<uint8_t> out_fg_;  // at output resolution
  std::vector<uint16_t> events_;
};

}  // namespace spikems
