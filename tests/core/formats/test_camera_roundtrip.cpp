// Writers of the camera formats: random streams and the golden files go through the EVT 3.0
// and AEDAT 4.0 writers and come back identical; hand-made EVT 3.0 words decode as the spec
// says (vectors, time wrap), AEDAT 2.0/3.1 bytes built from their specs decode as expected.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "common/test_paths.h"
#include "core/events/io.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// Random stream with what the encoders must handle: runs of one row and polarity with
// increasing x (vectors), many events per timestamp, gaps past the 2^24 us EVT 3.0 wrap.
EventStream random_stream(SensorSize s, size_t n, int64_t t0, uint32_t seed) {
  std::mt19937 rng(seed);
  EventStream e;
  e.sensor = s;
  int64_t t = t0;
  while (e.size() < n) {
    uint32_t r = rng() % 1000;
    if (r < 3)
      t += (int64_t(1) << 24) + rng() % 100000000;  // past a wrap, up to ~2 min
    else if (r < 600)
      t += rng() % 50;
    uint16_t y = uint16_t(rng() % s.height);
    uint8_t p = uint8_t(rng() & 1);
    if (rng() % 4 == 0) {  // a run along a row
      uint16_t x = uint16_t(rng() % s.width);
      int len = 1 + rng() % 40;
      for (int k = 0; k < len && x < s.width && e.size() < n; ++k) {
        e.push_back(t, x, y, p);
        x = uint16_t(x + 1 + rng() % 14);
      }
    } else {
      e.push_back(t, uint16_t(rng() % s.width), y, p);
    }
  }
  return e;
}

void write_in_chunks(const std::string& path, const EventStream& e, const WriteOptions& opt,
                     const std::string& format) {
  auto w = open_writer(path, e.sensor, opt, format);
  size_t i = 0, step = 1;
  while (i < e.size()) {
    size_t j = std::min(e.size(), i + step);
    w->write(e.slice_index(i, j));
    i = j;
    step = step * 3 + 1;  // varied chunk sizes
  }
  w->close();
}

void expect_same(const EventStream& a, const EventStream& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    if (a.t[i] != b.t[i] || a.x[i] != b.x[i] || a.y[i] != b.y[i] || a.p[i] != b.p[i]) {
      FAIL() << "event " << i << " differs: (" << a.t[i] << "," << a.x[i] << "," << a.y[i] << ","
             << int(a.p[i]) << ") vs (" << b.t[i] << "," << b.x[i] << "," << b.y[i] << ","
             << int(b.p[i]) << ")";
    }
  }
  EXPECT_EQ(a.sensor, b.sensor);
}

struct WriterCase {
  const char* format;
  const char* compression;
  const char* ext;
};

class CameraWriter : public ::testing::TestWithParam<WriterCase> {};

TEST_P(CameraWriter, RandomStreamsRoundTrip) {
  const WriterCase c = GetParam();
  std::string dir = test::scratch_dir();
  for (int64_t t0 : {int64_t(0), int64_t(123456), int64_t(1605537493718345)}) {
    EventStream e = random_stream({1280, 720}, 200000, t0, uint32_t(t0 + 7));
    std::string path = dir + "/r" + std::to_string(t0) + c.ext;
    WriteOptions opt;
    opt.compression = c.compression;
    write_in_chunks(path, e, opt, c.format);
    EXPECT_EQ(detect_format(path).name, c.format);
    expect_same(read_events(path), e);
  }
}

TEST_P(CameraWriter, GoldenFilesRoundTrip) {
  const WriterCase c = GetParam();
  std::string dir = test::scratch_dir();
  for (const char* f :
       {"evt2_sample.raw", "evt3_sample.raw", "sample_ncars.dat", "sample.aedat4", "dvs.es"}) {
    std::string src = test::shared_file(std::string("data/formats/") + f);
    if (src.empty()) GTEST_SKIP() << "shared material absent";
    EventStream e = read_events(src);
    if (!e.sensor.known()) e.sensor = {78, 42};  // N-CARS crop: DAT header has no size
    std::string path = dir + "/" + f + c.ext;
    WriteOptions opt;
    opt.compression = c.compression;
    write_in_chunks(path, e, opt, c.format);
    SCOPED_TRACE(f);
    expect_same(read_events(path), e);
  }
}

