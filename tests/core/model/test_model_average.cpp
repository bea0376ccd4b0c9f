// average_models: element-wise means of weights, delays and biases (checked against the
// arithmetic by hand), the record it leaves, and the refusals of models that are not snapshots
// of one network.
#include <gtest/gtest.h>

#include "common/tiny_models.h"
#include "core/model/model_average.h"
#include "core/model/output_threshold.h"
#include "core/util/error.h"

namespace spikems {
namespace {

std::string error_of(const std::vector<ModelSpec>& m, const std::vector<std::string>& s) {
  try {
    average_models(m, s);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(ModelAverage, MeansEveryWeightDelayAndBias) {
  ModelSpec a = test::random_conv_model(1, -1.f, 1.f);
  ModelSpec b = test::random_conv_model(2, -1.f, 1.f);
  ModelSpec c = test::random_conv_model(3, -1.f, 1.f);
  a.layers[0].delay = {0.f, 1.f, 2.f, 3.f};
  b.layers[0].delay = {3.f, 1.f, 0.f, 1.f};
  c.layers[0].delay = {0.f, 4.f, 1.f, 2.f};
  a.training = {{"steps", 100}, {"calibration", {{"factor", 1.2}}}, {"config", "x"}};
  b.training = {{"steps", 200}};
  const ModelSpec m = average_models({a, b, c}, {"a", "b", "c"});
  ASSERT_EQ(m.layers.size(), 2u);
  for (size_t k = 0; k < 2; ++k)
    for (size_t i = 0; i < a.layers[k].weight.size(); ++i)
      EXPECT_FLOAT_EQ(m.layers[k].weight[i], float((double(a.layers[k].weight[i]) +
                                                    b.layers[k].weight[i] + c.layers[k].weight[i]) /
                                                   3.0))
          << "layer " << k << " weight " << i;
  EXPECT_EQ(m.layers[0].delay, (std::vector<float>{1.f, 2.f, 1.f, 2.f}));
  EXPECT_TRUE(m.layers[1].delay.empty());
  EXPECT_EQ(m.layers[0].srm_kernel, a.layers[0].srm_kernel);  // kept, not averaged
  // The first model's record without its calibration, and where the average came from.
  EXPECT_FALSE(m.training.contains("calibration"));
  EXPECT_EQ(m.training["config"], "x");
  ASSERT_EQ(m.training["averaged_from"].size(), 3u);
  EXPECT_EQ(m.training["averaged_from"][1]["source"], "b");
  EXPECT_EQ(m.training["averaged_from"][1]["steps"], 200);
  EXPECT_FALSE(m.training["averaged_from"][2].contains("steps"));
}

TEST(ModelAverage, AveragingAModelWithItselfGivesItBack) {
  const ModelSpec a = test::random_conv_model(7, -0.5f, 0.5f);
  const ModelSpec m = average_models({a, a}, {"a", "a2"});
  for (size_t k = 0; k < 2; ++k) EXPECT_EQ(m.layers[k].weight, a.layers[k].weight);
}

TEST(ModelAverage, MeansAnnBiases) {
  ModelSpec a = ann2d_architecture({4, 4}), b = a;
  for (size_t k = 0; k < a.layers.size(); ++k) {
    std::fill(a.layers[k].weight.begin(), a.layers[k].weight.end(), 1.f);
    std::fill(b.layers[k].weight.begin(), b.layers[k].weight.end(), 2.f);
    std::fill(a.layers[k].bias.begin(), a.layers[k].bias.end(), -1.f);
    std::fill(b.layers[k].bias.begin(), b.layers[k].bias.end(), 0.f);
  }
  const ModelSpec m = average_models({a, b}, {"a", "b"});
  EXPECT_FLOAT_EQ(m.layers[1].weight[5], 1.5f);
  EXPECT_FLOAT_EQ(m.layers[2].bias[0], -0.5f);
}

TEST(ModelAverage, RefusesModelsThatAreNotSnapshotsOfOneNetwork) {
  const ModelSpec a = test::random_conv_model(1, -1.f, 1.f);
  EXPECT_NE(error_of({a}, {"a"}).find("at least two"), std::string::npos);

  // A calibrated snapshot: its output θ differs (1.3 x 0.22 = 0.286).
  const ModelSpec cal = with_output_threshold(a, 1.3, "cal");
  const std::string e = error_of({a, cal}, {"a", "cal.safetensors"});
  EXPECT_NE(e.find("cal.safetensors"), std::string::npos) << e;
  EXPECT_NE(e.find("layer 2"), std::string::npos) << e;
  EXPECT_NE(e.find("threshold"), std::string::npos) << e;
  EXPECT_NE(e.find("spikems calibrate"), std::string::npos) << e;

  ModelSpec wide = test::random_conv_model(2, -1.f, 1.f);
  wide.layers.pop_back();
  EXPECT_NE(error_of({a, wide}, {"a", "w"}).find("layer count"), std::string::npos);

  ModelSpec gated = a;
  gated.output_gate_steps = 3;
  EXPECT_NE(error_of({a, gated}, {"a", "g"}).find("output gate"), std::string::npos);

  ModelSpec delayed = a;
  delayed.layers[1].delay = {1.f, 1.f};
  EXPECT_NE(error_of({a, delayed}, {"a", "d"}).find("delay count"), std::string::npos);

  ModelSpec iir = a;
  for (auto& l : iir.layers) {
    l.neuron.discretisation = Discretisation::IIR;
    l.srm_kernel.clear();
    l.ref_kernel.clear();
  }
  EXPECT_NE(error_of({a, iir}, {"a", "i"}).find("layer 1"), std::string::npos);
}

}  // namespace
}  // namespace spikems
