#include "core/eval/boxes.h"

#include <algorithm>
#include <charconv>
#include <climits>
#include <fstream>
#include <string_view>

#include "core/util/error.h"

namespace spikems {

namespace {

constexpr const char* kHeader = "t_start_us,t_end_us,x0,y0,x1,y1";

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_commas(std::string_view s) {
  std::vector<std::string_view> out;
  for (;;) {
    const size_t c = s.find(',');
    out.push_back(trim(s.substr(0, c)));
    if (c == std::string_view::npos) return out;
    s.remove_prefix(c + 1);
  }
}

}  // namespace

BoxTruth BoxTruth::parse(std::istream& in, const std::string& source) {
  BoxTruth b;
  b.source_ = source;
  std::string raw;
  uint64_t no = 0, header_line = 0;
  size_t fields = 0;  // 6 or 7, from the header
  const std::string header_text =
      std::string("the header '") + kHeader + "' or '" + kHeader + ",id' (docs/evaluation.md)";
  while (std::getline(in, raw)) {
    ++no;
    const std::string_view line = trim(raw);
    if (line.empty() || line.front() == '#') continue;  // blank lines and comments
    std::vector<std::string_view> f = split_commas(line);
    if (fields == 0) {
      std::string h;
      for (size_t i = 0; i < f.size(); ++i) h += (i ? "," : "") + std::string(f[i]);
      if (h == kHeader)
        fields = 6;
      else if (h == std::string(kHeader) + ",id")
        fields = 7;
      else
        fail_at_line(
            source, no,
            "expected " + header_text + ", found \"" + std::string(line.substr(0, 120)) + "\"");
      header_line = no;
      continue;
    }
    if (f.size() != fields)
      fail_at_line(source, no,
                   "expected " + std::to_string(fields) + " comma-separated fields, found " +
                       std::to_string(f.size()));
    static const char* names[] = {"t_start_us", "t_end_us", "x0", "y0", "x1", "y1", "id"};
    int64_t v[7] = {};
    for (size_t i = 0; i < fields; ++i) {
      const auto [end, ec] = std::from_chars(f[i].data(), f[i].data() + f[i].size(), v[i]);
      if (f[i].empty() || ec != std::errc() || end != f[i].data() + f[i].size())
        fail_at_line(source, no,
                     std::string(names[i]) + " = \"" + std::string(f[i].substr(0, 40)) +
                         "\" is not a whole number");
      if (i >= 2 && (v[i] < 0 || (i < 6 && v[i] > 65535)))
        fail_at_line(source, no,
                     std::string(names[i]) + " = " + std::to_string(v[i]) +
                         (v[i] < 0 ? " is negative" : " is beyond any sensor (max 65535)"));
    }
    Box box;
    box.t_start_us = v[0];
    box.t_end_us = v[1];
    box.x0 = int(v[2]), box.y0 = int(v[3]), box.x1 = int(v[4]), box.y1 = int(v[5]);
    box.id = fields == 7 ? v[6] : -1;
    box.line = no;
    if (box.t_end_us <= box.t_start_us)
      fail_at_line(source, no,
                   "t_end_us (" + std::to_string(box.t_end_us) + ") must be after t_start_us (" +
                       std::to_string(box.t_start_us) + ")");
    if (box.x1 < box.x0)
      fail_at_line(source, no,
                   "x1 (" + std::to_string(box.x1) + ") is left of x0 (" + std::to_string(box.x0) +
                       "); corners are inclusive, x0 <= x1");
    if (box.y1 < box.y0)
      fail_at_line(source, no,
                   "y1 (" + std::to_string(box.y1) + ") is above y0 (" + std::to_string(box.y0) +
                       "); corners are inclusive, y0 <= y1");
    if (!b.boxes_.empty() && box.t_start_us < b.boxes_.back().t_start_us)
      fail_at_line(source, no,
                   "times go back: t_start_us " + std::to_string(box.t_start_us) +
                       " is before the previous row's " +
                       std::to_string(b.boxes_.back().t_start_us) +
                       " (rows must be in order of t_start_us)");
    b.end_max_.push_back(b.boxes_.empty() ? box.t_end_us
                                          : std::max(b.end_max_.back(), box.t_end_us));
    b.boxes_.push_back(box);
  }
  if (in.bad()) fail(source, "", "read error");
  if (fields == 0) fail_at_line(source, 1, "empty file: expected " + header_text);
  if (b.boxes_.empty()) fail_at_line(source, header_line, "no box after the header");
  return b;
}

BoxTruth BoxTruth::read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "", "cannot open the boxes file");
  return parse(in, path);
}

