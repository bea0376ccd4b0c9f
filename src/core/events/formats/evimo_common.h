// Pieces shared by the EV-IMO / EVIMO2 readers (evimo.cpp, evimo2.cpp).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/events/formats/npy.h"
#include "core/events/io.h"

namespace spikems {

// Parses the subset of Python literals that EV-IMO's meta.txt uses (dicts, lists, tuples,
// numbers, strings, True/False/None) into JSON. Errors name `source` and the byte.
nlohmann::json parse_python_literal(const std::string& text, const std::string& source);

// Per-frame (time in us, ground-truth file name or "") from a meta dict's 'frames' list.
struct EvimoFrameInfo {
  int64_t t_us = 0;
  int64_t id = -1;
  std::string gt_frame;
};
std::vector<EvimoFrameInfo> evimo_frames_from_meta(const nlohmann::json& meta,
                                                   const std::string& source);

// EV-IMO stores a mask pixel as object id x 1000; returns the id (rounded).
inline uint16_t evimo_mask_id(uint16_t v) {
  return uint16_t((v + 500) / 1000);
}

// Sensor size rule for EV-IMO data: ReadOptions::sensor if given; else the mask frame size if
// known; else the smallest of the DAVIS sizes 240x180, 346x260 and 640x480 holding every
// event; else max+1.
SensorSize evimo_sensor(const ReadOptions& opt, const EventStream& ev, int mask_w, int mask_h);

// K (3x3) and D (4 or 5) arrays to intrinsics.
CameraIntrinsics evimo_intrinsics(const NpyArray& K, const NpyArray* D, const std::string& src);

}  // namespace spikems
