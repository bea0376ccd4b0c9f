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

// Mask frame times (us) of `count` frames, from the first source that works: the pickled `meta`
// member of npz_path (when has_meta), the Python-literal file meta_txt ("" or absent: skipped),
// else spread evenly over the events: t_first + (i + 0.5) * duration / count. `info` gets
// "mask_times" ("meta", "meta.txt" or "uniform-estimate") and, when meta was there but could not
// be used, "meta_error". mask_name names the mask source in a count mismatch.
std::vector<int64_t> evimo_mask_times(const std::string& npz_path, bool has_meta,
                                      const std::string& meta_txt, size_t count,
                                      const EventStream& ev, const std::string& mask_name,
                                      nlohmann::json& info);

}  // namespace spikems
