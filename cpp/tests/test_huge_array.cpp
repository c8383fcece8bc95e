// HugeArray: a plain array below kHugeFrom, and from it on one aligned to the 2 MiB pages that
// Linux's transparent huge pages need (the madvise itself is advice that the kernel may refuse).
#include <doctest/doctest.h>

#include <cstdint>
#include <initializer_list>

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
