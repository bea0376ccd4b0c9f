// The SpikeMS authors' EV-IMO model and reference outputs from ../shared (README.md there),
// read with the npz reader, for the runtime tests.
#pragma once

#include <map>
#include <string>

#include "core/events/formats/npy.h"
#include "core/model/model_file.h"
#include "core/runtime/dense_tensor.h"

namespace spikems::test {

// weights.npz -> ModelSpec (padding 0, FIR, the stored sampled kernels).
inline ModelSpec authors_model(const std::string& weights_npz) {
  auto z = read_npz(weights_npz);
  const char* names[] = {"conv1", "conv2", "conv3", "deconv4.0", "deconv5.0", "deconv6.0"};
  auto np = z.at("neuron_params").to<float>();  // (6,8) theta,tauSr,tauRef,scaleRef,...,Ts
  auto transposed = z.at("layer_is_transposed").to<int>();
  ModelSpec m;
  m.name = "spikems-evimo";
  m.time_step_ms = np[6];
  for (int k = 0; k < 6; ++k) {
    const auto& w = z.at(std::string(names[k]) + ".weight");
    LayerSpec l;
    l.kind = transposed[k] ? LayerKind::ConvTranspose : LayerKind::Conv;
    l.in_channels = int(transposed[k] ? w.shape[0] : w.shape[1]);
    l.out_channels = int(transposed[k] ? w.shape[1] : w.shape[0]);
    l.kernel = int(w.shape[2]);
    l.stride = 2;
    l.weight = w.to<float>();  // trailing time dimension of size 1 changes nothing
    const float* p = &np[size_t(k) * 8];
    l.neuron.theta = p[0];
    l.neuron.tau_s = p[1];
    l.neuron.tau_r = p[2];
    l.neuron.scale_ref = p[3];
    l.neuron.tau_rho = p[4];
    l.neuron.scale_rho = p[5];
    std::string s = "slayer_conv" + std::to_string(k + 1);
    l.srm_kernel = z.at(s + ".srmKernel").to<float>();
    l.ref_kernel = z.at(s + ".refKernel").to<float>();
    m.layers.push_back(std::move(l));
  }
  m.validate(weights_npz);
  return m;
}

// (1, C, H, W, T) reference array -> [T, C, H, W].
inline DenseTensor from_reference(const NpyArray& a) {
  auto v = a.to<float>();
  const int C = int(a.shape[1]), H = int(a.shape[2]), W = int(a.shape[3]), T = int(a.shape[4]);
  DenseTensor d(T, C, H, W);
  for (int c = 0; c < C; ++c)
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        for (int t = 0; t < T; ++t) d.at(t, c, y, x) = v[(((size_t(c) * H + y) * W + x) * T) + t];
  return d;
}

}  // namespace spikems::test
