#include "core/events/io.h"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "core/util/error.h"

namespace spikems {

std::vector<FormatInfo> make_format_list();  // formats/registry.cpp

const std::vector<FormatInfo>& formats() {
  static const std::vector<FormatInfo> list = make_format_list();
  return list;
}

const FormatInfo* find_format(const std::string& name) {
  for (const auto& f : formats())
    if (f.name == name) return &f;
  return nullptr;
}

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

namespace {

std::string known_format_names() {
  std::string s;
  for (const auto& f : formats()) s += (s.empty() ? "" : ", ") + f.name;
  return s;
}

// Checks what every reader promises: coordinates inside the sensor, polarity 0/1, time order
// across chunk boundaries (unless sorting was asked for, which read_recording does at the end).
class ValidatingReader final : public EventReader {
 public:
  ValidatingReader(std::unique_ptr<EventReader> inner, std::string path, ReadOptions opt)
      : inner_(std::move(inner)), path_(std::move(path)), opt_(std::move(opt)) {}
  std::string format_name() const override { return inner_->format_name(); }
  SensorSize sensor() const override {
    return opt_.sensor.known() ? opt_.sensor : inner_->sensor();
  }
  size_t read(EventStream& out, size_t max_events) override {
    size_t start = out.size();
    size_t n = inner_->read(out, max_events);
    if (opt_.sensor.known()) out.sensor = opt_.sensor;
    SensorSize s = out.sensor.known() ? out.sensor : inner_->sensor();
    for (size_t i = start; i < start + n; ++i) {
      uint64_t idx = count_ + (i - start);
      if (out.p[i] > 1) fail_at_event(path_, idx, "polarity is not 0 or 1");
      if (s.known() && (out.x[i] >= s.width || out.y[i] >= s.height))
        fail_at_event(path_, idx,
                      "coordinates (" + std::to_string(out.x[i]) + ", " + std::to_string(out.y[i]) +
                          ") are outside the declared " + std::to_string(s.width) + "x" +
                          std::to_string(s.height) + " sensor");
      if (!opt_.sort && out.t[i] < last_t_)
        fail_at_event(path_, idx,
                      "timestamps go back in time (" + std::to_string(out.t[i]) + " us after " +
                          std::to_string(last_t_) + " us); pass --sort to accept and sort them");
      last_t_ = std::max(last_t_, out.t[i]);
    }
    count_ += n;
    return n;
  }
  void read_extras(Recording& rec) override { inner_->read_extras(rec); }

 private:
  std::unique_ptr<EventReader> inner_;
  std::string path_;
  ReadOptions opt_;
  int64_t last_t_ = INT64_MIN;
  uint64_t count_ = 0;
};

}  // namespace

const FormatInfo& detect_format(const std::string& path) {
  // "-" is standard input: a live stream, which is text lines ("t x y p") unless --format says.
  if (path == "-") {
    if (const FormatInfo* text = find_format("text")) return *text;
  }
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail(path, "", "no such file or folder");
  std::vector<uint8_t> head;
  if (std::filesystem::is_regular_file(path, ec)) head = open_file_source(path)->head(4096);
  std::string ext = lower_extension(path);
  const FormatInfo* best = nullptr;
  int best_score = 0;
  for (const auto& f : formats()) {
    int score = f.detect ? f.detect(head, path) : 0;
    if (score > 0 && std::find(f.extensions.begin(), f.extensions.end(), ext) != f.extensions.end())
      score += 5;  // the extension only breaks ties between content matches
    if (score > best_score) {
      best_score = score;
      best = &f;
    }
  }
  if (!best)
    fail(path, "",
         "unrecognised event format (known: " + known_format_names() +
             "); pass --format NAME if the file is one of them");
  return *best;
}

const FormatInfo& format_for_output(const std::string& path, const std::string& forced) {
  if (!forced.empty()) {
    const FormatInfo* f = find_format(forced);
    if (!f) fail(path, "", "unknown format '" + forced + "' (known: " + known_format_names() + ")");
    if (!f->open_writer) fail(path, "", "format '" + forced + "' can be read but not written");
    return *f;
  }
  std::string ext = lower_extension(path);
  for (const auto& f : formats())
    if (f.open_writer &&
        std::find(f.extensions.begin(), f.extensions.end(), ext) != f.extensions.end())
      return f;
  std::string writable;
  for (const auto& f : formats())
    if (f.open_writer) writable += (writable.empty() ? "" : ", ") + f.name;
  fail(path, "",
       "cannot tell the output format from the extension '" + ext +
           "'; pass --format NAME (writable: " + writable + ")");
}

std::unique_ptr<EventReader> open_reader(const std::string& path, const ReadOptions& opt) {
  const FormatInfo* f = nullptr;
  if (!opt.format.empty()) {
    f = find_format(opt.format);
    if (!f)
      fail(path, "", "unknown format '" + opt.format + "' (known: " + known_format_names() + ")");
  } else {
    f = &detect_format(path);
  }
  std::unique_ptr<EventReader> r;
  if (f->open_path)
    r = f->open_path(path, opt);
  else
    r = f->open_bytes(open_file_source(path), opt);
  return std::make_unique<ValidatingReader>(std::move(r), path, opt);
}

std::unique_ptr<EventWriter> open_writer(const std::string& path, SensorSize sensor,
                                         const WriteOptions& opt, const std::string& format) {
  const FormatInfo& f = format_for_output(path, format);
  if (!f.compresses &&
      ((!opt.compression.empty() && opt.compression != "none") || opt.level >= 0)) {
    std::string have;
    for (const auto& g : formats())
      if (g.compresses) have += (have.empty() ? "" : ", ") + g.name;
    fail(path, "",
         "the " + f.name + " format has no compression: drop the compression and level options (" +
             have + " have them)");
  }
  return f.open_writer(path, sensor, opt);
}

Recording read_recording(const std::string& path, const ReadOptions& opt) {
  Recording rec;
  auto r = open_reader(path, opt);
  while (r->read(rec.events, kReadChunk) > 0) {
  }
  if (!rec.events.sensor.known()) rec.events.sensor = r->sensor();
  r->read_extras(rec);
  if (opt.sort) rec.events.sort_by_time();
  return rec;
}

EventStream read_events(const std::string& path, const ReadOptions& opt) {
  return read_recording(path, opt).events;
}

void write_recording(const std::string& path, const Recording& rec, const WriteOptions& opt,
                     const std::string& format) {
  auto w = open_writer(path, rec.events.sensor, opt, format);
  w->write(rec.events);
  w->write_extras(rec);
  w->close();
}

}  // namespace spikems
