// HDF5 formats: the project's spikems-h5 (round trips of everything a Recording holds,
// streaming, atomicity, bad files) and DSEC (a file laid out as DSEC publishes it).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "common/test_paths.h"
#include "core/events/formats/hdf5_util.h"
#include "core/events/formats/spikems_h5.h"
#include "core/events/io.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {
namespace {

Recording sample_recording(size_t n, bool labels) {
  Recording r;
  r.events.sensor = {346, 260};
  for (size_t i = 0; i < n; ++i) {
    int64_t t = int64_t(i) * 7 + int64_t(i % 3);
    uint16_t x = uint16_t((i * 37) % 346), y = uint16_t((i * 11) % 260);
    if (labels)
      r.events.push_back(t, x, y, uint8_t(i % 2), uint16_t(i % 5));
    else
      r.events.push_back(t, x, y, uint8_t(i % 2));
  }
  for (int f = 0; f < 3; ++f) {
    MaskFrame m;
    m.t_us = 1000 * f;
    m.width = 346;
    m.height = 260;
    m.ids.assign(346 * 260, 0);
    m.ids[size_t(f) * 1000 + 5] = uint16_t(f + 1);
    r.masks.push_back(m);
  }
  r.intrinsics = CameraIntrinsics{226.4, 226.6, 173.1, 133.7, {-0.3, 0.1, 0.001, -0.002}};
  PoseSample p;
  p.t_us = 42;
  p.id = 2;
  p.translation = {1, -2, 0.5};
  p.rotation = {0.5, 0.5, -0.5, 0.5};
  r.poses = {p, PoseSample{}};
  r.moving_ids = {2, 3};
  r.metadata_json = R"({"scene":"box","fps":40})";
  return r;
}

void expect_same(const Recording& a, const Recording& b) {
  EXPECT_EQ(a.events.sensor, b.events.sensor);
  EXPECT_EQ(a.events.t, b.events.t);
  EXPECT_EQ(a.events.x, b.events.x);
  EXPECT_EQ(a.events.y, b.events.y);
  EXPECT_EQ(a.events.p, b.events.p);
  EXPECT_EQ(a.events.label, b.events.label);
  ASSERT_EQ(a.masks.size(), b.masks.size());
  for (size_t i = 0; i < a.masks.size(); ++i) {
    EXPECT_EQ(a.masks[i].t_us, b.masks[i].t_us);
    EXPECT_EQ(a.masks[i].width, b.masks[i].width);
    EXPECT_EQ(a.masks[i].ids, b.masks[i].ids);
  }
  ASSERT_EQ(a.intrinsics.has_value(), b.intrinsics.has_value());
  if (a.intrinsics) {
    EXPECT_EQ(a.intrinsics->fx, b.intrinsics->fx);
    EXPECT_EQ(a.intrinsics->cy, b.intrinsics->cy);
    EXPECT_EQ(a.intrinsics->distortion, b.intrinsics->distortion);
  }
  ASSERT_EQ(a.poses.size(), b.poses.size());
  for (size_t i = 0; i < a.poses.size(); ++i) {
    EXPECT_EQ(a.poses[i].t_us, b.poses[i].t_us);
    EXPECT_EQ(a.poses[i].id, b.poses[i].id);
    EXPECT_EQ(a.poses[i].translation, b.poses[i].translation);
    EXPECT_EQ(a.poses[i].rotation, b.poses[i].rotation);
  }
  EXPECT_EQ(a.moving_ids, b.moving_ids);
  EXPECT_EQ(a.metadata_json, b.metadata_json);
}

TEST(SpikemsH5, RoundTripEverything) {
  std::string dir = test::scratch_dir();
  for (bool labels : {true, false}) {
    Recording r = sample_recording(200000, labels);
    std::string p = dir + (labels ? "/l.h5" : "/n.h5");
    write_recording(p, r, {}, "spikems-h5");
    EXPECT_EQ(detect_format(p).name, "spikems-h5");
    Recording back = read_recording(p);
    expect_same(r, back);
    // The direct API gives the same.
    expect_same(r, read_spikems_h5(p));
  }
  // Deflate + shuffle shrink these regular arrays well below their raw 2.6 MB.
  EXPECT_LT(std::filesystem::file_size(dir + "/l.h5"), 200000u * 15 / 3);
  int files = 0;
  for ([[maybe_unused]] auto& e : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 2);  // no temporaries left
}

// Without mask planes (`spikems info`): every frame's time and size, no pixels; the rest as
// with them.
TEST(SpikemsH5, MaskTimesWithoutTheirPlanes) {
  std::string p = test::scratch_dir() + "/m.h5";
  const Recording r = sample_recording(1000, true);
  write_recording(p, r, {}, "spikems-h5");
  ReadOptions o;
  o.mask_planes = false;
  const Recording back = read_recording(p, o);
  ASSERT_EQ(back.masks.size(), r.masks.size());
  for (size_t i = 0; i < r.masks.size(); ++i) {
    EXPECT_EQ(back.masks[i].t_us, r.masks[i].t_us);
    EXPECT_EQ(back.masks[i].width, 346);
    EXPECT_EQ(back.masks[i].height, 260);
    EXPECT_TRUE(back.masks[i].ids.empty());
  }
  EXPECT_EQ(back.events.label, r.events.label);
  EXPECT_EQ(back.poses.size(), r.poses.size());
  EXPECT_EQ(back.moving_ids, r.moving_ids);
}

TEST(SpikemsH5, StreamsInChunksAndLabelsMayStartLate) {
  std::string p = test::scratch_dir() + "/s.h5";
  Recording r = sample_recording(1000, false);
  {
    WriteOptions o;
    o.compression = "none";
    auto w = open_writer(p, r.events.sensor, o, "spikems-h5");
    w->write(r.events.slice_index(0, 300));
    EventStream labelled = r.events.slice_index(300, 1000);
    labelled.add_zero_labels();
    for (size_t i = 0; i < labelled.size(); ++i) labelled.label[i] = uint16_t(7 + i % 2);
    w->write(labelled);
    w->close();
  }
  auto rd = open_reader(p);
  EventStream all;
  size_t chunks = 0, got;
  while ((got = rd->read(all, 128)) > 0) {
    EXPECT_LE(got, 128u);
    ++chunks;
  }
  EXPECT_EQ(chunks, 8u);
  EXPECT_EQ(all.t, r.events.t);
  ASSERT_TRUE(all.has_labels());
  EXPECT_EQ(all.label[299], 0);
  EXPECT_EQ(all.label[300], 7);
  EXPECT_EQ(all.label[301], 8);
}

TEST(SpikemsH5, UnclosedWriterLeavesNothing) {
  std::string dir = test::scratch_dir();
  {
    auto w = open_spikems_h5_writer(dir + "/x.h5", {10, 10});
    w->write(sample_recording(10, false).events.slice_index(0, 0));
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

TEST(SpikemsH5, BadFilesAreClearErrors) {
  std::string dir = test::scratch_dir();
  std::string p = dir + "/good.h5";
  write_spikems_h5(p, sample_recording(5000, true));
  auto bytes = read_file_bytes(p);
  for (size_t cut : {size_t(0), size_t(8), size_t(600), bytes.size() / 2, bytes.size() - 100}) {
    std::string c = dir + "/cut.h5";
    std::ofstream(c, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), long(cut));
    try {
      ReadOptions o;
      o.format = "spikems-h5";
      read_recording(c, o);
      ADD_FAILURE() << "truncated at " << cut << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("cut.h5"), std::string::npos) << e.what();
    }
  }
  // An HDF5 file that is not ours, and one from a future version.
  {
    H5Handle f = h5_create_file(dir + "/other.h5");
    h5_set_attr_int(f.get(), "format_version", 1, "x");
  }
  EXPECT_THROW(read_spikems_h5(dir + "/other.h5"), Error);
  {
    H5Handle f = h5_create_file(dir + "/future.h5");
    h5_set_attr_string(f.get(), "format", "spikems-h5", "x");
    h5_set_attr_int(f.get(), "format_version", 99, "x");
  }
  try {
    read_spikems_h5(dir + "/future.h5");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("newer"), std::string::npos) << e.what();
  }
  WriteOptions o;
  o.compression = "zstd";
  EXPECT_THROW(open_writer(dir + "/z.h5", {4, 4}, o, "spikems-h5"), Error);
}

