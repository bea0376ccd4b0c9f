// Procedural textures for the simulator. Each texture is baked once into a periodic square tile
// with a mip pyramid; rendering samples it trilinearly with the pixel's footprint, which
// approximates the spatial integration of a real pixel and keeps fine patterns from aliasing
// into spurious events.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/sim/fast_math.h"

namespace spikems::sim {

// Image: a PNG resampled to the tile (core/sim/image_texture.h); it has no name in the
// `textures` list (images come from "dir:PATH" entries).
enum class TextureKind {
  Noise,
  Stripes,
  Checkers,
  Grid,
  Blobs,
  Natural,
  Uniform,
  DeadLeaves,
  Gradient,
  Image
};

TextureKind texture_kind_from_name(const std::string& name);  // throws Error on unknown
const char* texture_kind_name(TextureKind k);
bool is_texture_kind_name(const std::string& name);  // a procedural kind usable in `textures`
// The procedural kind names, space-separated (for error messages).
const char* texture_kind_names();

struct TextureParams {
  TextureKind kind = TextureKind::Noise;
  uint64_t seed = 1;
  int frequency = 4;        // features per tile (noise base period, stripes, checkers...)
  double mean = 0.5;        // mean albedo
  double log_contrast = 1;  // albedo spans mean * exp(+-log_contrast/2)
  double angle = 0;         // stripes orientation (radians)
  // Share of the tile covered by flat patches (apply_flat_patches); 0 = none.
  double flat_fraction = 0;
  // Image: kTile x kTile values in [0,1] (row-major; see image_texture.h) and the file.
  std::shared_ptr<const std::vector<float>> image;
  std::string image_path;
};

// Level-0 values v in [0,1] (kTile x kTile, row-major) before the albedo map
// mean x exp(log_contrast x (v - 1/2)); normalised so min = 0 and max = 1 (0.5 if flat).
std::vector<float> texture_values(const TextureParams& p);

// Flat patches: large axis-aligned rectangles and discs (half-sizes 0.08-0.3 of the tile,
// wrapping across its border) in which the values' contrast about 1/2 is cut to a factor in
// [0, 0.3] drawn per patch, dropped until at least `fraction` of the texels lie in one (at most
// kMaxFlatPatches). A static surface then has event-dense and nearly silent regions side by
// side with sharp borders, as real posters, walls and furniture do, so that a network cannot
// take "a dense patch of events" for a moving object. The layout comes from `seed` alone.
// Returns the share of texels covered (>= fraction unless the patch cap was reached).
constexpr int kMaxFlatPatches = 64;
double apply_flat_patches(std::vector<float>& v, double fraction, uint64_t seed);

// Dead leaves (Lee, Mumford & Huang 2001): opaque discs, ellipses and rectangles at random
// orientations, radii with p(r) ~ r^-3 in [kRMin, kRMax] tile units and grey values uniform in
// [0,1], dropped one behind another (front to back: a leaf only paints what no earlier leaf
// covers) until the tile is covered; periodic; painted at kSuper x kSuper subsamples per texel
// and box-averaged, which anti-aliases the edges of level 0.
struct DeadLeaves {
  static constexpr double kRMin = 1.0 / 128, kRMax = 1.0 / 4;
  static constexpr int kSuper = 4;
  static constexpr int kMaxLeaves = 1'000'000;  // then a last leaf fills what is left
  std::vector<float> v;                         // kTile x kTile, values in [0,1]
  int leaves = 0;     // leaves dropped (most late ones land on covered ground)
  int64_t holes = 0;  // subsamples still bare after kMaxLeaves (0 in practice)
};
DeadLeaves bake_dead_leaves(uint64_t seed);

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
  // Texels of one mip level ((kTile >> level)^2, row-major), for the renderer's row sampler,
  // which evaluates sample()'s expressions for a row of pixels at once (tested equal).
  const float* level_data(int level) const { return mips_[size_t(level)].data(); }
  const TextureParams& params() const { return params_; }

 private:
  TextureParams params_;
  std::vector<std::vector<float>> mips_;  // level 0: kTile x kTile, then halves
};

// Inline: called for every pixel of every frame.
inline float Texture::bilinear(int level, float u, float v) const {
  const int s = kTile >> level;
  const auto& m = mips_[size_t(level)];
  float x = u * s - 0.5f, y = v * s - 0.5f;
  float fx0 = fast_floor(x), fy0 = fast_floor(y);
  float ax = x - fx0, ay = y - fy0;
  // Wrap (periodic); coordinates may be far from [0,1).
  int x0 = int(int64_t(fx0) & (s - 1)), y0 = int(int64_t(fy0) & (s - 1));
  int x1 = (x0 + 1) & (s - 1), y1 = (y0 + 1) & (s - 1);
  const float* r0 = &m[size_t(y0) * s];
  const float* r1 = &m[size_t(y1) * s];
  return (r0[x0] * (1 - ax) + r0[x1] * ax) * (1 - ay) + (r1[x0] * (1 - ax) + r1[x1] * ax) * ay;
}

inline float Texture::sample(float u, float v, float footprint) const {
  if (!(std::fabs(u) < 1e6f && std::fabs(v) < 1e6f)) return mips_.back()[0];  // also NaN
  u -= fast_floor(u);
  v -= fast_floor(v);
  float lod = fast_log2(std::max(footprint * kTile, 1e-6f));
  const int last = levels() - 1;
  if (lod <= 0) return bilinear(0, u, v);
  if (lod >= last) return mips_.back()[0];
  int l0 = int(lod);
  float a = lod - l0;
  return bilinear(l0, u, v) * (1 - a) + bilinear(l0 + 1, u, v) * a;
}

}  // namespace spikems::sim
