#include "core/events/formats/spikems_h5.h"

#include <algorithm>

#include "core/events/formats/hdf5_util.h"
#include "core/util/atomic_file.h"
#include "core/util/error.h"

namespace spikems {

namespace {

constexpr uint64_t kEventChunk = 1 << 16;
constexpr const char* kFormatTag = "spikems-h5";

int level_from(const WriteOptions& opt, const std::string& path) {
  const std::string& c = opt.compression;
  if (c == "none" || c == "stored") return 0;
  if (!c.empty() && c != "deflate" && c != "gzip")
    fail(path, "",
         "spikems-h5 supports compression 'deflate' (default) or 'none', not '" + c +
             "' (lz4/zstd would need HDF5 filter plugins that h5py lacks by default)");
  if (opt.level > 9) fail(path, "", "deflate level must be 0..9");
  return opt.level < 0 ? 4 : opt.level;
}

class SpikemsH5Writer final : public EventWriter {
 public:
  SpikemsH5Writer(const std::string& path, SensorSize sensor, int level)
      : out_(path), path_(path), sensor_(sensor), level_(level) {
    file_ = h5_create_file(out_.temp_path());
    events_ = h5_create_group(file_.get(), "events", path_);
    t_ = h5_create_extendible(events_.get(), "t", H5T_STD_I64LE, kEventChunk, level_, path_);
    x_ = h5_create_extendible(events_.get(), "x", H5T_STD_U16LE, kEventChunk, level_, path_);
    y_ = h5_create_extendible(events_.get(), "y", H5T_STD_U16LE, kEventChunk, level_, path_);
    p_ = h5_create_extendible(events_.get(), "p", H5T_STD_U8LE, kEventChunk, level_, path_);
  }
  void write(const EventStream& ev) override {
    if (closed_) fail(path_, "", "write after close");
    if (!sensor_.known()) sensor_ = ev.sensor;
    const uint64_t n = ev.size();
    if (n == 0) return;
    if (ev.has_labels() && !label_.valid()) {  // labels appear: back-fill earlier events with 0
      label_ =
          h5_create_extendible(events_.get(), "label", H5T_STD_U16LE, kEventChunk, level_, path_);
      std::vector<uint16_t> zeros(std::min<uint64_t>(count_, kEventChunk), 0);
      for (uint64_t done = 0; done < count_;) {
        uint64_t k = std::min<uint64_t>(zeros.size(), count_ - done);
        h5_append(label_.get(), H5T_NATIVE_UINT16, zeros.data(), k, label_len_, path_, "label");
        done += k;
      }
    }
    uint64_t len = count_;
    h5_append(t_.get(), H5T_NATIVE_INT64, ev.t.data(), n, len, path_, "events/t");
    len = count_;
    h5_append(x_.get(), H5T_NATIVE_UINT16, ev.x.data(), n, len, path_, "events/x");
    len = count_;
    h5_append(y_.get(), H5T_NATIVE_UINT16, ev.y.data(), n, len, path_, "events/y");
    len = count_;
    h5_append(p_.get(), H5T_NATIVE_UINT8, ev.p.data(), n, len, path_, "events/p");
    if (label_.valid()) {
      if (ev.has_labels()) {
        h5_append(label_.get(), H5T_NATIVE_UINT16, ev.label.data(), n, label_len_, path_, "label");
      } else {
        std::vector<uint16_t> zeros(n, 0);
        h5_append(label_.get(), H5T_NATIVE_UINT16, zeros.data(), n, label_len_, path_, "label");
      }
    }
    count_ += n;
  }
  void write_extras(const Recording& rec) override {
    const hid_t f = file_.get();
    if (!rec.masks.empty()) {
      const int w = rec.masks[0].width, h = rec.masks[0].height;
      const uint64_t plane = uint64_t(w) * uint64_t(h);
      std::vector<int64_t> ts;
      std::vector<uint16_t> ids;
      ids.reserve(plane * rec.masks.size());
      for (size_t i = 0; i < rec.masks.size(); ++i) {
        const MaskFrame& m = rec.masks[i];
        if (m.width != w || m.height != h || m.ids.size() != plane)
          fail(path_, "mask frame " + std::to_string(i),
               "all mask frames must have the same size (" + std::to_string(w) + "x" +
                   std::to_string(h) + ")");
        ts.push_back(m.t_us);
        ids.insert(ids.end(), m.ids.begin(), m.ids.end());
      }
      H5Handle g = h5_create_group(f, "masks", path_);
      const uint64_t F = rec.masks.size();
      h5_write_array(g.get(), "t", H5T_STD_I64LE, H5T_NATIVE_INT64, {F}, ts.data(), {}, 0, path_);
      h5_write_array(g.get(), "ids", H5T_STD_U16LE, H5T_NATIVE_UINT16,
                     {F, uint64_t(h), uint64_t(w)}, ids.data(), {1, uint64_t(h), uint64_t(w)},
                     std::max(level_, 1), path_);
    }
    if (rec.intrinsics) {
      H5Handle g = h5_create_group(f, "camera", path_);
      const auto& c = *rec.intrinsics;
      double k[4] = {c.fx, c.fy, c.cx, c.cy};
      h5_write_array(g.get(), "intrinsics", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {4}, k, {}, 0,
                     path_);
      h5_write_array(g.get(), "distortion", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                     {uint64_t(c.distortion.size())}, c.distortion.data(), {}, 0, path_);
    }
    if (!rec.poses.empty()) {
      const uint64_t P = rec.poses.size();
      std::vector<int64_t> t(P);
      std::vector<uint16_t> id(P);
      std::vector<double> tr(3 * P), rot(4 * P);
      for (uint64_t i = 0; i < P; ++i) {
        t[i] = rec.poses[i].t_us;
        id[i] = rec.poses[i].id;
        std::copy(rec.poses[i].translation.begin(), rec.poses[i].translation.end(), &tr[3 * i]);
        std::copy(rec.poses[i].rotation.begin(), rec.poses[i].rotation.end(), &rot[4 * i]);
      }
      H5Handle g = h5_create_group(f, "poses", path_);
      h5_write_array(g.get(), "t", H5T_STD_I64LE, H5T_NATIVE_INT64, {P}, t.data(), {}, 0, path_);
      h5_write_array(g.get(), "id", H5T_STD_U16LE, H5T_NATIVE_UINT16, {P}, id.data(), {}, 0, path_);
      h5_write_array(g.get(), "translation", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {P, 3}, tr.data(),
                     {}, 0, path_);
      h5_write_array(g.get(), "rotation", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {P, 4}, rot.data(), {},
                     0, path_);
    }
    if (!rec.moving_ids.empty())
      h5_write_array(f, "moving_ids", H5T_STD_U16LE, H5T_NATIVE_UINT16,
                     {uint64_t(rec.moving_ids.size())}, rec.moving_ids.data(), {}, 0, path_);
    metadata_ = rec.metadata_json;
  }
  void close() override {
    if (closed_) return;
    closed_ = true;
    const hid_t f = file_.get();
    h5_set_attr_string(f, "format", kFormatTag, path_);
    h5_set_attr_int(f, "format_version", kSpikemsH5Version, path_);
    h5_set_attr_int(f, "sensor_width", sensor_.width, path_);
    h5_set_attr_int(f, "sensor_height", sensor_.height, path_);
    h5_set_attr_string(f, "metadata_json", metadata_, path_);
    t_.reset();
    x_.reset();
    y_.reset();
    p_.reset();
    label_.reset();
    events_.reset();
    if (H5Fflush(f, H5F_SCOPE_GLOBAL) < 0) fail(path_, "", "HDF5 flush failed (disk full?)");
    if (!file_.close()) fail(path_, "", "HDF5 close failed (disk full?)");
    out_.commit();
  }

