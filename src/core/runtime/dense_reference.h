// The plain dense forward of a ModelSpec: the reference every optimised path (event-driven
// runtime, LibTorch, CUDA) is checked against. It follows the SLAYER/SpikeMS semantics of
// /work/shared/reference/spikems-evimo/README.md literally, loop by loop, favouring obvious
// correctness over speed:
//   a = psp(eps, s_in)                 a[t] = sum_{i<=t} eps[i] s_in[t-i]   (eps[0] = 0)
//   u = conv or conv_transpose(W, a)   per time step, no bias
//   s[t] = (u[t] >= theta); a spike adds nu[j] to u[t+j] of the same neuron
// Spikes are binary (SLAYER's 1/Ts amplitude times the Ts factor of its psp cancel).
// FIR layers use the stored sampled kernels, cut where they end. IIR layers use the exact
// continuous kernels without truncation (evaluated in double precision), which is what the
// runtime's recursions compute.
#pragma once

#include <vector>

#include "core/model/model_file.h"
#include "core/runtime/dense_tensor.h"

namespace spikems {

struct DenseLayerOutput {
  DenseTensor spikes;     // [T, C_out, H_out, W_out], 0/1
  DenseTensor potential;  // u[t] compared with theta (after earlier spikes' refractory terms)
};

// One block (psp -> synaptic op -> spike) on input spikes [T, C_in, H, W].
DenseLayerOutput dense_layer_forward(const LayerSpec& layer, double time_step_ms,
                                     const DenseTensor& input);

// Every block in order; result k is the output of layer k (the last one's spikes through the
// model's output gate, ModelSpec::output_gate_steps, when it has one). A model with skips runs on
// its fitted input size (dense_network_input) and each layer with skip_from = j takes its
// predecessor's spikes and layer j's concatenated on the channels (dense_layer_input), as the
// LibTorch network and the streaming runtime do; its outputs are in that padded geometry.
std::vector<DenseLayerOutput> dense_forward(const ModelSpec& model, const DenseTensor& input);

// Zeroes the spikes [T, C, H, W] of each step t at the pixels without an event of `input`
// [T, C_in, H_in, W_in] in steps t-steps+1 .. t (top-left aligned; pixels beyond the input have
// none): the output gate of ModelSpec::output_gate_steps.
void dense_output_gate(int steps, const DenseTensor& input, DenseTensor& spikes);

// The input the network runs on: for a model with skips, `input` zero-padded at the bottom and
// right to model.fitted_input_size (throws Error when no size fits); `input` otherwise.
DenseTensor dense_network_input(const ModelSpec& model, const DenseTensor& input);
// Layer k's input: `net_input` (dense_network_input's) for k = 0, else the spikes of layer k-1
// in `outs`, followed on the channels by those of its skip source when it has one.
DenseTensor dense_layer_input(const ModelSpec& model, size_t k, const DenseTensor& net_input,
                              const std::vector<DenseLayerOutput>& outs);
// [T, Ca, H, W] and [T, Cb, H, W] -> [T, Ca + Cb, H, W]: a's channels, then b's.
DenseTensor dense_concat_channels(const DenseTensor& a, const DenseTensor& b);

// The continuous kernels sampled at n steps, untruncated (IIR layers): eps(n Ts) (SameStep
// onset: eps((n + 1) Ts)) and nu[n].
double srm_kernel_value(const NeuronParams& n, double time_step_ms, int step);
double refractory_kernel_value(const NeuronParams& n, double time_step_ms, int step);

}  // namespace spikems
