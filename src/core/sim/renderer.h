// Ray casting of a Scene: for every pixel the nearest surface gives the log intensity
// L = log(eps + I), the object id (0 = background or occluder) and the depth. Per frame, each
// shape's pose is turned into a camera->local transform once; then every row is processed in
// vectorised passes (intersection per shape over its screen span, shading, texture sampling,
// log). Bit-identical to ReferenceRenderer, the first per-pixel implementation.
#pragma once

#include <cstdint>
#include <vector>

#include "core/sim/camera.h"
#include "core/sim/scene.h"

namespace spikems::sim {

struct Frame {
  double t_s = 0;
  std::vector<float> log_intensity;  // H x W
  std::vector<uint16_t> id;          // H x W
  std::vector<float> depth;          // H x W (camera z, metres; 0 where nothing is hit)
  std::vector<uint8_t> surface;      // H x W: index of the shape hit + 1 (0: none)
};

class Renderer {
 public:
  Renderer(const Scene& scene, const Camera& cam, double log_eps);
  void render(double t_s, Frame& out, int threads = 1) const;
  const Camera& camera() const { return cam_; }

 private:
  const Scene& scene_;
  Camera cam_;
  float log_eps_;
  std::vector<float> rx_, ry_;        // (x - cx)/fx per column, (y - cy)/fy per row
  std::vector<const float*> levels_;  // texture t, mip level l: levels_[t * n_levels_ + l]
  int n_levels_ = 1;
};

}  // namespace spikems::sim
