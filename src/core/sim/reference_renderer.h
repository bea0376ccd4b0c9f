// The simulator's first renderer, kept unchanged as the baseline for bench_sim and for the
// equivalence test of Renderer (tests/core/sim/test_renderer.cpp): one pixel at a time, every
// shape's intersection, then shading and a trilinear texture sample. Not used by simulate.
#pragma once

#include <vector>

#include "core/sim/camera.h"
#include "core/sim/renderer.h"
#include "core/sim/scene.h"

namespace spikems::sim {

class ReferenceRenderer {
 public:
  ReferenceRenderer(const Scene& scene, const Camera& cam, double log_eps);
  void render(double t_s, Frame& out, int threads = 1) const;
  const Camera& camera() const { return cam_; }

 private:
  const Scene& scene_;
  Camera cam_;
  float log_eps_;
  std::vector<float> rx_, ry_;  // (x - cx)/fx per column, (y - cy)/fy per row
};

}  // namespace spikems::sim
