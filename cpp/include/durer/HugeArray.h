#pragma once
// An array of n uninitialised T that the kernel may back with 2 MiB pages (Linux's transparent huge
// pages, where the system leaves them to madvise: the default on Debian) once it is large: a large
// array new each render costs a page fault every 4 KiB as it is first written. Adaptive sampling's
// per-pixel state (about 200 bytes a pixel) took 100,000 of them a 1920x1080 render, more time than
// its first pass's rays. Below kHugeFrom glibc hands a freed block out again from its heap (its mmap
// threshold rises to 32 MiB as mapped blocks are freed), so the next render writes pages already
// there, and a huge page's 2 MiB, zeroed whole, would cost more (measured: +3-7 % at 160x90). The
// advice is only advice: where it is refused, or off Linux, the array is a plain one.
//
// A freed large block is not handed back to the kernel at once (HugeBlocks): the kernel zeroes
// every page it gives a process, and zeroing the adaptive state's pages anew each render cost a
// 1080p first pass (4 samples a pixel) about 15 %. The block's pages are given up lazily instead
// (MADV_FREE: the kernel takes them when it needs memory, and until then a write finds them still
// there), and the next large array of half its size to its size takes it.
#include <cstddef>
#include <cstdlib>
#include <memory>
#include <new>
#include <type_traits>
#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace durer {

// The large blocks HugeArrays have freed, kept for the next ones (the file's head): up to kKept
// blocks and kKeptBytes in all, the oldest given back to the system first. Where the system cannot
// give pages up lazily (no MADV_FREE) nothing is kept. A block is taken only by an array at least
// half its size: a small array kept for long (a scene's grid) would otherwise hold a render's
// large one. The lock is only tried: where another thread holds it (or held it when a process
// forked), the array is made and freed as without a cache. One cache for the whole module, out of
// line in HugeArray.cpp: each kernel set keeps its inline code's statics to itself (CMakeLists.txt),
// and an array made in one (a grid, made in a search) is often freed in another (with its scene).
class HugeBlocks {
 public:
  static constexpr int kKept = 8;
  static constexpr size_t kKeptBytes = size_t(2) << 30;

  struct Block {
    void* memory;  // from std::aligned_alloc; null: none
    size_t bytes;
  };

  // The smallest kept block of `bytes` to 2 x `bytes`, or none.
  static Block take(size_t bytes);
  // Keeps `block` for a later take, or frees it.
  static void give(Block block);
};

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
    HugeBlocks::Block block = HugeBlocks::take(rounded);
    if (block.memory == nullptr) {
      block = {std::aligned_alloc(kHugePage, rounded), rounded};
      if (block.memory == nullptr) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
      madvise(block.memory, rounded, MADV_HUGEPAGE);
#endif
    }
    m_huge = std::unique_ptr<T, Give>(static_cast<T*>(block.memory), Give{block.bytes});
    m_data = m_huge.get();
  }

  T& operator[](size_t i) { return m_data[i]; }
  const T& operator[](size_t i) const { return m_data[i]; }
  const T* get() const { return m_data; }

 private:
  struct Give {
    size_t bytes;  // the block's (it may be larger than the array)
    void operator()(T* p) const { HugeBlocks::give({p, bytes}); }
  };
  std::unique_ptr<T[]> m_small;      // a plain array below kHugeFrom
  std::unique_ptr<T, Give> m_huge;   // from it on
  T* m_data = nullptr;               // the one of them there is
};

}  // namespace durer
