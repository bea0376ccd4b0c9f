// Helpers for the simulator tests: small hand-made scenes with uniform textures.
#pragma once

#include "core/sim/scene.h"
#include "core/sim/sim_config.h"

namespace spikems::sim::test {

inline int uniform_texture(Scene& s, double albedo) {
  TextureParams p;
  p.kind = TextureKind::Uniform;
  p.mean = albedo;
  s.textures.emplace_back(p);
  return int(s.textures.size()) - 1;
}

inline Shape plane(Scene& s, double z, double half, int texture, double tile_m = 1.0) {
  Shape q;
  q.kind = ShapeKind::Quad;
  q.half = {half, half, 0};
  q.motion.position = {0, 0, z};
  q.texture = texture;
  q.tile_m = tile_m;
  q.label = "plane";
  return q;
}

// Flat lighting: intensity = illumination * albedo exactly.
inline void flat_light(Scene& s) {
  s.ambient = 1.0;
  s.illumination = 1.0;
}

inline SimConfig clean_config(int w, int h, double duration_s) {
  SimConfig c;
  c.width = w;
  c.height = h;
  c.duration_us = int64_t(duration_s * 1e6);
  apply_noise_setting(c, "clean");
  return c;
}

}  // namespace spikems::sim::test
