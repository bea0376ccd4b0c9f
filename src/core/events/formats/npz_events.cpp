// Events as a NumPy npz archive ("npz"): one array per field, the layout Python tools use.
//   t      int64 (N,)  microseconds (a float array is read as seconds)
//   x, y   uint16 (N,) pixel, top-left origin
//   p      uint8 (N,)  1 = ON, 0 = OFF (-1/+1 and booleans accepted on read)
//   label  uint16 (N,) optional object id
//   sensor int32 (2,)  optional [width, height]
// The arrays are loaded whole (npz members are not seekable when deflated), then handed out in
// chunks; the writer gathers the chunks and writes the archive on close.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/events/formats/memory_reader.h"
#include "core/events/formats/npy.h"
#include "core/util/error.h"

namespace spikems {

namespace {

NpyArray column_array(const NpzFile& z, const std::string& key, size_t n) {
  NpyArray a = z.get(key);
  if (a.shape.size() != 1 || size_t(a.shape[0]) != n)
    fail(z.source(), "array '" + key + "'",
         "expected shape (" + std::to_string(n) + ",), the length of 't'");
  return a;
}

// Fills out with the column converted to T, every value checked to lie in [lo, hi]. The
// common case (already of type T) is a copy and a range scan, without temporaries.
template <typename T>
void column(const NpzFile& z, const std::string& key, size_t n, int64_t lo, int64_t hi,
            std::vector<T>& out, const char* what) {
  NpyArray a = column_array(z, key, n);
  out.resize(n);
  if (a.descr == npy_descr_of<T>()) {
    if (n) std::memcpy(out.data(), a.data.data(), n * sizeof(T));
    for (size_t i = 0; i < n; ++i)
      if (int64_t(out[i]) < lo || int64_t(out[i]) > hi)
        fail_at_event(
            z.source(), i,
            std::string(what) + " = " + std::to_string(int64_t(out[i])) + " is out of range");
    return;
  }
  if (a.descr[1] == 'f')
    fail(z.source(), "array '" + key + "'", "expected integers, found " + a.descr);
  auto v = a.to<int64_t>();
  for (size_t i = 0; i < n; ++i) {
    if (v[i] < lo || v[i] > hi)
      fail_at_event(z.source(), i,
                    std::string(what) + " = " + std::to_string(v[i]) + " is out of range");
    out[i] = T(v[i]);
  }
}

EventStream read_npz_events(const std::string& path, const ReadOptions& opt) {
  NpzFile z(path);
  for (const char* k : {"t", "x", "y", "p"})
    if (!z.has(k))
      fail(path, "", std::string("npz events need arrays t, x, y, p; '") + k + "' is missing");
  NpyArray ta = z.get("t");
  if (ta.shape.size() != 1) fail(path, "array 't'", "expected a 1-D array");
  const size_t n = size_t(ta.shape[0]);
  EventStream ev;
  const char kind = ta.descr[1];
  if (kind == 'f') {  // seconds
    auto ts = ta.to<double>();
    ev.t.resize(n);
    for (size_t i = 0; i < n; ++i) {
      if (!std::isfinite(ts[i]) || std::fabs(ts[i]) > 9e12)
        fail_at_event(path, i, "timestamp is not a finite number of seconds");
      ev.t[i] = std::llround(ts[i] * 1e6);
    }
  } else if (ta.descr == "<i8") {
    ev.t.resize(n);
    if (n) std::memcpy(ev.t.data(), ta.data.data(), n * 8);
  } else {
    ev.t = ta.to<int64_t>();
  }
  column(z, "x", n, 0, 65535, ev.x, "x");
  column(z, "y", n, 0, 65535, ev.y, "y");
  // p: 0/1, -1/+1 or bool.
  NpyArray pa = column_array(z, "p", n);
  if (pa.descr == "|u1" || pa.descr == "|b1") {
    ev.p.assign(pa.data.begin(), pa.data.end());
    for (size_t i = 0; i < n; ++i)
      if (ev.p[i] > 1)
        fail_at_event(path, i, "polarity " + std::to_string(ev.p[i]) + " is not 0/1 or -1/+1");
  } else {
    auto p = pa.to<int64_t>();
    ev.p.resize(n);
    for (size_t i = 0; i < n; ++i) {
      if (p[i] != 0 && p[i] != 1 && p[i] != -1)
        fail_at_event(path, i, "polarity " + std::to_string(p[i]) + " is not 0/1 or -1/+1");
      ev.p[i] = p[i] > 0 ? 1 : 0;
    }
  }
  if (z.has("label")) column(z, "label", n, 0, 65535, ev.label, "label");
  if (opt.sensor.known()) {
    ev.sensor = opt.sensor;
  } else if (z.has("sensor")) {
    auto s = z.get("sensor").to<int64_t>();
    if (s.size() != 2 || s[0] <= 0 || s[1] <= 0 || s[0] > 65536 || s[1] > 65536)
      fail(path, "array 'sensor'", "expected [width, height] with positive values");
    ev.sensor = {int(s[0]), int(s[1])};
  } else if (n > 0) {  // no size stored: the smallest sensor holding every event
    ev.sensor = {*std::max_element(ev.x.begin(), ev.x.end()) + 1,
                 *std::max_element(ev.y.begin(), ev.y.end()) + 1};
  }
  return ev;
}

class NpzEventWriter final : public EventWriter {
 public:
  // Deflate level 1 by default, not zlib's 6 (np.savez_compressed's): on labelled events
  // (docs/performance.md, "Writing labels") it deflates ~5x faster for files ~9 % larger,
  // so that writing a segmented recording does not take longer than segmenting it.
  static constexpr int kDefaultLevel = 1;
  NpzEventWriter(std::string path, SensorSize sensor, const WriteOptions& opt)
      : path_(std::move(path)),
        compress_(opt.compression != "none" && opt.compression != "stored" && opt.level != 0),
        level_(opt.level < 0 ? kDefaultLevel : opt.level) {
    if (!opt.compression.empty() && opt.compression != "none" && opt.compression != "stored" &&
        opt.compression != "deflate")
      fail(path_, "",
           "npz supports compression 'deflate' (default) or 'none', not '" + opt.compression + "'");
    if (opt.level > 9)
      fail(path_, "", "deflate level must be 0..9 (0 = stored), not " + std::to_string(opt.level));
    ev_.sensor = sensor;
  }
  void write(const EventStream& chunk) override {
    if (!ev_.sensor.known()) ev_.sensor = chunk.sensor;
    if (chunk.has_labels() && !ev_.has_labels()) ev_.add_zero_labels();
    ev_.append(chunk);
  }
  void close() override {
    // Members in name order, as np.savez of a dict and the writer of a map wrote them; the
    // columns are written where they are (no copy of a recording's arrays).
    const std::vector<int32_t> sensor{ev_.sensor.width, ev_.sensor.height};
    std::vector<std::pair<std::string, NpyView>> a;
    if (ev_.has_labels()) a.emplace_back("label", NpyView::of(ev_.label));
    a.emplace_back("p", NpyView::of(ev_.p));
    if (ev_.sensor.known()) a.emplace_back("sensor", NpyView::of(sensor));
    a.emplace_back("t", NpyView::of(ev_.t));
    a.emplace_back("x", NpyView::of(ev_.x));
    a.emplace_back("y", NpyView::of(ev_.y));
    write_npz_views(path_, a, compress_, level_);
  }

