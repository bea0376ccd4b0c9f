// Camera formats against golden values from an independent decoder (../shared/data/formats/
// golden.json): every statistic and the first/last ten events must match exactly, whether the
// file is read whole or streamed in small chunks.
#include <gtest/gtest.h>

#include <deque>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/test_paths.h"
#include "core/events/io.h"

namespace spikems {
namespace {

struct Stats {
  uint64_t count = 0, on = 0, off = 0;
  int64_t t_first = 0, t_last = 0;
  int64_t x_min = INT64_MAX, x_max = INT64_MIN, y_min = INT64_MAX, y_max = INT64_MIN;
  int64_t sum_x = 0, sum_y = 0, sum_dt = 0;
  std::vector<std::array<int64_t, 4>> first;
  std::deque<std::array<int64_t, 4>> last;

  void add(const EventStream& s) {
    for (size_t i = 0; i < s.size(); ++i) {
      if (count == 0) t_first = s.t[i];
      ++count;
      t_last = s.t[i];
      x_min = std::min<int64_t>(x_min, s.x[i]);
      x_max = std::max<int64_t>(x_max, s.x[i]);
      y_min = std::min<int64_t>(y_min, s.y[i]);
      y_max = std::max<int64_t>(y_max, s.y[i]);
      (s.p[i] ? on : off)++;
      sum_x += s.x[i];
      sum_y += s.y[i];
      sum_dt += s.t[i] - t_first;
      std::array<int64_t, 4> e{s.t[i], s.x[i], s.y[i], s.p[i]};
      if (first.size() < 10) first.push_back(e);
      last.push_back(e);
      if (last.size() > 10) last.pop_front();
    }
  }
};

void expect_golden(const Stats& s, const nlohmann::json& g, const std::string& what) {
  SCOPED_TRACE(what);
  EXPECT_EQ(s.count, g["count"].get<uint64_t>());
  EXPECT_EQ(s.t_first, g["t_first_us"].get<int64_t>());
  EXPECT_EQ(s.t_last, g["t_last_us"].get<int64_t>());
  EXPECT_EQ(s.x_min, g["x_min"].get<int64_t>());
  EXPECT_EQ(s.x_max, g["x_max"].get<int64_t>());
  EXPECT_EQ(s.y_min, g["y_min"].get<int64_t>());
  EXPECT_EQ(s.y_max, g["y_max"].get<int64_t>());
  EXPECT_EQ(s.on, g["on"].get<uint64_t>());
  EXPECT_EQ(s.off, g["off"].get<uint64_t>());
  EXPECT_EQ(s.sum_x, g["sum_x"].get<int64_t>());
  EXPECT_EQ(s.sum_y, g["sum_y"].get<int64_t>());
  EXPECT_EQ(s.sum_dt, g["sum_t_minus_first"].get<int64_t>());
  ASSERT_EQ(s.first.size(), g["first_events"].size());
  for (size_t i = 0; i < s.first.size(); ++i)
    for (int k = 0; k < 4; ++k)
      EXPECT_EQ(s.first[i][k], g["first_events"][i][k].get<int64_t>()) << "first event " << i;
  ASSERT_EQ(s.last.size(), g["last_events"].size());
  for (size_t i = 0; i < s.last.size(); ++i)
    for (int k = 0; k < 4; ++k)
      EXPECT_EQ(s.last[i][k], g["last_events"][i][k].get<int64_t>()) << "last event " << i;
}

struct Case {
  const char* file;
  const char* format;
  SensorSize sensor;
};

class CameraGolden : public ::testing::TestWithParam<Case> {};

TEST_P(CameraGolden, WholeFileMatchesGolden) {
  const Case c = GetParam();
  SPIKEMS_REQUIRE_SHARED(path, std::string("data/formats/") + c.file);
  SPIKEMS_REQUIRE_SHARED(gpath, "data/formats/golden.json");
  nlohmann::json golden = nlohmann::json::parse(std::ifstream(gpath));
  EXPECT_EQ(detect_format(path).name, c.format);
  EventStream ev = read_events(path);  // validated: in-sensor, time-ordered
  Stats s;
  s.add(ev);
  expect_golden(s, golden[c.file], "whole file");
  if (c.sensor.known()) {
    EXPECT_EQ(ev.sensor, c.sensor);
  }
}

TEST_P(CameraGolden, ChunkBoundariesDoNotMatter) {
  const Case c = GetParam();
  SPIKEMS_REQUIRE_SHARED(path, std::string("data/formats/") + c.file);
  SPIKEMS_REQUIRE_SHARED(gpath, "data/formats/golden.json");
  nlohmann::json golden = nlohmann::json::parse(std::ifstream(gpath));
  // From memory through the format's own reader, in odd chunk sizes.
  std::vector<uint8_t> bytes = read_file_bytes(path);
  for (size_t chunk : {size_t(1000), size_t(7), size_t(65536)}) {
    auto r = find_format(c.format)->open_bytes(open_memory_source(bytes.data(), bytes.size(), path),
                                               ReadOptions{});
    Stats s;
    EventStream out;
    size_t got;
    while ((got = r->read(out, chunk)) > 0) {
      ASSERT_LE(got, chunk);
      ASSERT_EQ(out.size(), got);
      s.add(out);
      out.clear();
    }
    expect_golden(s, golden[c.file], "chunks of " + std::to_string(chunk));
  }
}

INSTANTIATE_TEST_SUITE_P(Files, CameraGolden,
                         ::testing::Values(Case{"evt2_sample.raw", "evt2", {640, 480}},
                                           Case{"evt3_sample.raw", "evt3", {1280, 720}},
                                           Case{"sample_ncars.dat", "dat", {}},
                                           Case{"sample.aedat4", "aedat4", {320, 240}},
                                           Case{"dvs.es", "es", {320, 240}}),
                         [](const auto& info) { return std::string(info.param.format); });

}  // namespace
}  // namespace spikems
