// Per-pixel ray casting of a Scene: for every pixel the nearest surface gives the log
// intensity L = log(eps + I), the object id (0 = background or occluder) and the depth.
// Per frame, each shape's pose is turned into a camera->local transform once, so a pixel costs
// a 3x3 product and one analytic intersection per shape (with a screen-space box cull).
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
  std::vector<float> rx_, ry_;  // (x - cx)/fx per column, (y - cy)/fy per row
};

}  // namespace spikems::sim
