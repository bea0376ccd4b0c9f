#include "core/events/event_stream.h"

#include <algorithm>
#include <numeric>

#include "core/util/error.h"

namespace spikems {

void EventStream::reserve(size_t n) {
  t.reserve(n);
  x.reserve(n);
  y.reserve(n);
  p.reserve(n);
  if (!label.empty()) label.reserve(n);
}

void EventStream::clear() {
  t.clear();
  x.clear();
  y.clear();
  p.clear();
  label.clear();
}

void EventStream::push_back(int64_t tt, uint16_t xx, uint16_t yy, uint8_t pp) {
  t.push_back(tt);
  x.push_back(xx);
  y.push_back(yy);
  p.push_back(pp);
  if (!label.empty()) label.push_back(0);
}

void EventStream::push_back(int64_t tt, uint16_t xx, uint16_t yy, uint8_t pp, uint16_t l) {
  if (label.size() != t.size()) add_zero_labels();
  t.push_back(tt);
  x.push_back(xx);
  y.push_back(yy);
  p.push_back(pp);
  label.push_back(l);
}

void EventStream::push_back(const Event& e) {
  push_back(e.t, e.x, e.y, e.p, e.label);
}

void EventStream::add_zero_labels() {
  label.assign(t.size(), 0);
}

void EventStream::resize_labelled(size_t n) {
  if (label.size() != t.size()) add_zero_labels();
  t.resize(n);
  x.resize(n);
  y.resize(n);
  p.resize(n);
  label.resize(n);
}

void EventStream::append(const EventStream& o) {
  append(o, 0, o.size());
}

void EventStream::append(const EventStream& o, size_t b, size_t e) {
  bool was_empty = empty();
  if (!sensor.known()) sensor = o.sensor;
  t.insert(t.end(), o.t.begin() + long(b), o.t.begin() + long(e));
  x.insert(x.end(), o.x.begin() + long(b), o.x.begin() + long(e));
  y.insert(y.end(), o.y.begin() + long(b), o.y.begin() + long(e));
  p.insert(p.end(), o.p.begin() + long(b), o.p.begin() + long(e));
  if (o.has_labels() && (was_empty || has_labels())) {
    label.insert(label.end(), o.label.begin() + long(b), o.label.begin() + long(e));
  } else if (has_labels()) {
    label.resize(t.size(), 0);
  }
}

std::pair<size_t, size_t> EventStream::time_range(int64_t t0, int64_t t1) const {
  auto b = std::lower_bound(t.begin(), t.end(), t0);
  auto e = std::lower_bound(b, t.end(), std::max(t0, t1));
  return {size_t(b - t.begin()), size_t(e - t.begin())};
}

EventStream EventStream::slice_time(int64_t t0, int64_t t1) const {
  auto [b, e] = time_range(t0, t1);
  return slice_index(b, e);
}

EventStream EventStream::slice_index(size_t b, size_t e) const {
  EventStream s;
  s.sensor = sensor;
  e = std::min(e, size());
  b = std::min(b, e);
  s.append(*this, b, e);
  if (has_labels() && !s.has_labels()) s.add_zero_labels();
  return s;
}

void EventStream::validate(const std::string& source) const {
  size_t n = t.size();
  if (x.size() != n || y.size() != n || p.size() != n || (!label.empty() && label.size() != n))
    fail(source, "", "event arrays have different lengths");
  for (size_t i = 0; i < n; ++i) {
    if (p[i] > 1) fail_at_event(source, i, "polarity " + std::to_string(p[i]) + " is not 0 or 1");
    if (sensor.known() && (x[i] >= sensor.width || y[i] >= sensor.height))
      fail_at_event(source, i,
                    "coordinates (" + std::to_string(x[i]) + ", " + std::to_string(y[i]) +
                        ") outside the " + std::to_string(sensor.width) + "x" +
                        std::to_string(sensor.height) + " sensor");
    if (i > 0 && t[i] < t[i - 1])
      fail_at_event(source, i,
                    "timestamps go back in time (" + std::to_string(t[i]) + " us after " +
                        std::to_string(t[i - 1]) + " us); use --sort to accept and sort");
  }
}

bool EventStream::is_time_sorted() const {
  return std::is_sorted(t.begin(), t.end());
}

void EventStream::sort_by_time() {
  if (is_time_sorted()) return;
  std::vector<size_t> idx(size());
  std::iota(idx.begin(), idx.end(), size_t(0));
  std::stable_sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return t[a] < t[b]; });
  auto permute = [&](auto& v) {
    if (v.empty()) return;
    auto copy = v;
    for (size_t i = 0; i < idx.size(); ++i) v[i] = copy[idx[i]];
  };
  permute(t);
  permute(x);
  permute(y);
  permute(p);
  permute(label);
}

}  // namespace spikems
