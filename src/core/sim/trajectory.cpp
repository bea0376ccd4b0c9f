#include "core/sim/trajectory.h"

#include <cmath>

namespace spikems::sim {

namespace {
constexpr double kTwoPi = 6.283185307179586;

Vec3 sum_sinusoids(const std::vector<Sinusoid>& terms, double t) {
  Vec3 s;
  for (const auto& w : terms) {
    double a = kTwoPi * w.freq_hz * t;
    s = s + Vec3{w.amplitude.x * std::sin(a + w.phase.x), w.amplitude.y * std::sin(a + w.phase.y),
                 w.amplitude.z * std::sin(a + w.phase.z)};
  }
  return s;
}
}  // namespace

Pose Trajectory::at(double t) const {
  double dt = t - t_ref;
  Pose p;
  p.t = position + velocity * dt + acceleration * (0.5 * dt * dt) +
        sum_sinusoids(wobble_translation, t);
  Quat q = Quat::from_rotvec(spin * dt) * orientation;
  if (!wobble_rotation.empty()) q = q * Quat::from_rotvec(sum_sinusoids(wobble_rotation, t));
  p.q = q.normalized();
  return p;
}

bool Trajectory::is_static() const {
  auto zero = [](const Vec3& v) { return v.x == 0 && v.y == 0 && v.z == 0; };
  auto still = [&](const std::vector<Sinusoid>& w) {
    for (const auto& s : w)
      if (!zero(s.amplitude)) return false;
    return true;
  };
  return zero(velocity) && zero(acceleration) && zero(spin) && still(wobble_translation) &&
         still(wobble_rotation);
}

Trajectory random_camera_trajectory(std::mt19937_64& rng, double speed, double angular_speed,
                                    double f_lo, double f_hi, int terms) {
  std::uniform_real_distribution<double> U(0, 1);
  Trajectory tr;
  auto make = [&](double peak, std::vector<Sinusoid>& out) {
    for (int k = 0; k < terms; ++k) {
      Sinusoid s;
      s.freq_hz = f_lo + (f_hi - f_lo) * U(rng);
      // Speed of one term is amplitude * 2 pi f; share the peak among the terms.
      double a = peak / (kTwoPi * s.freq_hz * std::sqrt(double(terms)));
      s.amplitude = {a * (0.5 + U(rng)), a * (0.5 + U(rng)), a * (0.5 + U(rng))};
      s.phase = {kTwoPi * U(rng), kTwoPi * U(rng), kTwoPi * U(rng)};
      out.push_back(s);
    }
  };
  make(speed, tr.wobble_translation);
  make(angular_speed, tr.wobble_rotation);
  return tr;
}

}  // namespace spikems::sim
