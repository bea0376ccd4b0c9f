// Events as a NumPy npz archive ("npz"): one array per field, the layout Python tools use.
//   t      int64 (N,)  microseconds (a float array is read as seconds)
//   x, y   uint16 (N,) pixel, top-left origin
//   p      uint8 (N,)  1 = ON, 0 = OFF (-1/+1 and booleans accepted on read)
//   label  uint16 (N,) optional object id
//   sensor int32 (2,)  optional [width, height]
// The arrays are loaded whole (npz members are not seekable when deflated), then handed out in
// chunks. The writer streams each column into a temporary file of its own and assembles the
// archive from them on close: its memory does not grow with the recording.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>

#include "core/events/formats/memory_reader.h"
#include "core/events/formats/npy.h"
#include "core/events/formats/zip.h"
#include "core/util/atomic_file.h"
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

// One column of the archive being written: an unnamed temporary file beside the output
// (O_TMPFILE: it vanishes with the process, whatever happens) holding the column's npy member,
// its 128 header bytes reserved and written once the length is known. So the writer's memory
// stays bounded however long the recording, and the members stream through libzip at close.
class ColumnFile {
 public:
  ColumnFile(const std::string& target, std::string descr)
      : target_(target), descr_(std::move(descr)) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(target).parent_path();
    int fd = ::open(dir.empty() ? "." : dir.c_str(), O_TMPFILE | O_RDWR, 0600);
    if (fd < 0 && (errno == ENOENT || errno == ENOTDIR || errno == EACCES || errno == EROFS))
      fail(target, "",
           std::string("cannot write there: ") + std::strerror(errno));  // now, not at the end
    f_ = fd >= 0 ? ::fdopen(fd, "w+b") : std::tmpfile();  // tmpfile: no O_TMPFILE there
    if (!f_) {
      if (fd >= 0) ::close(fd);
      fail(target, "",
           std::string("cannot create a temporary column file: ") + std::strerror(errno));
    }
    std::setvbuf(f_, nullptr, _IOFBF, size_t(1) << 20);
    const uint8_t zeros[kHeader] = {};
    put(zeros, kHeader);
  }
  ~ColumnFile() {
    if (f_) std::fclose(f_);
  }
  ColumnFile(const ColumnFile&) = delete;
  ColumnFile& operator=(const ColumnFile&) = delete;
  void put(const void* data, size_t n) {
    if (n && std::fwrite(data, 1, n, f_) != n) failed();
  }
  // Writes the header of n elements and hands the file over, positioned at its start (where
  // libzip's file source begins reading).
  std::FILE* finish(int64_t n) {
    const std::vector<uint8_t> h = npy_header(descr_, {n});
    if (h.size() != kHeader) fail(target_, "", "internal: npy header is not 128 bytes");
    if (std::fflush(f_) != 0 || std::fseek(f_, 0, SEEK_SET) != 0) failed();
    put(h.data(), h.size());
    if (std::fflush(f_) != 0 || std::fseek(f_, 0, SEEK_SET) != 0) failed();
    // The member's attributes come from the file's mode: rw-rw-rw- as for a member from a
    // buffer, so that the same events give the same bytes as write_npz().
    ::fchmod(::fileno(f_), 0666);
    std::FILE* f = f_;
    f_ = nullptr;
    return f;
  }

 private:
  [[noreturn]] void failed() const {
    fail(target_, "",
         std::string("writing a temporary column file failed: ") + std::strerror(errno));
  }
  static constexpr size_t kHeader = kNpyHeader1d;
  std::string target_, descr_;
  std::FILE* f_ = nullptr;
};

class NpzEventWriter final : public EventWriter {
 public:
  // Deflate level 1 by default, not zlib's 6 (np.savez_compressed's): on labelled events
  // (docs/performance.md, "Writing labels") it deflates ~5x faster for files ~9 % larger,
  // so that writing a segmented recording does not take longer than segmenting it.
  static constexpr int kDefaultLevel = 1;
  NpzEventWriter(std::string path, SensorSize sensor, const WriteOptions& opt)
      : path_(std::move(path)),
        compress_(opt.compression != "none" && opt.compression != "stored" && opt.level != 0),
        level_(opt.level < 0 ? kDefaultLevel : opt.level),
        sensor_(sensor) {
    if (!opt.compression.empty() && opt.compression != "none" && opt.compression != "stored" &&
        opt.compression != "deflate")
      fail(path_, "",
           "npz supports compression 'deflate' (default) or 'none', not '" + opt.compression + "'");
    if (opt.level > 9)
      fail(path_, "", "deflate level must be 0..9 (0 = stored), not " + std::to_string(opt.level));
    t_.emplace(path_, npy_descr_of<int64_t>());
    x_.emplace(path_, npy_descr_of<uint16_t>());
    y_.emplace(path_, npy_descr_of<uint16_t>());
    p_.emplace(path_, npy_descr_of<uint8_t>());
  }
  void write(const EventStream& chunk) override {
    if (!sensor_.known()) sensor_ = chunk.sensor;
    const size_t n = chunk.size();
    if (chunk.has_labels() && !label_) {  // labels from here on: the events before get 0
      label_.emplace(path_, npy_descr_of<uint16_t>());
      put_zero_labels(n_);
    }
    t_->put(chunk.t.data(), n * sizeof(int64_t));
    x_->put(chunk.x.data(), n * sizeof(uint16_t));
    y_->put(chunk.y.data(), n * sizeof(uint16_t));
    p_->put(chunk.p.data(), n);
    if (label_) {
      if (chunk.has_labels())
        label_->put(chunk.label.data(), n * sizeof(uint16_t));
      else
        put_zero_labels(n);
    }
    n_ += n;
  }
  void close() override {
    // Members in name order, as np.savez of a dict and write_npz() of a map write them.
    AtomicFile f(path_);
    ZipWriter zip(f, compress_, level_);
    if (label_) zip.add_file("label.npy", label_->finish(int64_t(n_)));
    zip.add_file("p.npy", p_->finish(int64_t(n_)));
    const std::vector<int32_t> sensor{sensor_.width, sensor_.height};
    const std::vector<uint8_t> sh = npy_header(npy_descr_of<int32_t>(), {2});
    if (sensor_.known())
      zip.add("sensor.npy", {sh, {reinterpret_cast<const uint8_t*>(sensor.data()), 8}});
    zip.add_file("t.npy", t_->finish(int64_t(n_)));
    zip.add_file("x.npy", x_->finish(int64_t(n_)));
    zip.add_file("y.npy", y_->finish(int64_t(n_)));
    zip.finish();
    f.commit();
  }

 private:
  void put_zero_labels(size_t n) {
    static const uint16_t zeros[4096] = {};
    for (size_t k = 0; k < n; k += 4096) label_->put(zeros, std::min<size_t>(4096, n - k) * 2);
  }
  std::string path_;
  bool compress_;
  int level_;
  SensorSize sensor_;
  uint64_t n_ = 0;
  std::optional<ColumnFile> t_, x_, y_, p_, label_;
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
