#include "core/runtime/kalman_tracker.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace spikems {

std::vector<uint8_t> dilate(const std::vector<uint8_t>& m, int w, int h, int r) {
  if (r <= 0) return m;
  // Separable: rows, then columns.
  std::vector<uint8_t> tmp(m.size(), 0), out(m.size(), 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (m[size_t(y) * w + x])
        for (int d = std::max(0, x - r); d <= std::min(w - 1, x + r); ++d)
          tmp[size_t(y) * w + d] = 1;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (tmp[size_t(y) * w + x])
        for (int d = std::max(0, y - r); d <= std::min(h - 1, y + r); ++d)
          out[size_t(d) * w + x] = 1;
  return out;
}

std::vector<Component> connected_components(const std::vector<uint8_t>& m, int w, int h,
                                            int min_area) {
  std::vector<Component> comps;
  std::vector<uint8_t> seen(m.size(), 0);
  std::vector<int> stack;
  for (int y0 = 0; y0 < h; ++y0)
    for (int x0 = 0; x0 < w; ++x0) {
      size_t i0 = size_t(y0) * w + x0;
      if (!m[i0] || seen[i0]) continue;
      Component c{x0, y0, x0, y0, 0, 0, 0};
      double sx = 0, sy = 0;
      seen[i0] = 1;
      stack.assign(1, int(i0));
      while (!stack.empty()) {
        int i = stack.back();
        stack.pop_back();
        int x = i % w, y = i / w;
        ++c.area;
        sx += x;
        sy += y;
        c.x0 = std::min(c.x0, x);
        c.x1 = std::max(c.x1, x);
        c.y0 = std::min(c.y0, y);
        c.y1 = std::max(c.y1, y);
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            int nx = x + dx, ny = y + dy;
            if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
            size_t j = size_t(ny) * w + nx;
            if (m[j] && !seen[j]) {
              seen[j] = 1;
              stack.push_back(int(j));
            }
          }
      }
      if (c.area >= min_area) {
        c.cx = sx / c.area;
        c.cy = sy / c.area;
        comps.push_back(c);
      }
    }
  return comps;
}

// x <- F x, P <- F P F^T + Q for F = [[1,0,dt,0],[0,1,0,dt],[0,0,1,0],[0,0,0,1]] and the
// white-acceleration Q (per axis: q*[[dt^4/4, dt^3/2],[dt^3/2, dt^2]]).
void KalmanTracker::predict(Track& tr, double dt) const {
  auto& x = tr.x;
  x[0] += dt * x[2];
  x[1] += dt * x[3];
  std::array<double, 16> F{1, 0, dt, 0, 0, 1, 0, dt, 0, 0, 1, 0, 0, 0, 0, 1}, FP{}, P{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) FP[i * 4 + j] += F[i * 4 + k] * tr.P[k * 4 + j];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) P[i * 4 + j] += FP[i * 4 + k] * F[j * 4 + k];
  const double q = opt_.process_noise * opt_.process_noise;
  const double a = q * dt * dt * dt * dt / 4, b = q * dt * dt * dt / 2, c = q * dt * dt;
  P[0] += a, P[5] += a, P[2] += b, P[8] += b, P[7] += b, P[13] += b, P[10] += c, P[15] += c;
  tr.P = P;
}

