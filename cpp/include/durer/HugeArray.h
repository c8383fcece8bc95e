#pragma once
// An array of n uninitialised T that the kernel may back with 2 MiB pages (Linux's transparent huge
// pages, where the system leaves them to madvise: the default on Debian) once it is large: a large
// array new each render costs a page fault every 4 KiB as it is first written. Adaptive sampling's
// per-pixel state (about 200 bytes a pixel) took 100,000 of them a 1920x1080 render, more time than
// its first pass's rays. Below kHugeFrom glibc hands a freed block out again from its heap (its mmap
// threshold rises to 32 MiB as mapped blocks are freed), so the next render writes pages already
// there, and a huge page's 2 MiB, zeroed whole, would cost more (measured: +3-7 % at 160x90). The
// advice is only advice: where it is refused, or off Linux, the array is a plain one.
#include <cstddef>
#include <cstdlib>
#include <memory>
#include <new>
#include <type_traits>
#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace durer {

template <typename T>
class HugeArray {
  static_assert(std::is_trivially_default_constructible_v<T> && std::is_trivially_destructible_v<T>,
                "HugeArray leaves its elements unset and never destroys them");

 public:
  static constexpr size_t kHugePage = size_t(2) << 20;
  static constexpr size_t kHugeFrom = size_t(32) << 20;

  HugeArray() = default;
  // hugeFrom: the size from which to ask for huge pages (kHugeFrom for arrays made anew each render;
  // an array kept across renders pays for them from a few pages' worth).
  explicit HugeArray(size_t n, size_t hugeFrom = kHugeFrom) {
    const size_t bytes = n * sizeof(T);
    if (bytes < hugeFrom) {
      m_small.reset(new T[n]);
      m_data = m_small.get();
      return;
    }
    const size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;  // aligned_alloc's rule
    void* memory = std::aligned_alloc(kHugePage, rounded);
    if (memory == nullptr) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    madvise(memory, rounded, MADV_HUGEPAGE);
#endif
    m_huge.reset(static_cast<T*>(memory));
    m_data = m_huge.get();
  }

  T& operator[](size_t i) { return m_data[i]; }
  const T& operator[](size_t i) const { return m_data[i]; }
  const T* get() const { return m_data; }

 private:
  struct Free {
    void operator()(T* p) const { std::free(p); }
  };
  std::unique_ptr<T[]> m_small;      // a plain array below kHugeFrom
  std::unique_ptr<T, Free> m_huge;   // from it on
  T* m_data = nullptr;               // the one of them there is
};

}  // namespace durer