 private:
  std::string path_;
  bool compress_;
  int level_;
  EventStream ev_;
};

}  // namespace

// Member names of a zip file, or empty when it is not one (used by detect()).
std::vector<std::string> npz_member_keys(const std::vector<uint8_t>& head,
                                         const std::string& path) {
  if (head.size() < 4 || head[0] != 'P' || head[1] != 'K' || head[2] != 3 || head[3] != 4)
    return {};
  try {
    std::vector<std::string> keys;
    for (const auto& e : zip_list_file(path))
      if (e.name.size() > 4 && e.name.compare(e.name.size() - 4, 4, ".npy") == 0)
        keys.push_back(e.name.substr(0, e.name.size() - 4));
    return keys;
  } catch (const Error&) {
    return {};
  }
}

FormatInfo npz_events_format() {
  FormatInfo f;
  f.name = "npz";
  f.description = "NumPy npz with arrays t (us), x, y, p [, label, sensor]";
  f.extensions = {".npz"};
  f.detect = [](const std::vector<uint8_t>& head, const std::string& path) {
    auto keys = npz_member_keys(head, path);
    auto has = [&](const char* k) { return std::find(keys.begin(), keys.end(), k) != keys.end(); };
    if (has("t") && has("x") && has("y") && has("p")) return 90;
    return 0;
  };
  f.open_path = [](const std::string& path,
                   const ReadOptions& opt) -> std::unique_ptr<EventReader> {
    return std::make_unique<MemoryEventReader>("npz", read_npz_events(path, opt));
  };
  f.compresses = true;
  f.open_writer = [](const std::string& path, SensorSize s,
                     const WriteOptions& opt) -> std::unique_ptr<EventWriter> {
    return std::make_unique<NpzEventWriter>(path, s, opt);
  };
  return f;
}

}  // namespace spikems