INSTANTIATE_TEST_SUITE_P(Formats, CameraWriter,
                         ::testing::Values(WriterCase{"evt3", "", ".raw"},
                                           WriterCase{"aedat4", "lz4", ".aedat4"},
                                           WriterCase{"aedat4", "lz4_high", ".aedat4"},
                                           WriterCase{"aedat4", "zstd", ".aedat4"},
                                           WriterCase{"aedat4", "none", ".aedat4"}),
                         [](const auto& info) {
                           return std::string(info.param.format) +
                                  (info.param.compression[0] ? "_" : "") + info.param.compression;
                         });

TEST(CameraWriter, Evt3VectorisesDenseRows) {
  // A full 1280-pixel row at one instant: 2 words per 12 pixels (base + VECT_12) beat 1 word
  // per event, so the data part must be well under 2 bytes per event.
  EventStream e;
  e.sensor = {1280, 720};
  for (int row = 0; row < 100; ++row)
    for (int x = 0; x < 1280; ++x) e.push_back(1000 + row, uint16_t(x), uint16_t(row), 1);
  std::string path = test::scratch_dir() + "/dense.raw";
  write_in_chunks(path, e, {}, "evt3");
  auto size = std::filesystem::file_size(path);
  EXPECT_LT(size, e.size() * 2 / 5);  // 1280 events: 1 base + 107 VECT_12 words = 216 bytes
  expect_same(read_events(path), e);
}

TEST(CameraWriter, RefusesWhatTheFormatCannotHold) {
  std::string dir = test::scratch_dir();
  EventStream e;
  e.sensor = {640, 480};
  e.push_back(10, 5, 5, 1);
  e.push_back(5, 5, 5, 1);  // goes back in time
  auto w = open_writer(dir + "/a.raw", e.sensor, {}, "evt3");
  EXPECT_THROW(w->write(e), Error);
  EXPECT_THROW(open_writer(dir + "/b.raw", {4096, 10}, {}, "evt3"), Error);
  EXPECT_THROW(open_writer(dir + "/c.raw", {}, {}, "evt3"), Error);
  WriteOptions bad;
  bad.compression = "brotli";
  EXPECT_THROW(open_writer(dir + "/d.aedat4", {10, 10}, bad, "aedat4"), Error);
  w.reset();  // never closed: no file left behind
  EXPECT_FALSE(std::filesystem::exists(dir + "/a.raw"));
}

EventStream read_all_bytes(const std::vector<uint8_t>& b, const std::string& format,
                           ReadOptions opt = {}) {
  auto r = find_format(format)->open_bytes(open_memory_source(b.data(), b.size()), opt);
  EventStream out;
  while (r->read(out, 3) > 0) {
  }
  return out;
}

std::vector<uint8_t> evt3_bytes(const std::vector<uint16_t>& words) {
  std::string h = "% evt 3.0\n% format EVT3;height=720;width=1280\n% end\n";
  std::vector<uint8_t> b(h.begin(), h.end());
  for (uint16_t w : words) {
    b.push_back(uint8_t(w));
    b.push_back(uint8_t(w >> 8));
  }
  return b;
}

TEST(CameraEvt3, DecodesVectorsAndTimeAsTheSpecSays) {
  std::vector<uint16_t> w = {
      0x2005,  // EVT_ADDR_X before any TIME_HIGH: no time yet, dropped
      0x8001,  // TIME_HIGH 1 -> t = 4096
      0x6010,  // TIME_LOW 16 -> t = 4112
      0x0007,  // ADDR_Y 7
      0x2805,  // ADDR_X x=5 ON
      0x3864,  // VECT_BASE_X x=100, ON
      0x4805,  // VECT_12 bits 0, 2, 11 -> x = 100, 102, 111; base -> 112
      0x5081,  // VECT_8 bits 0, 7 -> x = 112, 119; base -> 120
      0x6005,  // TIME_LOW 5 (smaller: NOT a wrap) -> t = 4101
      0x2003,  // ADDR_X x=3 OFF
      0xA001,  // EXT_TRIGGER: ignored
      0x8FFF,  // TIME_HIGH 4095
      0x8002,  // TIME_HIGH 2 (decreased: wrap, + 2^24)
      0x6001,  // TIME_LOW 1
      0x2009,  // ADDR_X x=9 OFF
  };
  EventStream e = read_all_bytes(evt3_bytes(w), "evt3");
  std::vector<std::array<int64_t, 4>> want = {
      {4112, 5, 7, 1},   {4112, 100, 7, 1},
      {4112, 102, 7, 1}, {4112, 111, 7, 1},
      {4112, 112, 7, 1}, {4112, 119, 7, 1},
      {4101, 3, 7, 0},   {(int64_t(1) << 24) + 2 * 4096 + 1, 9, 7, 0}};
  ASSERT_EQ(e.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(e.t[i], want[i][0]) << i;
    EXPECT_EQ(e.x[i], want[i][1]) << i;
    EXPECT_EQ(e.y[i], want[i][2]) << i;
    EXPECT_EQ(e.p[i], want[i][3]) << i;
  }
  EXPECT_EQ(e.sensor, (SensorSize{1280, 720}));
}

