// `spikems energy`: the SNN's synaptic operations per sample, counted by the streaming runtime
// on real data, against the multiply-accumulates of the ANN-2D of the same shapes (the paper's
// energy table). A sample = one window of window_us on the whole sensor.
//
// SynOps: every (input spike, output neuron it reaches) pair a weight was added for, as the
// runtime counts them (StreamingLayer::synops): a spike near a border reaches fewer neurons.
// ANN MACs, one dense pass per sample at the same resolution, k = kernel size:
//   conv            output positions x C_out x C_in x k^2
//   transposed conv input positions  x C_in x C_out x k^2 (each input scatters a k x k
//                   patch per channel pair; the positions cut off at the borders are counted,
//                   as a dense implementation computes them)
// Energy: 0.9 pJ per accumulate (SNN), 4.6 pJ per MAC (ANN) (metrics.h).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/model/model_file.h"
#include "core/runtime/streaming_network.h"

namespace spikems {

struct LayerShape {
  LayerKind kind = LayerKind::Conv;
  int in_channels = 0, out_channels = 0, kernel = 3, stride = 2;
  int in_height = 0, in_width = 0, out_height = 0, out_width = 0;
};

// The shapes of a model's layers on a height x width input, as the runtime builds them (a
// model with skips on its fitted input size; a layer's in_channels count its skip source's).
// Throws Error (naming the model) when the model does not fit the size.
std::vector<LayerShape> layer_shapes(const ModelSpec& model, int height, int width);
// MACs of one dense pass of the ANN layer of that shape (convention above).
uint64_t ann_macs(const LayerShape& s);

struct LayerEnergy {
  LayerShape shape;
  uint64_t neurons = 0;  // output neurons
  uint64_t in_spikes = 0, out_spikes = 0, synops = 0;
  double firing_rate = 0;  // output spikes per neuron per step
  uint64_t ann_macs = 0;   // per sample
  double synops_per_sample = 0;
};

struct EnergyReport {
  std::string command_line, date, model_path, model_name;
  std::vector<std::string> data;
  std::string split;
  double time_step_ms = 1, window_ms = 10, max_seconds = 0;
  int width = 0, height = 0;  // the grid the network sees (the sensor's, or downsampled)
  int downsample = 1;         // model_scale.h: the factor its training grid asks for
  bool iir = false, interrupted = false;
  uint64_t sequences = 0, events = 0, steps = 0;
  double seconds = 0;  // data span run, summed over sequences
  double samples = 0;  // seconds / window
  std::vector<LayerEnergy> layers;
  // Per sample.
  double synops() const;
  double ann_macs() const;
  double snn_pj() const;
  double ann_pj() const;
  double benefit() const;  // ann_pj / snn_pj (0 when the SNN did nothing)
};

// Adds the counts of a network that has run (one sequence) to r, with the ANN MACs of its shapes.
void fill_layers(EnergyReport& r, const StreamingNetwork& net, const ModelSpec& model);
// Once every sequence is in (r.seconds, r.steps, r.window_ms set): samples, rates, per sample.
void finish_report(EnergyReport& r);

struct EnergyOptions {
  std::string model_path;
  std::vector<std::string> data;
  std::string split = "test";
  int64_t window_us = 10000;
  double max_seconds = 0;
  int threads = 1;
  bool iir = false, progress = false;
  std::string command_line;
};

// Runs every sequence once through the streaming network (whole sensor, as `spikems eval`) and
// counts. Throws Error naming the file: bad model, missing data, empty split, sequences of
// different sensor sizes, a window that is not positive.
EnergyReport measure_energy(const EnergyOptions& opt);

nlohmann::ordered_json energy_json(const EnergyReport& r);
// The paper's layout (SynOps per sample x10^8, SNN and ANN energy, benefit), then per layer.
std::string energy_table(const EnergyReport& r);
std::string energy_markdown(const EnergyReport& r);
// DIR/results.json and results.md, each written atomically.
void write_energy(const EnergyReport& r, const std::string& dir);

}  // namespace spikems
