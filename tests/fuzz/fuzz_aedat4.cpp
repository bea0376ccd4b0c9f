// libFuzzer target: arbitrary bytes through the aedat4 reader (see reader_fuzz_driver.h).
#include "reader_fuzz_driver.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return fuzz_registered_reader("aedat4", data, size);
}
