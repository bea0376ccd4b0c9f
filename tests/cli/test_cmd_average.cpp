// `spikems average` end to end: the written model holds the mean weights, and bad requests
// (one model, a missing file, the output over an input, models of two networks) exit 1 with a
// message naming the problem, leaving the inputs untouched.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/test_paths.h"
#include "common/tiny_models.h"
#include "core/model/model_file.h"

namespace spikems {
namespace {

using test::run_command;
using test::spikems_binary;

TEST(AverageCli, WritesTheMeanOfTheSnapshots) {
  const std::string d = test::scratch_dir();
  save_model(d + "/a.safetensors", test::pointwise_model({1.f, 0.f, 0.f, 0.5f}, "a"));
  save_model(d + "/b.safetensors", test::pointwise_model({0.f, 2.f, 1.f, 0.5f}, "b"));
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " average --model " + d + "/a.safetensors " + d +
                            "/b.safetensors --out " + d + "/avg.safetensors",
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("calibrate"), std::string::npos) << out;
  const ModelSpec m = load_model(d + "/avg.safetensors");
  EXPECT_EQ(m.name, "a");
  EXPECT_EQ(m.layers[0].weight, (std::vector<float>{0.5f, 1.f, 0.5f, 0.5f}));
  ASSERT_EQ(m.training["averaged_from"].size(), 2u);
  EXPECT_EQ(m.training["averaged_from"][1]["source"], d + "/b.safetensors");
}

TEST(AverageCli, RefusesBadRequestsWithAClearMessage) {
  const std::string d = test::scratch_dir();
  const std::string a = d + "/a.safetensors", b = d + "/b.safetensors";
  save_model(a, test::pointwise_model({1.f, 0.f, 0.f, 0.5f}, "a"));
  save_model(b, test::random_conv_model(3, -1.f, 1.f));
  const std::string bin = spikems_binary() + " average --model ";
  std::string out;
  EXPECT_EQ(run_command(bin + a + " --out " + d + "/o.safetensors", &out), 1);
  EXPECT_NE(out.find("at least two"), std::string::npos) << out;
  EXPECT_EQ(
      run_command(bin + a + " " + d + "/missing.safetensors --out " + d + "/o.safetensors", &out),
      1);
  EXPECT_NE(out.find("missing.safetensors"), std::string::npos) << out;
  EXPECT_EQ(run_command(bin + a + " " + a + " --out " + a, &out), 1);
  EXPECT_NE(out.find("one of the models"), std::string::npos) << out;
  EXPECT_EQ(run_command(bin + a + " " + b + " --out " + d + "/o.safetensors", &out), 1);
  EXPECT_NE(out.find(b), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(d + "/o.safetensors"));
  EXPECT_EQ(load_model(a).layers[0].weight, (std::vector<float>{1.f, 0.f, 0.f, 0.5f}));
}

}  // namespace
}  // namespace spikems
