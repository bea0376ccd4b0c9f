// `spikems info`, `convert` and `render` run as a user runs them: exit codes, messages, numbers.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <tuple>

#include "common/test_paths.h"
#include "core/events/event_ops.h"
#include "core/events/formats/npy.h"
#include "core/events/io.h"
#include "core/model/model_file.h"
#include "core/viz/event_frame.h"
#include "core/viz/image.h"

using namespace spikems;
using test::run_command;
using test::spikems_binary;

namespace {

// 8x6 sensor, t in microseconds, labels: object 3 (2 events), object 5 (1), background (3).
const char* kSmallText =
    "# sensor 8 6\n"
    "1000 1 1 1 0\n"
    "1500 2 1 0 0\n"
    "2000 5 4 1 3\n"
    "2500 6 4 1 3\n"
    "3000 0 5 0 5\n"
    "11000 7 0 1 0\n";

std::string write_text(const std::string& dir, const std::string& name, const char* body) {
  std::string p = dir + "/" + name;
  std::ofstream(p) << body;
  return p;
}

std::string q(const std::string& s) {
  return "'" + s + "'";
}

#define REQUIRE_FORMAT(name) \
  if (!find_format(name)) GTEST_SKIP() << "format '" << name << "' is not registered in this build"

}  // namespace

TEST(CliInfoConvertRender, HelpListsTheOptions) {
  struct Case {
    const char* cmd;
    std::vector<const char*> opts;
  };
  for (const Case& c :
       {Case{"info", {"--json", "--sort", "--time-unit", "--width", "--height"}},
        Case{"convert", {"--format", "--compression", "--from", "--to", "--sort"}},
        Case{"render",
             {"--from", "--window", "--out", "--scale", "--labels", "--mask-from-labels"}}}) {
    std::string out;
    EXPECT_EQ(run_command(spikems_binary() + " " + c.cmd + " --help", &out), 0) << out;
    for (const char* o : c.opts) EXPECT_NE(out.find(o), std::string::npos) << c.cmd << " " << o;
  }
}

// Every command's --help shows at least one example, and options that no shipped model depends
// on say they are experimental (docs/cli.md lists the same).
TEST(CliHelp, EveryCommandShowsExamples) {
  std::vector<std::string> cmds{"info",     "convert",       "render",    "segment",
                                "simulate", "eval",          "calibrate", "energy",
                                "average",  "import-slayer", "formats"};
  if (SPIKEMS_TEST_WITH_TRAIN) cmds.insert(cmds.end(), {"train", "forward"});
  for (const std::string& c : cmds) {
    std::string out;
    EXPECT_EQ(run_command(spikems_binary() + " " + c + " --help", &out), 0) << c << ": " << out;
    EXPECT_NE(out.find("Example"), std::string::npos) << c << " --help has no example:\n" << out;
    EXPECT_NE(out.find("spikems " + c), std::string::npos) << c << ": " << out;
  }
}

TEST(CliHelp, ExperimentalOptionsAreMarked) {
  struct Case {
    const char* cmd;
    const char* option;
  };
  for (const Case& c : {Case{"segment", "--time-step-us"}, Case{"eval", "--kalman"},
                        Case{"eval", "--time-step-ms"}, Case{"calibrate", "--time-step-ms"}}) {
    std::string out;
    ASSERT_EQ(run_command(spikems_binary() + " " + c.cmd + " --help", &out), 0) << out;
    // The option's entry: its name, then its description (on the next line when the name
    // column is full), up to the next option.
    const size_t at = out.find(std::string("\n  ") + c.option + " ");
    ASSERT_NE(at, std::string::npos) << c.cmd << " " << c.option << "\n" << out;
    const std::string entry = out.substr(at, out.find("\n  -", at + 1) - at);
    EXPECT_NE(entry.find("(experimental)"), std::string::npos) << c.cmd << ": " << entry;
  }
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " --help", &out), 0) << out;
  const size_t at = out.find("  average");
  ASSERT_NE(at, std::string::npos) << out;
  EXPECT_NE(out.substr(at, out.find('\n', at) - at).find("(experimental)"), std::string::npos)
      << out;
}

