// libFuzzer target: arbitrary bytes through the evt2 reader (see reader_fuzz_driver.h).
#include "reader_fuzz_driver.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return fuzz_registered_reader("evt2", data, size);
}
