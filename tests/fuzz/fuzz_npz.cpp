// libFuzzer target: ZIP directory, members (stored/deflate, CRC) and the .npy inside.
#include <cstddef>
#include <cstdint>

#include "core/events/formats/npy.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    (void)spikems::parse_npz(data, size, "fuzz.npz");
  } catch (const spikems::Error&) {
  }
  return 0;
}
