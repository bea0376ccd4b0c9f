// The output-threshold factor (core/model/output_threshold.h): what it changes in the model,
// an analytic firing case, the nesting of the labels it gives on a network without output
// refractory, and the inputs it refuses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "common/tiny_models.h"
#include "core/dataset/sequence.h"
#include "core/eval/sequence_scorer.h"
#include "core/model/output_threshold.h"
#include "core/runtime/segmenter.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// Two 3x3 convolutions (padding 1), seeded random weights, mostly excitatory; the output
// layer's refractory scaled by output_scale_ref.
ModelSpec two_layers(float output_scale_ref, float w_max = 0.3f) {
  ModelSpec m = test::random_conv_model(11, -0.1f, w_max);
  m.layers.back().neuron.scale_ref = output_scale_ref;
  fill_fir_kernels(m);
  return m;
}

TEST(OutputThreshold, ScalesTheOutputLayersThresholdAndRefractoryOnly) {
  const ModelSpec m = two_layers(2.f);
  const ModelSpec s = with_output_threshold(m, 1.5, "m");
  EXPECT_EQ(s.layers[0].neuron.theta, m.layers[0].neuron.theta);
  EXPECT_EQ(s.layers[0].ref_kernel, m.layers[0].ref_kernel);
  EXPECT_EQ(s.layers[0].weight, m.layers[0].weight);
  EXPECT_FLOAT_EQ(s.layers[1].neuron.theta, 1.5f * m.layers[1].neuron.theta);
  EXPECT_EQ(s.layers[1].srm_kernel, m.layers[1].srm_kernel);
  // The refractory kernel is the one the new θ samples (its length follows θ), so the FIR
  // model keeps its exact IIR form.
  EXPECT_EQ(s.layers[1].ref_kernel, sample_refractory_kernel(s.layers[1].neuron, s.time_step_ms));
  EXPECT_NE(s.layers[1].ref_kernel, m.layers[1].ref_kernel);
  EXPECT_TRUE(has_sampled_kernels(s.layers[1], s.time_step_ms));
  EXPECT_NO_THROW(with_iir_neurons(s, "m"));
  // A kernel of its own (not the sampled one) is proportional to θ: it scales.
  ModelSpec odd = m;
  odd.layers[1].ref_kernel[1] *= 0.5f;
  const ModelSpec t = with_output_threshold(odd, 1.5, "odd");
  ASSERT_EQ(t.layers[1].ref_kernel.size(), odd.layers[1].ref_kernel.size());
  for (size_t i = 0; i < t.layers[1].ref_kernel.size(); ++i)
    EXPECT_FLOAT_EQ(t.layers[1].ref_kernel[i], 1.5f * odd.layers[1].ref_kernel[i]) << i;
  // IIR neurons compute the refractory from θ: only θ changes.
  const ModelSpec iir = with_iir_neurons(m, "m");
  const ModelSpec u = with_output_threshold(iir, 2.0, "m");
  EXPECT_FLOAT_EQ(u.layers[1].neuron.theta, 2.f * iir.layers[1].neuron.theta);
  EXPECT_TRUE(u.layers[1].ref_kernel.empty());
}

