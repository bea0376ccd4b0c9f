// What a model file holds, for people (`spikems info model.safetensors`): kind, size, time step,
// layers, output threshold and gate, calibration and training provenance, from its spec alone.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/model/model_file.h"

namespace spikems {

// The summary as JSON: name, type, time_step_ms, input size, layers (kind, channels, stride,
// skip_from, θ, τ_s), weights, latency_steps (every layer) and shortest_path_steps (through
// the skips), output_theta, output_gate_ms, and from the
// training metadata (when present) the calibration (factor, output_threshold_scale, criterion,
// data, score) and the training (steps, wall_seconds, hardware device).
nlohmann::json model_summary(const ModelSpec& model);

// The same as aligned text lines, the first naming `path`.
std::string model_summary_text(const std::string& path, const ModelSpec& model);

}  // namespace spikems
