// DSEC event files (HDF5): /events/{x,y,t,p}, /t_offset (int64 us), /ms_to_idx.
// t is stored in microseconds relative to t_offset; the absolute time is t + t_offset.
// Sensor: 640x480 (the DSEC event cameras) unless ReadOptions::sensor says otherwise.
// Streams in chunks (HDF5 hyperslab reads), so files of any size read in bounded memory.
// Reference layout: https://dsec.ifi.uzh.ch/data-format/
#include <algorithm>

#include "core/events/formats/hdf5_util.h"
#include "core/events/io.h"
#include "core/util/error.h"

namespace spikems {

namespace {

class DsecReader final : public EventReader {
 public:
  DsecReader(const std::string& path, const ReadOptions& opt) : path_(path) {
    file_ = h5_open_read(path);
    const hid_t f = file_.get();
    H5EventColumns cols = h5_open_event_columns(f, "/events", path);
    t_ = std::move(cols.t);
    x_ = std::move(cols.x);
    y_ = std::move(cols.y);
    p_ = std::move(cols.p);
    n_ = cols.n;
    if (h5_exists(f, "/t_offset")) {
      H5Handle o = h5_open_dataset(f, "/t_offset", path);
      auto s = h5_shape(o.get());
      if (!(s.empty() || (s.size() == 1 && s[0] == 1)))
        fail(path, "dataset 't_offset'", "expected a scalar");
      h5_read_all(o.get(), H5T_NATIVE_INT64, &offset_, path, "t_offset");
    }
    sensor_ = opt.sensor.known() ? opt.sensor : SensorSize{640, 480};
  }
  std::string format_name() const override { return "dsec"; }
  SensorSize sensor() const override { return sensor_; }
  size_t read(EventStream& out, size_t max_events) override {
    const uint64_t k = std::min<uint64_t>(max_events, n_ - pos_);
    if (k == 0) return 0;
    out.sensor = sensor_;
    const size_t base = out.size();
    out.t.resize(base + k);
    out.x.resize(base + k);
    out.y.resize(base + k);
    out.p.resize(base + k);
    if (out.has_labels()) out.label.resize(base + k, 0);
    h5_read_range(t_.get(), H5T_NATIVE_INT64, pos_, k, out.t.data() + base, path_, "events/t");
    h5_read_range(x_.get(), H5T_NATIVE_UINT16, pos_, k, out.x.data() + base, path_, "events/x");
    h5_read_range(y_.get(), H5T_NATIVE_UINT16, pos_, k, out.y.data() + base, path_, "events/y");
    h5_read_range(p_.get(), H5T_NATIVE_UINT8, pos_, k, out.p.data() + base, path_, "events/p");
    for (size_t i = base; i < base + k; ++i) out.t[i] += offset_;
    pos_ += k;
    return size_t(k);
  }

 private:
  std::string path_;
  H5Handle file_, t_, x_, y_, p_;
  int64_t offset_ = 0;
  SensorSize sensor_;
  uint64_t n_ = 0, pos_ = 0;
};

}  // namespace

FormatInfo dsec_format() {
  FormatInfo f;
  f.name = "dsec";
  f.description = "DSEC events.h5: /events/{x,y,t,p} + /t_offset (HDF5, read only)";
  f.extensions = {".h5", ".hdf5"};
  f.detect = [](const std::vector<uint8_t>&, const std::string& path) {
    if (!h5_is_hdf5(path)) return 0;
    H5Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
    if (!file.valid()) return 0;
    const hid_t fh = file.get();
    if (h5_exists(fh, "/events/t") && h5_exists(fh, "/events/x") &&
        (h5_exists(fh, "/t_offset") || h5_exists(fh, "/ms_to_idx")))
      return 90;
    return 0;
  };
  f.open_path = [](const std::string& path,
                   const ReadOptions& opt) -> std::unique_ptr<EventReader> {
    return std::make_unique<DsecReader>(path, opt);
  };
  return f;
}

}  // namespace spikems
