#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "common/test_paths.h"
#include "core/model/model_file.h"
#include "core/model/safetensors.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

using namespace spikems;

// Kernel values from ../shared/reference/spikems-evimo/README.md (the authors' checkpoint
// buffers), so our sampling matches their code bit for bit in float32.
TEST(Kernels, SrmTau2MatchesAuthorsBuffer) {
  const float want[] = {0,
                        0.824360609f,
                        1,
                        0.909796f,
                        0.735758901f,
                        0.557825387f,
                        0.406005859f,
                        0.287297487f,
                        0.199148268f,
                        0.135888219f,
                        0.091578193f,
                        0.0610994808f,
                        0.0404276811f,
                        0.0265640151f,
                        0.017351266f,
                        0.0112757944f};
  auto k = sample_srm_kernel(2.0, 1.0);
  ASSERT_EQ(k.size(), 16u);
  for (size_t i = 0; i < k.size(); ++i) EXPECT_FLOAT_EQ(k[i], want[i]) << i;
}

TEST(Kernels, SrmTau4Has31Taps) {
  auto k = sample_srm_kernel(4.0, 1.0);
  ASSERT_EQ(k.size(), 31u);
  EXPECT_FLOAT_EQ(k[1], 0.529250026f);
  EXPECT_FLOAT_EQ(k[4], 1.0f);
  EXPECT_FLOAT_EQ(k[30], 0.0112757944f);
}

TEST(Kernels, RefractorySpikeMSMatchesAuthorsBuffer) {
  NeuronParams n;
  n.theta = 0.22f;
  n.tau_r = 1;
  n.scale_ref = 2;
  auto k = sample_refractory_kernel(n, 1.0);
  const float want[] = {0, -0.439999998f, -0.161866948f, -0.0595475249f, -0.0219063107f};
  ASSERT_EQ(k.size(), 5u);
  for (size_t i = 0; i < 5; ++i) EXPECT_FLOAT_EQ(k[i], want[i]) << i;
  n.theta = 0.24f;
  n.tau_r = 3;
  k = sample_refractory_kernel(n, 1.0);
  ASSERT_EQ(k.size(), 13u);
  EXPECT_FLOAT_EQ(k[1], -0.479999989f);
  EXPECT_FLOAT_EQ(k[12], -0.012269536f);
}

TEST(Kernels, RefractorySlayerIsAlphaShaped) {
  NeuronParams n;
  n.theta = 0.5f;
  n.tau_r = 2;
  n.scale_ref = 2;
  n.refractory = RefractoryShape::Slayer;
  auto k = sample_refractory_kernel(n, 1.0);
  EXPECT_FLOAT_EQ(k[0], 0.f);
  EXPECT_FLOAT_EQ(k[2], -1.0f);  // peak -scale_ref*theta at t = tau_r
  EXPECT_NEAR(k[1], -1.0 * 0.5 * std::exp(0.5), 1e-6);
}

TEST(Architecture, SpikeMSHas46656WeightsAndPaperGeometry) {
  ModelSpec s = spikems_architecture(false);
  int64_t total = 0;
  for (const auto& l : s.layers) total += l.weight_count();
  EXPECT_EQ(total, 46656);  // the paper's network
  EXPECT_EQ(s.output_size(64, 80), std::make_pair(63, 79));
  EXPECT_EQ(s.output_size(180, 190), std::make_pair(175, 183));
  ModelSpec p = spikems_architecture(true);
  EXPECT_EQ(p.output_size(256, 344), std::make_pair(256, 344));  // multiple of 8 keeps its size
  EXPECT_EQ(p.layers[3].output_padding, 1);
}

