// Pieces of AEDAT 4.0 shared by its reader and writer.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/events/event_stream.h"

namespace spikems {

// IOHeader CompressionType values.
enum : int { kAedatNone = 0, kAedatLz4 = 1, kAedatLz4High = 2, kAedatZstd = 3, kAedatZstdHigh = 4 };

struct Aedat4Stream {
  int id = -1;
  std::string type;  // typeIdentifier: "EVTS" for polarity events, "IMUS", "FRME", "TRIG"...
  SensorSize sensor;
};

// Streams declared by the IOHeader's infoNode XML (a minimal scan, not a full XML parser).
std::vector<Aedat4Stream> parse_aedat4_info(std::string_view xml);

// Decompresses one packet payload (a whole LZ4 frame or zstd frame) into dst.
void aedat4_decompress(int compression, const uint8_t* src, size_t n, std::vector<uint8_t>& dst,
                       const std::string& source, uint64_t offset);

}  // namespace spikems
