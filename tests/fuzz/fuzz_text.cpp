// libFuzzer target: text event lines (fields, numbers, comments, time-unit look-ahead).
#include <cstddef>
#include <cstdint>

#include "core/events/formats/text.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    spikems::ReadOptions opt;
    if (size > 0 && data[0] == 's') opt.time_unit = "s";
    auto r = spikems::open_text_reader(spikems::open_memory_source(data, size, "fuzz.txt"), opt);
    spikems::EventStream ev;
    while (r->read(ev, 64) > 0) {
    }
    (void)r->sensor();
  } catch (const spikems::Error&) {
  }
  return 0;
}
