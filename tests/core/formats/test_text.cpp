// Text events, npz events and the EVIMO2 folder: round trips, the time-unit rule, stdin,
// and bad lines reported with their line numbers.
#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "common/test_paths.h"
#include "core/events/formats/npy.h"
#include "core/events/formats/text.h"
#include "core/events/io.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {
namespace {

EventStream sample(size_t n, bool labels) {
  EventStream ev;
  ev.sensor = {346, 260};
  for (size_t i = 0; i < n; ++i) {
    int64_t t = 1600000000000000 + int64_t(i) * 13 + int64_t(i % 7);
    if (labels)
      ev.push_back(t, uint16_t(i % 346), uint16_t(i % 260), uint8_t(i % 2), uint16_t(i % 4));
    else
      ev.push_back(t, uint16_t(i % 346), uint16_t(i % 260), uint8_t(i % 2));
  }
  return ev;
}

EventStream read_string(const std::string& text, ReadOptions opt = {}) {
  auto src =
      open_memory_source(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "mem.txt");
  auto r = open_text_reader(std::move(src), opt);
  EventStream ev;
  while (r->read(ev, 1000) > 0) {
  }
  if (!ev.sensor.known()) ev.sensor = r->sensor();
  return ev;
}

std::string error_of(const std::string& text, ReadOptions opt = {}) {
  try {
    read_string(text, opt);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Text, RoundTripMicrosecondsAndSecondsWithLabels) {
  std::string dir = test::scratch_dir();
  for (bool labels : {false, true})
    for (std::string unit : {"us", "s"}) {
      EventStream ev = sample(25000, labels);
      std::string p = dir + "/e_" + unit + (labels ? "l" : "") + ".txt";
      WriteOptions o;
      o.time_unit = unit;
      Recording r;
      r.events = ev;
      write_recording(p, r, o);
      EXPECT_EQ(detect_format(p).name, "text");
      EventStream back = read_events(p);  // unit from the "# time_unit" comment
      EXPECT_EQ(back.sensor, ev.sensor);
      EXPECT_EQ(back.t, ev.t) << unit;  // seconds are written with exactly 6 decimals
      EXPECT_EQ(back.x, ev.x);
      EXPECT_EQ(back.p, ev.p);
      EXPECT_EQ(back.label, ev.label);
    }
}

// The writer's own decimal formatting, line by line against snprintf: every digit count of the
// time (negative ones, the extremes of int64) and of the uint16 columns, in both time units.
TEST(Text, LinesMatchPrintfForEveryDigitCount) {
  std::vector<int64_t> times = {0, -1, INT64_MIN + 1, INT64_MAX, 1600000000000000};
  for (int64_t p = 1; p <= INT64_MAX / 10; p *= 10)
    for (int64_t v : {p - 1, p, p + 1, 9 * p + (p - 1)}) times.insert(times.end(), {v, -v});
  const uint16_t small[] = {0, 1, 9, 10, 11, 99, 100, 101, 999, 1000, 1001, 9999, 10000, 65535};
  EventStream ev;
  ev.sensor = {65535, 65535};
  size_t k = 0;
  for (int64_t t : times)
    for (uint16_t v : small) {
      const uint16_t w = small[k++ % std::size(small)];
      ev.t.push_back(t), ev.x.push_back(v), ev.y.push_back(w), ev.p.push_back(uint8_t(k % 2));
      ev.label.push_back(small[(k * 5) % std::size(small)]);
    }
  std::string dir = test::scratch_dir();
  for (std::string unit : {"us", "s"}) {
    WriteOptions o;
    o.time_unit = unit;
    Recording r;
    r.events = ev;
    const std::string path = dir + "/digits_" + unit + ".txt";
    write_recording(path, r, o);
    std::ifstream f(path);
    std::string line;
    size_t i = 0;
    while (std::getline(f, line)) {
      if (line.empty() || line[0] == '#') continue;
      ASSERT_LT(i, ev.size());
      char want[96];
      const int64_t t = ev.t[i];
      if (unit == "us") {
        std::snprintf(want, sizeof want, "%lld %u %u %u %u", static_cast<long long>(t), ev.x[i],
                      ev.y[i], ev.p[i], ev.label[i]);
      } else {
        const unsigned long long a =
            t < 0 ? 0ull - static_cast<unsigned long long>(t) : static_cast<unsigned long long>(t);
        std::snprintf(want, sizeof want, "%s%llu.%06llu %u %u %u %u", t < 0 ? "-" : "", a / 1000000,
                      a % 1000000, ev.x[i], ev.y[i], ev.p[i], ev.label[i]);
      }
      EXPECT_EQ(line, want) << unit << " event " << i;
      ++i;
    }
    EXPECT_EQ(i, ev.size()) << unit;
  }
}

TEST(Text, TimeUnitRuleAndOverride) {
  // No header: a '.' in the first events means seconds.
  EventStream a = read_string("0.5 1 2 1\n1.25 3 4 0\n");
  EXPECT_EQ(a.t, (std::vector<int64_t>{500000, 1250000}));
  EventStream b = read_string("500 1 2 1\n1250 3 4 0\n");
  EXPECT_EQ(b.t, (std::vector<int64_t>{500, 1250}));
  // A later fractional value within the look-ahead still selects seconds.
  EventStream c = read_string("0 1 2 1\n1e-3 3 4 0\n");
  EXPECT_EQ(c.t, (std::vector<int64_t>{0, 1000}));
  ReadOptions s;
  s.time_unit = "s";
  EXPECT_EQ(read_string("2 1 2 1\n", s).t, (std::vector<int64_t>{2000000}));
  ReadOptions us;
  us.time_unit = "us";
  EXPECT_NE(error_of("0.5 1 2 1\n", us).find("--time-unit s"), std::string::npos);
}

TEST(Text, HeaderSensorAndMaxPlusOne) {
  EventStream e = read_string("# sensor 40 30\n10,1,2,-1\n11\t3\t4\t+1\r\n12 5 6 0\n");
  EXPECT_EQ(e.sensor, (SensorSize{40, 30}));
  EXPECT_EQ(e.p, (std::vector<uint8_t>{0, 1, 0}));
  EXPECT_EQ(e.t, (std::vector<int64_t>{10, 11, 12}));
  EventStream f = read_string("10 7 2 1\n11 3 9 0\n");
  EXPECT_EQ(f.sensor, (SensorSize{8, 10}));
  ReadOptions o;
  o.sensor = {100, 100};
  EXPECT_EQ(read_string("# sensor 40 30\n10 7 2 1\n", o).sensor, (SensorSize{100, 100}));
}

TEST(Text, CsvColumnHeaderRowIsSkipped) {
  std::string dir = test::scratch_dir();
  std::ofstream(dir + "/e.csv") << "timestamp,x,y,polarity\n0.25,1,2,1\n0.5,3,4,0\n";
  EXPECT_EQ(detect_format(dir + "/e.csv").name, "text");
  EventStream e = read_events(dir + "/e.csv");
  EXPECT_EQ(e.t, (std::vector<int64_t>{250000, 500000}));
  // Only before the first event: later it is a bad line.
  EXPECT_NE(error_of("1 2 3 1\nt x y p\n").find("line 2"), std::string::npos);
}

TEST(Text, BadLinesNameTheLine) {
  struct Case {
    std::string text, expect;
  };
  for (const Case& c : std::vector<Case>{
           {"1 2 3 1\n2 2 3\n", "line 2"},
           {"1 2 3 1\n2 2 3 1 4\n", "line 2"},
           {"# c\n1 2 3 1\nx 2 3 1\n", "line 3"},
           {"1 2 3 1\n2 -2 3 1\n", "line 2"},
           {"1 2 3 1\n2 2 70000 1\n", "line 2"},
           {"1 2 3 1\n2 2 3 2\n", "polarity"},
           {"0.1 2 3 1\nnan 2 3 1\n", "line 2"},
           {"0.1 2 3 1\ninf 2 3 1\n", "line 2"},
           {"0.1 2 3 1\n1e300 2 3 1\n", "line 2"},
           {"# sensor 0 10\n1 2 3 1\n", "sensor"},
           {"1 2 3 1 2 3 4\n", "line 1"},
       }) {
    std::string e = error_of(c.text);
    EXPECT_NE(e.find(c.expect), std::string::npos) << c.text << " -> " << e;
    EXPECT_NE(e.find("mem.txt"), std::string::npos) << e;
  }
  std::string binary(10000, '\x01');
  EXPECT_NE(error_of(binary).find("longer than"), std::string::npos);
}

TEST(Text, OutOfSensorAndBackwardsTimeThroughOpenReader) {
  std::string dir = test::scratch_dir();
  std::ofstream(dir + "/a.txt") << "# sensor 10 10\n1 2 3 1\n2 12 3 1\n";
  EXPECT_THROW(read_events(dir + "/a.txt"), Error);
  std::ofstream(dir + "/b.txt") << "5 2 3 1\n2 1 3 1\n";
  EXPECT_THROW(read_events(dir + "/b.txt"), Error);
  ReadOptions o;
  o.sort = true;
  EXPECT_EQ(read_events(dir + "/b.txt", o).t, (std::vector<int64_t>{2, 5}));
}

TEST(Text, ReadsStandardInput) {
  std::string dir = test::scratch_dir();
  std::ofstream(dir + "/in.txt") << "# sensor 20 20\n0.000001 1 2 1\n0.000002 3 4 0\n";
  ASSERT_NE(std::freopen((dir + "/in.txt").c_str(), "r", stdin), nullptr);
  const FormatInfo* f = find_format("text");
  ASSERT_NE(f, nullptr);
  auto src = open_stdin_source();
  EXPECT_EQ(src->head(6).size(), 6u);  // peeking then reading from the start works
  auto r = f->open_bytes(std::move(src), ReadOptions{});
  EventStream ev;
  while (r->read(ev, 1) > 0) {
  }
  EXPECT_EQ(ev.t, (std::vector<int64_t>{1, 2}));
  EXPECT_EQ(ev.sensor, (SensorSize{20, 20}));
}

TEST(NpzEvents, RoundTripStoredAndDeflate) {
  std::string dir = test::scratch_dir();
  for (std::string comp : {"none", "deflate"}) {
    Recording r;
    r.events = sample(10000, true);
    WriteOptions o;
    o.compression = comp;
    std::string p = dir + "/ev_" + comp + ".npz";
    write_recording(p, r, o);
    EXPECT_EQ(detect_format(p).name, "npz");
    auto z = read_npz(p);
    EXPECT_EQ(z["t"].descr, "<i8");
    EXPECT_EQ(z["x"].descr, "<u2");
    EXPECT_EQ(z["p"].descr, "|u1");
    EventStream back = read_events(p);
    EXPECT_EQ(back.t, r.events.t);
    EXPECT_EQ(back.y, r.events.y);
    EXPECT_EQ(back.label, r.events.label);
    EXPECT_EQ(back.sensor, r.events.sensor);
  }
}

// The writer takes a deflate level (default 1: fast; docs/formats.md), 0 = stored members;
// formats without compression refuse the options instead of ignoring them.
TEST(NpzEvents, DeflateLevelIsHonouredAndChecked) {
  std::string dir = test::scratch_dir();
  Recording r;
  r.events = sample(20000, true);
  auto write = [&](int level) {
    WriteOptions o;
    o.level = level;
    std::string p = dir + "/lvl" + std::to_string(level) + ".npz";
    write_recording(p, r, o);
    EXPECT_EQ(read_events(p).label, r.events.label);
    return p;
  };
  const std::string p0 = write(0), p1 = write(1), p9 = write(9), pd = write(-1);
  auto methods = [](const std::string& p) {
    std::vector<int> m;
    for (const auto& e : zip_list_file(p)) m.push_back(e.method);
    return m;
  };
  EXPECT_EQ(methods(p0), std::vector<int>(6, 0));
  EXPECT_EQ(methods(p9), std::vector<int>(6, 8));
  EXPECT_LT(std::filesystem::file_size(p9), std::filesystem::file_size(p1));
  EXPECT_LT(std::filesystem::file_size(p1), std::filesystem::file_size(p0) / 2);
  // The default is level 1, byte for byte (the writer is reproducible).
  EXPECT_EQ(read_file_bytes(pd), read_file_bytes(p1));

  WriteOptions bad;
  bad.level = 10;
  try {
    write_recording(dir + "/bad.npz", r, bad);
    FAIL() << "level 10 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("deflate level must be 0..9"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.npz"));
  for (const auto& [comp, level] : {std::pair<std::string, int>{"", 3}, {"lz4", -1}}) {
    WriteOptions o;
    o.compression = comp;
    o.level = level;
    try {
      write_recording(dir + "/t.txt", r, o);
      FAIL() << "text accepted compression '" << comp << "' level " << level;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("the text format has no compression"), std::string::npos)
          << e.what();
    }
  }
  WriteOptions none;
  none.compression = "none";  // harmless: says what text does anyway
  write_recording(dir + "/t.txt", r, none);
  EXPECT_EQ(read_events(dir + "/t.txt").size(), r.events.size());
}