TEST(Architecture, WidthsSetLevelsAndMirrorTheNeurons) {
  const ModelSpec base = spikems_architecture(true, Discretisation::IIR);
  const ModelSpec s = spikems_architecture(true, Discretisation::IIR, {8, 24, 40, 48});
  ASSERT_EQ(s.layers.size(), 8u);
  const int ci[] = {2, 8, 24, 40, 48, 40, 24, 8}, co[] = {8, 24, 40, 48, 40, 24, 8, 2};
  for (size_t k = 0; k < 8; ++k) {
    EXPECT_EQ(s.layers[k].in_channels, ci[k]) << k;
    EXPECT_EQ(s.layers[k].out_channels, co[k]) << k;
    EXPECT_EQ(s.layers[k].kind, k < 4 ? LayerKind::Conv : LayerKind::ConvTranspose) << k;
  }
  // The paper's levels keep the paper's neurons; the fourth takes the third's.
  auto same = [](const NeuronParams& a, const NeuronParams& b) {
    return a.theta == b.theta && a.tau_s == b.tau_s && a.tau_r == b.tau_r &&
           a.scale_rho == b.scale_rho;
  };
  for (size_t k = 0; k < 3; ++k) EXPECT_TRUE(same(s.layers[k].neuron, base.layers[k].neuron)) << k;
  EXPECT_TRUE(same(s.layers[3].neuron, base.layers[2].neuron));
  EXPECT_TRUE(same(s.layers[4].neuron, base.layers[3].neuron));
  for (size_t k = 5; k < 8; ++k)
    EXPECT_TRUE(same(s.layers[k].neuron, base.layers[k - 2].neuron)) << k;
  EXPECT_EQ(s.output_size(256, 352), std::make_pair(256, 352));  // multiple of 16 keeps its size
  EXPECT_EQ(s.output_size(260, 346), std::make_pair(272, 352));
  EXPECT_NO_THROW(s.validate("widths"));
  EXPECT_THROW(spikems_architecture(true, Discretisation::IIR, {}), Error);
  EXPECT_THROW(spikems_architecture(true, Discretisation::IIR, {8, 8, 8, 8, 8, 8, 8}), Error);
  EXPECT_THROW(spikems_architecture(true, Discretisation::IIR, {16, 0}), Error);
  EXPECT_THROW(spikems_architecture(true, Discretisation::IIR, {2000}), Error);
  EXPECT_EQ(ann2d_architecture({32, 64}).layers.size(), 4u);
  EXPECT_EQ(ann2d_architecture({32, 64}).layers.back().out_channels, 1);
}

// model.tau_s: one synaptic time constant per level, the decoder's layers mirrored; the FIR
// kernels are sampled from it (the peak of eps sits at tau_s).
TEST(Architecture, TauPerLevelMirrorsAndSetsTheKernels) {
  const ModelSpec s = spikems_architecture(true, Discretisation::FIR, {8, 16, 32}, {1, 3, 5});
  const double want[] = {1, 3, 5, 5, 3, 1};
  for (size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(s.layers[k].neuron.tau_s, want[k]) << k;
    const auto& e = s.layers[k].srm_kernel;
    ASSERT_GT(e.size(), size_t(want[k]) + 1) << k;
    const size_t peak = size_t(std::max_element(e.begin(), e.end()) - e.begin());
    EXPECT_EQ(double(peak), want[k]) << "eps peaks at tau_s (1 ms steps), layer " << k;
  }
  const ModelSpec base = spikems_architecture(true, Discretisation::FIR, {8, 16, 32});
  EXPECT_EQ(s.layers[0].neuron.theta, base.layers[0].neuron.theta);  // only tau_s changes
  EXPECT_EQ(s.layers[2].neuron.tau_r, base.layers[2].neuron.tau_r);
  EXPECT_THROW(spikems_architecture(true, Discretisation::IIR, {8, 16}, {1}), Error);
  EXPECT_THROW(spikems_architecture(true, Discretisation::IIR, {8}, {0}), Error);
  // One per layer (2 x levels), in layer order: encoder, then the decoder to the output.
  const ModelSpec p =
      spikems_architecture(true, Discretisation::FIR, {8, 16, 32}, {8, 2, 3, 4, 5, 6});
  for (size_t k = 0; k < 6; ++k) {
    const double t = k == 0 ? 8 : double(k + 1);
    EXPECT_EQ(p.layers[k].neuron.tau_s, t) << k;
    const auto& e = p.layers[k].srm_kernel;
    EXPECT_EQ(double(std::max_element(e.begin(), e.end()) - e.begin()), t) << k;
  }
  EXPECT_THROW(spikems_architecture(true, Discretisation::IIR, {8, 16}, {1, 1, 1}), Error);
}

