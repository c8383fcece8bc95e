#pragma once
// A tile's pixels as the 64 bits of a mask: pixel (x, y) of the image is bit (y mod 8) * 8 + (x mod 8)
// of the mask of its tile, the kTileSize square of the image's grid that holds it (a tile clipped by
// a region keeps its square's numbering, so that neighbouring tiles' masks line up).
#include <cstdint>

#include "durer/geometry/RayPacket.h"

namespace durer {
namespace tiles {

static_assert(kTileSize == 8, "a tile's pixels are the 64 bits of a mask");

inline uint64_t tileBit(int x, int y) { return uint64_t(1) << ((y % kTileSize) * kTileSize + x % kTileSize); }

// The pixels of the middle tile of a 3x3 block of tiles' masks (masks[row][column], row 0 above,
// column 0 to the left) that have a pixel set in the block within one pixel of them, diagonals and
// themselves included: the block's pixels spread by one each way, seen in the middle tile.
inline uint64_t spreadByOne(const uint64_t (&masks)[3][3]) {
  constexpr uint64_t kFirstColumn = 0x0101010101010101, kLastColumn = kFirstColumn << 7;
  const auto widened = [&](const uint64_t(&row)[3]) {  // a row of tiles' pixels spread across the middle column, a pixel each way
    const uint64_t m = row[1];
    return m | ((m << 1) & ~kFirstColumn) | ((m >> 1) & ~kLastColumn) | ((row[0] & kLastColumn) >> 7) |
           ((row[2] & kFirstColumn) << 7);
  };
  const uint64_t middle = widened(masks[1]);
  return middle | (middle << 8) | (middle >> 8) | (widened(masks[0]) >> 56) | (widened(masks[2]) << 56);
}

}  // namespace tiles
}  // namespace durer