TEST(CameraEvt3, BinaryStartingWithPercentEndsAHeaderWithoutEndLine) {
  // No "% end" line, and the first data byte is '%' (0x25): TIME_HIGH 0x025.
  std::string h = "% evt 3.0\n% geometry 1280x720\n";
  std::vector<uint8_t> b(h.begin(), h.end());
  for (uint16_t w : {uint16_t(0x8025), uint16_t(0x6001), uint16_t(0x0003), uint16_t(0x2805)}) {
    b.push_back(uint8_t(w));
    b.push_back(uint8_t(w >> 8));
  }
  EventStream e = read_all_bytes(b, "evt3");
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].t, (0x25 << 12) + 1);
  EXPECT_EQ(e[0].x, 5);
  EXPECT_EQ(e[0].y, 3);
  EXPECT_EQ(e.sensor, (SensorSize{1280, 720}));
}

void put_be32(std::vector<uint8_t>& b, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) b.push_back(uint8_t(v >> s));
}
void put_le32(std::vector<uint8_t>& b, uint32_t v) {
  for (int s = 0; s < 32; s += 8) b.push_back(uint8_t(v >> s));
}

TEST(CameraAedat2, DecodesDavisAddressesWithTopLeftOrigin) {
  std::string h =
      "#!AER-DAT2.0\r\n# This is a raw AE data file\r\n# AEChip: "
      "eu.seebetter.ini.chips.davis.DAVIS240C\r\n";
  std::vector<uint8_t> b(h.begin(), h.end());
  auto addr = [](uint32_t x, uint32_t y, uint32_t p) { return (y << 22) | (x << 12) | (p << 11); };
  put_be32(b, addr(10, 0, 1));  // bottom row in jAER -> y = 179
  put_be32(b, 100);
  put_be32(b, 0x80000000u | addr(3, 3, 0));  // APS sample: skipped
  put_be32(b, 101);
  put_be32(b, addr(239, 179, 0));  // top row -> y = 0
  put_be32(b, 150);
  EventStream e = read_all_bytes(b, "aedat2");
  ASSERT_EQ(e.size(), 2u);
  EXPECT_EQ(e.sensor, (SensorSize{240, 180}));
  EXPECT_EQ(e[0].t, 100);
  EXPECT_EQ(e[0].x, 10);
  EXPECT_EQ(e[0].y, 179);
  EXPECT_EQ(e[0].p, 1);
  EXPECT_EQ(e[1].t, 150);
  EXPECT_EQ(e[1].x, 239);
  EXPECT_EQ(e[1].y, 0);
  EXPECT_EQ(e[1].p, 0);
}

TEST(CameraAedat2, DecodesDvs128Addresses) {
  std::string h = "#!AER-DAT2.0\r\n# AEChip: ch.unizh.ini.jaer.chip.retina.DVS128\r\n";
  std::vector<uint8_t> b(h.begin(), h.end());
  put_be32(b, (5u << 8) | (20u << 1) | 1u);
  put_be32(b, 7);
  EventStream e = read_all_bytes(b, "aedat2");
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].x, 20);
  EXPECT_EQ(e[0].y, 127 - 5);
  EXPECT_EQ(e[0].p, 1);
  EXPECT_EQ(e[0].t, 7);
}

