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

#include "core/events/formats/memory_reader.h"
#include "core/events/formats/npy.h"
#include "core/util/error.h"

namespace spikems {

namespace {

template <typename T>
std::vector<T> column(const NpzFile& z, const std::string& key, size_t n) {
  NpyArray a = z.get(key);
  if (a.shape.size() != 1 || size_t(a.shape[0]) != n)
    fail(z.source(), "array '" + key + "'",
         "expected shape (" + std::to_string(n) + ",), the length of 't'");
  return a.to<T>();
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
  ev.t.resize(n);
  const char kind = ta.descr[1];
  if (kind == 'f') {  // seconds
    auto ts = ta.to<double>();
    for (size_t i = 0; i < n; ++i) {
      if (!std::isfinite(ts[i]) || std::fabs(ts[i]) > 9e12)
        fail_at_event(path, i, "timestamp is not a finite number of seconds");
      ev.t[i] = std::llround(ts[i] * 1e6);
    }
  } else {
    ev.t = ta.to<int64_t>();
  }
  auto coord = [&](const char* key, std::vector<uint16_t>& out) {
    auto v = column<int64_t>(z, key, n);
    out.resize(n);
    for (size_t i = 0; i < n; ++i) {
      if (v[i] < 0 || v[i] > 65535)
        fail_at_event(
            path, i,
            std::string(key) + " = " + std::to_string(v[i]) + " is not a pixel coordinate");
      out[i] = uint16_t(v[i]);
    }
  };
  coord("x", ev.x);
  coord("y", ev.y);
  auto p = column<int64_t>(z, "p", n);
  ev.p.resize(n);
  for (size_t i = 0; i < n; ++i) {
    if (p[i] != 0 && p[i] != 1 && p[i] != -1)
      fail_at_event(path, i, "polarity " + std::to_string(p[i]) + " is not 0/1 or -1/+1");
    ev.p[i] = p[i] > 0 ? 1 : 0;
  }
  if (z.has("label")) {
    auto l = column<int64_t>(z, "label", n);
    ev.label.resize(n);
    for (size_t i = 0; i < n; ++i) {
      if (l[i] < 0 || l[i] > 65535) fail_at_event(path, i, "label is not an object id (0..65535)");
      ev.label[i] = uint16_t(l[i]);
    }
  }
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
  NpzEventWriter(std::string path, SensorSize sensor, const WriteOptions& opt)
      : path_(std::move(path)),
        compress_(opt.compression != "none" && opt.compression != "stored") {
    if (!opt.compression.empty() && opt.compression != "none" && opt.compression != "stored" &&
        opt.compression != "deflate")
      fail(path_, "",
           "npz supports compression 'deflate' (default) or 'none', not '" + opt.compression + "'");
    ev_.sensor = sensor;
  }
  void write(const EventStream& chunk) override {
    if (!ev_.sensor.known()) ev_.sensor = chunk.sensor;
    if (chunk.has_labels() && !ev_.has_labels()) ev_.add_zero_labels();
    ev_.append(chunk);
  }
  void close() override {
    const int64_t n = int64_t(ev_.size());
    std::map<std::string, NpyArray> a;
    a["t"] = NpyArray::from(ev_.t, {n});
    a["x"] = NpyArray::from(ev_.x, {n});
    a["y"] = NpyArray::from(ev_.y, {n});
    a["p"] = NpyArray::from(ev_.p, {n});
    if (ev_.has_labels()) a["label"] = NpyArray::from(ev_.label, {n});
    if (ev_.sensor.known())
      a["sensor"] = NpyArray::from(std::vector<int32_t>{ev_.sensor.width, ev_.sensor.height}, {2});
    write_npz(path_, a, compress_);
  }

 private:
  std::string path_;
  bool compress_;
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
  f.open_writer = [](const std::string& path, SensorSize s,
                     const WriteOptions& opt) -> std::unique_ptr<EventWriter> {
    return std::make_unique<NpzEventWriter>(path, s, opt);
  };
  return f;
}

}  // namespace spikems