 private:
  AtomicFile out_;  // declared first: the HDF5 handles close before the temp file is removed
  std::string path_;
  SensorSize sensor_;
  int level_;
  H5Handle file_, events_, t_, x_, y_, p_, label_;
  uint64_t count_ = 0, label_len_ = 0;
  std::string metadata_ = "{}";
  bool closed_ = false;
};

class SpikemsH5Reader final : public EventReader {
 public:
  SpikemsH5Reader(const std::string& path, const ReadOptions& opt)
      : path_(path), mask_planes_(opt.mask_planes) {
    file_ = h5_open_read(path);
    const hid_t f = file_.get();
    std::string tag;
    if (!h5_get_attr_string(f, "format", tag) || tag != kFormatTag)
      fail(path, "",
           "HDF5 file is not a spikems-h5 dataset (root attribute format != \"spikems-h5\")");
    int64_t version = 0;
    if (!h5_get_attr_int(f, "format_version", version) || version < 1)
      fail(path, "", "spikems-h5 file has no valid format_version attribute");
    if (version > kSpikemsH5Version)
      fail(path, "",
           "spikems-h5 format_version " + std::to_string(version) +
               " is newer than this build understands (" + std::to_string(kSpikemsH5Version) +
               "); update spikems");
    int64_t w = 0, h = 0;
    h5_get_attr_int(f, "sensor_width", w);
    h5_get_attr_int(f, "sensor_height", h);
    if (w < 0 || h < 0 || w > 65536 || h > 65536) fail(path, "", "absurd sensor size attributes");
    sensor_ = opt.sensor.known() ? opt.sensor : SensorSize{int(w), int(h)};
    H5EventColumns cols = h5_open_event_columns(f, "/events", path);
    t_ = std::move(cols.t);
    x_ = std::move(cols.x);
    y_ = std::move(cols.y);
    p_ = std::move(cols.p);
    n_ = cols.n;
    if (h5_exists(f, "/events/label")) {
      label_ = h5_open_dataset(f, "/events/label", path);
      if (h5_length_1d(label_.get(), path, "events/label") != n_)
        fail(path, "", "events/label length differs from events/t");
    }
  }
  std::string format_name() const override { return "spikems-h5"; }
  SensorSize sensor() const override { return sensor_; }
  size_t read(EventStream& out, size_t max_events) override {
    const uint64_t k = std::min<uint64_t>(max_events, n_ - pos_);
    if (k == 0) return 0;
    if (sensor_.known()) out.sensor = sensor_;
    const size_t base = out.size();
    // An empty stream has an empty label array either way, so test the sizes.
    if (label_.valid() && out.label.size() != base) out.add_zero_labels();
    const bool labels = label_.valid() || out.has_labels();
    out.t.resize(base + k);
    out.x.resize(base + k);
    out.y.resize(base + k);
    out.p.resize(base + k);
    if (labels) out.label.resize(base + k, 0);
    h5_read_range(t_.get(), H5T_NATIVE_INT64, pos_, k, out.t.data() + base, path_, "events/t");
    h5_read_range(x_.get(), H5T_NATIVE_UINT16, pos_, k, out.x.data() + base, path_, "events/x");
    h5_read_range(y_.get(), H5T_NATIVE_UINT16, pos_, k, out.y.data() + base, path_, "events/y");
    h5_read_range(p_.get(), H5T_NATIVE_UINT8, pos_, k, out.p.data() + base, path_, "events/p");
    if (label_.valid())
      h5_read_range(label_.get(), H5T_NATIVE_UINT16, pos_, k, out.label.data() + base, path_,
                    "events/label");
    pos_ += k;
    return size_t(k);
  }
  void read_extras(Recording& rec) override {
    const hid_t f = file_.get();
    if (h5_exists(f, "/masks/t")) {
      H5Handle t = h5_open_dataset(f, "/masks/t", path_);
      H5Handle ids = h5_open_dataset(f, "/masks/ids", path_);
      const uint64_t F = h5_length_1d(t.get(), path_, "masks/t");
      auto shape = h5_shape(ids.get());
      if (shape.size() != 3 || shape[0] != F || shape[1] > 65536 || shape[2] > 65536)
        fail(path_, "dataset 'masks/ids'", "expected shape (F, H, W) matching masks/t");
      std::vector<int64_t> ts(F);
      h5_read_all(t.get(), H5T_NATIVE_INT64, ts.data(), path_, "masks/t");
      // Frame by frame, straight into each frame (one chunk each): no second copy of them all.
      H5Handle fspace(H5Dget_space(ids.get()));
      const hsize_t count[3] = {1, shape[1], shape[2]}, plane = shape[1] * shape[2];
      H5Handle mspace(H5Screate_simple(3, count, nullptr));
      for (uint64_t i = 0; i < F; ++i) {
        MaskFrame m;
        m.t_us = ts[i];
        m.height = int(shape[1]);
        m.width = int(shape[2]);
        if (mask_planes_) {
          m.ids.resize(plane);
          const hsize_t start[3] = {i, 0, 0};
          if (H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) <
                  0 ||
              H5Dread(ids.get(), H5T_NATIVE_UINT16, mspace.get(), fspace.get(), H5P_DEFAULT,
                      m.ids.data()) < 0)
            fail(path_, "dataset 'masks/ids' frame " + std::to_string(i),
                 "HDF5 read failed (corrupt chunk, missing filter or wrong type)");
        }
        rec.masks.push_back(std::move(m));
      }
    }
    if (h5_exists(f, "/camera/intrinsics")) {
      H5Handle k = h5_open_dataset(f, "/camera/intrinsics", path_);
      if (h5_length_1d(k.get(), path_, "camera/intrinsics") != 4)
        fail(path_, "dataset 'camera/intrinsics'", "expected 4 values fx, fy, cx, cy");
      double v[4];
      h5_read_all(k.get(), H5T_NATIVE_DOUBLE, v, path_, "camera/intrinsics");
      CameraIntrinsics c{v[0], v[1], v[2], v[3], {}};
      if (h5_exists(f, "/camera/distortion")) {
        H5Handle d = h5_open_dataset(f, "/camera/distortion", path_);
        uint64_t n = h5_length_1d(d.get(), path_, "camera/distortion");
        if (n > 16) fail(path_, "dataset 'camera/distortion'", "more than 16 coefficients");
        c.distortion.resize(n);
        if (n)
          h5_read_all(d.get(), H5T_NATIVE_DOUBLE, c.distortion.data(), path_, "camera/distortion");
      }
      rec.intrinsics = c;
    }
    if (h5_exists(f, "/poses/t")) {
      H5Handle t = h5_open_dataset(f, "/poses/t", path_);
      const uint64_t P = h5_length_1d(t.get(), path_, "poses/t");
      H5Handle id = h5_open_dataset(f, "/poses/id", path_);
      H5Handle tr = h5_open_dataset(f, "/poses/translation", path_);
      H5Handle rot = h5_open_dataset(f, "/poses/rotation", path_);
      if (h5_length_1d(id.get(), path_, "poses/id") != P ||
          h5_shape(tr.get()) != std::vector<uint64_t>{P, 3} ||
          h5_shape(rot.get()) != std::vector<uint64_t>{P, 4})
        fail(path_, "group 'poses'", "datasets t, id, translation (P,3), rotation (P,4) disagree");
      std::vector<int64_t> tv(P);
      std::vector<uint16_t> iv(P);
      std::vector<double> trv(3 * P), rv(4 * P);
      h5_read_all(t.get(), H5T_NATIVE_INT64, tv.data(), path_, "poses/t");
      h5_read_all(id.get(), H5T_NATIVE_UINT16, iv.data(), path_, "poses/id");
      h5_read_all(tr.get(), H5T_NATIVE_DOUBLE, trv.data(), path_, "poses/translation");
      h5_read_all(rot.get(), H5T_NATIVE_DOUBLE, rv.data(), path_, "poses/rotation");
      for (uint64_t i = 0; i < P; ++i) {
        PoseSample s;
        s.t_us = tv[i];
        s.id = iv[i];
        std::copy(&trv[3 * i], &trv[3 * i] + 3, s.translation.begin());
        std::copy(&rv[4 * i], &rv[4 * i] + 4, s.rotation.begin());
        rec.poses.push_back(s);
      }
    }
    if (h5_exists(f, "/moving_ids")) {
      H5Handle m = h5_open_dataset(f, "/moving_ids", path_);
      uint64_t n = h5_length_1d(m.get(), path_, "moving_ids");
      if (n > 65536) fail(path_, "dataset 'moving_ids'", "more than 65536 ids");
      rec.moving_ids.resize(n);
      if (n) h5_read_all(m.get(), H5T_NATIVE_UINT16, rec.moving_ids.data(), path_, "moving_ids");
    }
    std::string meta;
    if (h5_get_attr_string(f, "metadata_json", meta) && !meta.empty()) rec.metadata_json = meta;
  }

