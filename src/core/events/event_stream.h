// The one event container of spikems: structure of arrays, fit for tens of millions of events.
// t is in microseconds (int64), x/y have a top-left origin, p is 1 for ON and 0 for OFF,
// label (optional) is the object id of the event, 0 for background.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace spikems {

struct SensorSize {
  int width = 0;
  int height = 0;
  bool known() const { return width > 0 && height > 0; }
  bool operator==(const SensorSize&) const = default;
};

struct Event {
  int64_t t;
  uint16_t x, y;
  uint8_t p;
  uint16_t label = 0;
};

class EventStream {
 public:
  std::vector<int64_t> t;
  std::vector<uint16_t> x, y;
  std::vector<uint8_t> p;
  std::vector<uint16_t> label;  // empty when the stream has no labels
  SensorSize sensor;

  size_t size() const { return t.size(); }
  bool empty() const { return t.empty(); }
  bool has_labels() const { return !label.empty(); }
  void reserve(size_t n);
  void clear();
  void push_back(int64_t t, uint16_t x, uint16_t y, uint8_t p);
  void push_back(int64_t t, uint16_t x, uint16_t y, uint8_t p, uint16_t label);
  void push_back(const Event& e);
  Event operator[](size_t i) const {
    return Event{t[i], x[i], y[i], p[i], label.empty() ? uint16_t(0) : label[i]};
  }
  // Appends all events of `other` (labels kept only if both have them or this is empty).
  void append(const EventStream& other);
  void append(const EventStream& other, size_t begin, size_t end);
  // Gives every event label 0 (allocates the label array).
  void add_zero_labels();
  // Resizes every array, labels included, to n events (new ones all zero), for writers that
  // fill a block of events in place rather than one push_back() per event.
  void resize_labelled(size_t n);

  // Index range of events with t in [t0, t1), by binary search (requires time order).
  std::pair<size_t, size_t> time_range(int64_t t0, int64_t t1) const;
  EventStream slice_time(int64_t t0, int64_t t1) const;
  EventStream slice_index(size_t begin, size_t end) const;

  int64_t t_first() const { return t.empty() ? 0 : t.front(); }
  int64_t t_last() const { return t.empty() ? 0 : t.back(); }
  int64_t duration_us() const { return t.empty() ? 0 : t.back() - t.front(); }

  // Throws spikems::Error naming `source` and the first offending event when coordinates are
  // outside the sensor, polarity is not 0/1, arrays differ in length, or time goes backwards.
  void validate(const std::string& source) const;
  bool is_time_sorted() const;
  // Stable sort by time (keeps the order of equal timestamps).
  void sort_by_time();
};

}  // namespace spikems