// The writer streams each column through a temporary file of its own: chunks with and
// without labels (the events before the first labelled chunk, and those of unlabelled chunks
// after it, get 0), the same archive byte for byte as the whole arrays written at once, and
// nothing left beside the output.
TEST(NpzEvents, StreamedColumnsEqualTheWholeArrays) {
  std::string dir = test::scratch_dir();
  const EventStream all = sample(30000, true);
  std::vector<uint16_t> want_labels(all.size(), 0);
  {
    auto w = open_writer(dir + "/s.npz", all.sensor);
    size_t at = 0;
    for (size_t n : {7000, 8000, 0, 9000, 6000}) {
      EventStream c;
      c.sensor = all.sensor;
      c.append(all, at, at + n);
      const bool labelled = at >= 7000 && at < 15000;  // only the second chunk
      if (!labelled) c.label.clear();
      if (labelled)
        std::copy(all.label.begin() + std::ptrdiff_t(at),
                  all.label.begin() + std::ptrdiff_t(at + n),
                  want_labels.begin() + std::ptrdiff_t(at));
      w->write(c);
      at += n;
    }
    w->close();
  }
  const EventStream back = read_events(dir + "/s.npz");
  EXPECT_EQ(back.t, all.t);
  EXPECT_EQ(back.x, all.x);
  EXPECT_EQ(back.p, all.p);
  EXPECT_EQ(back.label, want_labels);
  EXPECT_EQ(back.sensor, all.sensor);
  const std::vector<int32_t> sensor{all.sensor.width, all.sensor.height};
  const int64_t n = int64_t(all.size());
  write_npz(dir + "/whole.npz",
            {{"label", NpyArray::from(want_labels, {n})},
             {"p", NpyArray::from(all.p, {n})},
             {"sensor", NpyArray::from(sensor, {2})},
             {"t", NpyArray::from(all.t, {n})},
             {"x", NpyArray::from(all.x, {n})},
             {"y", NpyArray::from(all.y, {n})}},
            true, 1);
  EXPECT_EQ(read_file_bytes(dir + "/s.npz"), read_file_bytes(dir + "/whole.npz"));
  int files = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 2);
}

