#include "core/util/host_memory.h"

#include <cstdlib>  // defines __GLIBC__ where the C library is glibc

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace spikems {

bool keep_freed_memory() {
#if defined(__GLIBC__)
  // No block is mmap'ed (large ones come from the heap and go back to its free lists), and the
  // heap's top is never trimmed (-1 reads as SIZE_MAX). Both are ordinary mallopt settings.
  return mallopt(M_MMAP_MAX, 0) == 1 && mallopt(M_TRIM_THRESHOLD, -1) == 1;
#else
  return false;
#endif
}

}  // namespace spikems