TEST(SpikemsH5, OutOfSensorEventsAreRejectedOnRead) {
  std::string p = test::scratch_dir() + "/o.h5";
  Recording r = sample_recording(100, false);
  r.events.sensor = {100, 100};  // x reaches 345
  write_spikems_h5(p, r);
  EXPECT_THROW(read_recording(p), Error);
}

// A DSEC-layout file: t uint32 relative to t_offset, ms_to_idx.
TEST(Dsec, ReadsEventsWithOffset) {
  std::string p = test::scratch_dir() + "/events.h5";
  const uint64_t n = 70000;
  std::vector<uint32_t> t(n);
  std::vector<uint16_t> x(n), y(n);
  std::vector<uint8_t> pol(n);
  for (uint64_t i = 0; i < n; ++i) {
    t[i] = uint32_t(i * 3);
    x[i] = uint16_t(i % 640);
    y[i] = uint16_t((i / 640) % 480);
    pol[i] = uint8_t(i % 3 == 0);
  }
  int64_t offset = 50000000000;
  std::vector<uint64_t> ms_to_idx = {0, 334, 667};
  {
    H5Handle f = h5_create_file(p);
    H5Handle g = h5_create_group(f.get(), "events", p);
    h5_write_array(g.get(), "t", H5T_STD_U32LE, H5T_NATIVE_UINT32, {n}, t.data(), {16384}, 4, p);
    h5_write_array(g.get(), "x", H5T_STD_U16LE, H5T_NATIVE_UINT16, {n}, x.data(), {16384}, 4, p);
    h5_write_array(g.get(), "y", H5T_STD_U16LE, H5T_NATIVE_UINT16, {n}, y.data(), {16384}, 4, p);
    h5_write_array(g.get(), "p", H5T_STD_U8LE, H5T_NATIVE_UINT8, {n}, pol.data(), {16384}, 4, p);
    h5_write_array(f.get(), "t_offset", H5T_STD_I64LE, H5T_NATIVE_INT64, {}, &offset, {}, 0, p);
    h5_write_array(f.get(), "ms_to_idx", H5T_STD_U64LE, H5T_NATIVE_UINT64, {3}, ms_to_idx.data(),
                   {}, 0, p);
  }
  EXPECT_EQ(detect_format(p).name, "dsec");
  EventStream ev = read_events(p);
  ASSERT_EQ(ev.size(), n);
  EXPECT_EQ(ev.sensor, (SensorSize{640, 480}));
  EXPECT_EQ(ev.t[0], offset);
  EXPECT_EQ(ev.t[n - 1], offset + int64_t(n - 1) * 3);
  EXPECT_EQ(ev.x[12345], 12345 % 640);
  EXPECT_EQ(ev.y[12345], (12345 / 640) % 480);
  EXPECT_EQ(ev.p[3], 1);
  EXPECT_EQ(ev.p[4], 0);
}

}  // namespace
}  // namespace spikems
