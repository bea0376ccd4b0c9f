// with_time_step: a model moved to another time step, its time constants scaled ("steps") or
// kept in ms ("ms"), and the cases it refuses.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/error_text.h"
#include "core/model/time_step.h"
#include "core/util/error.h"

namespace spikems {
namespace {

ModelSpec iir_model() {
  ModelSpec m = spikems_architecture(true, Discretisation::IIR);
  m.time_step_ms = 2;
  m.output_gate_steps = 5;
  m.layers[2].neuron.tau_r = 3;
  return m;
}

using test::error_of;

TEST(TimeStep, StepsScalesEveryTimeConstantAndKeepsStepCounts) {
  const ModelSpec m = iir_model();
  const ModelSpec s = with_time_step(m, 5, TimeConstants::Steps, "test");
  EXPECT_DOUBLE_EQ(s.time_step_ms, 5);
  EXPECT_EQ(s.output_gate_steps, 5);  // a count of steps: 25 ms now
  ASSERT_EQ(s.layers.size(), m.layers.size());
  for (size_t k = 0; k < m.layers.size(); ++k) {
    EXPECT_FLOAT_EQ(s.layers[k].neuron.tau_s, m.layers[k].neuron.tau_s * 2.5f) << k;
    EXPECT_FLOAT_EQ(s.layers[k].neuron.tau_r, m.layers[k].neuron.tau_r * 2.5f) << k;
    // Not a time: the surrogate's width in units of theta.
    EXPECT_FLOAT_EQ(s.layers[k].neuron.tau_rho, m.layers[k].neuron.tau_rho) << k;
    EXPECT_EQ(s.layers[k].weight, m.layers[k].weight) << k;
  }
  EXPECT_FLOAT_EQ(s.layers[2].neuron.tau_r, 7.5f);
  // Back again gives the model it came from.
  const ModelSpec b = with_time_step(s, 2, TimeConstants::Steps, "test");
  for (size_t k = 0; k < m.layers.size(); ++k)
    EXPECT_FLOAT_EQ(b.layers[k].neuron.tau_r, m.layers[k].neuron.tau_r) << k;
}

TEST(TimeStep, StepsKeepsFirKernelsAndDelays) {
  ModelSpec m = spikems_architecture(false, Discretisation::FIR);
  m.time_step_ms = 1;
  fill_fir_kernels(m);
  m.layers[0].delay.assign(size_t(m.layers[0].out_channels), 2.f);
  const ModelSpec s = with_time_step(m, 3, TimeConstants::Steps, "test");
  EXPECT_EQ(s.layers[0].srm_kernel, m.layers[0].srm_kernel);
  EXPECT_EQ(s.layers[0].ref_kernel, m.layers[0].ref_kernel);
  EXPECT_EQ(s.layers[0].delay, m.layers[0].delay);
  EXPECT_FLOAT_EQ(s.layers[0].neuron.tau_s, 3 * m.layers[0].neuron.tau_s);
}

TEST(TimeStep, MsKeepsTimeConstantsAndTheGatesDuration) {
  const ModelSpec m = iir_model();
  const ModelSpec s = with_time_step(m, 5, TimeConstants::Ms, "test");
  EXPECT_DOUBLE_EQ(s.time_step_ms, 5);
  EXPECT_EQ(s.output_gate_steps, 2);  // 10 ms
  for (size_t k = 0; k < m.layers.size(); ++k) {
    EXPECT_EQ(s.layers[k].neuron.tau_s, m.layers[k].neuron.tau_s) << k;
    EXPECT_EQ(s.layers[k].neuron.tau_r, m.layers[k].neuron.tau_r) << k;
  }
  // 10 ms is not a whole number of 4 ms steps.
  EXPECT_NE(
      error_of([&] { with_time_step(m, 4, TimeConstants::Ms, "src"); }).find("not a whole number"),
      std::string::npos);
  ModelSpec no_gate = m;
  no_gate.output_gate_steps = 0;
  EXPECT_EQ(with_time_step(no_gate, 4, TimeConstants::Ms, "src").output_gate_steps, 0);
}

TEST(TimeStep, RefusesWhatCannotBeMoved) {
  ModelSpec fir = spikems_architecture(false, Discretisation::FIR);
  fill_fir_kernels(fir);
  EXPECT_NE(error_of([&] { with_time_step(fir, 2, TimeConstants::Ms, "src"); }).find("FIR"),
            std::string::npos);
  ModelSpec delayed = iir_model();
  delayed.layers[1].delay.assign(size_t(delayed.layers[1].out_channels), 1.f);
  EXPECT_NE(error_of([&] {
              with_time_step(delayed, 4, TimeConstants::Ms, "src");
            }).find("layer 2 has delays"),
            std::string::npos);
  const ModelSpec m = iir_model();
  for (double bad : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::infinity()})
    EXPECT_NE(error_of([&] {
                with_time_step(m, bad, TimeConstants::Steps, "src");
              }).find("must be positive"),
              std::string::npos)
        << bad;
  ModelSpec ann = ann2d_architecture({8, 16}, false);
  EXPECT_NE(error_of([&] { with_time_step(ann, 5, TimeConstants::Steps, "src"); }).find("ANN-2D"),
            std::string::npos);
  // At its own step any model comes back as it is, whatever it holds.
  EXPECT_EQ(with_time_step(fir, fir.time_step_ms, TimeConstants::Ms, "src").layers[0].srm_kernel,
            fir.layers[0].srm_kernel);
  EXPECT_EQ(with_time_step(ann, ann.time_step_ms, TimeConstants::Steps, "src").type,
            ModelType::ANN2D);
  EXPECT_TRUE(same_time_step(2, 2 + 1e-12));
  EXPECT_FALSE(same_time_step(2, 2.001));
  EXPECT_EQ(parse_time_constants("steps", "k"), TimeConstants::Steps);
  EXPECT_EQ(parse_time_constants("ms", "k"), TimeConstants::Ms);
  EXPECT_NE(error_of([] { parse_time_constants("seconds", "k"); }).find("'seconds'"),
            std::string::npos);
}

}  // namespace
}  // namespace spikems
