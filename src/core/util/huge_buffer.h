// A zero-initialised array of trivially copyable T for large, randomly accessed state (the
// runtime's neuron state: tens of megabytes touched at scattered places every step). From
// 64 KiB on it is its own anonymous mapping (zero pages: nothing to clear), from 1 MiB on
// 2 MiB aligned and backed by transparent huge pages where the kernel allows (madvise): with
// 4 KiB pages nearly every visited position would also miss the TLB.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <type_traits>
#include <utility>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace spikems {

template <class T>
class HugeBuffer {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  HugeBuffer() = default;
  explicit HugeBuffer(size_t n) { assign(n); }
  HugeBuffer(const HugeBuffer&) = delete;
  HugeBuffer& operator=(const HugeBuffer&) = delete;
  HugeBuffer(HugeBuffer&& o) noexcept { *this = std::move(o); }
  HugeBuffer& operator=(HugeBuffer&& o) noexcept {
    std::swap(p_, o.p_);
    std::swap(n_, o.n_);
    std::swap(mapped_, o.mapped_);
    return *this;
  }
  ~HugeBuffer() { release(); }

  void assign(size_t n) {
    release();
    n_ = n;
    if (n == 0) return;
    constexpr size_t kHuge = size_t(2) << 20, kMap = size_t(64) << 10;
    const size_t bytes = n * sizeof(T);
#if defined(__linux__)
    if (bytes >= kMap) {
      // Fresh anonymous pages read as zero: no memset, and pages the run never touches are
      // never faulted in (zeroing tens of MB up front was ~6 % of a 2 s `segment`; buffers
      // sized for the worst case, a spike from every neuron, are mostly never touched).
      // From 1 MiB on, the mapping is 2 MiB aligned and asks for huge pages (one huge page
      // fault beats 256+ small ones, and the drive buffers are written at random).
      const bool huge = bytes >= kHuge / 2;
      const size_t unit = huge ? kHuge : size_t(4096);
      const size_t padded = (bytes + unit - 1) / unit * unit;
      const size_t extra = huge ? kHuge : 0;
      void* raw =
          mmap(nullptr, padded + extra, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      if (raw == MAP_FAILED) throw std::bad_alloc();
      const uintptr_t r = reinterpret_cast<uintptr_t>(raw);
      uintptr_t a = r;
      if (huge) {
        a = (r + kHuge - 1) / kHuge * kHuge;                         // 2 MiB aligned inside
        if (a > r) munmap(raw, a - r);                               // the head
        munmap(reinterpret_cast<void*>(a + padded), r + kHuge - a);  // the tail (a < r + kHuge)
      }
      p_ = reinterpret_cast<T*>(a);
      mapped_ = padded;
#if defined(MADV_HUGEPAGE)
      if (huge) madvise(p_, padded, MADV_HUGEPAGE);  // a hint: failure is harmless
#endif
      return;
    }
#endif
    const size_t padded = (bytes + 63) / 64 * 64;
    p_ = static_cast<T*>(std::aligned_alloc(64, padded));
    if (!p_) throw std::bad_alloc();
    std::memset(static_cast<void*>(p_), 0, padded);
  }
  T* data() {
    return p_;
  }
  const T* data() const {
    return p_;
  }
  size_t size() const {
    return n_;
  }
  T& operator[](size_t i) {
    return p_[i];
  }
  const T& operator[](size_t i) const {
    return p_[i];
  }

 private:
  void release() {
#if defined(__linux__)
    if (mapped_) munmap(p_, mapped_);
#endif
    if (!mapped_) std::free(p_);
    p_ = nullptr;
    n_ = 0;
    mapped_ = 0;
  }
  T* p_ = nullptr;
  size_t n_ = 0;
  size_t mapped_ = 0;  // bytes mapped with mmap (0: from aligned_alloc)
};

}  // namespace spikems
