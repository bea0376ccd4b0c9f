// `spikems segment` through the command line: outputs, live stdin, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "common/test_paths.h"
#include "common/tiny_models.h"
#include "core/events/formats/npy.h"
#include "core/events/formats/zip.h"
#include "core/events/io.h"
#include "core/model/model_file.h"
#include "core/model/time_step.h"
#include "core/viz/image.h"

namespace spikems {
namespace {

using test::run_command;
using test::scratch_dir;
using test::spikems_binary;

// A 1x1 conv passing OFF events (channel 0) through to output channel 0; ON events reach a
// zero weight. Every OFF event is foreground, every ON event background.
std::string write_pass_off_model(const std::string& dir, int w = 0, int h = 0) {
  ModelSpec m = test::pointwise_model({1.f, 0.f, 0.f, 0.f}, "spikems");
  m.input_width = w;
  m.input_height = h;
  std::string p = dir + "/pass_off.safetensors";
  save_model(p, m);
  return p;
}

// A 6x6 square moving right 1 px per ms over a 64x48 sensor, OFF on its left edge, ON right.
std::string write_events(const std::string& dir, bool backwards = false) {
  std::string p = dir + "/events.txt";
  std::ofstream f(p);
  f << "# sensor 64 48\n";
  for (int t = 0; t < 40; ++t)
    for (int p = 0; p < 2; ++p)
      for (int y = 20; y < 26; ++y)
        f << t * 1000 + 100 + 100 * p << " " << 10 + 6 * p + t << " " << y << " " << p << "\n";
  if (backwards) f << "5 3 3 1\n";
  return p;
}

std::vector<std::vector<long>> read_rows(const std::string& path) {
  std::ifstream f(path);
  std::string line;
  std::vector<std::vector<long>> rows;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    std::vector<long> r;
    long v;
    while (s >> v) r.push_back(v);
    rows.push_back(r);
  }
  return rows;
}

// Without --model, segment takes the shipped model: $SPIKEMS_MODEL when set (the same labels
// as naming the file), and says what to do when it is not there.
TEST(SegmentCli, DefaultModelComesFromSpikemsModel) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d), ev = write_events(d);
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " segment --quiet --model " + model + " --input " + ev +
                            " --out " + d + "/named.txt",
                        &out),
            0)
      << out;
  ASSERT_EQ(run_command("SPIKEMS_MODEL=" + model + " " + spikems_binary() +
                            " segment --quiet --input " + ev + " --out " + d + "/default.txt",
                        &out),
            0)
      << out;
  EXPECT_EQ(read_rows(d + "/named.txt"), read_rows(d + "/default.txt"));
  EXPECT_EQ(run_command("SPIKEMS_MODEL=" + d + "/none.safetensors " + spikems_binary() +
                            " segment --quiet --input " + ev + " --out " + d + "/x.txt 2>&1",
                        &out),
            1);
  EXPECT_NE(out.find("give --model FILE, or set SPIKEMS_MODEL"), std::string::npos) << out;
  // A bare name is a shipped model (models/spikems-NAME.safetensors beside the build); one
  // that is not shipped lists those that are. (tests/package/test_install.sh runs `fast`.)
  EXPECT_EQ(run_command(spikems_binary() + " segment --quiet --model nosuchname --input " + ev +
                            " --out " + d + "/x.txt 2>&1",
                        &out),
            1);
  EXPECT_NE(out.find("no shipped model of that name (spikems-nosuchname.safetensors"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("shipped: default, fast."), std::string::npos) << out;  // sorted
  EXPECT_FALSE(std::filesystem::exists(d + "/x.txt"));
}

