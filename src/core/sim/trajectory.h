// Smooth motions: a drift with constant acceleration (gravity for throws) plus a sum of
// sinusoids for translation, a constant spin plus a sum of sinusoids (as a rotation vector)
// for orientation. Infinitely differentiable,
// cheap to evaluate at any time, so the renderer can sample any instant.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "core/sim/geometry.h"

namespace spikems::sim {

struct Sinusoid {
  Vec3 amplitude;  // per axis (m, or rad for rotation)
  double freq_hz = 0;
  Vec3 phase;  // per axis (rad)
};

struct Trajectory {
  Vec3 position;      // at t = t_ref (plus the sinusoids' value there)
  Vec3 velocity;      // m/s, at t = t_ref
  Vec3 acceleration;  // m/s^2 (constant)
  Quat orientation;   // at t = t_ref
  Vec3 spin;          // world-frame angular velocity (rad/s)
  std::vector<Sinusoid> wobble_translation, wobble_rotation;
  double t_ref = 0;  // seconds

  Pose at(double t_s) const;
  bool is_static() const;
};

// A camera path with peak speeds about `speed` (m/s) and `angular_speed` (rad/s), made of
// `terms` sinusoids per axis with frequencies in [f_lo, f_hi]. Starts at the origin looking
// along +z (the world frame is the initial camera frame, up to the wobble at t = 0).
Trajectory random_camera_trajectory(std::mt19937_64& rng, double speed, double angular_speed,
                                    double f_lo, double f_hi, int terms = 3);

}  // namespace spikems::sim
