// Sensor sizes of iniVation cameras named in AEDAT 2.0/3.1 headers.
#pragma once

#include <algorithm>
#include <cctype>
#include <string>

#include "core/events/event_stream.h"

namespace spikems {

inline SensorSize inivation_sensor_from_text(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  if (s.find("dvs128") != std::string::npos) return {128, 128};
  if (s.find("davis346") != std::string::npos) return {346, 260};
  if (s.find("davis240") != std::string::npos) return {240, 180};
  if (s.find("davis640") != std::string::npos) return {640, 480};
  if (s.find("dvxplorer_lite") != std::string::npos ||
      s.find("dvxplorer lite") != std::string::npos)
    return {320, 240};
  if (s.find("dvxplorer") != std::string::npos) return {640, 480};
  return {};
}

}  // namespace spikems