TEST(SegmentCli, LabelsMasksBoxesAndStats) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d), ev = write_events(d);
  std::string out;
  int rc = run_command(spikems_binary() + " segment --quiet --model " + model + " --input " + ev +
                           " --out " + d + "/labels.txt --masks-dir " + d +
                           "/masks --mask-window 10ms --boxes " + d + "/boxes.csv --stats",
                       &out);
  ASSERT_EQ(rc, 0) << out;
  auto rows = read_rows(d + "/labels.txt");
  ASSERT_EQ(rows.size(), 480u);
  for (const auto& r : rows) {
    ASSERT_EQ(r.size(), 5u);
    EXPECT_EQ(r[4], r[3] == 0 ? 1 : 0) << "t=" << r[0] << " p=" << r[3];
  }
  EXPECT_EQ(rows[0][0], 100);  // input order and times kept
  // The labels file is the text event format: spikems reads it back, labels and all.
  const EventStream back = read_events(d + "/labels.txt");
  ASSERT_EQ(back.size(), rows.size());
  ASSERT_TRUE(back.has_labels());
  for (size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(back.t[i], rows[i][0]);
    ASSERT_EQ(long(back.label[i]), rows[i][4]) << i;
  }
  // 40 ms of events in 10 ms windows, plus the label window's run-out (< 1 window).
  int pngs = 0;
  for (auto& e : std::filesystem::directory_iterator(d + "/masks"))
    pngs += e.path().extension() == ".png";
  EXPECT_GE(pngs, 4);
  EXPECT_LE(pngs, 5);
  // The OFF edge is one tracked object moving right at about 1000 px/s.
  auto text = [&] {
    std::ifstream f(d + "/boxes.csv");
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  }();
  EXPECT_EQ(text.rfind("t_us,id,x0,y0,x1,y1,vx,vy\n", 0), 0u);
  int lines = 0;
  double vx = 0;
  std::istringstream s(text);
  std::string line;
  std::getline(s, line);
  while (std::getline(s, line)) {
    ++lines;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream ls(line);
    double t, id, x0, y0, x1, y1, vy;
    ls >> t >> id >> x0 >> y0 >> x1 >> y1 >> vx >> vy;
    EXPECT_EQ(id, 1);
  }
  EXPECT_GE(lines, 2);
  EXPECT_NEAR(vx, 1000, 250);
  EXPECT_NE(out.find("SynOps"), std::string::npos);
  EXPECT_NE(out.find("real-time factor"), std::string::npos);
  // The setup lies inside the wall time; leaving it out can only raise the factor.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m,
                                std::regex(R"(in ([0-9.]+) s wall \(setup ([0-9.]+) s, network )"
                                           R"([0-9.]+ s\).*real-time factor ([0-9.]+) \(after )"
                                           R"(setup ([0-9.]+), network only)")))
      << out;
  EXPECT_LE(std::stod(m[2]), std::stod(m[1]));
  EXPECT_GE(std::stod(m[4]), std::stod(m[3]));
}

// Labels written as npz (deflate level 1 by default), stored with --compression none or
// --level 0: the same labels as the text file; a level for a text output is an error.
TEST(SegmentCli, NpzLabelsTakeTheWritersCompressionOptions) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d), ev = write_events(d);
  std::string base = spikems_binary() + " segment --quiet --model " + model + " --input " + ev;
  std::string out;
  ASSERT_EQ(run_command(base + " --out " + d + "/l.txt", &out), 0) << out;
  const EventStream want = read_events(d + "/l.txt");
  ASSERT_EQ(want.size(), 480u);
  for (const auto& [args, method] : {std::pair<std::string, int>{"", 8},
                                     {" --level 9", 8},
                                     {" --compression none", 0},
                                     {" --level 0", 0}}) {
    SCOPED_TRACE(args);
    ASSERT_EQ(run_command(base + " --out " + d + "/l.npz" + args, &out), 0) << out;
    for (const auto& e : zip_list_file(d + "/l.npz")) EXPECT_EQ(e.method, method) << e.name;
    const EventStream got = read_events(d + "/l.npz");
    EXPECT_EQ(got.t, want.t);
    EXPECT_EQ(got.label, want.label);
  }
  EXPECT_EQ(run_command(base + " --out " + d + "/x.txt --level 3", &out), 1);
  EXPECT_NE(out.find("the text format has no compression"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(d + "/x.txt"));
  EXPECT_EQ(run_command(base + " --out " + d + "/x.npz --compression zstd", &out), 1);
  EXPECT_NE(out.find("npz supports compression 'deflate' (default) or 'none'"), std::string::npos)
      << out;
}

