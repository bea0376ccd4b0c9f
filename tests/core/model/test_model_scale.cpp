// The pixel scale a model records (train_width/height) and the downsampling factor chosen from
// it: hand-worked cases, the file round trip, and bad values.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/test_paths.h"
#include "common/tiny_models.h"
#include "core/model/model_file.h"
#include "core/model/model_scale.h"
#include "core/util/error.h"

namespace spikems {
namespace {

ModelSpec with_grid(int w, int h) {
  ModelSpec m = test::pointwise_model({1.f, 0.f, 0.f, 0.f});
  m.train_width = w;
  m.train_height = h;
  return m;
}

TEST(ModelScale, NearestDownsampleBringsTheSensorToTheTrainingGrid) {
  // Trained on 346x260 rooms downsampled 2x (173x130, geometric mean 150 px).
  const ModelSpec m = with_grid(173, 130);
  EXPECT_EQ(nearest_downsample(m, 346, 260), 2);  // exactly the training grid
  EXPECT_EQ(nearest_downsample(m, 173, 130), 1);
  // 240x180 (mean 207.8): log2(207.8/150) = 0.47 at 1 against -0.53 at 2.
  EXPECT_EQ(nearest_downsample(m, 240, 180), 1);
  EXPECT_EQ(nearest_downsample(m, 640, 480), 4);    // 160x120: -0.23 (2: 320x240, +0.77)
  EXPECT_EQ(nearest_downsample(m, 1280, 720), 8);   // 160x90: -0.32 (4: 320x180, +0.68)
  EXPECT_EQ(nearest_downsample(m, 4000, 3000), 8);  // the largest factor at most
  EXPECT_EQ(nearest_downsample(m, 64, 48), 1);
  // Odd sides round up (ceil(W/f)), as the runtime's grid does.
  EXPECT_EQ(nearest_downsample(m, 345, 259), 2);
  // No recorded grid, an ANN-2D model, an unknown sensor: 1.
  EXPECT_EQ(nearest_downsample(with_grid(0, 0), 1280, 720), 1);
  ModelSpec ann = m;
  ann.type = ModelType::ANN2D;
  EXPECT_EQ(nearest_downsample(ann, 346, 260), 1);
  EXPECT_EQ(nearest_downsample(m, 0, 0), 1);
  // A fixed input size: the factor that reaches it, else 1 (the runtime names the mismatch).
  ModelSpec fixed = with_grid(0, 0);
  fixed.input_width = 173;
  fixed.input_height = 130;
  EXPECT_EQ(nearest_downsample(fixed, 346, 260), 2);
  EXPECT_EQ(nearest_downsample(fixed, 692, 520), 4);
  EXPECT_EQ(nearest_downsample(fixed, 173, 130), 1);
  EXPECT_EQ(nearest_downsample(fixed, 300, 200), 1);
}

TEST(ModelScale, ExplicitFactorsAndParsing) {
  const ModelSpec m = with_grid(173, 130);
  EXPECT_EQ(resolve_downsample(m, 346, 260, 0, "x"), 2);  // 0 = auto
  EXPECT_EQ(resolve_downsample(m, 346, 260, 1, "x"), 1);  // the user's choice wins
  EXPECT_EQ(resolve_downsample(m, 346, 260, 8, "x"), 8);
  EXPECT_THROW(resolve_downsample(m, 346, 260, 3, "x"), Error);
  EXPECT_THROW(resolve_downsample(m, 346, 260, -2, "x"), Error);
  EXPECT_EQ(parse_downsample("auto", "--downsample"), 0);
  EXPECT_EQ(parse_downsample("1", "--downsample"), 1);
  EXPECT_EQ(parse_downsample("4", "--downsample"), 4);
  for (const char* bad : {"3", "0", "", "2x", "16", "half"}) {
    try {
      parse_downsample(bad, "--downsample");
      ADD_FAILURE() << bad;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("--downsample"), std::string::npos) << e.what();
    }
  }
}

TEST(ModelScale, TheGridRoundTripsThroughTheFileAndIsChecked) {
  const std::string d = test::scratch_dir();
  const ModelSpec m = with_grid(173, 130);
  save_model(d + "/g.safetensors", m);
  const ModelSpec back = load_model(d + "/g.safetensors");
  EXPECT_EQ(back.train_width, 173);
  EXPECT_EQ(back.train_height, 130);
  EXPECT_NE(spec_to_json(m).dump().find("\"train_width\":173"), std::string::npos);
  // Not recorded: not written (older files rewrite byte for byte).
  EXPECT_EQ(spec_to_json(with_grid(0, 0)).dump().find("train_width"), std::string::npos);
  EXPECT_EQ(load_model(d + "/g.safetensors").train_width, 173);
  for (auto [w, h] :
       {std::pair{173, 0}, std::pair{0, 130}, std::pair{-1, 5}, std::pair{70000, 10}}) {
    ModelSpec bad = with_grid(w, h);
    try {
      bad.validate("bad.safetensors");
      ADD_FAILURE() << w << "x" << h;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("train_width"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace spikems
