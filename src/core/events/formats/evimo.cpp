// EV-IMO (v1) ground truth, in its two published layouts:
//   "evimo1"      one npz per sequence: events float32 (N,4) = [t s, x, y, p], index,
//                 discretization, K (3x3), D, depth uint16 (F,H,W), mask uint16 (F,H,W) =
//                 object id x 1000, meta (a pickled dict, read with the restricted unpickler).
//   "evimo1-txt"  a folder: events.txt ("t x y p", t in seconds), meta.txt (a Python literal
//                 dict whose 'frames' list gives each frame's 'ts' and 'gt_frame'), and
//                 img/depth_mask_<id>.png (16-bit, 3 channels; BGR channel 2 = id x 1000).
// Mask frame times of the npz live only in `meta`. They come from the first that works of:
// `meta` unpickled by pickle.h, which accepts plain data and numpy's object-array wrapper that
// np.savez(meta=dict) writes, without running anything ("mask_times": "meta"); a meta.txt
// next to the npz (same folder, or a folder named like the npz without its extension;
// "meta.txt"); else frames evenly spaced over the events, frame i at
// t_first + (i + 0.5) * (t_last - t_first) / F ("uniform-estimate": good enough for display, not
// for scoring). When `meta` cannot be used, "meta_error" in the metadata says why (e.g. a meta
// pickled with protocol 2 by Python 3, or holding numpy scalars: see docs/formats.md).
#include <cmath>
#include <filesystem>

#include "core/events/formats/evimo_common.h"
#include "core/events/formats/memory_reader.h"
#include "core/events/formats/pickle.h"
#include "core/events/formats/png16.h"
#include "core/events/formats/text.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {

std::vector<std::string> npz_member_keys(const std::vector<uint8_t>& head, const std::string& path);

namespace fs = std::filesystem;

namespace {

std::string read_text_file(const std::string& path) {
  auto b = read_file_bytes(path);
  return std::string(b.begin(), b.end());
}

// Converts the (N,4) float events array; t in seconds.
EventStream evimo_events(const NpyArray& a, const std::string& src) {
  if (a.shape.size() != 2 || a.shape[1] != 4)
    fail(src, "array 'events'", "expected shape (N, 4) = [t, x, y, p]");
  auto v = a.to<double>();
  const size_t n = size_t(a.shape[0]);
  EventStream ev;
  ev.t.resize(n);
  ev.x.resize(n);
  ev.y.resize(n);
  ev.p.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const double* r = &v[4 * i];
    if (!std::isfinite(r[0]) || std::fabs(r[0]) > 9e12)
      fail_at_event(src, i, "timestamp is NaN, infinite or out of range");
    if (!(r[1] >= 0 && r[1] < 65536 && r[2] >= 0 && r[2] < 65536))
      fail_at_event(src, i, "x or y is not a pixel coordinate");
    ev.t[i] = std::llround(r[0] * 1e6);
    ev.x[i] = uint16_t(std::lround(r[1]));
    ev.y[i] = uint16_t(std::lround(r[2]));
    ev.p[i] = r[3] > 0 ? 1 : 0;
  }
  return ev;
}

std::string find_meta_txt(const std::string& npz_path) {
  fs::path p(npz_path);
  for (fs::path c : {p.parent_path() / "meta.txt", p.parent_path() / p.stem() / "meta.txt"}) {
    std::error_code ec;
    if (fs::is_regular_file(c, ec)) return c.string();
  }
  return "";
}

std::unique_ptr<EventReader> open_evimo1_npz(const std::string& path, const ReadOptions& opt) {
  NpzFile z(path);
  if (!z.has("events")) fail(path, "", "EV-IMO npz without an 'events' array");
  Recording extras;
  EventStream ev = evimo_events(z.get("events"), path + ":events");
  nlohmann::json meta = {{"source_format", "evimo1"}};
  if (z.has("discretization"))
    meta["discretization_s"] = z.get("discretization").to<double>().at(0);
  if (z.has("K")) {
    NpyArray D;
    bool hasD = z.has("D");
    if (hasD) D = z.get("D");
    extras.intrinsics = evimo_intrinsics(z.get("K"), hasD ? &D : nullptr, path);
  }
  int mw = 0, mh = 0;
  if (z.has("mask")) {
    NpyArray m = z.get("mask");
    if (m.shape.size() != 3 || m.descr[1] == 'f')
      fail(path, "array 'mask'", "expected an integer (F, H, W) stack");
    const int64_t F = m.shape[0];
    mh = int(m.shape[1]);
    mw = int(m.shape[2]);
    auto ids = m.to<uint16_t>();
    std::vector<int64_t> times = evimo_mask_times(path, z.has("meta"), find_meta_txt(path),
                                                  size_t(F), ev, "the npz mask", meta);
    const size_t plane = size_t(mw) * size_t(mh);
    for (int64_t i = 0; i < F; ++i) {
      MaskFrame f;
      f.t_us = times[size_t(i)];
      f.width = mw;
      f.height = mh;
      f.ids.resize(plane);
      for (size_t k = 0; k < plane; ++k) f.ids[k] = evimo_mask_id(ids[size_t(i) * plane + k]);
      extras.masks.push_back(std::move(f));
    }
    std::stable_sort(extras.masks.begin(), extras.masks.end(),
                     [](const MaskFrame& a, const MaskFrame& b) { return a.t_us < b.t_us; });
  }
  extras.metadata_json = meta.dump();
  ev.sensor = evimo_sensor(opt, ev, mw, mh);
  return std::make_unique<MemoryEventReader>("evimo1", std::move(ev), std::move(extras));
}

