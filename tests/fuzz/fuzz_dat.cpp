// libFuzzer target: arbitrary bytes through the dat reader (see reader_fuzz_driver.h).
#include "reader_fuzz_driver.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return fuzz_registered_reader("dat", data, size);
}
