// One spiking layer (block): psp (eps * s) -> synapse (conv / transposed conv over all T*B
// frames) -> spike (threshold + refractory) -> optional axonal delay. Built from a LayerSpec;
// the weight (and delay) are the trainable parameters, the kernels are fixed.
#pragma once

#include <torch/torch.h>

#include "core/model/model_file.h"
#include "train/neuron/spike.h"
#include "train/neuron/temporal_kernel.h"
#include "train/synapse/conv.h"
#include "train/synapse/sparse_conv.h"

namespace spikems::train {

class SpikingLayerImpl : public torch::nn::Module {
 public:
  SpikingLayerImpl(const LayerSpec& spec, double ts,
                   SpikeGradient gradient = SpikeGradient::Slayer);

  // x: [T, B, C_in, H, W] spikes -> [T, B, C_out, H', W'] spikes. `u`, when given, receives
  // the synaptic potential the spikes came from (the potential readout's value; with the
  // refractory off, scale_ref = 0, it is the membrane and the spikes are u >= theta).
  torch::Tensor forward(const torch::Tensor& x, torch::Tensor* u = nullptr);
  // The synaptic potential u = W (*) (eps * x), before spike generation (for diagnostics).
  torch::Tensor potential(const torch::Tensor& x);
  // Truncated warm-up: the layer's spikes over steps [w0, T) only, given its whole input x
  // ([T, ...]; the first w0 steps are constants from a pass without gradients) and its own
  // spikes over [0, w0) from that pass (`warm_out`). The values equal forward(x)'s last T - w0
  // steps (the warm-up's refractory enters as a constant offset, the synapse runs on the
  // window's frames only); no gradient flows into the warm-up. Refuses layers with delays.
  // `u` as forward's, over the window's steps (the warm-up's refractory responses included).
  torch::Tensor forward_window(const torch::Tensor& x, int64_t w0, const torch::Tensor& warm_out,
                               torch::Tensor* u = nullptr);

  // The layer spec with the current weight and delay values.
  LayerSpec to_spec() const;
  void set_gradient(SpikeGradient g) { spike_.gradient = g; }
  // Dense (default): psp then LibTorch conv; Sparse / Auto: train/synapse/sparse_conv.h.
  void set_kernels(KernelPath k) { kernels_ = k; }
  void enable_delay(bool on);  // adds a zero-initialised learnable delay if absent

  torch::Tensor weight, delay;  // delay undefined when the layer has none

 private:
  LayerSpec spec_;  // geometry and neuron parameters (weights kept in `weight`)
  double ts_;
  TemporalKernel eps_;
  SpikeParams spike_;
  SynapseGeometry geom_;
  KernelPath kernels_ = KernelPath::Dense;
};
TORCH_MODULE(SpikingLayer);

}  // namespace spikems::train
