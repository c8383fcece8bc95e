#pragma once
// Sorting 64-bit values by their high 32 bits (a key above the value's place, or any payload),
// stably: the order std::sort gives (key << 32 | place) when the places ascend. A byte of the key at
// a time (least significant first), skipping bytes all keys share; no pass branches on the keys,
// where std::sort's comparisons of unordered keys mispredict about every other one.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace durer {

inline void radixSortByHigh32(std::vector<uint64_t>& values, std::vector<uint64_t>& scratch) {
  const size_t n = values.size();
  scratch.resize(n);
  for (int shift = 32; shift < 64; shift += 8) {
    size_t start[257] = {};
    for (const uint64_t v : values) ++start[((v >> shift) & 0xff) + 1];
    if (std::find(start + 1, start + 257, n) != start + 257) continue;  // one byte for all: no move
    for (int b = 0; b < 256; ++b) start[b + 1] += start[b];
    for (const uint64_t v : values) scratch[start[(v >> shift) & 0xff]++] = v;
    values.swap(scratch);
  }
}

}  // namespace durer
