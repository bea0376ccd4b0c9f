// EVIMO2 v2 sequence folder ("evimo2", Samsung DVS Gen3 640x480 by default):
//   dataset_events_t.npy   float64 (N,)   seconds
//   dataset_events_xy.npy  uint16 (N, 2)  x, y
//   dataset_events_p.npy   uint8 (N,)     1 = ON, 0 = OFF
//   dataset_mask.npz       mask_%010d.npy uint16 (H, W) = object id x 1000, one per frame
//   dataset_info.npz       K, D, index, discretization, meta (a pickled dict)
// Layout from better-flow/evimo (pydvs evimo-gen.py) and the EVIMO2 "Ground Truth Format"
// page. Frame times (frame i = the i-th mask in key order) live only in meta; as for EV-IMO v1
// they come from the first that works of: meta read by the restricted unpickler (pickle.h:
// plain data and np.savez's numpy object-array wrapper, nothing run; "mask_times": "meta"), a
// meta.txt in the folder ("meta.txt"), else frames spread evenly over the events
// ("uniform-estimate"). When meta cannot be used, "meta_error" in metadata_json says why.
// Arrays are loaded whole (npy/npz); the events are then handed out in chunks.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/events/formats/evimo_common.h"
#include "core/events/formats/memory_reader.h"
#include "core/events/formats/pickle.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {

namespace fs = std::filesystem;

namespace {

std::unique_ptr<EventReader> open_evimo2(const std::string& dir, const ReadOptions& opt) {
  auto file = [&](const char* n) { return (fs::path(dir) / n).string(); };
  NpyArray ta = read_npy(file("dataset_events_t.npy"));
  NpyArray xya = read_npy(file("dataset_events_xy.npy"));
  NpyArray pa = read_npy(file("dataset_events_p.npy"));
  if (ta.shape.size() != 1) fail(file("dataset_events_t.npy"), "", "expected shape (N,)");
  const size_t n = size_t(ta.shape[0]);
  if (xya.shape != std::vector<int64_t>{int64_t(n), 2})
    fail(file("dataset_events_xy.npy"), "", "expected shape (" + std::to_string(n) + ", 2)");
  if (pa.shape != std::vector<int64_t>{int64_t(n)})
    fail(file("dataset_events_p.npy"), "", "expected shape (" + std::to_string(n) + ",)");
  auto t = ta.to<double>();
  auto xy = xya.to<int64_t>();
  auto p = pa.to<int64_t>();
  EventStream ev;
  ev.t.resize(n);
  ev.x.resize(n);
  ev.y.resize(n);
  ev.p.resize(n);
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(t[i]) || std::fabs(t[i]) > 9e12)
      fail_at_event(file("dataset_events_t.npy"), i, "timestamp is NaN, infinite or out of range");
    if (xy[2 * i] < 0 || xy[2 * i] > 65535 || xy[2 * i + 1] < 0 || xy[2 * i + 1] > 65535)
      fail_at_event(file("dataset_events_xy.npy"), i, "not a pixel coordinate");
    if (p[i] != 0 && p[i] != 1 && p[i] != -1)
      fail_at_event(file("dataset_events_p.npy"), i,
                    "polarity " + std::to_string(p[i]) + " is not 0/1 or -1/+1");
    ev.t[i] = std::llround(t[i] * 1e6);
    ev.x[i] = uint16_t(xy[2 * i]);
    ev.y[i] = uint16_t(xy[2 * i + 1]);
    ev.p[i] = p[i] > 0 ? 1 : 0;
  }
  Recording extras;
  nlohmann::json meta = {{"source_format", "evimo2"}};
  std::error_code ec;
  bool has_meta = false;
  if (fs::is_regular_file(file("dataset_info.npz"), ec)) {
    NpzFile info(file("dataset_info.npz"));
    if (info.has("K")) {
      NpyArray D;
      bool hasD = info.has("D");
      if (hasD) D = info.get("D");
      extras.intrinsics = evimo_intrinsics(info.get("K"), hasD ? &D : nullptr, info.source());
    }
    has_meta = info.has("meta");
  }
  int mw = 0, mh = 0;
  if (fs::is_regular_file(file("dataset_mask.npz"), ec)) {
    NpzFile masks(file("dataset_mask.npz"));
    std::vector<std::string> keys;
    for (const auto& k : masks.keys())
      if (k.rfind("mask_", 0) == 0) keys.push_back(k);
    std::sort(keys.begin(), keys.end());  // zero-padded numbers sort in frame order
    std::vector<int64_t> times = evimo_mask_times((fs::path(dir) / "dataset_info.npz").string(),
                                                  has_meta, (fs::path(dir) / "meta.txt").string(),
                                                  keys.size(), ev, "dataset_mask.npz", meta);
    for (size_t i = 0; i < keys.size(); ++i) {
      NpyArray m = masks.get(keys[i]);
      if (m.shape.size() != 2 || m.descr[1] == 'f')
        fail(masks.source(), "array '" + keys[i] + "'", "expected an integer (H, W) mask");
      MaskFrame f;
      f.t_us = times[i];
      f.height = int(m.shape[0]);
      f.width = int(m.shape[1]);
      auto raw = m.to<uint16_t>();
      f.ids.resize(raw.size());
      for (size_t k = 0; k < raw.size(); ++k) f.ids[k] = evimo_mask_id(raw[k]);
      mw = f.width;
      mh = f.height;
      extras.masks.push_back(std::move(f));
    }
    std::stable_sort(extras.masks.begin(), extras.masks.end(),
                     [](const MaskFrame& a, const MaskFrame& b) { return a.t_us < b.t_us; });
  }
  extras.metadata_json = meta.dump();
  ev.sensor = opt.sensor.known() ? opt.sensor : mw > 0 ? SensorSize{mw, mh} : SensorSize{640, 480};
  return std::make_unique<MemoryEventReader>("evimo2", std::move(ev), std::move(extras));
}

}  // namespace

FormatInfo evimo2_format() {
  FormatInfo f;
  f.name = "evimo2";
  f.description =
      "EVIMO2 v2 folder: dataset_events_{t,xy,p}.npy, dataset_mask.npz, dataset_info.npz";
  f.extensions = {};
  f.detect = [](const std::vector<uint8_t>&, const std::string& path) {
    std::error_code ec;
    if (fs::is_directory(path, ec) &&
        fs::is_regular_file(fs::path(path) / "dataset_events_t.npy", ec) &&
        fs::is_regular_file(fs::path(path) / "dataset_events_xy.npy", ec))
      return 90;
    return 0;
  };
  f.open_path = open_evimo2;
  return f;
}

}  // namespace spikems