TEST(CameraAedat3, DecodesPolarityPacketsAndSkipsOthers) {
  std::string h =
      "#!AER-DAT3.1\r\n#Format: RAW\r\n#Source 1: DAVIS346B\r\n#Start-Time: x\r\n#!END-HEADER\r\n";
  std::vector<uint8_t> b(h.begin(), h.end());
  auto packet = [&](int16_t type, int32_t size, int32_t ovf, int32_t number) {
    b.push_back(uint8_t(type));
    b.push_back(uint8_t(type >> 8));
    b.push_back(1);
    b.push_back(0);
    for (int32_t v : {size, 4, ovf, number, number, number}) put_le32(b, uint32_t(v));
  };
  auto pol = [](uint32_t x, uint32_t y, uint32_t p, uint32_t valid) {
    return (x << 17) | (y << 2) | (p << 1) | valid;
  };
  packet(2, 12, 0, 1);  // a frame-ish packet of another type: skipped
  for (int i = 0; i < 12; ++i) b.push_back(0xAB);
  packet(1, 8, 0, 3);
  put_le32(b, pol(345, 259, 1, 1));
  put_le32(b, 1000);
  put_le32(b, pol(1, 1, 0, 0));  // invalidated
  put_le32(b, 1001);
  put_le32(b, pol(7, 8, 0, 1));
  put_le32(b, 1002);
  packet(1, 8, 1, 1);  // timestamp overflow: + 2^31
  put_le32(b, pol(2, 3, 1, 1));
  put_le32(b, 5);
  EventStream e = read_all_bytes(b, "aedat3");
  ASSERT_EQ(e.size(), 3u);
  EXPECT_EQ(e.sensor, (SensorSize{346, 260}));
  EXPECT_EQ(e[0].t, 1000);
  EXPECT_EQ(e[0].x, 345);
  EXPECT_EQ(e[0].y, 259);
  EXPECT_EQ(e[0].p, 1);
  EXPECT_EQ(e[1].t, 1002);
  EXPECT_EQ(e[1].x, 7);
  EXPECT_EQ(e[1].y, 8);
  EXPECT_EQ(e[1].p, 0);
  EXPECT_EQ(e[2].t, (int64_t(1) << 31) + 5);
  EXPECT_EQ(e[2].x, 2);
}

TEST(CameraEventStream, DecodesAtisKeepingDvsEventsOnly) {
  std::string h("Event Stream\x02\x00\x00\x02", 16);
  std::vector<uint8_t> b(h.begin(), h.end());
  for (uint8_t v : {uint8_t(10), uint8_t(0), uint8_t(8), uint8_t(0)}) b.push_back(v);  // 10x8
  auto ev = [&](int dt, int pol, int tc, int x, int y) {
    for (uint8_t v :
         {uint8_t((dt << 2) | (pol << 1) | tc), uint8_t(x), uint8_t(0), uint8_t(y), uint8_t(0)})
      b.push_back(v);
  };
  ev(5, 1, 0, 3, 0);  // t=5, DVS ON at bottom row -> y = 7
  b.push_back(0xFE);  // overflow x2: +126
  b.push_back(0xFC);  // reset: nothing
  ev(4, 0, 1, 1, 1);  // t=135, threshold crossing: skipped
  ev(1, 0, 0, 9, 7);  // t=136, DVS OFF at top row -> y = 0
  EventStream e = read_all_bytes(b, "es");
  ASSERT_EQ(e.size(), 2u);
  EXPECT_EQ(e[0].t, 5);
  EXPECT_EQ(e[0].x, 3);
  EXPECT_EQ(e[0].y, 7);
  EXPECT_EQ(e[0].p, 1);
  EXPECT_EQ(e[1].t, 136);
  EXPECT_EQ(e[1].x, 9);
  EXPECT_EQ(e[1].y, 0);
  EXPECT_EQ(e[1].p, 0);
}

TEST(CameraReaderBase, AppendsAfterExistingEventsAndKeepsLabelsAligned) {
  EventStream e = random_stream({640, 480}, 5000, 0, 3);
  std::string path = test::scratch_dir() + "/l.raw";
  write_in_chunks(path, e, {}, "evt3");
  EventStream out;
  out.push_back(0, 1, 1, 1, 42);  // a labelled event already there
  auto r = open_reader(path);
  while (r->read(out, 777) > 0) {
  }
  ASSERT_EQ(out.size(), e.size() + 1);
  ASSERT_EQ(out.label.size(), out.size());
  EXPECT_EQ(out.label[0], 42);
  for (size_t i = 1; i < out.size(); ++i) ASSERT_EQ(out.label[i], 0) << i;
  EXPECT_EQ(out.t[1], e.t[0]);
  EXPECT_EQ(out.x.back(), e.x.back());
}

}  // namespace
}  // namespace spikems