static ModelSpec small_model() {
  ModelSpec s = spikems_architecture(true, Discretisation::FIR);
  s.input_width = 64;
  s.input_height = 48;
  for (auto& l : s.layers)
    for (size_t i = 0; i < l.weight.size(); ++i) l.weight[i] = float(std::sin(double(i) * 0.37));
  s.layers[2].delay.assign(64, 0.5f);
  s.layers[4].neuron.discretisation = Discretisation::IIR;
  fill_fir_kernels(s);
  return s;
}

TEST(ModelFile, RoundTripKeepsEverything) {
  auto dir = test::scratch_dir();
  ModelSpec s = small_model();
  s.training = {{"epochs", 3}};
  save_model(dir + "/m.safetensors", s);
  ModelSpec r = load_model(dir + "/m.safetensors");
  ASSERT_EQ(r.layers.size(), 6u);
  EXPECT_EQ(r.input_width, 64);
  EXPECT_EQ(r.training["epochs"], 3);
  for (size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(r.layers[k].weight, s.layers[k].weight);
    EXPECT_EQ(r.layers[k].srm_kernel, s.layers[k].srm_kernel);
    EXPECT_EQ(r.layers[k].ref_kernel, s.layers[k].ref_kernel);
    EXPECT_EQ(r.layers[k].kind, s.layers[k].kind);
    EXPECT_EQ(r.layers[k].neuron.discretisation, s.layers[k].neuron.discretisation);
    EXPECT_FLOAT_EQ(r.layers[k].neuron.theta, s.layers[k].neuron.theta);
  }
  EXPECT_TRUE(r.layers[4].srm_kernel.empty());  // IIR layers store no sampled kernels
  EXPECT_EQ(r.layers[2].delay.size(), 64u);
}