// Measurement z = (cx, cy), H = [I 0]: K = P H^T (H P H^T + R)^-1, x += K (z - H x),
// P = (I - K H) P.
void KalmanTracker::correct(Track& tr, double mx, double my) const {
  const auto& P = tr.P;
  const double r = opt_.measurement_noise * opt_.measurement_noise;
  const double s00 = P[0] + r, s01 = P[1], s10 = P[4], s11 = P[5] + r;
  const double det = s00 * s11 - s01 * s10;
  const double i00 = s11 / det, i01 = -s01 / det, i10 = -s10 / det, i11 = s00 / det;
  double K[8];
  for (int i = 0; i < 4; ++i) {
    const double p0 = P[i * 4 + 0], p1 = P[i * 4 + 1];
    K[i * 2 + 0] = p0 * i00 + p1 * i10;
    K[i * 2 + 1] = p0 * i01 + p1 * i11;
  }
  const double e0 = mx - tr.x[0], e1 = my - tr.x[1];
  for (int i = 0; i < 4; ++i) tr.x[i] += K[i * 2] * e0 + K[i * 2 + 1] * e1;
  std::array<double, 16> np{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      np[i * 4 + j] = P[i * 4 + j] - (K[i * 2] * P[0 * 4 + j] + K[i * 2 + 1] * P[1 * 4 + j]);
  tr.P = np;
}

std::vector<TrackedBox> KalmanTracker::update(int64_t t, const std::vector<uint8_t>& mask, int w,
                                              int h) {
  const double dt = started_ ? std::max(1e-6, double(t - last_t_) * 1e-6) : 0.0;
  started_ = true;
  last_t_ = t;
  auto comps = connected_components(dilate(mask, w, h, opt_.dilate_radius), w, h, opt_.min_area);
  for (auto& tr : tracks_) predict(tr, dt);
  // Greedy association: closest (track, component) pairs first, inside the gate.
  struct Pair {
    double d;
    size_t t, c;
  };
  std::vector<Pair> pairs;
  for (size_t i = 0; i < tracks_.size(); ++i)
    for (size_t j = 0; j < comps.size(); ++j) {
      double d = std::hypot(tracks_[i].x[0] - comps[j].cx, tracks_[i].x[1] - comps[j].cy);
      if (d <= opt_.gate_px) pairs.push_back({d, i, j});
    }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.d < b.d; });
  std::vector<int> track_of(comps.size(), -1);
  std::vector<uint8_t> used(tracks_.size(), 0);
  for (const auto& p : pairs)
    if (!used[p.t] && track_of[p.c] < 0) {
      used[p.t] = 1;
      track_of[p.c] = int(p.t);
    }
  for (size_t i = 0; i < tracks_.size(); ++i)
    if (!used[i]) ++tracks_[i].missed;
  std::vector<TrackedBox> out;
  for (size_t j = 0; j < comps.size(); ++j) {
    const Component& c = comps[j];
    const double cw = c.x1 - c.x0 + 1, ch = c.y1 - c.y0 + 1;
    if (track_of[j] >= 0) {
      Track& tr = tracks_[size_t(track_of[j])];
      correct(tr, c.cx, c.cy);
      tr.w = 0.6 * tr.w + 0.4 * cw;
      tr.h = 0.6 * tr.h + 0.4 * ch;
      ++tr.hits;
      tr.missed = 0;
    } else {
      Track tr;
      tr.id = next_id_++;
      tr.x = {c.cx, c.cy, 0, 0};
      const double r = opt_.measurement_noise * opt_.measurement_noise;
      // Unknown velocity: a wide prior (std 2000 px/s), so two frames already give an estimate.
      tr.P = {r, 0, 0, 0, 0, r, 0, 0, 0, 0, 4e6, 0, 0, 0, 0, 4e6};
      tr.w = cw;
      tr.h = ch;
      tr.hits = 1;
      tracks_.push_back(tr);
      used.push_back(1);
    }
  }
  std::erase_if(tracks_, [&](const Track& tr) { return tr.missed > opt_.max_missed; });
  for (const auto& tr : tracks_)
    if ((tr.missed == 0 || opt_.report_coasting) && tr.hits >= opt_.min_hits)
      out.push_back({t, tr.id, tr.x[0] - tr.w / 2, tr.x[1] - tr.h / 2, tr.x[0] + tr.w / 2,
                     tr.x[1] + tr.h / 2, tr.x[2], tr.x[3]});
  return out;
}

}  // namespace spikems