// --labels writes the label column alone (.npy uint8 or .txt lines), in the events' order,
// equal to --out's label column, beside --out or on its own; another extension stops the
// command before it writes anything.
TEST(SegmentCli, LabelColumnEqualsTheLabelledEvents) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d), ev = write_events(d);
  std::string base = spikems_binary() + " segment --quiet --model " + model + " --input " + ev;
  std::string out;
  ASSERT_EQ(run_command(base + " --out " + d + "/l.txt --labels " + d + "/both.npy", &out), 0)
      << out;
  const EventStream want = read_events(d + "/l.txt");
  ASSERT_EQ(want.size(), 480u);
  std::vector<int> want_labels(want.label.begin(), want.label.end());
  EXPECT_EQ(std::count(want_labels.begin(), want_labels.end(), 1), 240);  // the OFF events
  EXPECT_EQ(read_npy(d + "/both.npy").to<int>(), want_labels);
  ASSERT_EQ(run_command(base + " --labels " + d + "/alone.npy", &out), 0) << out;
  EXPECT_EQ(read_npy(d + "/alone.npy").to<int>(), want_labels);
  ASSERT_EQ(run_command(base + " --labels " + d + "/alone.txt", &out), 0) << out;
  std::ifstream f(d + "/alone.txt");
  std::vector<int> lines;
  for (int v; f >> v;) lines.push_back(v);
  EXPECT_EQ(lines, want_labels);
  EXPECT_EQ(run_command(base + " --labels " + d + "/x.csv --out " + d + "/x.txt", &out), 1);
  EXPECT_NE(out.find(".npy"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(d + "/x.txt"));
  // One path for two outputs, or the input itself, is refused before anything is written.
  EXPECT_EQ(run_command(base + " --labels " + d + "/same.txt --out " + d + "/./same.txt", &out), 1);
  EXPECT_NE(out.find("same file as --out"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(d + "/same.txt"));
  EXPECT_EQ(run_command(base + " --labels " + ev, &out), 1);
  EXPECT_NE(out.find("same file as --input"), std::string::npos) << out;
  EXPECT_EQ(read_events(ev).size(), 480u);  // the input is intact
}

// --block-steps changes when outputs are written, not what: labels, mask PNGs and boxes are
// byte for byte those of step-by-step runs (the default for files: default_block_steps()).
TEST(SegmentCli, BlockStepsGiveIdenticalOutputs) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d), ev = write_events(d);
  auto slurp = [](const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  };
  std::vector<std::string> runs;
  for (std::string block : {"1", "3", "", "500"}) {
    const std::string o = d + "/b" + block;
    std::string out;
    ASSERT_EQ(
        run_command(spikems_binary() + " segment --quiet --model " + model + " --input " + ev +
                        " --out " + o + ".txt --masks-dir " + o + " --mask-window 5ms --boxes " +
                        o + ".csv" + (block.empty() ? "" : " --block-steps " + block),
                    &out),
        0)
        << out;
    std::string all = slurp(o + ".txt") + slurp(o + ".csv");
    for (int i = 0; i < 10; ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "/mask_%06d.png", i);
      all += slurp(o + name);
    }
    runs.push_back(all);
    EXPECT_TRUE(std::filesystem::exists(o + "/mask_000007.png"));  // 40 ms in 5 ms windows
  }
  EXPECT_GT(runs[0].size(), 480u * 8);
  for (size_t i = 1; i < runs.size(); ++i) EXPECT_EQ(runs[i], runs[0]) << "run " << i;
  std::string out;
  EXPECT_NE(run_command(spikems_binary() + " segment --quiet --model " + model + " --input " + ev +
                            " --out " + d + "/zero.txt --block-steps 0",
                        &out),
            0);
  EXPECT_NE(out.find("block-steps"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(d + "/zero.txt"));
}

