// libFuzzer target: the .npy parser must reject any input with spikems::Error, never crash,
// hang or allocate from an unchecked header size.
#include <cstddef>
#include <cstdint>

#include "core/events/formats/npy.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    spikems::NpyArray a = spikems::parse_npy(data, size, "fuzz.npy");
    if (a.descr[1] == 'U' || a.descr[1] == 'S')
      (void)a.to_strings();
    else if (a.descr != "<f2")
      (void)a.to<double>();
    (void)spikems::serialize_npy(a);
  } catch (const spikems::Error&) {
  }
  return 0;
}