TEST(CliInfoConvertRender, BadInputsFailWithTheFileName) {
  std::string dir = test::scratch_dir();
  std::string missing = dir + "/missing_file.raw";
  std::string out;
  EXPECT_NE(run_command(spikems_binary() + " info " + q(missing), &out), 0);
  EXPECT_NE(out.find(missing), std::string::npos) << out;
  EXPECT_NE(
      run_command(spikems_binary() + " convert " + q(missing) + " " + q(dir + "/o.txt"), &out), 0);
  EXPECT_NE(out.find(missing), std::string::npos) << out;
  EXPECT_NE(
      run_command(spikems_binary() + " render " + q(missing) + " --out " + q(dir + "/f.png"), &out),
      0);
  EXPECT_NE(out.find(missing), std::string::npos) << out;
  // Garbage bytes: not any known format.
  std::string junk = dir + "/junk.bin";
  std::ofstream(junk, std::ios::binary) << std::string("\x01\x02\x03garbage\xff\xfe", 12);
  EXPECT_NE(run_command(spikems_binary() + " info " + q(junk), &out), 0);
  EXPECT_NE(out.find(junk), std::string::npos) << out;
  // A bad duration names the text.
  REQUIRE_FORMAT("text");
  std::string txt = write_text(dir, "a.txt", kSmallText);
  EXPECT_NE(run_command(spikems_binary() + " render " + q(txt) + " --time-unit us --from 5parsecs" +
                            " --out " + q(dir + "/f.png"),
                        &out),
            0);
  EXPECT_NE(out.find("5parsecs"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/f.png"));
  // Unknown output extension: names the output.
  EXPECT_NE(run_command(spikems_binary() + " convert " + q(txt) + " " + q(dir + "/o.xyz"), &out),
            0);
  EXPECT_NE(out.find("o.xyz"), std::string::npos) << out;
}

TEST(CliInfoConvertRender, InfoNumbersOnASmallTextFile) {
  REQUIRE_FORMAT("text");
  std::string dir = test::scratch_dir();
  std::string txt = write_text(dir, "small.txt", kSmallText);
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " info --time-unit us " + q(txt), &out), 0) << out;
  EXPECT_NE(out.find("text"), std::string::npos) << out;
  EXPECT_NE(out.find("8 x 6"), std::string::npos) << out;
  EXPECT_NE(out.find("events        6"), std::string::npos) << out;
  EXPECT_NE(out.find("10.000 ms"), std::string::npos) << out;          // 11000 - 1000 us
  EXPECT_NE(out.find("66.7 % ON"), std::string::npos) << out;          // 4 of 6
  EXPECT_NE(out.find("0:3 3:2 5:1"), std::string::npos) << out;        // events per id
  EXPECT_NE(out.find("50.00 % of events"), std::string::npos) << out;  // 3 of 6 labelled

  ASSERT_EQ(run_command(spikems_binary() + " info --json --time-unit us " + q(txt) + " 2>/dev/null",
                        &out),
            0)
      << out;
  auto j = nlohmann::json::parse(out);
  ASSERT_EQ(j.size(), 1u);
  auto& f = j[0];
  EXPECT_EQ(f["format"], "text");
  EXPECT_EQ(f["width"], 8);
  EXPECT_EQ(f["height"], 6);
  EXPECT_EQ(f["events"], 6);
  EXPECT_EQ(f["t_min_us"], 1000);
  EXPECT_EQ(f["t_max_us"], 11000);
  EXPECT_DOUBLE_EQ(f["duration_s"].get<double>(), 0.01);
  EXPECT_DOUBLE_EQ(f["rate_ev_per_s"].get<double>(), 600.0);
  EXPECT_DOUBLE_EQ(f["on_fraction"].get<double>(), 4.0 / 6.0);
  EXPECT_EQ(f["events_per_label"]["3"], 2);
  EXPECT_EQ(f["events_per_label"]["5"], 1);
  EXPECT_EQ(f["events_per_label"]["0"], 3);
  EXPECT_DOUBLE_EQ(f["foreground_fraction"].get<double>(), 0.5);
  EXPECT_EQ(f["mask_frames"], 0);

  // Two files, one bad: the good one is reported, the exit status says something failed.
  ASSERT_NE(
      run_command(spikems_binary() + " info --time-unit us " + q(txt) + " " + q(dir + "/nope.txt"),
                  &out),
      0);
  EXPECT_NE(out.find("events        6"), std::string::npos) << out;
  EXPECT_NE(out.find("nope.txt"), std::string::npos) << out;
}