void BoxTruth::check_sensor(SensorSize sensor) const {
  if (!sensor.known()) fail(source_, "", "the recording's sensor size is unknown");
  for (const Box& b : boxes_)
    if (b.x1 >= sensor.width || b.y1 >= sensor.height)
      fail_at_line(source_, b.line,
                   "box (" + std::to_string(b.x0) + ", " + std::to_string(b.y0) + ")-(" +
                       std::to_string(b.x1) + ", " + std::to_string(b.y1) +
                       ") reaches outside the " + std::to_string(sensor.width) + "x" +
                       std::to_string(sensor.height) + " sensor");
}

template <class F>
void BoxTruth::for_valid(int64_t t0, int64_t t1, F&& f) const {
  // Boxes are sorted by start: those starting before t1 are a prefix; going back through it,
  // once no earlier box ends after t0 (end_max_), none can be valid.
  const auto it = std::lower_bound(boxes_.begin(), boxes_.end(), t1,
                                   [](const Box& b, int64_t t) { return b.t_start_us < t; });
  for (size_t i = size_t(it - boxes_.begin()); i-- > 0 && end_max_[i] > t0;)
    if (boxes_[i].t_end_us > t0) f(boxes_[i]);
}

bool BoxTruth::contains(int64_t t, int x, int y) const {
  bool in = false;
  // Valid at t: [t, t + 1) overlaps [t_start, t_end).
  for_valid(t, t + 1,
            [&](const Box& b) { in = in || (x >= b.x0 && x <= b.x1 && y >= b.y0 && y <= b.y1); });
  return in;
}

void BoxTruth::label(EventStream& ev) const {
  ev.label.assign(ev.size(), 0);
  // A sweep over the time-sorted events, keeping the boxes valid now: each event is checked
  // against those only (contains() may walk back over many boxes behind one long box).
  std::vector<const Box*> active;
  size_t next = 0;
  int64_t now = INT64_MIN;
  for (size_t i = 0; i < ev.size(); ++i) {
    const int64_t t = ev.t[i];
    if (t < now) {  // not time-sorted: no sweep for this one
      ev.label[i] = contains(t, ev.x[i], ev.y[i]) ? 1 : 0;
      continue;
    }
    if (t != now) {
      now = t;
      for (; next < boxes_.size() && boxes_[next].t_start_us <= t; ++next)
        active.push_back(&boxes_[next]);
      std::erase_if(active, [t](const Box* b) { return b->t_end_us <= t; });
    }
    for (const Box* b : active)
      if (ev.x[i] >= b->x0 && ev.x[i] <= b->x1 && ev.y[i] >= b->y0 && ev.y[i] <= b->y1) {
        ev.label[i] = 1;
        break;
      }
  }
}

size_t BoxTruth::fill_window(int64_t t0, int64_t t1, std::vector<uint8_t>& mask,
                             SensorSize sensor) const {
  if (mask.size() != size_t(sensor.width) * size_t(sensor.height))
    fail(source_, "", "internal: the mask does not have the sensor's size");
  size_t n = 0;
  for_valid(t0, t1, [&](const Box& b) {
    ++n;
    if (b.x0 >= sensor.width || b.y0 >= sensor.height) return;
    // Clipped to the sensor as a guard; check_sensor refuses boxes outside it.
    for (int y = b.y0; y <= std::min(b.y1, sensor.height - 1); ++y)
      std::fill(mask.begin() + ptrdiff_t(size_t(y) * size_t(sensor.width) + size_t(b.x0)),
                mask.begin() + ptrdiff_t(size_t(y) * size_t(sensor.width) +
                                         size_t(std::min(b.x1, sensor.width - 1)) + 1),
                uint8_t(1));
  });
  return n;
}

}  // namespace spikems
