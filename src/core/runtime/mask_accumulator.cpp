#include "core/runtime/mask_accumulator.h"

#include <algorithm>

#include "core/util/error.h"

namespace spikems {

size_t PredictionFrame::foreground_pixels() const {
  return size_t(std::count(foreground.begin(), foreground.end(), uint8_t(1)));
}

MaskAccumulator::MaskAccumulator(SensorSize sensor, int oh, int ow, int oc, int64_t origin,
                                 int64_t window, int scale)
    : sensor_(sensor), oh_(oh), ow_(ow), oc_(oc), scale_(scale), origin_(origin), window_(window) {
  if (window <= 0) fail("mask frames", "", "the mask window must be positive");
  out_fg_.assign(size_t(oh) * ow, 0);
  events_.assign(size_t(sensor.width) * sensor.height, 0);
}

void MaskAccumulator::start(int64_t index) {
  index_ = index;
  dirty_ = false;
  std::fill(out_fg_.begin(), out_fg_.end(), 0);
  std::fill(events_.begin(), events_.end(), 0);
}

void MaskAccumulator::add_event(int x, int y) {
  uint16_t& c = events_[size_t(y) * sensor_.width + x];
  if (c < 65535) ++c;
  dirty_ = true;
}

void MaskAccumulator::add_spikes(int64_t t, const std::vector<uint32_t>& spikes) {
  for (uint32_t n : spikes) out_fg_[n / uint32_t(oc_)] = 1;
  if (!spikes.empty()) dirty_ = true;
}

void MaskAccumulator::emit(std::vector<PredictionFrame>& out) {
  PredictionFrame f;
  f.index = int(index_);
  f.t0_us = origin_ + index_ * window_;
  f.t1_us = f.t0_us + window_;
  f.width = sensor_.width;
  f.height = sensor_.height;
  f.scale = scale_;
  f.foreground.assign(size_t(f.width) * f.height, 0);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      int ox = std::min(x, ow_ - 1), oy = std::min(y, oh_ - 1);
      f.foreground[size_t(y) * f.width + x] = out_fg_[size_t(oy) * ow_ + ox];
    }
  f.events = events_;
  out.push_back(std::move(f));
}

void MaskAccumulator::close_until(int64_t t, std::vector<PredictionFrame>& out) {
  while (origin_ + (index_ + 1) * window_ <= t) {
    emit(out);
    start(index_ + 1);
  }
}

void MaskAccumulator::flush(std::vector<PredictionFrame>& out) {
  if (dirty_) emit(out);
  start(index_ + 1);
}

}  // namespace spikems