 private:
  std::string path_;
  bool mask_planes_;
  H5Handle file_, t_, x_, y_, p_, label_;
  SensorSize sensor_;
  uint64_t n_ = 0, pos_ = 0;
};

}  // namespace

std::unique_ptr<EventReader> open_spikems_h5_reader(const std::string& path,
                                                    const ReadOptions& opt) {
  return std::make_unique<SpikemsH5Reader>(path, opt);
}

std::unique_ptr<EventWriter> open_spikems_h5_writer(const std::string& path, SensorSize sensor,
                                                    const WriteOptions& opt) {
  return std::make_unique<SpikemsH5Writer>(path, sensor, level_from(opt, path));
}

void write_spikems_h5(const std::string& path, const Recording& rec, int level) {
  WriteOptions o;
  o.level = level;
  auto w = open_spikems_h5_writer(path, rec.events.sensor, o);
  w->write(rec.events);
  w->write_extras(rec);
  w->close();
}

Recording read_spikems_h5(const std::string& path, const ReadOptions& opt) {
  SpikemsH5Reader r(path, opt);
  Recording rec;
  while (r.read(rec.events, kReadChunk) > 0) {
  }
  rec.events.sensor = r.sensor();
  r.read_extras(rec);
  return rec;
}

FormatInfo spikems_h5_format() {
  FormatInfo f;
  f.name = "spikems-h5";
  f.description = "spikems dataset (HDF5): events + labels, masks, intrinsics, poses, metadata";
  f.extensions = {".h5", ".hdf5"};
  f.detect = [](const std::vector<uint8_t>& head, const std::string& path) {
    if (!h5_is_hdf5(path)) return 0;
    H5Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
    std::string tag;
    if (file.valid() && h5_get_attr_string(file.get(), "format", tag) && tag == kFormatTag)
      return 100;
    return 0;
  };
  f.open_path = [](const std::string& path, const ReadOptions& opt) {
    return open_spikems_h5_reader(path, opt);
  };
  f.compresses = true;
  f.writes_extras = true;
  f.open_writer = [](const std::string& path, SensorSize s, const WriteOptions& opt) {
    return open_spikems_h5_writer(path, s, opt);
  };
  return f;
}

}  // namespace spikems
