// Box ground truth for recordings annotated with bounding boxes instead of per-event labels
// (EED style; the paper scores such recordings with the boxes as G). A boxes file is
// CSV (docs/evaluation.md):
//
//   t_start_us,t_end_us,x0,y0,x1,y1[,id]
//   1000,21000,10,10,19,19,1
//
// one box per row, valid over [t_start_us, t_end_us) in the events' clock (microseconds),
// corners inclusive. Rows come in order of t_start_us (ties allowed: several objects at once).
// For a window [t0, t1), G = the pixels inside every box valid at some time in the window; an
// event is moving when it lies in a box valid at its own time.
#pragma once

#include <cstdint>
#include <istream>
#include <string>
#include <vector>

#include "core/events/event_stream.h"

namespace spikems {

struct Box {
  int64_t t_start_us = 0, t_end_us = 0;  // valid over [t_start_us, t_end_us)
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;    // inclusive corners, x0 <= x1, y0 <= y1
  int64_t id = -1;                       // the optional id column; -1 when absent
  uint64_t line = 0;                     // line of the file it came from (for messages)
};

class BoxTruth {
 public:
  // Parses a boxes file; `source` names it in messages. Throws Error naming source:line and
  // the reason: a missing or wrong header, a row with the wrong number of fields, a field
  // that is not a whole number, t_end_us <= t_start_us, x1 < x0 or y1 < y0, a negative
  // coordinate, t_start_us smaller than the row before, or no box at all.
  static BoxTruth parse(std::istream& in, const std::string& source);
  static BoxTruth read(const std::string& path);  // parse() of a file; Error if unreadable

  const std::string& source() const { return source_; }
  const std::vector<Box>& boxes() const { return boxes_; }

  // Throws Error naming source:line of the first box reaching outside a W x H sensor.
  void check_sensor(SensorSize sensor) const;
  // Whether pixel (x, y) lies in a box valid at t.
  bool contains(int64_t t_us, int x, int y) const;
  // Labels every event 1 when contains(t, x, y), else 0 (replacing any labels it had); one
  // sweep over time-sorted events.
  void label(EventStream& events) const;
  // Sets to 1 the pixels of `mask` (row-major, sensor-sized, checked by check_sensor) inside
  // the boxes valid at some time in [t0_us, t1_us); returns how many boxes that was.
  size_t fill_window(int64_t t0_us, int64_t t1_us, std::vector<uint8_t>& mask,
                     SensorSize sensor) const;

 private:
  // Calls f(box) for each box with t_start < t1 and t_end > t0, walking back from the last
  // box starting before t1 while an earlier box may still be valid (end_max_).
  template <class F>
  void for_valid(int64_t t0_us, int64_t t1_us, F&& f) const;

  std::string source_;
  std::vector<Box> boxes_;        // in order of t_start_us
  std::vector<int64_t> end_max_;  // end_max_[i] = max t_end_us of boxes_[0..i]
};

}  // namespace spikems