TEST(NpzEvents, FloatSecondsSignedPolarityAndBadArrays) {
  std::string dir = test::scratch_dir();
  std::map<std::string, NpyArray> a;
  a["t"] = NpyArray::from(std::vector<double>{0.5, 0.75}, {2});
  a["x"] = NpyArray::from(std::vector<int32_t>{1, 2}, {2});
  a["y"] = NpyArray::from(std::vector<int32_t>{3, 4}, {2});
  a["p"] = NpyArray::from(std::vector<int8_t>{-1, 1}, {2});
  write_npz(dir + "/f.npz", a, false);
  EventStream e = read_events(dir + "/f.npz");
  EXPECT_EQ(e.t, (std::vector<int64_t>{500000, 750000}));
  EXPECT_EQ(e.p, (std::vector<uint8_t>{0, 1}));
  EXPECT_EQ(e.sensor, (SensorSize{3, 5}));
  a["x"] = NpyArray::from(std::vector<int32_t>{1, 2, 3}, {3});
  write_npz(dir + "/g.npz", a, false);
  EXPECT_THROW(read_events(dir + "/g.npz"), Error);
  a["x"] = NpyArray::from(std::vector<int32_t>{1, -2}, {2});
  write_npz(dir + "/h.npz", a, false);
  EXPECT_THROW(read_events(dir + "/h.npz"), Error);
  a["x"] = NpyArray::from(std::vector<int32_t>{1, 2}, {2});
  a["t"] = NpyArray::from(std::vector<double>{0.5, std::nan("")}, {2});
  write_npz(dir + "/i.npz", a, false);
  EXPECT_THROW(read_events(dir + "/i.npz"), Error);
}

