// A 3-D scene: a textured background (room or planes at several depths), independently moving
// textured objects, optional static occluders (a net), one light, and the camera's path.
// Object ids: 1..N for moving objects; background and occluders are 0.
#pragma once

#include <cstdint>
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
  Net,        // planar grid of bars in local z = 0 (holes are see-through)
};

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
  Trajectory motion;  // pose of the local frame in the world
  std::string label;  // "sphere", "box", ... (metadata)
};

struct Scene {
  std::vector<Texture> textures;
  std::vector<Shape> shapes;
  Trajectory camera;                // camera-to-world pose over time
  Vec3 light_dir{0.3, -0.8, -0.5};  // direction towards the light (world)
  double ambient = 0.5;
  double illumination = 1.0;

  std::vector<uint16_t> moving_ids() const;
  // One line per shape, for recording metadata (JSON array text).
  std::string describe_json() const;
};

// A random scene drawn from the config ranges with the sequence's own generator.
Scene make_random_scene(const SimConfig& cfg, const Camera& cam, std::mt19937_64& rng);

}  // namespace spikems::sim
