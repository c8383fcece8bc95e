// HugeArray: a plain array below kHugeFrom, and from it on one aligned to the 2 MiB pages that
// Linux's transparent huge pages need (the madvise itself is advice that the kernel may refuse),
// whose block, freed, the next such array takes (HugeBlocks).
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <initializer_list>
#include <vector>

#include "durer/HugeArray.h"

namespace {

template <typename T>
void fillAndCheck(durer::HugeArray<T>& a, size_t n) {
  for (size_t i = 0; i < n; ++i) a[i] = static_cast<T>(i * 2654435761u);
  size_t wrong = 0;
  for (size_t i = 0; i < n; ++i) wrong += a[i] != static_cast<T>(i * 2654435761u);
  CHECK(wrong == 0);
}

}  // namespace

TEST_CASE("a small HugeArray holds its elements") {
  const size_t n = 1000;
  durer::HugeArray<uint32_t> a(n);
  fillAndCheck(a, n);
  CHECK(reinterpret_cast<uintptr_t>(a.get()) % alignof(uint32_t) == 0);
}

TEST_CASE("a large HugeArray holds its elements and starts on a 2 MiB boundary") {
  using Array = durer::HugeArray<uint64_t>;
  const size_t n = Array::kHugeFrom / sizeof(uint64_t) + 3;  // just past the threshold: a partial last page
  Array a(n);
  fillAndCheck(a, n);
  CHECK(reinterpret_cast<uintptr_t>(a.get()) % Array::kHugePage == 0);
}

TEST_CASE("a HugeArray of over-aligned elements keeps their alignment") {
  struct alignas(64) Line {
    double values[8];
  };
  for (const size_t n : {size_t(3), durer::HugeArray<Line>::kHugeFrom / sizeof(Line) + 1}) {
    durer::HugeArray<Line> a(n);
    CHECK(reinterpret_cast<uintptr_t>(a.get()) % 64 == 0);
    a[n - 1].values[7] = 1.5;
    CHECK(a[n - 1].values[7] == 1.5);
  }
}

#if defined(__linux__) && defined(MADV_FREE)
TEST_CASE("a large HugeArray freed leaves its block for the next one of no more than its size, nor under half") {
  using Array = durer::HugeArray<uint64_t>;
  const size_t n = (size_t(98) << 20) / sizeof(uint64_t) + 3;  // 100 MiB rounded: other tests' blocks are smaller
  const void *first = nullptr, *second = nullptr;
  {
    Array a(n);
    fillAndCheck(a, n);
    first = a.get();
  }
  {
    Array b(n - 1);  // the same rounded size: the kept block, its pages written again
    CHECK(b.get() == first);
    fillAndCheck(b, n - 1);
    Array c(n);  // while b holds it, another block
    CHECK(c.get() != first);
    fillAndCheck(c, n);
    second = c.get();
  }
  Array larger(3 * n);  // none kept is large enough
  CHECK((larger.get() != first && larger.get() != second));
  Array smaller(n * 2 / 5);  // 40 MiB: the kept 100 MiB blocks are more than twice that
  CHECK((smaller.get() != first && smaller.get() != second));
  fillAndCheck(smaller, n * 2 / 5);
  Array half(n / 2 + 1);  // 50 MiB: a kept 100 MiB block serves it
  CHECK((half.get() == first || half.get() == second));
  fillAndCheck(half, n / 2 + 1);
}

TEST_CASE("HugeBlocks keeps at most kKept blocks and kKeptBytes, the oldest freed first") {
  using Blocks = durer::HugeBlocks;
  const size_t page = durer::HugeArray<char>::kHugePage;
  std::vector<void*> made;
  for (int i = 0; i < Blocks::kKept + 2; ++i) {
    made.push_back(std::aligned_alloc(page, page));
    REQUIRE(made.back() != nullptr);
  }
  for (void* p : made) Blocks::give({p, page});
  std::vector<void*> taken;
  for (Blocks::Block b = Blocks::take(page); b.memory != nullptr; b = Blocks::take(page)) taken.push_back(b.memory);
  CHECK(taken.size() == size_t(Blocks::kKept));
  for (void* p : taken) CHECK(std::find(made.begin() + 2, made.end(), p) != made.end());  // the two oldest went
  for (void* p : taken) std::free(p);

  // Three blocks of half kKeptBytes (address space only: never written): the two newest stay.
  const size_t halfLimit = Blocks::kKeptBytes / 2;
  std::vector<void*> large;
  for (int i = 0; i < 3; ++i) {
    large.push_back(std::aligned_alloc(page, halfLimit));
    REQUIRE(large.back() != nullptr);
    Blocks::give({large.back(), halfLimit});
  }
  const Blocks::Block a = Blocks::take(halfLimit), b = Blocks::take(halfLimit);
  CHECK(Blocks::take(halfLimit).memory == nullptr);
  CHECK(((a.memory == large[1] && b.memory == large[2]) || (a.memory == large[2] && b.memory == large[1])));
  std::free(a.memory);
  std::free(b.memory);

  void* huge = std::aligned_alloc(page, Blocks::kKeptBytes + page);
  REQUIRE(huge != nullptr);
  Blocks::give({huge, Blocks::kKeptBytes + page});  // larger than all that may be kept: freed
  CHECK(Blocks::take(Blocks::kKeptBytes + page).memory == nullptr);
}
#endif
