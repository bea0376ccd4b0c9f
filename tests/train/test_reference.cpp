// The authors' pretrained EV-IMO network against their golden outputs
// (../shared/reference/spikems-evimo: case_random.npz, weights.npz; README there).
#include <gtest/gtest.h>

#include "train/network/spikems_network.h"
#include "train/threads.h"
#include "train_test_util.h"

namespace spikems::train {
namespace {

using spikems::test::time_major;

// Teacher-forced: block k fed the saved layer k-1. Every mismatch must be explained by a decision
// within 1e-5 of theta: the first mismatch of each neuron lies at a potential that close to
// theta (later ones of the same neuron follow from its changed refractory history).
TEST(Reference, TeacherForcedLayersMatchUpToNearThresholdDecisions) {
  SPIKEMS_REQUIRE_SHARED(weights, "reference/spikems-evimo/weights.npz");
  SPIKEMS_REQUIRE_SHARED(golden, "reference/spikems-evimo/case_random.npz");
  set_torch_threads(2);
  ModelSpec spec = spikems::test::import_reference_model(weights, spikems::test::scratch_dir());
  auto z = read_npz(golden);
  torch::NoGradGuard ng;
  SpikeMSNetwork net(spec);
  torch::Tensor prev = time_major(z.at("input"));
  EXPECT_EQ(prev.sum().item<double>(), 20494);
  int total_mismatch = 0;
  for (size_t k = 0; k < spec.layers.size(); ++k) {
    torch::Tensor ref = time_major(z.at("layer" + std::to_string(k + 1)));
    torch::Tensor u = net->layer(k)->potential(prev);
    ASSERT_EQ(u.sizes(), ref.sizes()) << "layer " << k + 1;
    const int64_t T = u.size(0);
    auto sp = SpikeParams::from_layer(spec.layers[k], spec.time_step_ms, SpikeGradient::Slayer);
    auto [s, ur] = spike_forward(u.reshape({T, -1}), sp, true);
    torch::Tensor r2 = ref.reshape({T, -1});
    torch::Tensor diff = (s != r2);
    int64_t n = diff.sum().item<int64_t>();
    total_mismatch += int(n);
    // First mismatch per neuron must be near threshold.
    torch::Tensor any = diff.any(0);
    torch::Tensor first = diff.to(torch::kInt).argmax(0);
    auto idx = any.nonzero().view(-1);
    for (int64_t i = 0; i < idx.numel(); ++i) {
      int64_t nn = idx[i].item<int64_t>(), t = first[nn].item<int64_t>();
      double v = ur[t][nn].item<double>();
      EXPECT_LT(std::abs(v - double(sp.theta)), 1e-5)
          << "layer " << k + 1 << " neuron " << nn << " t " << t << " u~ " << v;
    }
    std::printf("layer %zu: %lld teacher-forced mismatches of %lld\n", k + 1, (long long)n,
                (long long)s.numel());
    prev = ref;
  }
  EXPECT_LE(total_mismatch, 20);
}

TEST(Reference, EndToEndLayer6WithinAFewTensOfMismatches) {
  SPIKEMS_REQUIRE_SHARED(weights, "reference/spikems-evimo/weights.npz");
  SPIKEMS_REQUIRE_SHARED(golden, "reference/spikems-evimo/case_random.npz");
  set_torch_threads(2);
  ModelSpec spec = spikems::test::import_reference_model(weights, spikems::test::scratch_dir());
  auto z = read_npz(golden);
  auto layers = forward_all_layers(spec, time_major(z.at("input")));
  ASSERT_EQ(layers.size(), 6u);
  const int64_t expect_counts[6] = {305170, 304432, 100952, 117236, 196718, 182704};
  for (size_t k = 0; k < 6; ++k) {
    torch::Tensor ref = time_major(z.at("layer" + std::to_string(k + 1)));
    ASSERT_EQ(layers[k].sizes(), ref.sizes());
    int64_t n = (layers[k] != ref).sum().item<int64_t>();
    int64_t count = layers[k].sum().item<int64_t>();
    std::printf("layer %zu end to end: %lld mismatches, %lld spikes (reference %lld)\n", k + 1,
                (long long)n, (long long)count, (long long)expect_counts[k]);
    if (k < 2) {
      EXPECT_EQ(n, 0) << "layers 1-2 have no near-threshold decisions";
    }
    EXPECT_LE(n, 200) << "layer " << k + 1;
  }
  EXPECT_LE((layers[5] != time_major(z.at("layer6"))).sum().item<int64_t>(), 60);
}

// CLI: import-slayer + forward write the layers in the authors' layout.
TEST(Reference, CliImportAndForward) {
  SPIKEMS_REQUIRE_SHARED(weights, "reference/spikems-evimo/weights.npz");
  SPIKEMS_REQUIRE_SHARED(golden, "reference/spikems-evimo/case_random.npz");
  std::string dir = spikems::test::scratch_dir(), out;
  std::string model = dir + "/m.safetensors", res = dir + "/out.npz";
  std::string bin = spikems::test::spikems_binary();
  ASSERT_EQ(spikems::test::run_command(bin + " import-slayer " + weights + " --out " + model, &out),
            0)
      << out;
  ModelSpec spec = load_model(model);
  ASSERT_EQ(spec.layers.size(), 6u);
  EXPECT_EQ(spec.layers[3].kind, LayerKind::ConvTranspose);
  EXPECT_EQ(spec.layers[2].srm_kernel.size(), 31u);
  EXPECT_EQ(spec.layers[2].ref_kernel.size(), 13u);
  EXPECT_FLOAT_EQ(spec.layers[0].ref_kernel[1], -0.439999998f);
  EXPECT_FLOAT_EQ(spec.layers[0].neuron.scale_rho, 0.2f);
  ASSERT_EQ(spikems::test::run_command(bin + " forward --model " + model + " --input " + golden +
                                           " --output " + res + " --threads 2",
                                       &out),
            0)
      << out;
  auto a = read_npz(res), g = read_npz(golden);
  for (int k = 1; k <= 6; ++k) {
    const auto& y = a.at("layer" + std::to_string(k));
    const auto& r = g.at("layer" + std::to_string(k));
    ASSERT_EQ(y.shape, r.shape);
    EXPECT_EQ(y.descr, "<f4");
    auto yv = y.to<float>(), rv = r.to<float>();
    int64_t n = 0;
    for (size_t i = 0; i < yv.size(); ++i) n += yv[i] != rv[i];
    EXPECT_LE(n, k <= 2 ? 0 : 200) << "layer" << k;
  }
  // Bad input: a missing key fails with a clear message.
  EXPECT_NE(spikems::test::run_command(bin + " forward --model " + model + " --input " + golden +
                                           " --output " + res + " --key nope",
                                       &out),
            0);
  EXPECT_NE(out.find("nope"), std::string::npos) << out;
  EXPECT_NE(spikems::test::run_command(bin + " import-slayer " + golden + " --out " + model, &out),
            0);
}

}  // namespace
}  // namespace spikems::train
