// Writers of the camera formats (EVT 3.0 and AEDAT 4.0), used by their FormatInfo entries.
#pragma once

#include <memory>
#include <string>

#include "core/events/io.h"

namespace spikems {

std::unique_ptr<EventWriter> open_evt3_writer(const std::string& path, SensorSize sensor,
                                              const WriteOptions& opt);
std::unique_ptr<EventWriter> open_aedat4_writer(const std::string& path, SensorSize sensor,
                                                const WriteOptions& opt);

}  // namespace spikems
