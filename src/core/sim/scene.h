// A 3-D scene: a textured background (room or planes at several depths), independently moving
// textured objects, static look-alikes of them, optional static occluders (a net, bars or
// foliage), one light, and the camera's path.
// Object ids: 1..N for moving objects; background, look-alikes and occluders are 0.
#pragma once

#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/sim/camera.h"
#include "core/sim/sim_config.h"
#include "core/sim/texture.h"
#include "core/sim/trajectory.h"

namespace spikems::sim {

enum class ShapeKind {
  Ellipsoid,  // semi-axes `half` (a sphere when equal)
  Box,        // half extents `half`
  Quad,       // planar cut-out in local z = 0, half extents half.x, half.y, with an outline
  Room,       // axis-aligned box seen from inside (one texture per wall pair)
  Net,        // planar occluder in local z = 0 (pattern below; holes are see-through)
};

// What of a Net plane is solid: a grid of bars, parallel bars along local y, or leaves.
enum class NetPattern { Grid, Bars, Foliage };

enum class Outline { Rect, Disc, Star };

struct Shape {
  ShapeKind kind = ShapeKind::Ellipsoid;
  Outline outline = Outline::Rect;
  Vec3 half{0.2, 0.2, 0.2};
  uint16_t id = 0;          // 0: background / occluder
  int texture = 0;          // index into Scene::textures (Room: first of 3, per axis)
  double tile_m = 1.0;      // metres per texture tile
  double albedo_scale = 1;  // multiplies the texture
  double net_spacing = 0.05, net_bar = 0.005;
  NetPattern net_pattern = NetPattern::Grid;
  // Foliage: a periodic kLeafN x kLeafN field (cells of leaf_cell_m); solid where the
  // bilinearly interpolated field is >= leaf_threshold (smooth leaf outlines).
  static constexpr int kLeafN = 128;
  std::vector<float> leaf_field;
  double leaf_cell_m = 0.005;
  float leaf_threshold = 0.5f;
  Trajectory motion;                   // pose of the local frame in the world
  std::string label;                   // "sphere", "box", ... (metadata)
  std::string motion_kind = "static";  // linear, curved, ballistic, spin (moving objects)

  // Foliage test at local plane coordinates (x, y) in metres.
  bool leaf_at(float x, float y) const {
    const float inv = float(1.0 / leaf_cell_m);
    float u = x * inv, v = y * inv;
    float fu = std::floor(u), fv = std::floor(v);
    float a = u - fu, b = v - fv;
    // kLeafN is a power of two: & wraps negative indices too (two's complement).
    int i0 = int(fu) & (kLeafN - 1), j0 = int(fv) & (kLeafN - 1);
    int i1 = (i0 + 1) & (kLeafN - 1), j1 = (j0 + 1) & (kLeafN - 1);
    const float* f = leaf_field.data();
    float top = f[j0 * kLeafN + i0] * (1 - a) + f[j0 * kLeafN + i1] * a;
    float bot = f[j1 * kLeafN + i0] * (1 - a) + f[j1 * kLeafN + i1] * a;
    return top * (1 - b) + bot * b >= leaf_threshold;
  }
};

struct Scene {
  std::vector<Texture> textures;
  std::vector<Shape> shapes;
  Trajectory camera;                // camera-to-world pose over time
  Vec3 light_dir{0.3, -0.8, -0.5};  // direction towards the light (world)
  double ambient = 0.5;
  double illumination = 1.0;
  std::string camera_motion = "handheld";  // metadata: the kind drawn for the camera

  std::vector<uint16_t> moving_ids() const;
  // One object per shape, for recording metadata (a JSON array).
  nlohmann::json describe() const;
};

// A random scene drawn from the config ranges with the sequence's own generator.
Scene make_random_scene(const SimConfig& cfg, const Camera& cam, std::mt19937_64& rng);

}  // namespace spikems::sim