// --downsample 2: the pass-OFF model sees the square at half resolution, where its OFF and ON
// edges (6 px apart) stay in different pixels, so every OFF event is still foreground and
// every ON event background; the label lines keep the events' own coordinates. A model that
// records a 32x24 training grid is run so on this 64x48 sensor by default (auto), the same
// labels; its mask frames come at the sensor's size in 2x2 blocks (1 ms frames: the OFF edge
// is one column wide at full resolution, two at half) and its boxes in sensor pixels.
TEST(SegmentCli, DownsampleLabelsTheOriginalEvents) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d), ev = write_events(d);
  ModelSpec gm = load_model(model);
  gm.train_width = 32;
  gm.train_height = 24;
  const std::string grid_model = d + "/grid.safetensors";
  save_model(grid_model, gm);
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " segment --quiet --model " + model + " --input " + ev +
                            " --downsample 2 --out " + d + "/ds.txt",
                        &out),
            0)
      << out;
  const auto rows = read_rows(d + "/ds.txt"), src = read_rows(ev);
  ASSERT_EQ(rows.size(), src.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].size(), 5u);
    EXPECT_EQ(rows[i][1], src[i][1]);  // x and y as in the input
    EXPECT_EQ(rows[i][2], src[i][2]);
    EXPECT_EQ(rows[i][4], rows[i][3] == 0 ? 1 : 0) << "row " << i;  // OFF foreground
  }
  // Auto: the note names the grid and the factor; the labels are the explicit factor's.
  ASSERT_EQ(run_command(spikems_binary() + " segment --model " + grid_model + " --input " + ev +
                            " --stats --out " + d + "/auto.txt --masks-dir " + d +
                            "/m2 --mask-window 1ms --boxes " + d + "/b2.csv",
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("32x24 grid"), std::string::npos) << out;
  EXPECT_NE(out.find("downsampled 2x"), std::string::npos) << out;
  EXPECT_NE(out.find("steps, the sensor downsampled 2x"), std::string::npos) << out;  // --stats
  EXPECT_EQ(read_rows(d + "/auto.txt"), rows);
  ASSERT_EQ(run_command(spikems_binary() + " segment --quiet --model " + grid_model + " --input " +
                            ev + " --downsample 1 --masks-dir " + d + "/m1 --mask-window 1ms",
                        &out),
            0)
      << out;
  // Frame 10 (1 ms): at half resolution every white pixel's 2x2 block is white (pairs of
  // columns x = 2k, 2k+1); at full resolution the trail of the moving OFF edge is not.
  std::vector<int> cols[2];
  for (int k = 0; k < 2; ++k) {
    const Image img = read_png_rgb(d + (k == 0 ? "/m1" : "/m2") + "/mask_000010.png");
    ASSERT_EQ(img.width, 64);
    ASSERT_EQ(img.height, 48);
    for (int x = 0; x < 64; ++x)
      if (img.is(x, 22, 255, 255, 255)) cols[k].push_back(x);
  }
  auto paired = [](const std::vector<int>& c) {
    if (c.size() % 2) return false;
    for (size_t i = 0; i < c.size(); i += 2)
      if (c[i] % 2 != 0 || c[i + 1] != c[i] + 1) return false;
    return true;
  };
  ASSERT_FALSE(cols[1].empty());
  EXPECT_TRUE(paired(cols[1])) << ::testing::PrintToString(cols[1]);
  ASSERT_FALSE(cols[0].empty());
  EXPECT_FALSE(paired(cols[0])) << ::testing::PrintToString(cols[0]);
  std::ifstream boxes(d + "/b2.csv");
  std::string header, line;
  std::getline(boxes, header);
  int lines = 0;
  while (std::getline(boxes, line)) {
    double t, id, x0, y0, x1, y1;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf", &t, &id, &x0, &y0, &x1, &y1), 6)
        << line;
    // The square's rows 20..25 in sensor pixels: at grid scale they would centre near 11.
    EXPECT_GE((y0 + y1) / 2, 20) << line;
    EXPECT_LE((y0 + y1) / 2, 26) << line;
    EXPECT_GE(y1 - y0, 4) << line;
    ++lines;
  }
  EXPECT_GT(lines, 0);
  for (const std::string& extra : std::vector<std::string>{" --downsample 3", " --downsample x"}) {
    EXPECT_NE(run_command(spikems_binary() + " segment --quiet --model " + model + " --input " +
                              ev + " --out " + d + "/bad.txt" + extra,
                          &out),
              0)
        << extra;
    EXPECT_NE(out.find("downsampl"), std::string::npos) << out;
    EXPECT_FALSE(std::filesystem::exists(d + "/bad.txt"));
  }
}

