// Procedural textures for the simulator. Each texture is baked once into a periodic square tile
// with a mip pyramid; rendering samples it trilinearly with the pixel's footprint, which
// approximates the spatial integration of a real pixel and keeps fine patterns from aliasing
// into spurious events.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace spikems::sim {

enum class TextureKind { Noise, Stripes, Checkers, Grid, Blobs, Natural, Uniform };

TextureKind texture_kind_from_name(const std::string& name);  // throws Error on unknown
const char* texture_kind_name(TextureKind k);

struct TextureParams {
  TextureKind kind = TextureKind::Noise;
  uint64_t seed = 1;
  int frequency = 4;        // features per tile (noise base period, stripes, checkers...)
  double mean = 0.5;        // mean albedo
  double log_contrast = 1;  // albedo spans mean * exp(+-log_contrast/2)
  double angle = 0;         // stripes orientation (radians)
};

class Texture {
 public:
  static constexpr int kTile = 256;
  explicit Texture(const TextureParams& p);
  // Albedo at tile coordinates (u, v) (one tile = 1, periodic); footprint = pixel size in tile
  // units (selects the mip level).
  float sample(float u, float v, float footprint) const;
  // Plain bilinear lookup at one level (reference for tests).
  float bilinear(int level, float u, float v) const;
  int levels() const { return int(mips_.size()); }
  const TextureParams& params() const { return params_; }

 private:
  TextureParams params_;
  std::vector<std::vector<float>> mips_;  // level 0: kTile x kTile, then halves
};

}  // namespace spikems::sim