// A model file: the 3-level U-Net with skips (layer 5 takes layer 2's spikes, layer 6 layer
// 1's; 1-based), 2 ms steps, a 6 ms output gate and calibration metadata. Its shortest path is
// layer 1 -> layer 6: 2 steps; the longest, every layer: 6.
TEST(CliInfoConvertRender, InfoDescribesAModelFile) {
  std::string dir = test::scratch_dir();
  ModelSpec m = spikems_architecture(true, Discretisation::IIR, {4, 6, 8}, {}, true);
  m.name = "tiny-unet";
  m.time_step_ms = 2;
  m.output_gate_steps = 3;
  m.training = {{"steps", 40},
                {"wall_seconds", 12.5},
                {"calibration",
                 {{"factor", 1.5},
                  {"output_threshold_scale", 1.5},
                  {"criterion", "iou"},
                  {"score", 31.25},
                  {"data", {"data/val"}},
                  {"static_moving", 2.5},
                  {"max_static_moving", 5}}}};
  const std::string path = dir + "/m.safetensors";
  save_model(path, m);
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " info " + q(path), &out), 0) << out;
  for (const char* want :
       {"\"tiny-unet\", spiking network, 6 layers", "after 2 (through the skips) to 6 steps",
        "any sensor size", "2 -> 4, 6, 8, 6, 4(+2), 2(+1)", "output gate   6 ms (3 steps)",
        "θ x 1.5, by iou 31.2 % on data/val, static scenes 2.5 % called moving (at most 5 %)",
        "training      40 steps, 12 s"})
    EXPECT_NE(out.find(want), std::string::npos) << want << "\n" << out;
  ASSERT_EQ(run_command(spikems_binary() + " info --json " + q(path), &out), 0) << out;
  const auto j = nlohmann::json::parse(out).at(0);
  EXPECT_EQ(j["file"], path);
  EXPECT_EQ(j["type"], "snn");
  EXPECT_EQ(j["layers"].size(), 6u);
  EXPECT_EQ(j["layers"][4]["skip_from"], 1);
  EXPECT_EQ(j["weights"], int64_t(2 * 4 + 4 * 6 + 6 * 8 + 8 * 6 + 12 * 4 + 8 * 2) * 9);
  EXPECT_EQ(j["latency_steps"], 6);
  EXPECT_EQ(j["shortest_path_steps"], 2);
  EXPECT_EQ(j["srm_onset"], "next_step");
  // Same-step neurons answer in the input's own step.
  ModelSpec same = m;
  for (auto& l : same.layers) l.neuron.srm_onset = SrmOnset::SameStep;
  const std::string same_path = dir + "/same.safetensors";
  save_model(same_path, same);
  ASSERT_EQ(run_command(spikems_binary() + " info " + q(same_path), &out), 0) << out;
  EXPECT_NE(out.find("reaches the output in its own step (srm_onset same_step)"), std::string::npos)
      << out;
  ASSERT_EQ(run_command(spikems_binary() + " info --json " + q(same_path), &out), 0) << out;
  const auto js = nlohmann::json::parse(out).at(0);
  EXPECT_EQ(js["srm_onset"], "same_step");
  EXPECT_EQ(js["latency_steps"], 0);
  EXPECT_EQ(js["shortest_path_steps"], 0);
  EXPECT_DOUBLE_EQ(j["output_gate_ms"].get<double>(), 6.0);
  EXPECT_DOUBLE_EQ(j["calibration"]["output_threshold_scale"].get<double>(), 1.5);
  // An ANN-2D with two past frames: 12 input channels, its frames named in both outputs.
  const std::string ann = dir + "/ann.safetensors";
  save_model(ann, ann2d_architecture({4, 6}, false, {}, 2));
  ASSERT_EQ(run_command(spikems_binary() + " info " + q(ann), &out), 0) << out;
  for (const char* want :
       {"ANN-2D baseline, 4 layers", "12 -> 4, 6, 4, 1",
        "input frames  the window's and the 2 windows of the same length before it"})
    EXPECT_NE(out.find(want), std::string::npos) << want << "\n" << out;
  ASSERT_EQ(run_command(spikems_binary() + " info --json " + q(ann), &out), 0) << out;
  EXPECT_EQ(nlohmann::json::parse(out).at(0)["history_frames"], 2);
  // A broken model file fails naming it, as an event file would.
  const std::string bad = write_text(dir, "bad.safetensors", "not a model");
  EXPECT_EQ(run_command(spikems_binary() + " info " + q(bad), &out), 1);
  EXPECT_NE(out.find("bad.safetensors"), std::string::npos) << out;
}