static void expect_load_error(const std::string& path, const std::string& needle) {
  try {
    load_model(path);
    FAIL() << "expected an error containing '" << needle << "'";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(ModelFile, RejectsTruncatedAndCorruptFiles) {
  auto dir = test::scratch_dir();
  save_model(dir + "/m.safetensors", small_model());
  auto bytes = read_file_bytes(dir + "/m.safetensors");
  for (size_t cut : {size_t(0), size_t(5), size_t(12), bytes.size() / 2, bytes.size() - 1}) {
    std::ofstream(dir + "/t.safetensors", std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), long(cut));
    EXPECT_THROW(load_model(dir + "/t.safetensors"), Error) << "cut at " << cut;
  }
  auto bad = bytes;
  bad[9] = '!';  // break the JSON header
  std::ofstream(dir + "/j.safetensors", std::ios::binary)
      .write(reinterpret_cast<const char*>(bad.data()), long(bad.size()));
  expect_load_error(dir + "/j.safetensors", "JSON");
}

TEST(ModelFile, RejectsForeignVersionAndShapeMismatch) {
  auto dir = test::scratch_dir();
  ModelSpec s = small_model();
  SafeTensors st;
  st.metadata = {{"format", "spikems-model"}, {"version", "99"}, {"spec", spec_to_json(s).dump()}};
  write_safetensors(dir + "/v.safetensors", st);
  expect_load_error(dir + "/v.safetensors", "version 99");

  st.metadata = {{"format", "something-else"}};
  write_safetensors(dir + "/f.safetensors", st);
  expect_load_error(dir + "/f.safetensors", "not a spikems model");

  save_model(dir + "/ok.safetensors", s);
  SafeTensors good = read_safetensors(dir + "/ok.safetensors");
  good.tensors["layers.1.weight"].shape = {16, 32, 3, 3};  // transposed by mistake
  write_safetensors(dir + "/s.safetensors", good);
  expect_load_error(dir + "/s.safetensors", "layers.1.weight");
}

// Number fields hold numbers of their type (nlohmann would read 0.5 or true as an int), the
// spec is there, and the time step is one the runtime can run (whole microseconds).
TEST(ModelFile, RefusesMistypedFieldsAMissingSpecAndRoundedSteps) {
  auto dir = test::scratch_dir();
  save_model(dir + "/ok.safetensors", small_model());
  const SafeTensors good = read_safetensors(dir + "/ok.safetensors");
  const nlohmann::json spec = nlohmann::json::parse(good.metadata.at("spec"));
  auto with = [&](const std::string& pointer, const nlohmann::json& v) {
    SafeTensors st = good;
    nlohmann::json j = spec;
    j[nlohmann::json::json_pointer(pointer)] = v;
    st.metadata["spec"] = j.dump();
    write_safetensors(dir + "/m.safetensors", st);
    return dir + "/m.safetensors";
  };
  expect_load_error(with("/layers/1/stride", 0.5), "'stride' must be an integer, not 0.5");
  expect_load_error(with("/layers/0/kernel", true), "'kernel' must be an integer");
  expect_load_error(with("/input_width", 64.5), "'input_width' must be an integer");
  expect_load_error(with("/layers/2/neuron/theta", true), "'theta' must be a number, not true");
  expect_load_error(with("/layers/3/neuron", 7), "not a JSON object");
  expect_load_error(with("/time_step_ms", 0.0005), "whole number of microseconds");
  expect_load_error(with("/time_step_ms", 1.0005), "whole number of microseconds");
  EXPECT_EQ(load_model(with("/time_step_ms", 0.25)).time_step_ms, 0.25);  // 250 us: fine
  SafeTensors st = good;
  st.metadata.erase("spec");
  write_safetensors(dir + "/n.safetensors", st);
  expect_load_error(dir + "/n.safetensors", "'spec' (the network's layers) is missing");
}

TEST(ModelFile, ValidateRejectsBrokenChainAndNaN) {
  ModelSpec s = small_model();
  s.layers[2].in_channels = 31;
  EXPECT_THROW(s.validate("x"), Error);
  s = small_model();
  s.layers[0].weight[3] = std::nanf("");
  EXPECT_THROW(s.validate("x"), Error);
  s = small_model();
  s.layers[1].neuron.theta = -1;
  EXPECT_THROW(s.validate("x"), Error);
}

// The error of f() contains every needle.
template <class F>
static void expect_error(F&& f, std::initializer_list<const char*> needles) {
  try {
    f();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    for (const char* n : needles)
      EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
  }
}

// The U-Net variant: decoder layer 4 takes layer 1's spikes too, layer 5 layer 0's; skip_from
// goes through the file (written only where set) and validate() checks it.
TEST(ModelFile, SkipFromRoundTripsAndIsValidated) {
  ModelSpec s = spikems_architecture(true, Discretisation::FIR, {4, 6, 8}, {}, true);
  const int skip[] = {-1, -1, -1, -1, 1, 0}, ci[] = {2, 4, 6, 8, 6 + 6, 4 + 4};
  ASSERT_EQ(s.layers.size(), 6u);
  for (size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(s.layers[k].skip_from, skip[k]) << k;
    EXPECT_EQ(s.layers[k].in_channels, ci[k]) << k;
  }
  EXPECT_TRUE(s.has_skips());
  EXPECT_FALSE(spikems_architecture(true, Discretisation::FIR, {4, 6, 8}).has_skips());
  EXPECT_THROW(spikems_architecture(false, Discretisation::FIR, {4, 6, 8}, {}, true), Error);
  // skip_levels: level 1 alone (the finest) feeds layer 5; level 2's skip is left out.
  const ModelSpec f = spikems_architecture(true, Discretisation::FIR, {4, 6, 8}, {}, true, {1});
  EXPECT_EQ(f.layers[4].skip_from, -1);
  EXPECT_EQ(f.layers[4].in_channels, 6);
  EXPECT_EQ(f.layers[5].skip_from, 0);
  EXPECT_EQ(f.layers[5].in_channels, 4 + 4);
  EXPECT_NO_THROW(f.validate("f"));
  expect_error(
      [] {
        spikems_architecture(true, Discretisation::FIR, {4, 6, 8}, {}, true, {3});
      },
      {"skip_levels", "1..2", "got 3"});
  for (auto& l : s.layers)
    for (size_t i = 0; i < l.weight.size(); ++i) l.weight[i] = float(std::cos(double(i) * 0.1));
  const auto j = spec_to_json(s);
  EXPECT_FALSE(j["layers"][0].contains("skip_from"));
  EXPECT_EQ(j["layers"][4]["skip_from"], 1);
  const auto dir = test::scratch_dir();
  save_model(dir + "/skip.safetensors", s);
  const ModelSpec r = load_model(dir + "/skip.safetensors");
  ASSERT_EQ(r.layers.size(), 6u);
  for (size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(r.layers[k].skip_from, skip[k]) << k;
    EXPECT_EQ(r.layers[k].in_channels, ci[k]) << k;
    EXPECT_EQ(r.layers[k].weight, s.layers[k].weight) << k;
  }
  EXPECT_NO_THROW(r.validate("r"));

  ModelSpec b = s;  // the predecessor is no skip
  b.layers[4].skip_from = 3;
  expect_error([&] { b.validate("m"); }, {"layer 4", "skip_from", "0..2", "got 3"});
  b = s;
  b.layers[5].skip_from = 7;  // out of range: later layers are refused as well
  expect_error([&] { b.validate("m"); }, {"layer 5", "got 7"});
  b.layers[5].skip_from = 5;
  expect_error([&] { b.validate("m"); }, {"layer 5", "got 5"});
  b.layers[5].skip_from = -2;
  expect_error([&] { b.validate("m"); }, {"layer 5", "got -2"});
  b = s;
  b.layers[1].skip_from = 0;  // layer 0 is layer 1's predecessor
  expect_error([&] { b.validate("m"); }, {"layer 1", "got 0"});
  b = s;  // in_channels without the skip's
  b.layers[4].in_channels = 6;
  b.layers[4].weight.resize(size_t(b.layers[4].weight_count()));
  expect_error([&] { b.validate("m"); },
               {"layer 4", "takes 6 channels", "layer 3 gives 6", "skip from layer 1 6"});
  b = s;  // a skip the chain does not expect
  b.layers[4].skip_from = -1;
  expect_error([&] { b.validate("m"); }, {"layer 4", "takes 12 channels"});

  // The ANN-2D with skips: the same layers and skips as the spiking network, 4 input channels
  // and one output; it round-trips like any model, and its chain is checked the same way.
  ModelSpec a = ann2d_architecture({4, 6, 8}, true);
  for (size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(a.layers[k].skip_from, skip[k]) << k;
    EXPECT_EQ(a.layers[k].in_channels, k == 0 ? 4 : ci[k]) << k;
  }
  EXPECT_EQ(a.layers[5].out_channels, 1);
  a.layers[4].weight[3] = 0.25f;
  a.layers[5].bias[0] = -1.f;
  save_model(dir + "/ann-skip.safetensors", a);
  const ModelSpec ra = load_model(dir + "/ann-skip.safetensors");
  EXPECT_EQ(ra.type, ModelType::ANN2D);
  EXPECT_EQ(ra.layers[4].skip_from, 1);
  EXPECT_EQ(ra.layers[4].weight, a.layers[4].weight);
  EXPECT_EQ(ra.layers[5].bias, a.layers[5].bias);
  a.layers[4].in_channels -= a.layers[1].out_channels;
  a.layers[4].weight.resize(size_t(a.layers[4].weight_count()));
  expect_error([&] { a.validate("ann"); }, {"layer 4", "skip from layer 1"});
}

// Sizes for the 3-level padded network with skips: a conv (3x3, stride 2, padding 1) gives
// ceil(n/2), a transposed conv 2n, and a skip needs its source's size to equal the decoder
// layer's input. For n = 260: 130 -> 65 -> 33, then 66 != 65 (layer 1) at layer 4; 261, 262
// give 131 -> 66 -> 33 -> 66 -> 132 != 131 (layer 0) at layer 5; 263 gives 132 -> 66 -> 33 ->
// 66 -> 132 -> 264: fits, its output one row larger. For n = 346: 173 -> 87 -> 44 -> 88 != 87;
// 347, 348 give 87 as well; 349, 350 give 175 -> 88 -> 44 -> 88 -> 176 != 175; 351 gives 176
// -> 88 -> 44 -> 88 -> 176 -> 352. Sizes that are multiples of 8 fit as they are.
TEST(Architecture, SkipsFitTheirInputSize) {
  const ModelSpec s = spikems_architecture(true, Discretisation::IIR, {16, 32, 64}, {}, true);
  EXPECT_EQ(s.fitted_input_size(260, 346), std::make_pair(263, 351));
  EXPECT_EQ(s.output_size(263, 351), std::make_pair(264, 352));
  EXPECT_EQ(s.fitted_input_size(256, 344), std::make_pair(256, 344));
  EXPECT_EQ(s.fitted_input_size(13, 21), std::make_pair(15, 23));
  EXPECT_EQ(s.fitted_input_size(1, 8), std::make_pair(7, 8));  // 7 -> 4 -> 2 -> 1 -> 2 -> 4 -> 8
  EXPECT_NO_THROW(s.check_input_size(263, 351, "m"));
  EXPECT_NO_THROW(s.check_input_size(256, 344, "m"));
  expect_error(
      [&] { s.check_input_size(260, 346, "m.safetensors"); },
      {"m.safetensors", "layer 4", "skip connection from layer 1 is 87x65", "its input is 88x66"});
  expect_error([&] { s.check_input_size(262, 351, "m"); },
               {"layer 5", "skip connection from layer 0 is 176x131", "its input is 176x132"});
  // Without skips any size passes that reaches every layer; the fitted size is the input's.
  const ModelSpec p = spikems_architecture(true, Discretisation::IIR);
  EXPECT_NO_THROW(p.check_input_size(260, 346, "m"));
  EXPECT_EQ(p.fitted_input_size(260, 346), std::make_pair(260, 346));
  // The sensor size a model was made for is the size before the padding.
  ModelSpec m = s;
  m.input_width = 346;
  m.input_height = 260;
  EXPECT_NO_THROW(m.validate("m"));
}

namespace spikems {
namespace {

TEST(WithIirNeurons, SwitchesSampledFirLayersAndRefusesOtherKernels) {
  ModelSpec m = spikems_architecture(true, Discretisation::FIR);
  ModelSpec i = with_iir_neurons(m, "m");
  ASSERT_EQ(i.layers.size(), m.layers.size());
  for (size_t k = 0; k < i.layers.size(); ++k) {
    EXPECT_EQ(i.layers[k].neuron.discretisation, Discretisation::IIR);
    EXPECT_TRUE(i.layers[k].srm_kernel.empty());
    EXPECT_TRUE(i.layers[k].ref_kernel.empty());
    EXPECT_EQ(i.layers[k].neuron.tau_s, m.layers[k].neuron.tau_s);
    EXPECT_EQ(i.layers[k].weight, m.layers[k].weight);
  }
  i.validate("i");
  m.layers[2].srm_kernel[3] *= 1.01f;  // a hand-made kernel has no IIR form
  try {
    with_iir_neurons(m, "model.safetensors");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("layer 2"), std::string::npos) << e.what();
  }
}

// The output gate (ModelSpec::output_gate_steps): written only when set, read back, absent = 0,
// and refused out of range, with the wrong type, or on an ANN-2D model.
TEST(ModelFile, OutputGateRoundTripsAndIsValidated) {
  ModelSpec s = spikems_architecture(true, Discretisation::IIR, {4, 6, 8}, {}, true);
  EXPECT_EQ(s.output_gate_steps, 0);
  EXPECT_FALSE(spec_to_json(s).contains("output_gate_steps"));  // files without a gate unchanged
  s.output_gate_steps = 7;
  EXPECT_EQ(spec_to_json(s)["output_gate_steps"], 7);
  const auto dir = test::scratch_dir();
  save_model(dir + "/gate.safetensors", s);
  EXPECT_EQ(load_model(dir + "/gate.safetensors").output_gate_steps, 7);
  ModelSpec b = s;
  b.output_gate_steps = -1;
  expect_error([&] { b.validate("m"); }, {"output_gate_steps", "0 (off)", "got -1"});
  b.output_gate_steps = kMaxOutputGateSteps + 1;
  expect_error([&] { b.validate("m"); }, {"output_gate_steps", "got 100001"});
  b.output_gate_steps = kMaxOutputGateSteps;
  EXPECT_NO_THROW(b.validate("m"));
  nlohmann::json j = spec_to_json(s);
  j["output_gate_steps"] = "seven";
  EXPECT_THROW(spec_from_json(j, "m"), Error);
  ModelSpec a = ann2d_architecture({4, 6, 8});
  a.output_gate_steps = 3;
  expect_error([&] { a.validate("ann"); }, {"output gate", "spiking models"});
}

// model.srm_onset: written only when "same_step" (older files rewrite unchanged), read back,
// and refused where the runtime cannot run it (mixed onsets, FIR layers).
TEST(ModelFile, SrmOnsetRoundTripsAndIsValidated) {
  ModelSpec s = spikems_architecture(true, Discretisation::IIR, {4, 6, 8}, {}, true);
  EXPECT_FALSE(spec_to_json(s)["layers"][0]["neuron"].contains("srm_onset"));
  for (auto& l : s.layers) l.neuron.srm_onset = SrmOnset::SameStep;
  EXPECT_EQ(spec_to_json(s)["layers"][3]["neuron"]["srm_onset"], "same_step");
  const auto dir = test::scratch_dir();
  save_model(dir + "/same.safetensors", s);
  const ModelSpec r = load_model(dir + "/same.safetensors");
  for (const auto& l : r.layers) EXPECT_EQ(l.neuron.srm_onset, SrmOnset::SameStep);
  ModelSpec mixed = s;
  mixed.layers[2].neuron.srm_onset = SrmOnset::NextStep;
  expect_error([&] { mixed.validate("m"); }, {"layer 2", "mixes srm_onset"});
  ModelSpec fir = spikems_architecture(true, Discretisation::FIR, {4, 6, 8});
  for (auto& l : fir.layers) l.neuron.srm_onset = SrmOnset::SameStep;
  expect_error([&] { fir.validate("m"); }, {"layer 0", "needs IIR neurons"});
  nlohmann::json j = spec_to_json(s);
  j["layers"][1]["neuron"]["srm_onset"] = "soon";
  EXPECT_THROW(spec_from_json(j, "m"), Error);
}

}  // namespace
}  // namespace spikems