TEST(Evimo2, SyntheticFolder) {
  std::string dir = test::scratch_dir();
  write_npy(dir + "/dataset_events_t.npy", NpyArray::from(std::vector<double>{1.0, 1.5, 2.0}, {3}));
  write_npy(dir + "/dataset_events_xy.npy",
            NpyArray::from(std::vector<uint16_t>{10, 20, 639, 479, 0, 0}, {3, 2}));
  write_npy(dir + "/dataset_events_p.npy", NpyArray::from(std::vector<uint8_t>{1, 0, 1}, {3}));
  std::vector<uint16_t> m0(640 * 480, 0), m1(640 * 480, 0);
  m0[20 * 640 + 10] = 23000;
  m1[479 * 640 + 639] = 5000;
  write_npz(dir + "/dataset_mask.npz",
            {{"mask_0000000001", NpyArray::from(m1, {480, 640})},
             {"mask_0000000000", NpyArray::from(m0, {480, 640})}},
            true);
  write_npz(dir + "/dataset_info.npz",
            {{"K", NpyArray::from(std::vector<double>{520, 0, 320, 0, 521, 240, 0, 0, 1}, {3, 3})},
             {"D", NpyArray::from(std::vector<double>{0.01, 0.02, 0, 0}, {4})}},
            false);
  EXPECT_EQ(detect_format(dir).name, "evimo2");
  Recording r = read_recording(dir);
  EXPECT_EQ(r.events.t, (std::vector<int64_t>{1000000, 1500000, 2000000}));
  EXPECT_EQ(r.events.x[1], 639);
  EXPECT_EQ(r.events.sensor, (SensorSize{640, 480}));
  ASSERT_EQ(r.masks.size(), 2u);
  EXPECT_EQ(r.masks[0].at(10, 20), 23);
  EXPECT_EQ(r.masks[1].at(639, 479), 5);
  EXPECT_EQ(r.masks[0].t_us, 1250000);  // uniform estimate over 1 s, 2 frames
  EXPECT_EQ(r.masks[1].t_us, 1750000);
  EXPECT_EQ(r.intrinsics->fy, 521);
  std::ofstream(dir + "/meta.txt") << "{'frames': [{'ts': 1.1}, {'ts': 1.9}]}";
  r = read_recording(dir);
  EXPECT_EQ(r.masks[0].t_us, 1100000);
  EXPECT_EQ(r.masks[1].t_us, 1900000);
}

}  // namespace
}  // namespace spikems
