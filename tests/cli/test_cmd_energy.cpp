// `spikems energy` as a user runs it: on a tiny simulated dataset with a hand-built two-layer
// hourglass, the counts against the data and the ANN MACs counted by hand; bad input stops
// with exit 1 and a clear message.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/test_paths.h"
#include "core/dataset/sequence.h"
#include "core/events/io.h"
#include "core/model/model_file.h"

namespace spikems {
namespace {

namespace fs = std::filesystem;
using test::run_command;
using test::spikems_binary;

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// conv 2->4 (3x3, stride 2, padding 1), then transposed conv 4->2 back to the input size.
ModelSpec hourglass() {
  ModelSpec m;
  m.name = "hourglass";
  for (auto [kind, ci, co] :
       {std::tuple{LayerKind::Conv, 2, 4}, std::tuple{LayerKind::ConvTranspose, 4, 2}}) {
    LayerSpec l;
    l.kind = kind;
    l.in_channels = ci;
    l.out_channels = co;
    l.kernel = 3;
    l.stride = 2;
    l.padding = 1;
    l.output_padding = kind == LayerKind::ConvTranspose ? 1 : 0;
    l.weight.assign(size_t(l.weight_count()), 0.3f);
    m.layers.push_back(l);
  }
  fill_fir_kernels(m);
  return m;
}

TEST(EnergyCli, CountsOnATinyDataset) {
  const std::string dir = test::scratch_dir();
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() +
                            " simulate --preset tiny --sequences 2 --duration "
                            "0.1s --out " +
                            dir + "/tiny --no-progress",
                        &out),
            0)
      << out;
  const std::string model = dir + "/hourglass.safetensors";
  save_model(model, hourglass());
  const std::string o = dir + "/out";
  const std::string cmd = spikems_binary() + " energy --quiet --model " + model;
  ASSERT_EQ(
      run_command(cmd + " --data " + dir + "/tiny --split all --window-ms 10 --out " + o, &out), 0)
      << out;
  const auto j = nlohmann::json::parse(slurp(o + "/results.json"));
  EXPECT_EQ(j["format"], "spikems-energy");
  EXPECT_EQ(j["sequences"], 2);
  // Every event of both sequences ran; samples = seconds / 10 ms.
  int64_t events = 0;
  double seconds = 0;
  for (const auto& f : sequence_files({dir + "/tiny", "all"})) {
    const EventStream e = read_events(f);
    events += int64_t(e.size());
    seconds += double(e.t_last() + 1 - e.t_first()) * 1e-6;
  }
  EXPECT_EQ(j["events"], events);
  EXPECT_NEAR(j["samples"].get<double>(), seconds / 0.01, 1e-6);
  const int w = j["sensor"]["width"], h = j["sensor"]["height"];
  ASSERT_EQ(j["layers"].size(), 2u);
  // conv: (w/2)(h/2) output positions x 4 x 2 x 9; transposed: (w/2)(h/2) inputs x 4 x 2 x 9.
  const int64_t macs = int64_t((w + 1) / 2) * ((h + 1) / 2) * 4 * 2 * 9;
  EXPECT_EQ(j["layers"][0]["ann_macs_per_sample"], macs);
  EXPECT_EQ(j["layers"][1]["ann_macs_per_sample"], macs);
  EXPECT_EQ(j["layers"][1]["out"], nlohmann::json({2, h, w}));
  EXPECT_EQ(j["layers"][0]["neurons"], 4 * ((w + 1) / 2) * ((h + 1) / 2));
  // Layer 2 takes what layer 1 emits.
  EXPECT_EQ(j["layers"][1]["in_spikes"], j["layers"][0]["out_spikes"]);
  const double syn =
      j["layers"][0]["synops"].get<double>() + j["layers"][1]["synops"].get<double>();
  ASSERT_GT(syn, 0);
  const double per_sample = syn / j["samples"].get<double>();
  EXPECT_NEAR(j["per_sample"]["synops"].get<double>(), per_sample, 1e-6 * per_sample);
  EXPECT_NEAR(j["per_sample"]["benefit"].get<double>(), 2.0 * macs * 4.6 / (per_sample * 0.9),
              1e-6 * j["per_sample"]["benefit"].get<double>());
  EXPECT_NE(out.find("SynOps per sample (x10^8)"), std::string::npos) << out;
  EXPECT_NE(slurp(o + "/results.md").find("| layer | kind |"), std::string::npos);
  EXPECT_EQ(j["downsample"], 1);
  // A model whose training grid is half the sensor runs at half resolution, and the ANN's MACs
  // are counted on that grid (a quarter of the positions).
  {
    ModelSpec half = hourglass();
    half.train_width = (w + 1) / 2;
    half.train_height = (h + 1) / 2;
    save_model(dir + "/half.safetensors", half);
    const std::string oh = dir + "/out_half";
    ASSERT_EQ(run_command(spikems_binary() + " energy --quiet --model " + dir +
                              "/half.safetensors --data " + dir +
                              "/tiny --split all --window-ms 10 --out " + oh,
                          &out),
              0)
        << out;
    const auto jh = nlohmann::json::parse(slurp(oh + "/results.json"));
    EXPECT_EQ(jh["downsample"], 2);
    const int hw = jh["sensor"]["width"], hh = jh["sensor"]["height"];
    EXPECT_EQ(hw, (w + 1) / 2);
    EXPECT_EQ(hh, (h + 1) / 2);
    EXPECT_EQ(jh["layers"][0]["ann_macs_per_sample"],
              int64_t((hw + 1) / 2) * ((hh + 1) / 2) * 4 * 2 * 9);
    EXPECT_EQ(jh["events"], events);
  }

  // Bad input: exit 1, a message naming what is wrong, nothing written.
  const std::string o2 = dir + "/out_bad";
  EXPECT_EQ(run_command(cmd + " --data " + dir + "/nowhere --out " + o2, &out), 1);
  EXPECT_NE(out.find(dir + "/nowhere"), std::string::npos) << out;
  EXPECT_EQ(run_command(cmd + " --data " + dir + "/tiny --window-ms 0 --out " + o2, &out), 1);
  EXPECT_NE(out.find("--window-ms"), std::string::npos) << out;
  EXPECT_EQ(run_command(cmd + " --data " + dir + "/tiny --split nope --out " + o2, &out), 1);
  EXPECT_NE(out.find("nope"), std::string::npos) << out;
  EXPECT_EQ(run_command(cmd + " --out " + o2, &out), 1);  // no --data
  EXPECT_NE(out.find("--data"), std::string::npos) << out;
  const std::string other = dir + "/other.txt";  // another sensor size than the dataset's
  std::ofstream(other) << "# sensor 32 32\n1000 1 1 1\n2000 2 2 0\n";
  EXPECT_EQ(
      run_command(cmd + " --data " + dir + "/tiny --split all --data " + other + " --out " + o2,
                  &out),
      1);
  EXPECT_NE(out.find("other.txt"), std::string::npos) << out;
  EXPECT_NE(out.find("differs"), std::string::npos) << out;
  EXPECT_EQ(run_command(spikems_binary() + " energy --quiet --model " + dir +
                            "/missing.safetensors --data " + dir + "/tiny --out " + o2,
                        &out),
            1);
  EXPECT_NE(out.find("missing.safetensors"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(o2 + "/results.json"));
  EXPECT_EQ(run_command(spikems_binary() + " energy --help", &out), 0);
  EXPECT_NE(out.find("--window-ms"), std::string::npos) << out;
}

}  // namespace
}  // namespace spikems