// One OFF event through a 1x1 weight w to an output without refractory: the potential at the
// pixel is w·eps[n], n steps after the event, so the pixel spikes (and the event is labelled
// moving) exactly when the factor is at most w·max(eps)/θ.
TEST(OutputThreshold, AnEventIsLabelledMovingUpToTheFactorItsPotentialReaches) {
  ModelSpec m = test::pointwise_model({0.3f, 0.f, 0.f, 0.f});
  m.layers[0].neuron.scale_ref = 0;
  fill_fir_kernels(m);
  const auto& eps = m.layers[0].srm_kernel;
  const double reach = 0.3 * *std::max_element(eps.begin(), eps.end()) / m.layers[0].neuron.theta;
  ASSERT_GT(reach, 1.2);  // the untouched model labels it
  LabelledSequence seq;
  seq.name = "one event";
  seq.events.sensor = SensorSize{8, 8};
  seq.events.push_back(0, 0, 0, 1, 0);      // ON, background: the origin, predicts nothing
  seq.events.push_back(2500, 3, 3, 0, 1);   // OFF at (3, 3), moving
  seq.events.push_back(25000, 0, 0, 1, 0);  // the data goes on: windows [0,10) and [10,20) ms
  for (double f : {1.0, 0.99 * reach, 1.01 * reach, 2 * reach}) {
    const SequenceScore s = score_sequence(with_output_threshold(m, f, "m"), seq, {10000}, {});
    const bool fires = f <= reach;
    EXPECT_DOUBLE_EQ(s.scores[0].mean_iou(), fires ? 1.0 : 0.0) << "factor " << f;
    EXPECT_EQ(s.events_pr[0].tp, fires ? 1u : 0u) << "factor " << f;
    EXPECT_EQ(s.events_pr[0].fn, fires ? 0u : 1u) << "factor " << f;
  }
}

// Without output refractory the output's potential does not depend on its θ: the events a
// higher factor labels moving are among those a lower one labels, and the count falls.
TEST(OutputThreshold, LabelsAtAHigherFactorAreASubsetWithoutOutputRefractory) {
  const ModelSpec m = two_layers(0.f, 0.12f);
  EventStream ev;
  ev.sensor = SensorSize{24, 16};
  std::mt19937 rng(5);
  for (int64_t t = 0; t < 60000; t += 50)
    ev.push_back(t, uint16_t(rng() % 24), uint16_t(rng() % 16), uint8_t(rng() % 2), 0);
  std::vector<std::vector<uint8_t>> labels;
  for (double f : {0.8, 1.0, 1.3, 1.7, 2.5}) {
    Segmenter seg(with_output_threshold(m, f, "m"), ev.sensor, SegmenterOptions{});
    seg.push(ev);
    seg.finish();
    std::vector<uint8_t> l(seg.labelled().label.begin(), seg.labelled().label.end());
    labels.push_back(l);
  }
  for (size_t k = 0; k + 1 < labels.size(); ++k) {
    ASSERT_EQ(labels[k].size(), labels[k + 1].size());
    size_t lo = 0, hi = 0;
    for (size_t i = 0; i < labels[k].size(); ++i) {
      lo += labels[k][i] != 0;
      hi += labels[k + 1][i] != 0;
      EXPECT_TRUE(labels[k + 1][i] == 0 || labels[k][i] != 0) << "event " << i << ", step " << k;
    }
    EXPECT_LT(hi, lo) << "factor step " << k << ": nothing changed, the test is vacuous";
  }
  EXPECT_GT(std::count(labels[0].begin(), labels[0].end(), 1), 100);
}

TEST(OutputThreshold, RefusesBadFactorsAndAnn2dModels) {
  const ModelSpec m = two_layers(0.f);
  for (double f : {0.0, -1.0, 101.0, double(NAN), double(INFINITY)})
    EXPECT_THROW(with_output_threshold(m, f, "m"), Error) << f;
  try {
    with_output_threshold(ann2d_architecture(), 1.2, "ann.safetensors");
    FAIL() << "an ANN-2D was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ann.safetensors"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("spiking models only"), std::string::npos) << e.what();
  }
  EXPECT_EQ(parse_threshold_scales("1,1.1,1.25", "--x"), (std::vector<double>{1, 1.1, 1.25}));
  EXPECT_EQ(parse_threshold_scales("2", "--x"), (std::vector<double>{2}));
  for (const char* bad : {"", "1,,2", "1,", "a", "1.2x", "0", "1,1", "-1", "200"}) {
    try {
      parse_threshold_scales(bad, "--output-thresholds");
      FAIL() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("--output-thresholds"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace spikems
