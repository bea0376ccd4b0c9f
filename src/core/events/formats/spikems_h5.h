// The project's own dataset format ("spikems-h5"): one HDF5 file per labelled recording.
//
//   /                        attrs: format = "spikems-h5", format_version = 1,
//                            sensor_width, sensor_height, metadata_json (UTF-8 string)
//   /events/t                int64  (N,)  microseconds, non-decreasing
//   /events/x, /events/y     uint16 (N,)  pixels, top-left origin
//   /events/p                uint8  (N,)  1 = ON, 0 = OFF
//   /events/label            uint16 (N,)  object id, 0 = background (optional)
//   /masks/t                 int64  (F,)  microseconds             (optional group)
//   /masks/ids               uint16 (F, H, W) object id per pixel
//   /camera/intrinsics       float64 (4,) fx, fy, cx, cy            (optional group)
//   /camera/distortion       float64 (k,) k1 k2 p1 p2 [k3]
//   /poses/t, /poses/id      int64 (P,), uint16 (P,)  id 0 = camera (optional group)
//   /poses/translation       float64 (P, 3) metres
//   /poses/rotation          float64 (P, 4) unit quaternion w, x, y, z
//   /moving_ids              uint16 (M,) ids that move independently (optional)
// Event datasets are chunked (65536 events) with shuffle + deflate (HDF5's built-in filters,
// so h5py and every HDF5 tool read them without plugins); masks are chunked per frame.
// Readers stream events chunk by chunk; writers append chunk by chunk and rename the file
// into place on close (atomic).
#pragma once

#include <memory>
#include <string>

#include "core/events/io.h"

namespace spikems {

inline constexpr int kSpikemsH5Version = 1;

// level: deflate level 0 (none) .. 9; -1 = default (4).
void write_spikems_h5(const std::string& path, const Recording& rec, int level = -1);
Recording read_spikems_h5(const std::string& path, const ReadOptions& opt = {});

std::unique_ptr<EventReader> open_spikems_h5_reader(const std::string& path,
                                                    const ReadOptions& opt = {});
std::unique_ptr<EventWriter> open_spikems_h5_writer(const std::string& path, SensorSize sensor,
                                                    const WriteOptions& opt = {});
FormatInfo spikems_h5_format();

}  // namespace spikems
