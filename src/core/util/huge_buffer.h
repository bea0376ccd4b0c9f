// A zero-initialised array of trivially copyable T for large, randomly accessed state (the
// runtime's neuron state: tens of megabytes touched at scattered places every step). When it
// is large enough, it is backed by 2 MiB transparent huge pages where the kernel allows
// (madvise): with 4 KiB pages nearly every visited position would also miss the TLB.
#pragma once

#include <cstddef>
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
    return *this;
  }
  ~HugeBuffer() { std::free(p_); }

  void assign(size_t n) {
    std::free(p_);
    p_ = nullptr;
    n_ = n;
    if (n == 0) return;
    constexpr size_t kHuge = size_t(2) << 20;
    const size_t bytes = n * sizeof(T);
    const size_t align = bytes >= kHuge ? kHuge : 64;
    const size_t padded = (bytes + align - 1) / align * align;
    p_ = static_cast<T*>(std::aligned_alloc(align, padded));
    if (!p_) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (align == kHuge) madvise(p_, padded, MADV_HUGEPAGE);  // a hint: failure is harmless
#endif
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
  T* p_ = nullptr;
  size_t n_ = 0;
};

}  // namespace spikems
