// Config files: presets equal the committed TOML files, every key parses, typos are errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/test_paths.h"
#include "core/sim/presets.h"
#include "core/sim/sim_config.h"
#include "core/sim/texture.h"
#include "core/util/error.h"

using namespace spikems;
using namespace spikems::sim;

TEST(SimConfig, PresetsMatchConfigFiles) {
  for (const auto& n : preset_names()) {
    std::ifstream f(spikems::test::source_dir() + "/configs/sim/" + n + ".toml", std::ios::binary);
    ASSERT_TRUE(f) << n;
    std::stringstream ss;
    ss << f.rdbuf();
    EXPECT_EQ(ss.str(), preset_toml(n)) << "configs/sim/" << n << ".toml differs from presets.cpp";
    SimConfig c = preset_config(n);
    EXPECT_EQ(c.name, n);
  }
  // ... and every file of the folder is a named preset.
  const auto names = preset_names();
  for (const auto& e :
       std::filesystem::directory_iterator(spikems::test::source_dir() + "/configs/sim"))
    EXPECT_NE(std::find(names.begin(), names.end(), e.path().stem().string()), names.end())
        << e.path();
  EXPECT_EQ(preset_config("mod").width, 346);
  EXPECT_EQ(preset_config("tiny").width, 64);
  EXPECT_TRUE(preset_config("eed-net").net);
  EXPECT_THROW(preset_toml("nope"), Error);
}

TEST(SimConfig, ValuesAndErrors) {
  SimConfig c = parse_sim_config(
      "[time]\nduration_s = 0.5\n[events]\nthreshold = 0.3\n[objects]\nspeed = [1, 2]\n", "x");
  EXPECT_EQ(c.duration_us, 500000);
  EXPECT_DOUBLE_EQ(c.threshold, 0.3);
  EXPECT_DOUBLE_EQ(c.object_speed.lo, 1);
  EXPECT_DOUBLE_EQ(c.object_speed.hi, 2);
  EXPECT_THROW(parse_sim_config("[events]\nthreshhold = 0.3\n", "x"), Error);  // typo
  EXPECT_THROW(parse_sim_config("[evnts]\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[objects]\nspeed = [2, 1]\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[events]\nthreshold = -1\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[scene]\ntextures = [\"plaid\"]\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[time\n", "x"), Error);
  // Noise rates per pixel within what sensors show, and a sequence's noise within 10^9 events.
  EXPECT_THROW(parse_sim_config("[events]\nleak_hz = 1e9\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[events]\nshot_hz = [0.0, 1000.0]\n", "x"), Error);
  EXPECT_THROW(parse_sim_config("[events]\nhot_pixel_fraction = 0.5\nhot_pixel_hz = 1e5\n", "x"),
               Error);
  EXPECT_NO_THROW(parse_sim_config("[events]\nshot_hz = 100\n", "x"));  // 9 M events in 2 s
  try {
    parse_sim_config(
        "[sensor]\nwidth = 4096\nheight = 4096\n[time]\nduration_s = 60\n"
        "[events]\nshot_hz = 50\n",
        "x");
    ADD_FAILURE() << "5 x 10^10 noise events per sequence must be refused";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("noise events per sequence"), std::string::npos)
        << e.what();
  }
  SimConfig n = preset_config("mod");
  apply_noise_setting(n, "clean");
  EXPECT_EQ(n.threshold_sigma, 0);
  EXPECT_EQ(n.shot_hz, 0);
  EXPECT_EQ(n.leak_hz, 0);
  EXPECT_THROW(apply_noise_setting(n, "loud"), Error);
}

// The mip pyramid keeps the mean: a footprint of the whole tile gives the tile average.
TEST(SimTexture, MipLevelsAverage) {
  TextureParams p;
  p.kind = TextureKind::Checkers;
  p.frequency = 4;
  Texture t(p);
  double mean = 0;
  for (int y = 0; y < Texture::kTile; ++y)
    for (int x = 0; x < Texture::kTile; ++x)
      mean += t.bilinear(0, (x + 0.5f) / Texture::kTile, (y + 0.5f) / Texture::kTile);
  mean /= double(Texture::kTile) * Texture::kTile;
  EXPECT_NEAR(t.sample(0.3f, 0.7f, 2.0f), mean, 1e-4);
  // Periodic: one tile further gives the same value.
  EXPECT_NEAR(t.sample(0.3f, 0.7f, 0.001f), t.sample(1.3f, -0.3f, 0.001f), 1e-4);
}
