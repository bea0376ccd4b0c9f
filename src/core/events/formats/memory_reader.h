// A reader over events already decoded in memory, for formats whose arrays must be loaded
// whole (npz, EV-IMO): hands them out in chunks like a streaming reader.
#pragma once

#include <algorithm>
#include <string>
#include <utility>

#include "core/events/io.h"

namespace spikems {

class MemoryEventReader final : public EventReader {
 public:
  MemoryEventReader(std::string format, EventStream events, Recording extras = {})
      : format_(std::move(format)), ev_(std::move(events)), extras_(std::move(extras)) {}
  std::string format_name() const override { return format_; }
  SensorSize sensor() const override { return ev_.sensor; }
  size_t read(EventStream& out, size_t max_events) override {
    size_t n = std::min(max_events, ev_.size() - pos_);
    if (n == 0) return 0;
    if (!out.sensor.known()) out.sensor = ev_.sensor;
    if (ev_.has_labels() && !out.has_labels()) out.add_zero_labels();
    out.append(ev_, pos_, pos_ + n);
    pos_ += n;
    return n;
  }
  void read_extras(Recording& rec) override {
    rec.masks = std::move(extras_.masks);
    rec.moving_ids = std::move(extras_.moving_ids);
    if (extras_.intrinsics) rec.intrinsics = extras_.intrinsics;
    rec.poses = std::move(extras_.poses);
    rec.metadata_json = extras_.metadata_json;
  }

 private:
  std::string format_;
  EventStream ev_;
  Recording extras_;
  size_t pos_ = 0;
};

}  // namespace spikems
