// Pinhole camera of the simulator. Pixel (x, y) has its centre at image coordinates (x, y)
// (OpenCV convention); no distortion. Default intrinsics are DAVIS346-like (346 x 260,
// fx = fy = 0.65 * width, about 75 degrees of horizontal field of view).
#pragma once

#include "core/events/recording.h"
#include "core/sim/geometry.h"

namespace spikems::sim {

struct Camera {
  int width = 346, height = 260;
  double fx = 225, fy = 225, cx = 172.5, cy = 129.5;

  static Camera davis346() { return Camera{}; }
  // Defaults for a sensor size: fx = fy = 0.65 * width, centre of the image.
  static Camera for_sensor(int w, int h) {
    return Camera{w, h, 0.65 * w, 0.65 * w, (w - 1) * 0.5, (h - 1) * 0.5};
  }
  // Image coordinates of a point in the camera frame (z > 0).
  void project(const Vec3& p, double& u, double& v) const {
    u = fx * p.x / p.z + cx;
    v = fy * p.y / p.z + cy;
  }
  CameraIntrinsics intrinsics() const {
    CameraIntrinsics k;
    k.fx = fx;
    k.fy = fy;
    k.cx = cx;
    k.cy = cy;
    return k;
  }
};

}  // namespace spikems::sim
