// `spikems import-slayer WEIGHTS.npz --out MODEL`: converts the SpikeMS authors' SLAYER
// checkpoint (exported to npz: conv/deconv weights, srm/ref kernels, neuron_params,
// layer_stride/padding/is_transposed) into a spikems model file. The sampled kernels are copied
// verbatim (FIR layers, SpikeMS refractory and surrogate), so the model reproduces the authors'
// forward pass. Needs no LibTorch.
#include <cmath>
#include <cstdio>

#include "cli/command.h"
#include "core/events/formats/npy.h"
#include "core/model/model_file.h"
#include "core/util/error.h"

namespace {

using spikems::fail;

const spikems::NpyArray& need(const std::map<std::string, spikems::NpyArray>& z,
                              const std::string& key, const std::string& src) {
  auto it = z.find(key);
  if (it == z.end())
    fail(src, "", "array '" + key + "' is missing: this is not a SpikeMS/SLAYER weight export");
  return it->second;
}

spikems::ModelSpec import_slayer(const std::string& src) {
  auto z = spikems::read_npz(src);
  const auto& np = need(z, "neuron_params", src);
  if (np.shape.size() != 2 || np.shape[1] < 7)
    fail(src, "neuron_params",
         "expected shape (layers, 8) [theta,tauSr,tauRef,scaleRef,tauRho,scaleRho,Ts,tSample]");
  const int L = int(np.shape[0]);
  if (L <= 0 || L > 64) fail(src, "neuron_params", "layer count out of range");
  auto params = np.to<double>();
  auto ints = [&](const char* key) {
    const auto& a = need(z, key, src);
    if (a.numel() != L) fail(src, key, "expected " + std::to_string(L) + " values");
    return a.to<int64_t>();
  };
  auto stride = ints("layer_stride"), padding = ints("layer_padding"),
       transposed = ints("layer_is_transposed");
  const int cols = int(np.shape[1]);
  spikems::ModelSpec spec;
  spec.name = "spikems-slayer-import";
  spec.time_step_ms = params[6];
  spec.training = {{"imported_from", src}, {"source", "SLAYER/SpikeMS checkpoint export"}};
  if (cols > 7) spec.training["tSample"] = params[7];
  for (int k = 0; k < L; ++k) {
    const double* p = &params[size_t(k * cols)];
    std::string where = "layer " + std::to_string(k + 1);
    if (std::fabs(p[6] - spec.time_step_ms) > 1e-9)
      fail(src, where, "layers use different time steps Ts; spikems needs one Ts per model");
    spikems::LayerSpec l;
    l.kind = transposed[k] ? spikems::LayerKind::ConvTranspose : spikems::LayerKind::Conv;
    std::string n = std::to_string(k + 1), key;
    for (std::string c :
         {"conv" + n + ".weight", "deconv" + n + ".0.weight", "deconv" + n + ".weight"})
      if (z.count(c)) {
        key = c;
        break;
      }
    if (key.empty())
      fail(src, where, "no weight array conv" + n + ".weight or deconv" + n + ".0.weight");
    const auto& w = z.at(key);
    // (C_a, C_b, kH, kW[, 1]): drop the trailing singleton time dimension of the 3-D conv.
    if (!(w.shape.size() == 4 || (w.shape.size() == 5 && w.shape[4] == 1)) ||
        w.shape[2] != w.shape[3])
      fail(src, key, "expected a square (C, C, k, k, 1) kernel");
    l.kernel = int(w.shape[2]);
    l.in_channels = int(l.kind == spikems::LayerKind::Conv ? w.shape[1] : w.shape[0]);
    l.out_channels = int(l.kind == spikems::LayerKind::Conv ? w.shape[0] : w.shape[1]);
    l.stride = int(stride[k]);
    l.padding = int(padding[k]);
    l.output_padding = 0;
    l.weight = w.to<float>();
    auto& nu = l.neuron;
    nu.theta = float(p[0]);
    nu.tau_s = float(p[1]);
    nu.tau_r = float(p[2]);
    nu.scale_ref = float(p[3]);
    nu.tau_rho = float(p[4]);
    nu.scale_rho = float(p[5]);
    nu.refractory = spikems::RefractoryShape::SpikeMS;
    nu.discretisation = spikems::Discretisation::FIR;
    nu.surrogate = spikems::SurrogateForm::SpikeMS;
    l.srm_kernel = need(z, "slayer_conv" + n + ".srmKernel", src).to<float>();
    l.ref_kernel = need(z, "slayer_conv" + n + ".refKernel", src).to<float>();
    spec.layers.push_back(std::move(l));
  }
  spec.validate(src);
  return spec;
}

struct Args {
  std::string in, out;
};

void add(CLI::App& app) {
  static Args a;
  auto* cmd = app.add_subcommand(
      "import-slayer",
      "Convert a SpikeMS/SLAYER weight export (npz) into a spikems model file.\n"
      "The npz holds the checkpoint state_dict (conv<k>.weight, deconv<k>.0.weight, "
      "slayer_conv<k>.srmKernel/.refKernel) plus neuron_params (layers x 8: theta, tauSr, tauRef, "
      "scaleRef, tauRho, scaleRho, Ts, tSample), layer_stride, layer_padding, "
      "layer_is_transposed.\n"
      "Kernels are copied verbatim (FIR), the refractory and surrogate are the SpikeMS forms.");
  cmd->add_option("weights", a.in, "weights .npz")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out,-o", a.out, "output model file (.safetensors)")->required();
  cmd->footer(
      "Examples:\n"
      "  spikems import-slayer weights.npz --out authors.safetensors\n"
      "  spikems segment --model authors.safetensors --input recording.aedat4 --out labels.txt");
  cmd->callback([] {
    spikems::ModelSpec spec = import_slayer(a.in);
    spikems::save_model(a.out, spec);
    std::printf("%s: %zu layers, Ts %g ms, written to %s\n", a.in.c_str(), spec.layers.size(),
                spec.time_step_ms, a.out.c_str());
    for (size_t k = 0; k < spec.layers.size(); ++k) {
      const auto& l = spec.layers[k];
      std::printf(
          "  layer %zu: %-14s %3d -> %-3d k%d s%d p%d  theta %.3g tau_s %g tau_r %g  "
          "eps %zu taps, nu %zu taps\n",
          k + 1, l.kind == spikems::LayerKind::Conv ? "conv" : "conv_transpose", l.in_channels,
          l.out_channels, l.kernel, l.stride, l.padding, l.neuron.theta, l.neuron.tau_s,
          l.neuron.tau_r, l.srm_kernel.size(), l.ref_kernel.size());
    }
  });
}

}  // namespace

SPIKEMS_COMMAND(import_slayer, 60, add);
