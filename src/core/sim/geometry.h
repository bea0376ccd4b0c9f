// Small 3-D math for the simulator: vectors, 3x3 rotations, unit quaternions and rigid poses.
// Frames follow OpenCV: camera x right, y down, z forward. A Pose maps local points into the
// world: p_world = R * p_local + t.
#pragma once

#include <array>
#include <cmath>

namespace spikems::sim {

struct Vec3 {
  double x = 0, y = 0, z = 0;
  Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  Vec3 operator-() const { return {-x, -y, -z}; }
  double dot(const Vec3& o) const { return x * o.x + y * o.y + z * o.z; }
  Vec3 cross(const Vec3& o) const {
    return {y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x};
  }
  double norm() const { return std::sqrt(dot(*this)); }
  Vec3 normalized() const {
    double n = norm();
    return n > 0 ? *this * (1.0 / n) : Vec3{0, 0, 1};
  }
};

struct Mat3 {
  std::array<double, 9> m{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major
  double operator()(int r, int c) const { return m[size_t(r * 3 + c)]; }
  double& operator()(int r, int c) { return m[size_t(r * 3 + c)]; }
  Vec3 operator*(const Vec3& v) const {
    return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
            m[6] * v.x + m[7] * v.y + m[8] * v.z};
  }
  Mat3 operator*(const Mat3& o) const {
    Mat3 r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        r(i, j) = (*this)(i, 0) * o(0, j) + (*this)(i, 1) * o(1, j) + (*this)(i, 2) * o(2, j);
    return r;
  }
  Mat3 transposed() const {
    Mat3 r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r(i, j) = (*this)(j, i);
    return r;
  }
};

// Unit quaternion (w, x, y, z).
struct Quat {
  double w = 1, x = 0, y = 0, z = 0;
  Quat operator*(const Quat& q) const {
    return {w * q.w - x * q.x - y * q.y - z * q.z, w * q.x + x * q.w + y * q.z - z * q.y,
            w * q.y - x * q.z + y * q.w + z * q.x, w * q.z + x * q.y - y * q.x + z * q.w};
  }
  Quat normalized() const {
    double n = std::sqrt(w * w + x * x + y * y + z * z);
    return {w / n, x / n, y / n, z / n};
  }
  // Rotation by the rotation vector r (axis * angle in radians).
  static Quat from_rotvec(const Vec3& r) {
    double a = r.norm();
    if (a < 1e-12) return Quat{1, r.x * 0.5, r.y * 0.5, r.z * 0.5}.normalized();
    double s = std::sin(a * 0.5) / a;
    return {std::cos(a * 0.5), r.x * s, r.y * s, r.z * s};
  }
  Mat3 to_matrix() const {
    Mat3 r;
    r.m = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
           2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
           2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
    return r;
  }
};

struct Pose {
  Quat q;  // local -> world rotation
  Vec3 t;  // position of the local origin in the world
  Vec3 apply(const Vec3& p) const { return q.to_matrix() * p + t; }
};

}  // namespace spikems::sim
