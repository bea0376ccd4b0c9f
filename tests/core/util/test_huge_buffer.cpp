#include <gtest/gtest.h>

#include <cstdint>
#include <utility>

#include "core/util/huge_buffer.h"

namespace spikems {
namespace {

TEST(HugeBuffer, ZeroedAlignedAndMovable) {
  // small (heap), mapped with small pages (>= 64 KiB), with huge pages (>= 1 MiB)
  for (size_t n : {size_t(1), size_t(1000), size_t(100000), size_t(300000), size_t(3) << 20}) {
    HugeBuffer<float> b(n);
    ASSERT_EQ(b.size(), n);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(b.data()) % 64, 0u);
    for (size_t i = 0; i < n; i += 997) ASSERT_EQ(b[i], 0.f);
    EXPECT_EQ(b[n - 1], 0.f);
    b[n - 1] = 3.f;
    HugeBuffer<float> c(std::move(b));
    EXPECT_EQ(c.size(), n);
    EXPECT_EQ(c[n - 1], 3.f);
    c.assign(n);  // a new buffer: zeros again, whatever was written before
    for (size_t i = 0; i < n; i += 997) ASSERT_EQ(c[i], 0.f);
    EXPECT_EQ(c[n - 1], 0.f);
    if (n >= (size_t(1) << 20) / sizeof(float)) {  // huge-page sized: a whole page aligned
      EXPECT_EQ(reinterpret_cast<uintptr_t>(c.data()) % (size_t(2) << 20), 0u);
    }
    c.assign(5);
    EXPECT_EQ(c.size(), 5u);
    EXPECT_EQ(c[4], 0.f);
  }
  HugeBuffer<int64_t> e;
  EXPECT_EQ(e.size(), 0u);
  EXPECT_EQ(e.data(), nullptr);
  HugeBuffer<int64_t> f(size_t(1) << 20);  // moved into a buffer that owns a mapping
  f[7] = 9;
  HugeBuffer<int64_t> g(size_t(5) << 20);
  g = std::move(f);
  EXPECT_EQ(g.size(), size_t(1) << 20);
  EXPECT_EQ(g[7], 9);
}

}  // namespace
}  // namespace spikems
