// Image textures: PNG files turned into texture tiles (docs/simulator.md, Textures). Each file is
// listed, checked and decoded once per process (thread-safe caches), not per frame or sequence.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/viz/image.h"

namespace spikems::sim {

// A `textures` entry "dir:PATH" stands for the PNG files in PATH.
inline constexpr const char* kTextureDirPrefix = "dir:";

// The *.png files of `dir` (any case of the extension), sorted by name. Throws spikems::Error
// naming the path when the folder is missing, holds no PNG, or a file is not a readable PNG
// (header check; a file corrupt further in fails when decoded).
const std::vector<std::string>& image_texture_files(const std::string& dir);

// The tile of one PNG file (decoded on first use, then cached); throws Error naming the file.
std::shared_ptr<const std::vector<float>> image_texture_tile(const std::string& file);

// Texture::kTile^2 values in [0,1] from an image: centred square crop, linear luminance
// Y = 0.2126 R + 0.7152 G + 0.0722 B of the sRGB-decoded pixels, area-averaged to the tile,
// L = ln(Y + 0.01), then t = (L - P1) / (P99 - P1) clipped to [0,1], with P1 and P99 the 1st
// and 99th percentiles of L over the tile (0.5 everywhere if they are equal). The albedo map
// mean x exp(log_contrast x (t - 1/2)) then gives log-albedo percentiles 1..99 spread over
// exactly log_contrast while keeping the image's log-luminance ordering and proportions.
std::vector<float> image_to_tile(const Image& img);

}  // namespace spikems::sim
