// The pixel scale a model was trained at (ModelSpec::train_width/height) and the downsampling
// factor that brings a sensor to it. A network learns edges and objects of a size in pixels: a
// model trained on 173x130 grids (346x260 rooms downsampled 2x) sees a 346x260 sensor's
// objects twice as large as it learned them unless the sensor is downsampled too
// (docs/runtime.md, "Pixel scale").
#pragma once

#include <string>

#include "core/model/model_file.h"

namespace spikems {

// The factors the runtime takes (pixel (x / f, y / f), a shift).
inline constexpr int kDownsampleFactors[] = {1, 2, 4, 8};

// The factor of kDownsampleFactors whose grid (ceil(W/f) x ceil(H/f)) comes nearest the model's
// training grid in scale (the ratio of the geometric means of the sides, on a log scale; a tie
// takes the smaller factor). 1 for a model with no recorded grid, an ANN-2D model (its scorer
// runs at the sensor's size) or a model of a fixed input size that the sensor already has; for a
// fixed size the sensor reaches only by downsampling, that factor.
int nearest_downsample(const ModelSpec& model, int width, int height);

// `requested` > 0: that factor (checked: 1, 2, 4 or 8; else Error naming `source`); 0 = auto:
// nearest_downsample.
int resolve_downsample(const ModelSpec& model, int width, int height, int requested,
                       const std::string& source);

// Parses "auto" (0) or a factor 1, 2, 4, 8; throws Error naming `what` otherwise.
int parse_downsample(const std::string& text, const std::string& what);

}  // namespace spikems