// The txt folder: events stream from events.txt; masks are decoded in read_extras().
class EvimoTxtReader final : public EventReader {
 public:
  EvimoTxtReader(const std::string& dir, const ReadOptions& opt)
      : dir_(dir), mask_planes_(opt.mask_planes) {
    std::string meta_path = (fs::path(dir) / "meta.txt").string();
    frames_ = evimo_frames_from_meta(parse_python_literal(read_text_file(meta_path), meta_path),
                                     meta_path);
    SensorSize s = opt.sensor;
    if (!s.known()) {
      for (const auto& f : frames_) {
        std::string png = png_path(f);
        if (!png.empty()) {
          Image16 img = read_png16(png);
          s = {img.width, img.height};
          break;
        }
      }
    }
    if (!s.known()) s = {346, 260};  // EV-IMO v1 was recorded with a DAVIS346
    sensor_ = s;
    ReadOptions topt = opt;
    topt.sensor = s;
    if (topt.time_unit == "auto") topt.time_unit = "s";
    text_ = open_text_reader(open_file_source((fs::path(dir) / "events.txt").string()), topt);
  }
  std::string format_name() const override { return "evimo1-txt"; }
  SensorSize sensor() const override { return sensor_; }
  size_t read(EventStream& out, size_t max_events) override { return text_->read(out, max_events); }
  void read_extras(Recording& rec) override {
    for (const auto& f : frames_) {
      std::string png = png_path(f);
      if (png.empty()) continue;
      if (!mask_planes_) {  // its time and the sensor's size: no PNG decoded
        MaskFrame m;
        m.t_us = f.t_us;
        m.width = sensor_.width;
        m.height = sensor_.height;
        rec.masks.push_back(std::move(m));
        continue;
      }
      Image16 img = read_png16(png);
      if (img.channels < 3) fail(png, "", "EV-IMO depth/mask PNG must have 3 channels");
      MaskFrame m;
      m.t_us = f.t_us;
      m.width = img.width;
      m.height = img.height;
      m.ids.resize(size_t(img.width) * size_t(img.height));
      for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
          m.ids[size_t(y) * size_t(img.width) + size_t(x)] = evimo_mask_id(img.at_bgr(x, y, 2));
      rec.masks.push_back(std::move(m));
    }
    std::stable_sort(rec.masks.begin(), rec.masks.end(),
                     [](const MaskFrame& a, const MaskFrame& b) { return a.t_us < b.t_us; });
    rec.metadata_json =
        nlohmann::json{{"source_format", "evimo1-txt"}, {"mask_times", "meta.txt"}}.dump();
  }

 private:
  std::string png_path(const EvimoFrameInfo& f) const {
    std::vector<fs::path> cands;
    if (!f.gt_frame.empty()) {
      cands.push_back(fs::path(dir_) / "img" / f.gt_frame);
      cands.push_back(fs::path(dir_) / f.gt_frame);
    }
    if (f.id >= 0)
      cands.push_back(fs::path(dir_) / "img" / ("depth_mask_" + std::to_string(f.id) + ".png"));
    for (auto& c : cands) {
      std::error_code ec;
      if (fs::is_regular_file(c, ec)) return c.string();
    }
    return "";
  }
  std::string dir_;
  bool mask_planes_;
  std::vector<EvimoFrameInfo> frames_;
  SensorSize sensor_;
  std::unique_ptr<EventReader> text_;
};

}  // namespace

FormatInfo evimo1_format() {
  FormatInfo f;
  f.name = "evimo1";
  f.description = "EV-IMO npz: events (N,4) [t s, x, y, p], K, D, mask (F,H,W) id x 1000";
  f.extensions = {".npz"};
  f.detect = [](const std::vector<uint8_t>& head, const std::string& path) {
    auto keys = npz_member_keys(head, path);
    auto has = [&](const char* k) { return std::find(keys.begin(), keys.end(), k) != keys.end(); };
    if (has("events") && (has("K") || has("index") || has("discretization") || has("mask")))
      return 90;
    return 0;
  };
  f.open_path = open_evimo1_npz;
  return f;
}

FormatInfo evimo1_txt_format() {
  FormatInfo f;
  f.name = "evimo1-txt";
  f.description = "EV-IMO text folder: events.txt, meta.txt, img/depth_mask_<id>.png";
  f.extensions = {};
  f.detect = [](const std::vector<uint8_t>&, const std::string& path) {
    std::error_code ec;
    if (fs::is_directory(path, ec) && fs::is_regular_file(fs::path(path) / "events.txt", ec) &&
        fs::is_regular_file(fs::path(path) / "meta.txt", ec))
      return 90;
    return 0;
  };
  f.open_path = [](const std::string& path,
                   const ReadOptions& opt) -> std::unique_ptr<EventReader> {
    return std::make_unique<EvimoTxtReader>(path, opt);
  };
  return f;
}

}  // namespace spikems
