// The spikems model file: one format shared by training (LibTorch) and the streaming runtime.
// A safetensors file (see safetensors.h) whose "__metadata__" holds
//   "format": "spikems-model", "version": "1", "spec": <JSON text of ModelSpec>
// and whose tensors are, for each layer k (0-based):
//   layers.k.weight      F32, conv [C_out, C_in, kH, kW], transposed conv [C_in, C_out, kH, kW]
//   layers.k.srm_kernel  F32 [K]   sampled spike-response kernel (FIR layers only)
//   layers.k.ref_kernel  F32 [R]   sampled refractory kernel (FIR layers only)
//   layers.k.delay       F32 [C_out] axonal delay in time steps (optional)
//   layers.k.bias        F32 [C_out] (ANN-2D models only)
// A model is a spiking network ("type": "snn", the default) or the ANN-2D baseline ("ann2d":
// the same hourglass with ReLU units on event frames, ann_features.h).
// The full description is docs/model-format.md.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/model/safetensors.h"

namespace spikems {

inline constexpr int kModelFormatVersion = 1;
inline constexpr int kMaxOutputGateSteps = 100000;
inline constexpr int kMaxAnnHistory = 16;

enum class LayerKind { Conv, ConvTranspose };
// Refractory kernel shape: the SpikeMS authors' delayed exponential
//   nu[0] = 0, nu[n] = -scale_ref*theta*exp(-(n-1)Ts/tau_r) (n >= 1),
// or SLAYER's alpha form nu(t) = -scale_ref*theta*(t/tau_r)*exp(1 - t/tau_r).
enum class RefractoryShape { SpikeMS, Slayer };
// FIR: the sampled, truncated kernels stored in the file (as SLAYER computes them).
// IIR: the exact recursions of the same continuous kernels (no truncation, O(1) state).
enum class Discretisation { FIR, IIR };
// Surrogate gradient scale: SLAYER divides by tau_rho*theta; the SpikeMS code by theta.
enum class SurrogateForm { Slayer, SpikeMS };
// When an input spike first moves the potential (IIR layers). NextStep: SLAYER's sampled
// kernel eps[n] = (nTs/tau) e^(1-nTs/tau), eps[0] = 0, so every layer answers one step late.
// SameStep: the kernel sampled at the end of the step the spike arrives in, eps[n + 1], so a
// spike reaches the next layer in its own step and coarse steps cost no latency per layer.
enum class SrmOnset { NextStep, SameStep };

struct NeuronParams {
  float theta = 0.22f;
  float tau_s = 2.f;  // ms
  float tau_r = 1.f;  // ms
  float scale_ref = 2.f;
  float tau_rho = 0.3f;
  float scale_rho = 0.2f;
  RefractoryShape refractory = RefractoryShape::SpikeMS;
  Discretisation discretisation = Discretisation::FIR;
  SurrogateForm surrogate = SurrogateForm::SpikeMS;
  SrmOnset srm_onset = SrmOnset::NextStep;
};

struct LayerSpec {
  LayerKind kind = LayerKind::Conv;
  int in_channels = 0, out_channels = 0;
  int kernel = 3, stride = 2, padding = 0, output_padding = 0;
  NeuronParams neuron;
  std::vector<float> weight;      // PyTorch layout (see above)
  std::vector<float> srm_kernel;  // FIR only
  std::vector<float> ref_kernel;  // FIR only
  std::vector<float> delay;       // optional, per output channel, in steps
  std::vector<float> bias;        // ANN-2D only, per output channel
  // A skip connection (U-Net): the index of an earlier layer, not the predecessor, whose spikes
  // of the same step enter this layer too, as channels after the predecessor's (in_channels
  // counts both). Its output must have the predecessor's spatial size. -1: none.
  int skip_from = -1;
  int64_t weight_count() const { return int64_t(in_channels) * out_channels * kernel * kernel; }
  // Spatial output size for an input size (conv: floor((H+2p-k)/s)+1;
  // convT: (H-1)s - 2p + k + output_padding).
  int output_size(int in) const;
};

enum class ModelType { SNN, ANN2D };

struct ModelSpec {
  std::string name = "spikems";
  ModelType type = ModelType::SNN;
  double time_step_ms = 1.0;
  // Sensor size the model was trained for (0 = any). The runtime checks it when set.
  int input_width = 0, input_height = 0;
  // The pixel grid of the data it was trained on (after any downsampling; 0 = not recorded).
  // A network learns objects and edges of a pixel scale: the runtime downsamples a larger
  // sensor by the power of two that brings its grid nearest this one (model_scale.h).
  int train_width = 0, train_height = 0;
  std::vector<LayerSpec> layers;
  // The output gate (docs/model-format.md, "Output gate"), spiking models only: K > 0 keeps an
  // output spike of step s only where its pixel (output pixel (y, x) = input pixel (y, x)) had
  // an input event in steps s-K+1 .. s, the output's own step included. The task labels events,
  // so an output where none fell labels nothing, yet the decoder's stride-2 upsampling spreads
  // the output onto event-less neighbours (they cost a default model 10.6 points of 20 ms IoU;
  // docs/results.md). A shunting synapse from the input: the runtime, the dense reference and the
  // LibTorch network apply it to the last layer's spikes alike. 0: off.
  int output_gate_steps = 0;
  // ANN-2D only: how many past frames the network sees beside the window's own, each of the
  // window's length and just before it (docs/model-format.md, "Frame history"). A frame alone
  // shows edges, not which of them move against the camera's motion; its predecessors do.
  // The input then has ann_input_channels() channels: the window's 4 features first, then each
  // past frame's, newest first. 0: the window's frame only.
  int ann_history = 0;
  nlohmann::json training = nlohmann::json::object();  // free provenance (config, epochs, ...)