// --iir runs the FIR model with the exact recursions of the same neurons: on this clean input
// the labels are the same; a model whose kernels are not the sampled ones is refused.
TEST(SegmentCli, IirOptionGivesTheSameLabelsHereAndRefusesOddKernels) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d), ev = write_events(d);
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " segment --quiet --model " + model + " --input " + ev +
                            " --out " + d + "/fir.txt",
                        &out),
            0)
      << out;
  ASSERT_EQ(run_command(spikems_binary() + " segment --quiet --iir --model " + model + " --input " +
                            ev + " --out " + d + "/iir.txt",
                        &out),
            0)
      << out;
  auto fir = read_rows(d + "/fir.txt"), iir = read_rows(d + "/iir.txt");
  ASSERT_EQ(fir.size(), 480u);
  EXPECT_EQ(fir, iir);
  ModelSpec m = load_model(model);
  m.layers[0].srm_kernel[2] += 0.5f;
  save_model(d + "/odd.safetensors", m);
  EXPECT_NE(run_command(spikems_binary() + " segment --quiet --iir --model " + d +
                            "/odd.safetensors --input " + ev + " --out " + d + "/odd.txt",
                        &out),
            0);
  EXPECT_NE(out.find("no exact IIR form"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(d + "/odd.txt"));
}

// --output-threshold F multiplies the output layer's θ: each OFF event's potential peaks at
// 1.0 (weight 1) against θ = 0.22, so every OFF event stays labelled at F = 4 and none at 5.
TEST(SegmentCli, OutputThresholdMovesTheOperatingPoint) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d), ev = write_events(d);
  std::string out;
  auto moving = [&](const std::string& flag) {
    const std::string f = d + "/f" + std::to_string(flag.size()) + ".txt";
    EXPECT_EQ(run_command(spikems_binary() + " segment --quiet --model " + model + " --input " +
                              ev + " --out " + f + " " + flag,
                          &out),
              0)
        << out;
    long n = 0;
    for (const auto& r : read_rows(f)) n += r.back() != 0;
    return n;
  };
  EXPECT_EQ(moving(""), 240);
  EXPECT_EQ(moving("--output-threshold 4"), 240);
  EXPECT_EQ(moving("--output-threshold 5.0"), 0);
  // The output gate: each OFF event's pixel answers one step (1 ms) later and sees its next
  // event (ON) 6 ms after, so a 1 ms gate (the output's own step) drops every label and a 2 ms
  // one keeps them all.
  EXPECT_EQ(moving("--output-gate 1"), 0);
  EXPECT_EQ(moving("--output-gate 2"), 240);
  EXPECT_EQ(moving("--output-gate 0"), 240);
  for (const char* bad : {"--output-gate -1", "--output-gate 1,2", "--output-gate 0.5"}) {
    EXPECT_NE(run_command(spikems_binary() + " segment --quiet --model " + model + " --input " +
                              ev + " --out " + d + "/bad.txt " + bad,
                          &out),
              0)
        << bad;
    EXPECT_NE(out.find("--output-gate"), std::string::npos) << bad << ": " << out;
  }
  EXPECT_NE(run_command(spikems_binary() + " segment --quiet --model " + model + " --input " + ev +
                            " --out " + d + "/bad.txt --output-threshold 0",
                        &out),
            0);
  EXPECT_NE(out.find("--output-threshold"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(d + "/bad.txt"));
}

// --time-step-us runs the model moved to that step with its time constants scaled: the labels of
// the model file moved by with_time_step, and an --output-gate in ms counts the new steps (at
// 2 ms steps a gate of 2 ms is the output's own step only, as 1 ms was at 1 ms steps).
TEST(SegmentCli, TimeStepRunsTheModelMovedToThatStep) {
  std::string d = scratch_dir();
  const std::string model = write_pass_off_model(d), ev = write_events(d);
  const std::string moved = d + "/moved.safetensors";
  save_model(moved, with_time_step(load_model(model), 2, TimeConstants::Steps, "test"));
  std::string out;
  auto run = [&](const std::string& m, const std::string& flags, const std::string& f) {
    EXPECT_EQ(run_command(spikems_binary() + " segment --quiet --stats --model " + m + " --input " +
                              ev + " --out " + f + " " + flags,
                          &out),
              0)
        << out;
    return read_rows(f);
  };
  const auto by_flag = run(model, "--time-step-us 2000", d + "/a.txt");
  EXPECT_NE(out.find("steps of 2000 us"), std::string::npos) << out;
  const auto by_file = run(moved, "", d + "/b.txt");
  EXPECT_EQ(by_flag, by_file);
  ASSERT_EQ(by_flag.size(), 480u);
  long n = 0;
  for (const auto& r : run(model, "--time-step-us 2000 --output-gate 2", d + "/c.txt"))
    n += r.back() != 0;
  EXPECT_EQ(n, 0);
  EXPECT_NE(out.find("output gate 1 steps"), std::string::npos) << out;
}

