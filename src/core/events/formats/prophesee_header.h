// The ASCII header of Prophesee files (RAW EVT 2.0/3.0 and DAT): lines "% key value" at the
// start of the file, ended by the first line that does not start with '%' (or by "% end").
// Reference: docs.prophesee.ai, "RAW File Format" and "DAT File Format".
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/events/event_stream.h"

namespace spikems {

struct PropheseeHeader {
  std::vector<std::pair<std::string, std::string>> fields;  // in file order
  std::string evt;             // "2.0", "3.0", "2.1" or "" (from "% evt" or "% format EVTn;...")
  SensorSize sensor;           // from format/geometry/Width+Height, else from the sensor generation
  int64_t time_offset_us = 0;  // "% spikems_time_offset_us" (written by our EVT 3.0 writer)

  // Value of the first field named `key` (case-insensitive), or "".
  std::string get(const std::string& key) const;
};

// Parses header lines (each starting with '%'). `source` names the file in errors.
PropheseeHeader parse_prophesee_header(const std::vector<std::string>& lines,
                                       const std::string& source);
// Quick look at the first bytes of a file: the header text if it starts with '%' lines.
std::string prophesee_header_text(const std::vector<uint8_t>& head);

}  // namespace spikems
