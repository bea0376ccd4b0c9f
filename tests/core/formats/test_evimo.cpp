// EV-IMO readers: the real poster_translation.npz against golden.json, the txt folder layout
// on a synthetic sequence, meta.txt parsing, and the EVIMO2 ground-truth PNG.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>

#include "common/test_paths.h"
#include "core/events/formats/evimo_common.h"
#include "core/events/formats/npy.h"
#include "core/events/formats/png16.h"
#include "core/events/io.h"
#include "core/util/error.h"

namespace spikems {
namespace {

nlohmann::json golden(const std::string& key) {
  std::string g = test::shared_file("data/formats/golden.json");
  std::ifstream in(g);
  return nlohmann::json::parse(in)[key];
}

TEST(Evimo1, PosterTranslationMatchesGolden) {
  SPIKEMS_REQUIRE_SHARED(path, "data/formats/poster_translation.npz");
  auto g = golden("poster_translation.npz");
  EXPECT_EQ(detect_format(path).name, "evimo1");
  Recording rec = read_recording(path);
  const EventStream& ev = rec.events;
  ASSERT_EQ(int64_t(ev.size()), g["count"].get<int64_t>());
  EXPECT_NEAR(double(ev.t_first()), g["t_first_us"].get<double>(), 4);
  EXPECT_NEAR(double(ev.t_last()), g["t_last_us"].get<double>(), 4);
  EXPECT_EQ(ev.sensor, (SensorSize{240, 180}));  // DAVIS240C: smallest DAVIS size holding all
  int64_t on = 0, sx = 0, sy = 0, st = 0;
  int xmin = 1 << 20, xmax = -1, ymin = 1 << 20, ymax = -1;
  for (size_t i = 0; i < ev.size(); ++i) {
    on += ev.p[i];
    sx += ev.x[i];
    sy += ev.y[i];
    st += ev.t[i] - ev.t_first();
    xmin = std::min<int>(xmin, ev.x[i]);
    xmax = std::max<int>(xmax, ev.x[i]);
    ymin = std::min<int>(ymin, ev.y[i]);
    ymax = std::max<int>(ymax, ev.y[i]);
  }
  EXPECT_EQ(on, g["on"].get<int64_t>());
  EXPECT_EQ(int64_t(ev.size()) - on, g["off"].get<int64_t>());
  EXPECT_EQ(sx, g["sum_x"].get<int64_t>());
  EXPECT_EQ(sy, g["sum_y"].get<int64_t>());
  EXPECT_EQ(xmin, g["x_min"].get<int>());
  EXPECT_EQ(xmax, g["x_max"].get<int>());
  EXPECT_EQ(ymin, g["y_min"].get<int>());
  EXPECT_EQ(ymax, g["y_max"].get<int>());
  // float32 seconds carry ~4 us of rounding per event.
  EXPECT_NEAR(double(st), g["sum_t_minus_first"].get<double>(), 4.0 * double(ev.size()));
  for (int k = 0; k < 10; ++k) {
    auto f = g["first_events"][k];
    EXPECT_NEAR(double(ev.t[k]), f[0].get<double>(), 4) << k;
    EXPECT_EQ(ev.x[k], f[1].get<int>()) << k;
    EXPECT_EQ(ev.y[k], f[2].get<int>()) << k;
    EXPECT_EQ(ev.p[k], f[3].get<int>()) << k;
    auto l = g["last_events"][k];
    size_t j = ev.size() - 10 + size_t(k);
    EXPECT_NEAR(double(ev.t[j]), l[0].get<double>(), 4) << k;
    EXPECT_EQ(ev.x[j], l[1].get<int>()) << k;
    EXPECT_EQ(ev.y[j], l[2].get<int>()) << k;
    EXPECT_EQ(ev.p[j], l[3].get<int>()) << k;
  }
  ASSERT_TRUE(rec.intrinsics.has_value());
  EXPECT_GT(rec.intrinsics->fx, 100);
  EXPECT_EQ(rec.intrinsics->distortion.size(), 4u);
  EXPECT_TRUE(rec.masks.empty());  // this sample has no mask stack
}

TEST(Evimo1, SensorOptionOverridesAndOutOfSensorIsAnError) {
  SPIKEMS_REQUIRE_SHARED(path, "data/formats/poster_translation.npz");
  ReadOptions o;
  o.sensor = {346, 260};
  EXPECT_EQ(read_events(path, o).sensor, (SensorSize{346, 260}));
  o.sensor = {200, 180};  // x reaches 239
  try {
    read_events(path, o);
    FAIL() << "expected an out-of-sensor error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("outside"), std::string::npos) << e.what();
  }
}

// A synthetic EV-IMO npz with masks, K, D, a pickled meta and a meta.txt beside it.
TEST(Evimo1, MasksAndFrameTimesFromMetaTxt) {
  std::string dir = test::scratch_dir();
  std::vector<float> ev = {0.5f, 1, 2, 1, 0.75f, 3, 1, 0, 1.0f, 0, 0, -1};
  std::vector<uint16_t> mask(2 * 3 * 4, 0);
  mask[1] = 3000;            // frame 0, pixel (1,0): object 3
  mask[12 + 4 + 3] = 12000;  // frame 1, pixel (3,1): object 12
  std::map<std::string, NpyArray> a;
  a["events"] = NpyArray::from(ev, {3, 4});
  a["K"] = NpyArray::from(std::vector<double>{200, 0, 170, 0, 201, 130, 0, 0, 1}, {3, 3});
  a["D"] = NpyArray::from(std::vector<double>{0.1, -0.2, 0, 0}, {4});
  a["mask"] = NpyArray::from(mask, {2, 3, 4});
  a["discretization"] = NpyArray::from(std::vector<double>{0.01}, {});
  write_npz(dir + "/seq.npz", a, true);
  EXPECT_EQ(detect_format(dir + "/seq.npz").name, "evimo1");

  Recording r = read_recording(dir + "/seq.npz");
  EXPECT_EQ(r.events.sensor, (SensorSize{4, 3}));  // the mask size
  EXPECT_EQ(r.events.t, (std::vector<int64_t>{500000, 750000, 1000000}));
  EXPECT_EQ(r.events.p, (std::vector<uint8_t>{1, 0, 0}));
  ASSERT_EQ(r.masks.size(), 2u);
  EXPECT_EQ(r.masks[0].at(1, 0), 3);
  EXPECT_EQ(r.masks[1].at(3, 1), 12);
  EXPECT_EQ(r.masks[0].t_us, 500000 + 125000);  // uniform estimate: (0 + 0.5) * 0.5 s / 2
  EXPECT_EQ(nlohmann::json::parse(r.metadata_json)["mask_times"], "uniform-estimate");
  EXPECT_DOUBLE_EQ(r.intrinsics->cx, 170);
  EXPECT_DOUBLE_EQ(r.intrinsics->fy, 201);
  EXPECT_EQ(r.intrinsics->distortion[1], -0.2);

  std::ofstream(dir + "/meta.txt") << "{'meta': {'name': 'x'}, 'frames': [\n"
                                      "  {'id': 0, 'ts': 0.6, 'gt_frame': 'depth_mask_0.png'},\n"
                                      "  {'id': 1, 'ts': 0.9, 'cam': {'vel': (1, -2.5e-1)}}]}\n";
  r = read_recording(dir + "/seq.npz");
  EXPECT_EQ(r.masks[0].t_us, 600000);
  EXPECT_EQ(r.masks[1].t_us, 900000);
  EXPECT_EQ(nlohmann::json::parse(r.metadata_json)["mask_times"], "meta.txt");
}

TEST(Evimo1, TruncatedFlippedAndNanInputsAreErrors) {
  SPIKEMS_REQUIRE_SHARED(path, "data/formats/poster_translation.npz");
  std::string dir = test::scratch_dir();
  std::ifstream in(path, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ReadOptions forced;
  forced.format = "evimo1";
  for (size_t cut : {size_t(10), size_t(1000), bytes.size() / 3, bytes.size() / 2,
                     bytes.size() - 100, bytes.size() - 1}) {
    std::string c = dir + "/cut.npz";
    std::ofstream(c, std::ios::binary).write(bytes.data(), long(cut));
    try {
      read_recording(c, forced);
      ADD_FAILURE() << "truncated at " << cut << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("cut.npz"), std::string::npos) << e.what();
    }
  }
  auto flipped = bytes;
  flipped[0] = 'X';
  std::ofstream(dir + "/flip.npz", std::ios::binary).write(flipped.data(), long(flipped.size()));
  EXPECT_THROW(read_recording(dir + "/flip.npz", forced), Error);
  EXPECT_THROW(detect_format(dir + "/flip.npz"), Error);  // nothing recognises it
  std::map<std::string, NpyArray> a;
  a["events"] = NpyArray::from(std::vector<float>{0.5f, 1, 2, 1, NAN, 1, 1, 0}, {2, 4});
  a["K"] = NpyArray::from(std::vector<double>{1, 0, 0, 0, 1, 0, 0, 0, 1}, {3, 3});
  write_npz(dir + "/nan.npz", a, false);
  try {
    read_recording(dir + "/nan.npz");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("event 1"), std::string::npos) << e.what();
  }
}

TEST(PythonLiteral, ParsesTheMetaSubset) {
  auto j = parse_python_literal(
      "{'a': [1, -2, 3.5e2, None, True, False], \"b\": (0,), 'c': {'d': 'it\\'s'}, 7: 'n',}", "m");
  EXPECT_EQ(j["a"][0], 1);
  EXPECT_EQ(j["a"][1], -2);
  EXPECT_DOUBLE_EQ(j["a"][2].get<double>(), 350.0);
  EXPECT_TRUE(j["a"][3].is_null());
  EXPECT_EQ(j["a"][4], true);
  EXPECT_EQ(j["b"].size(), 1u);
  EXPECT_EQ(j["c"]["d"], "it's");
  EXPECT_EQ(j["7"], "n");
  for (const char* bad : {"{'a': }", "{'a' 1}", "[1, 2", "'open", "{'a': 1} x", "[@]"})
    EXPECT_THROW(parse_python_literal(bad, "m"), Error) << bad;
  std::string deep(100, '[');
  EXPECT_THROW(parse_python_literal(deep, "m"), Error);
}

TEST(Evimo1Txt, FolderWithPngMasks) {
  std::string dir = test::scratch_dir();
  std::filesystem::create_directories(dir + "/img");
  std::ofstream(dir + "/events.txt") << "0.100000 1 2 1\n0.200000 5 3 0\n0.350000 6 4 1\n";
  std::ofstream(dir + "/meta.txt")
      << "{'frames': [{'id': 7, 'ts': 0.15, 'gt_frame': 'depth_mask_7.png'},"
         " {'id': 8, 'ts': 0.30}]}";
  for (int id : {7, 8}) {
    Image16 img;
    img.width = 8;
    img.height = 6;
    img.channels = 3;
    img.data.assign(8 * 6 * 3, 0);
    // File order RGB: R (= BGR channel 2) holds id x 1000, B holds depth.
    img.data[(2 * 8 + 5) * 3 + 0] = uint16_t(id == 7 ? 2000 : 5000);
    img.data[(2 * 8 + 5) * 3 + 2] = 1234;
    write_png16(dir + "/img/depth_mask_" + std::to_string(id) + ".png", img);
  }
  EXPECT_EQ(detect_format(dir).name, "evimo1-txt");
  Recording r = read_recording(dir);
  EXPECT_EQ(r.events.t, (std::vector<int64_t>{100000, 200000, 350000}));
  EXPECT_EQ(r.events.sensor, (SensorSize{8, 6}));
  ASSERT_EQ(r.masks.size(), 2u);
  EXPECT_EQ(r.masks[0].t_us, 150000);
  EXPECT_EQ(r.masks[0].at(5, 2), 2);
  EXPECT_EQ(r.masks[1].at(5, 2), 5);
  EXPECT_EQ(r.masks[1].at(4, 2), 0);
}

// The EVIMO2 frame: values checked with an independent decoder (zlib + PNG filter 1 by hand).
TEST(Png16, Evimo2DepthMaskFrame) {
  SPIKEMS_REQUIRE_SHARED(path, "data/formats/evimo2_depth_mask_280.png");
  Image16 img = read_png16(path);
  EXPECT_EQ(img.width, 640);
  EXPECT_EQ(img.height, 480);
  EXPECT_EQ(img.channels, 3);
  EXPECT_EQ(img.bit_depth, 16);
  std::map<uint16_t, int64_t> ids;
  int64_t depth_sum = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      ids[evimo_mask_id(img.at_bgr(x, y, 2))]++;
      EXPECT_EQ(img.at_bgr(x, y, 2) % 1000, 0);
      depth_sum += img.at_bgr(x, y, 0);
    }
  // One object (id 9) fills the whole field of view in this FOV-check frame.
  EXPECT_EQ(ids, (std::map<uint16_t, int64_t>{{9, 640 * 480}}));
  EXPECT_EQ(depth_sum, 127998473);
  EXPECT_EQ(img.at_bgr(0, 0, 0), 429);
  EXPECT_EQ(img.at_bgr(320, 240, 0), 416);
  EXPECT_EQ(img.at_bgr(639, 479, 0), 405);
  EXPECT_EQ(img.at_bgr(100, 50, 1), 424);
}

TEST(Png16, RoundTripAndBadInput) {
  Image16 img;
  img.width = 5;
  img.height = 3;
  img.channels = 1;
  for (int i = 0; i < 15; ++i) img.data.push_back(uint16_t(i * 4000 + 7));
  auto bytes = encode_png16(img);
  Image16 back = decode_png16(bytes.data(), bytes.size(), "mem");
  EXPECT_EQ(back.data, img.data);
  EXPECT_EQ(back.bit_depth, 16);
  for (size_t cut : {size_t(0), size_t(7), size_t(20), bytes.size() / 2, bytes.size() - 13})
    EXPECT_THROW(decode_png16(bytes.data(), cut, "cut.png"), Error) << cut;
  auto bad = bytes;
  bad[0] = 'X';
  EXPECT_THROW(decode_png16(bad.data(), bad.size(), "bad.png"), Error);
}

}  // namespace
}  // namespace spikems
