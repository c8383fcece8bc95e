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

// Frees every block HugeBlocks keeps (arrays other tests freed), for a test that counts them.
void forgetKept() {
  while (void* p = durer::HugeBlocks::take(0)) std::free(p);
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
TEST_CASE("a large HugeArray freed leaves its block for the next one of no more than its size") {
  using Array = durer::HugeArray<uint64_t>;
  const size_t n = Array::kHugeFrom / sizeof(uint64_t) + 3, bytes = Array::kHugeFrom + Array::kHugePage;
  forgetKept();
  const void* first = nullptr;
  {
    Array a(n);
    fillAndCheck(a, n);
    first = a.get();
  }
  CHECK(durer::HugeBlocks::keptBytes() == bytes);
  {
    Array b(n - 1);  // the same rounded size: the kept block, its pages written again
    CHECK(b.get() == first);
    CHECK(durer::HugeBlocks::keptBytes() == 0);
    fillAndCheck(b, n - 1);
    Array c(n);  // while b holds it, another block
    CHECK(c.get() != first);
    fillAndCheck(c, n);
  }
  Array larger(2 * n);  // none kept is large enough
  CHECK(larger.get() != first);
  fillAndCheck(larger, 2 * n);
}

TEST_CASE("HugeBlocks keeps at most kKept blocks and kKeptBytes, the oldest freed first") {
  using Blocks = durer::HugeBlocks;
  const size_t page = durer::HugeArray<char>::kHugePage;
  forgetKept();
  std::vector<void*> made;
  for (int i = 0; i < Blocks::kKept + 2; ++i) {
    made.push_back(std::aligned_alloc(page, page));
    REQUIRE(made.back() != nullptr);
  }
  for (void* p : made) Blocks::give(p, page);
  CHECK(Blocks::keptBytes() == Blocks::kKept * page);
  std::vector<void*> taken;
  while (void* p = Blocks::take(page)) taken.push_back(p);
  CHECK(taken.size() == size_t(Blocks::kKept));
  for (void* p : taken) CHECK(std::find(made.begin() + 2, made.end(), p) != made.end());  // the two oldest went
  void* huge = std::aligned_alloc(page, Blocks::kKeptBytes + page);
  REQUIRE(huge != nullptr);
  Blocks::give(huge, Blocks::kKeptBytes + page);  // larger than all that is kept: freed
  CHECK(Blocks::keptBytes() == 0);
  for (void* p : taken) std::free(p);
}
#endif
