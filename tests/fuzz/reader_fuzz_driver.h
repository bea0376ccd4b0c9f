// Shared body of the libFuzzer targets for binary readers: arbitrary bytes through one
// registered format's reader. Any outcome but a spikems::Error (a crash, a sanitizer report, a
// hang, a foreign exception) is a bug.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/events/io.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

inline int fuzz_registered_reader(const char* format_name, const uint8_t* data, size_t size) {
  static const spikems::FormatInfo* format = spikems::find_format(format_name);
  try {
    spikems::ReadOptions opt;
    opt.sensor = {346, 260};  // lets headerless-size formats (AEDAT 2.0) get past the header
    auto reader = format->open_bytes(spikems::open_memory_source(data, size, "fuzz"), opt);
    spikems::EventStream out;
    size_t chunk = size % 13 + 1;  // odd chunk sizes exercise the carry-over of vectors
    while (reader->read(out, chunk) > 0) {
      if (out.size() > (1u << 16)) out.clear();
    }
  } catch (const spikems::Error&) {
  }
  return 0;
}
