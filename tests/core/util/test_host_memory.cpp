// keep_freed_memory (core/util/host_memory.h): a large block comes from the heap, not from a fresh
// mapping, and its memory stays in the process after free (so the next step's tensors reuse
// those pages instead of faulting in and zeroing new ones).
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>

#include "core/util/host_memory.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace spikems {
namespace {

TEST(HostMemory, LargeBlocksComeFromTheHeapAndStayAfterFree) {
#if !defined(__GLIBC__)
  GTEST_SKIP() << "not glibc: keep_freed_memory has nothing to set";
#else
  constexpr size_t kBytes = size_t(96) << 20;  // above glibc's largest mmap threshold (32 MiB)
  ASSERT_TRUE(keep_freed_memory());
  const struct mallinfo2 before = mallinfo2();
  void* volatile p = std::malloc(kBytes);  // volatile: the allocation must not be elided
  ASSERT_NE(p, nullptr);
  std::memset(p, 1, kBytes);
  const struct mallinfo2 held = mallinfo2();
  EXPECT_EQ(held.hblkhd, before.hblkhd) << "the block must not be a separate mapping";
  std::free(p);
  const struct mallinfo2 after = mallinfo2();
  EXPECT_GE(after.fordblks, kBytes) << "freed memory must stay in the heap's free lists";
  // Measured against the heap while the block was held, not before it: in a process whose heap
  // already has that much free (other tests ran first), the block comes from the free lists.
  EXPECT_GE(held.arena, kBytes) << "the block must lie in the heap";
  EXPECT_GE(after.arena, held.arena) << "and the heap must not shrink back";
#endif
}

}  // namespace
}  // namespace spikems