TEST(CliInfoConvertRender, ConvertTimeRangeTextToText) {
  REQUIRE_FORMAT("text");
  std::string dir = test::scratch_dir();
  std::string txt = write_text(dir, "small.txt", kSmallText);
  std::string out;
  // From 1 ms to 2 ms after the first event (t = 1000): keeps t in [2000, 3000).
  ASSERT_EQ(run_command(spikems_binary() + " convert --time-unit us " + q(txt) + " " +
                            q(dir + "/cut.txt") + " --from 1ms --to 2ms",
                        &out),
            0)
      << out;
  ReadOptions ro;
  ro.time_unit = "us";
  auto ev = read_events(dir + "/cut.txt", ro);
  ASSERT_EQ(ev.size(), 2u);
  EXPECT_EQ(ev.t[0], 2000);
  EXPECT_EQ(ev.t[1], 2500);
  EXPECT_EQ(ev.sensor, (SensorSize{8, 6}));
  // --absolute: the file's own times.
  ASSERT_EQ(run_command(spikems_binary() + " convert --time-unit us " + q(txt) + " " +
                            q(dir + "/abs.txt") + " --absolute --from 1.5ms --to 3ms",
                        &out),
            0)
      << out;
  auto ab = read_events(dir + "/abs.txt", ro);
  ASSERT_EQ(ab.size(), 3u);
  EXPECT_EQ(ab.t[0], 1500);
  EXPECT_EQ(ab.t[2], 2500);
  ASSERT_NE(run_command(spikems_binary() + " convert --time-unit us " + q(txt) + " " +
                            q(dir + "/bad.txt") + " --from 3ms --to 2ms",
                        &out),
            0);
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.txt"));
}

TEST(CliInfoConvertRender, ConvertRoundTripTextNpzText) {
  REQUIRE_FORMAT("text");
  REQUIRE_FORMAT("npz");
  std::string dir = test::scratch_dir();
  std::string txt = write_text(dir, "small.txt", kSmallText);
  std::string out;
  ASSERT_EQ(
      run_command(spikems_binary() + " convert --time-unit us " + q(txt) + " " + q(dir + "/a.npz"),
                  &out),
      0)
      << out;
  ASSERT_EQ(
      run_command(spikems_binary() + " convert " + q(dir + "/a.npz") + " " + q(dir + "/back.txt"),
                  &out),
      0)
      << out;
  ReadOptions ro;
  ro.time_unit = "us";
  auto a = read_events(txt, ro);
  auto b = read_events(dir + "/back.txt", ro);
  EXPECT_EQ(a.t, b.t);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.y, b.y);
  EXPECT_EQ(a.p, b.p);
  EXPECT_EQ(a.sensor, b.sensor);
  if (b.has_labels()) {
    EXPECT_EQ(a.label, b.label);
  }
}

TEST(CliInfoConvertRender, ConvertRoundTripTextToEveryWritableFormat) {
  REQUIRE_FORMAT("text");
  std::string dir = test::scratch_dir();
  std::string txt = write_text(dir, "small.txt", kSmallText);
  ReadOptions ro;
  ro.time_unit = "us";
  auto a = read_events(txt, ro);
  int tried = 0;
  std::string names;
  for (const auto& f : formats()) {
    if (!f.open_writer || f.extensions.empty()) continue;
    std::string mid = dir + "/mid" + f.extensions.front();
    std::string out;
    int rc = run_command(spikems_binary() + " convert --time-unit us " + q(txt) + " " + q(mid) +
                             " --format " + f.name,
                         &out);
    if (rc != 0) {
      // Formats with a fixed sensor or without room for our events may refuse: say so clearly.
      EXPECT_NE(out.find("error"), std::string::npos) << f.name << ": " << out;
      continue;
    }
    ++tried;
    names += " " + f.name;
    auto b = read_events(mid);
    ASSERT_EQ(b.size(), a.size()) << f.name;
    EXPECT_EQ(b.x, a.x) << f.name;
    EXPECT_EQ(b.y, a.y) << f.name;
    EXPECT_EQ(b.p, a.p) << f.name;
    for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(b.t[i] - b.t[0], a.t[i] - a.t[0]) << f.name;
  }
  EXPECT_GE(tried, 1);
  std::printf("[ round-tripped through:%s ]\n", names.c_str());
}