  // Output spatial size for an input size (through all layers).
  std::pair<int, int> output_size(int height, int width) const;
  bool has_skips() const;
  // ANN-2D: 4 features (ann_features.h) per frame shown, 4 x (1 + ann_history).
  int ann_input_channels() const { return 4 * (1 + ann_history); }
  // Checks that an input of this size reaches every layer with a positive size and that each
  // skip connection meets its layer's input at the same size; throws Error naming the layer.
  void check_input_size(int height, int width, const std::string& source) const;
  // The smallest size >= (height, width) that check_input_size accepts: a network with skips
  // pads its input there (zeros at the bottom and right; outputs stay top-left aligned).
  std::pair<int, int> fitted_input_size(int height, int width) const;
  // Checks channel chaining, kernel/stride sanity, weight and kernel lengths; throws Error.
  void validate(const std::string& source) const;
};

// Sampled kernels exactly as the SLAYER/SpikeMS code computes them (double precision, then
// float32). Time step and taus in ms.
std::vector<float> sample_srm_kernel(double tau_s, double ts);
std::vector<float> sample_refractory_kernel(const NeuronParams& n, double ts);
// Fills srm_kernel/ref_kernel of every FIR layer from its neuron parameters.
void fill_fir_kernels(ModelSpec& spec);

// The same model with IIR neurons: each FIR layer whose stored kernels are the sampled kernels
// of its neuron parameters (as fill_fir_kernels makes them, within 1e-6) switches to the exact
// recursions of those kernels, i.e. the same neuron without the kernels' truncation (the
// streaming runtime's fast path). Throws Error naming the layer when its kernels differ.
ModelSpec with_iir_neurons(ModelSpec spec, const std::string& source);
// Whether a FIR layer's kernels are the sampled kernels of its neuron parameters (to 1e-6
// relative), i.e. the truncations of the exact IIR recursions.
bool has_sampled_kernels(const LayerSpec& l, double time_step_ms);

// The SpikeMS network of the paper, weights zero-filled.
// padded=false: the authors' geometry (padding 0, output one pixel smaller per 8);
// padded=true: padding 1 and output_padding 1, so a multiple-of-2^levels input keeps its size.
// widths: the encoder's channels, one stride-2 level each (the paper: 16, 32, 64); the decoder
// mirrors them back to 2. Levels past the third take the third's neuron parameters.
// tau_s (ms), when given, one per level: the synaptic time constant of the level's encoder and
// decoder layers (the paper's 2, 2, 4 otherwise); or one per layer (2 x levels, in layer order:
// encoder levels 1.., then the decoder back to the output). Each layer delays its output by about
// its tau_s (the kernel's peak), so a deep stack answers late: see docs/training.md. skips: U-Net
// skip connections, encoder level i's spikes into the decoder layer that works at its resolution
// (every decoder layer but the first); needs padded. They give the gradient of a deep stack a short
// path to the early layers (docs/training.md, "Skip connections"). skip_levels (with skips): only
// these encoder levels, 1-based (1 = the finest) and below the bottleneck's level, feed the
// decoder; empty = every level. Throws Error naming a bad level.
ModelSpec spikems_architecture(bool padded, Discretisation d = Discretisation::FIR,
                               const std::vector<int>& widths = {16, 32, 64},
                               const std::vector<double>& tau_s = {}, bool skips = false,
                               const std::vector<int>& skip_levels = {});
// Throws Error unless widths holds 1-6 levels of 1-1024 channels each.
void check_widths(const std::vector<int>& widths, const std::string& where);
// The ANN-2D baseline (EVDodgeNet-like): the same 3x3 stride-2 layers and channel widths,
// padding 1 (output_padding 1 for the transposed ones), ReLU after each but the last, biases;
// 4 input channels (ann_features.h) per frame and one output channel, the logit of "moving".
// Zero weights. skips / skip_levels: U-Net skip connections exactly as spikems_architecture
// places them, so a teacher with skips has its student's shape layer for layer. history: past
// frames shown beside the window's (ModelSpec::ann_history, 0-16).
ModelSpec ann2d_architecture(const std::vector<int>& widths = {16, 32, 64}, bool skips = false,
                             const std::vector<int>& skip_levels = {}, int history = 0);

ModelSpec load_model(const std::string& path);
// The same from a parsed file (path names it in errors): what load_model does after reading.
ModelSpec model_from_safetensors(const SafeTensors& st, const std::string& path);
void save_model(const std::string& path, const ModelSpec& spec);  // atomic

nlohmann::json spec_to_json(const ModelSpec& spec);  // without weights
ModelSpec spec_from_json(const nlohmann::json& j, const std::string& source);

}  // namespace spikems
