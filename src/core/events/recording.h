// A labelled recording: events plus what datasets carry beside them (mask frames, camera
// intrinsics, free metadata). The project's own HDF5 dataset format stores exactly this.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/events/event_stream.h"

namespace spikems {

// One ground-truth frame: per-pixel object id (0 = background), row-major H x W.
struct MaskFrame {
  int64_t t_us = 0;
  int width = 0, height = 0;
  std::vector<uint16_t> ids;
  uint16_t at(int x, int y) const { return ids[size_t(y) * size_t(width) + size_t(x)]; }
};

struct CameraIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::vector<double> distortion;  // k1 k2 p1 p2 [k3]
  bool known() const { return fx > 0 && fy > 0; }
};

// Pose of a camera or object at a time: translation (m) and unit quaternion (w, x, y, z).
struct PoseSample {
  int64_t t_us = 0;
  uint16_t id = 0;  // 0 = camera, else object id
  std::array<double, 3> translation{};
  std::array<double, 4> rotation{1, 0, 0, 0};
};

struct Recording {
  EventStream events;
  std::vector<MaskFrame> masks;      // sorted by time
  std::vector<uint16_t> moving_ids;  // object ids that move independently (empty: all non-zero)
  std::optional<CameraIntrinsics> intrinsics;
  std::vector<PoseSample> poses;
  std::string metadata_json = "{}";  // free metadata (JSON object text)
};

}  // namespace spikems