TEST(CliInfoConvertRender, RenderDrawsEventsWhereTheyAre) {
  REQUIRE_FORMAT("text");
  std::string dir = test::scratch_dir();
  std::string txt = write_text(dir, "small.txt", kSmallText);
  std::string png = dir + "/f.png";
  std::string out;
  // Window [1000, 3000) us from the first event: ON at (1,1), OFF at (2,1), objects at
  // (5,4), (6,4) (id 3); (0,5) at t=3000 is outside.
  ASSERT_EQ(run_command(spikems_binary() + " render " + q(txt) +
                            " --time-unit us --from 0 --window 2ms --out " + q(png) + " --scale 2",
                        &out),
            0)
      << out;
  Image img = read_png_rgb(png);
  ASSERT_EQ(img.width, 16);
  ASSERT_EQ(img.height, 12);
  auto is = [&](int x, int y, Rgb c) { return img.is(x, y, c.r, c.g, c.b); };
  EXPECT_TRUE(is(2, 2, kOnColor) && is(3, 3, kOnColor));    // (1,1) ON, block 2x2
  EXPECT_TRUE(is(4, 2, kOffColor) && is(5, 3, kOffColor));  // (2,1) OFF
  EXPECT_TRUE(is(0, 10, kBackground));                      // (0,5) at t = 3000: outside
  EXPECT_TRUE(is(14, 0, kBackground));                      // (7,0) at t = 11000: outside
  // The labelled events' footprint (5,4)-(6,4) is outlined: block of (5,4) is (10..11, 8..9);
  // its left, top and bottom sides face outside.
  EXPECT_TRUE(is(10, 8, kOutlineColor));
  EXPECT_TRUE(is(10, 9, kOutlineColor));
  EXPECT_TRUE(is(11, 8, kOutlineColor));
  EXPECT_NE(out.find("footprint"), std::string::npos) << out;

  // --labels tints labelled events with their object's colour; --no-outline keeps the event.
  ASSERT_EQ(
      run_command(spikems_binary() + " render " + q(txt) +
                      " --time-unit us --from 0 --window 2ms --labels --no-outline --out " + q(png),
                  &out),
      0)
      << out;
  img = read_png_rgb(png);
  EXPECT_TRUE(is(5, 4, label_color(3)));
  EXPECT_TRUE(is(1, 1, kOnColor));
}