TEST(SegmentCli, LiveStdinToStdout) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d);
  std::string out;
  int rc =
      run_command("printf '1000 3 4 0\\n1500 5 5 1\\n9000 7 7 0\\n' | " + spikems_binary() +
                      " segment --model " + model + " --input - --width 16 --height 12 --out -",
                  &out);
  ASSERT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("1000 3 4 0 1\n"), std::string::npos) << out;
  EXPECT_NE(out.find("1500 5 5 1 0\n"), std::string::npos) << out;
  EXPECT_NE(out.find("9000 7 7 0 1\n"), std::string::npos) << out;
}

// Ctrl-C on a live stream: reading stops, the events read so far are labelled, the output is
// committed complete and the exit status is 0.
TEST(SegmentCli, InterruptCommitsCompleteOutput) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d);
  std::string out;
  // The segment process writes its own pid, so the signal reaches it (not a subshell); the
  // script waits for that file, then until the process catches SIGINT (/proc's SigCgt, bit 2):
  // a background job starts with SIGINT ignored, so a signal sent before spikems installs its
  // handler (~0.5 s in on a loaded machine) would be lost. The input ends only after the signal
  // was sent: on a machine so loaded that spikems starts after the third event, it has read
  // everything when the signal comes, and the stream's end must not beat it.
  std::string script =
      "( printf '1000 3 4 0\\n2000 5 5 1\\n'; sleep 2; printf '3000 6 6 0\\n'; i=0; "
      "while [ ! -e " +
      d +
      "/killed ] && [ $i -lt 300 ]; do sleep 0.1; i=$((i+1)); done; "
      "sleep 0.3 ) 2>/dev/null | sh -c 'echo $$ > " +
      d + "/pid; exec " + spikems_binary() + " segment --model " + model +
      " --input - --width 16 --height 12 --out " + d + "/live.txt' & P=$!; i=0; while [ ! -s " + d +
      "/pid ] && [ $i -lt 100 ]; do sleep 0.1; " + "i=$((i+1)); done; Q=$(cat " + d +
      "/pid); i=0; while [ $i -lt 200 ]; do m=$(sed -n 's/^SigCgt:[[:space:]]*//p' "
      "/proc/$Q/status); "
      "[ \"$(cat /proc/$Q/comm)\" = spikems ] && [ -n \"$m\" ] && [ $((0x$m & 2)) -ne 0 ] && "
      "break; sleep 0.05; i=$((i+1)); done; "
      "sleep 0.2; kill -INT $Q; touch " +
      d + "/killed; wait $P; echo rc=$?";
  std::ofstream(d + "/run.sh") << script << "\n";
  run_command("sh " + d + "/run.sh", &out);
  EXPECT_NE(out.find("rc=0"), std::string::npos) << out;
  EXPECT_NE(out.find("interrupted"), std::string::npos) << out;
  auto rows = read_rows(d + "/live.txt");
  ASSERT_EQ(rows.size(), 3u) << out;
  EXPECT_EQ(rows[0], (std::vector<long>{1000, 3, 4, 0, 1}));
  EXPECT_EQ(rows[1], (std::vector<long>{2000, 5, 5, 1, 0}));
  EXPECT_EQ(rows[2], (std::vector<long>{3000, 6, 6, 0, 1}));
}