// An EV-IMO npz with one mask frame: info counts it, render outlines it and derives labels.
TEST(CliInfoConvertRender, RenderOutlinesTheMaskFrameOfAnEvimoFile) {
  REQUIRE_FORMAT("evimo1");
  std::string dir = test::scratch_dir();
  // Events [t s, x, y, p]: ON (1,1), ON (5,4) inside the object, OFF (2,1).
  std::vector<float> events{0.001f, 1, 1, 1, 0.002f, 5, 4, 1, 0.003f, 2, 1, 0};
  // One 8x6 mask frame: object 2 (stored as 2000) on the 3x3 square x 4..6, y 3..5.
  std::vector<uint16_t> mask(6 * 8, 0);
  for (int y = 3; y <= 5; ++y)
    for (int x = 4; x <= 6; ++x) mask[size_t(y * 8 + x)] = 2000;
  std::vector<double> K{100, 0, 4, 0, 100, 3, 0, 0, 1};
  std::string npz = dir + "/seq.npz";
  write_npz(npz,
            {{"events", NpyArray::from(events, {3, 4})},
             {"mask", NpyArray::from(mask, {1, 6, 8})},
             {"K", NpyArray::from(K, {3, 3})}},
            false);
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " info --json " + q(npz) + " 2>/dev/null", &out), 0)
      << out;
  auto j = nlohmann::json::parse(out)[0];
  EXPECT_EQ(j["format"], "evimo1");
  EXPECT_EQ(j["mask_frames"], 1);
  EXPECT_EQ(j["width"], 8);
  EXPECT_EQ(j["events"], 3);
  EXPECT_DOUBLE_EQ(j["intrinsics"]["fx"].get<double>(), 100.0);

  // convert carries the mask frame and intrinsics into a format that holds them, and keeps
  // only the mask frames of the selected range. The mask time is EV-IMO's uniform estimate
  // (no meta.txt): t_first + duration / 2 = 2000 us.
  if (find_format("spikems-h5")) {
    for (auto [from, want_events, want_masks] :
         {std::tuple{"0", 3, 1}, std::tuple{"1ms", 2, 1}, std::tuple{"1.5ms", 1, 0}}) {
      std::string h5 = dir + "/seq.h5";
      ASSERT_EQ(
          run_command(spikems_binary() + " convert -q " + q(npz) + " " + q(h5) + " --from " + from,
                      &out),
          0)
          << out;
      ASSERT_EQ(run_command(spikems_binary() + " info --json " + q(h5) + " 2>/dev/null", &out), 0)
          << out;
      auto h = nlohmann::json::parse(out)[0];
      EXPECT_EQ(h["events"], want_events) << from;
      EXPECT_EQ(h["mask_frames"], want_masks) << from;
      EXPECT_DOUBLE_EQ(h["intrinsics"]["cx"].get<double>(), 4.0);
      // Into a format that holds no masks: the events, and no mask frame read or written.
      ASSERT_EQ(
          run_command(spikems_binary() + " convert " + q(h5) + " " + q(dir + "/seq.txt"), &out), 0)
          << out;
      EXPECT_NE(out.find(std::to_string(want_events) + " events written"), std::string::npos)
          << out;
      EXPECT_NE(out.find(", 0 mask frames"), std::string::npos) << out;
    }
  }

  std::string png = dir + "/f.png";
  ASSERT_EQ(
      run_command(spikems_binary() + " render " + q(npz) + " --from 0 --window 5ms --out " + q(png),
                  &out),
      0)
      << out;
  EXPECT_NE(out.find("mask frame"), std::string::npos) << out;
  Image img = read_png_rgb(png);
  auto is = [&](int x, int y, Rgb c) { return img.is(x, y, c.r, c.g, c.b); };
  EXPECT_TRUE(is(1, 1, kOnColor));
  EXPECT_TRUE(is(2, 1, kOffColor));
  EXPECT_TRUE(is(5, 4, kOnColor));  // the square's centre is not on the contour
  for (auto [x, y] : {std::pair{4, 3}, {5, 3}, {6, 3}, {4, 4}, {6, 4}, {4, 5}, {6, 5}})
    EXPECT_TRUE(is(x, y, kOutlineColor)) << x << "," << y;
  // (5,5) lies on the sensor's bottom edge with region pixels left and right: the image border
  // is not a region border, so it is not outlined.
  EXPECT_TRUE(is(5, 5, kBackground));
  EXPECT_TRUE(is(3, 3, kBackground));
  EXPECT_TRUE(is(7, 4, kBackground));

  // --labels: the event inside the object takes object 2's colour (labels from the mask).
  ASSERT_EQ(run_command(spikems_binary() + " render " + q(npz) +
                            " --from 0 --window 5ms --labels --out " + q(png),
                        &out),
            0)
      << out;
  img = read_png_rgb(png);
  EXPECT_TRUE(is(5, 4, label_color(2)));
  EXPECT_TRUE(is(1, 1, kOnColor));
}

TEST(CliInfoConvertRender, ConvertCropsDownsamplesAndDenoises) {
  REQUIRE_FORMAT("text");
  std::string dir = test::scratch_dir();
  std::string txt = write_text(dir, "small.txt", kSmallText);
  std::string out;
  ReadOptions ro;
  ro.time_unit = "us";
  // Crop x 4..7, y 2..5, then halve: (5,4) -> (0,1), (6,4) -> (1,1); others are outside.
  ASSERT_EQ(run_command(spikems_binary() + " convert -q --time-unit us " + q(txt) + " " +
                            q(dir + "/c.txt") + " --crop 4,2,4,4 --downsample 2",
                        &out),
            0)
      << out;
  auto c = read_events(dir + "/c.txt", ro);
  EXPECT_EQ(c.sensor, (SensorSize{2, 2}));
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.x, (std::vector<uint16_t>{0, 1}));
  EXPECT_EQ(c.y, (std::vector<uint16_t>{1, 1}));
  EXPECT_EQ(c.t, (std::vector<int64_t>{2000, 2500}));
  // Flip x on the full sensor: x -> 7 - x.
  ASSERT_EQ(run_command(spikems_binary() + " convert -q --time-unit us " + q(txt) + " " +
                            q(dir + "/f.txt") + " --flip-x",
                        &out),
            0)
      << out;
  auto f = read_events(dir + "/f.txt", ro);
  ASSERT_EQ(f.size(), 6u);
  EXPECT_EQ(f.x[0], 6);
  // Denoise with 600 us: only (6,4) at 2500 has a neighbour event ((5,4) at 2000) close enough;
  // (2,1) at 1500 has (1,1) at 1000 as neighbour: kept too.
  ASSERT_EQ(run_command(spikems_binary() + " convert -q --time-unit us " + q(txt) + " " +
                            q(dir + "/d.txt") + " --denoise 600us",
                        &out),
            0)
      << out;
  auto d = read_events(dir + "/d.txt", ro);
  EXPECT_EQ(d.t, (std::vector<int64_t>{1500, 2500}));
  // A crop that does not fit the sensor is refused and nothing is written.
  EXPECT_NE(run_command(spikems_binary() + " convert -q --time-unit us " + q(txt) + " " +
                            q(dir + "/bad.txt") + " --crop 4,2,8,8",
                        &out),
            0);
  EXPECT_NE(out.find("does not fit"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.txt"));
  EXPECT_NE(run_command(spikems_binary() + " convert -q --time-unit us " + q(txt) + " " +
                            q(dir + "/bad.txt") + " --crop 4,2",
                        &out),
            0);
  EXPECT_NE(out.find("X,Y,W,H"), std::string::npos) << out;
}

// More events than one read chunk (kReadChunk): filters keep their state across chunks and the
// remapped sensor size of one chunk does not leak into the reading of the next.
TEST(CliInfoConvertRender, ConvertStreamsAcrossChunks) {
  REQUIRE_FORMAT("text");
  std::string dir = test::scratch_dir();
  std::string txt = dir + "/big.txt";
  {
    std::string body = "# sensor 64 48\n";
    body.reserve(kReadChunk * 16);
    uint32_t r = 99;
    char line[64];
    for (size_t i = 0; i < kReadChunk + kReadChunk / 5; ++i) {
      r = r * 1664525u + 1013904223u;
      int n = std::snprintf(line, sizeof line, "%zu %u %u %u\n", i * 2, (r >> 8) % 64,
                            (r >> 16) % 48, (r >> 30) & 1);
      body.append(line, size_t(n));
    }
    std::ofstream(txt) << body;
  }
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " convert -q --time-unit us " + q(txt) + " " +
                            q(dir + "/o.npz") + " --crop 8,4,48,40 --downsample 2 --denoise 40us",
                        &out),
            0)
      << out;
  ReadOptions ro;
  ro.time_unit = "us";
  EventStream all = read_events(txt, ro);
  ASSERT_GT(all.size(), kReadChunk);
  BinningConfig geo;
  geo.crop_x = 8, geo.crop_y = 4, geo.crop_w = 48, geo.crop_h = 40, geo.downsample = 2;
  EventStream want = remap_events(background_activity_filter(all, 40), geo);
  EventStream got = read_events(dir + "/o.npz");
  EXPECT_EQ(got.sensor, (SensorSize{24, 20}));
  ASSERT_EQ(got.size(), want.size());
  EXPECT_EQ(got.t, want.t);
  EXPECT_EQ(got.x, want.x);
  EXPECT_EQ(got.y, want.y);
}