TEST(SegmentCli, BadInputFailsWithAClearMessage) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d);
  std::string out;
  // Time going back.
  std::string back = write_events(d, true);
  EXPECT_NE(run_command(spikems_binary() + " segment --quiet --model " + model + " --input " +
                            back + " --out " + d + "/l.txt",
                        &out),
            0);
  EXPECT_NE(out.find("time"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(d + "/l.txt"));  // no half-written output
  // A model made for another sensor.
  std::string ev = write_events(d);
  std::string other = write_pass_off_model(d, 346, 260);
  EXPECT_NE(run_command(spikems_binary() + " segment --model " + other + " --input " + ev, &out),
            0);
  EXPECT_NE(out.find("346x260"), std::string::npos) << out;
  // A corrupt model file.
  std::ofstream(d + "/bad.safetensors") << "not a model";
  EXPECT_NE(
      run_command(spikems_binary() + " segment --model " + d + "/bad.safetensors --input " + ev,
                  &out),
      0);
  EXPECT_NE(out.find("bad.safetensors"), std::string::npos) << out;
  // A network too deep for the sensor.
  ModelSpec deep = spikems_architecture(false);
  save_model(d + "/deep.safetensors", deep);
  EXPECT_NE(run_command("printf '1 1 1 1\\n' | " + spikems_binary() + " segment --model " + d +
                            "/deep.safetensors --input - --width 8 --height 8",
                        &out),
            0);
  EXPECT_NE(out.find("too small"), std::string::npos) << out;
}

}  // namespace
}  // namespace spikems

namespace spikems {
namespace {

// A 48x16 sensor, 40 ms: OFF events every millisecond at x = 10..13 (y = 5), labelled moving
// where x < moving_below, and ON events at x = 30..33, all background.
std::string write_labelled_row(const std::string& path, int moving_below) {
  std::ofstream f(path);
  f << "# sensor 48 16\n";
  for (int t = 0; t < 40; ++t) {
    for (int x = 10; x < 14; ++x)
      f << t * 1000 + 100 << " " << x << " 5 0 " << (x < moving_below) << "\n";
    for (int x = 30; x < 34; ++x) f << t * 1000 + 200 << " " << x << " 5 1 0\n";
  }
  return path;
}

// --score on an analytic case: OFF events every millisecond at 4 fixed pixels, all passed
// through by the model, so every 10 ms window predicts those 4 pixels; only 2 of them carry a
// moving-object label. Each window: |P∩G| = 2, |P∪G| = 4 → IoU 0.5; |P∩G| = |P \ G| → no
// detection. ON events (label 0) reach a zero weight and predict nothing.
TEST(SegmentCli, ScoreGivesThePapersIoUAndDetectionRate) {
  std::string d = scratch_dir();
  std::string model = write_pass_off_model(d);
  std::string ev = write_labelled_row(d + "/labelled.txt", 12);
  std::string out;
  int rc = run_command(spikems_binary() + " segment --quiet --score --mask-window 10ms --model " +
                           model + " --input " + ev,
                       &out);
  ASSERT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("score over 4 windows of 10 ms"), std::string::npos) << out;
  EXPECT_NE(out.find("IoU 50.0 % +- 0.0, detection rate 0.0 %"), std::string::npos) << out;

  // Only x = 10 moving: P = {10..13}, G = {10} at full resolution (IoU 25 %); at half, P = the
  // network's pixels {5, 6}, G = {5} (IoU 50 %): the score is on the grid the network sees.
  std::string ev1 = write_labelled_row(d + "/labelled1.txt", 11);
  for (const auto& [factor, want] :
       {std::pair{1, "IoU 25.0 % +- 0.0"}, std::pair{2, "IoU 50.0 % +- 0.0"}}) {
    ASSERT_EQ(
        run_command(spikems_binary() + " segment --quiet --score --mask-window 10ms --model " +
                        model + " --input " + ev1 + " --downsample " + std::to_string(factor),
                    &out),
        0)
        << out;
    EXPECT_NE(out.find(want), std::string::npos) << factor << ": " << out;
  }

  // Unlabelled input cannot be scored: a clear error, non-zero exit.
  std::string plain = write_events(d);
  EXPECT_NE(run_command(spikems_binary() + " segment --quiet --score --model " + model +
                            " --input " + plain,
                        &out),
            0);
  EXPECT_NE(out.find("--score needs labelled events"), std::string::npos) << out;
}

}  // namespace
}  // namespace spikems
