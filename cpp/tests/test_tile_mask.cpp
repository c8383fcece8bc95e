// Unit tests of tiles' pixel masks (TileMask.h) against the pixels they stand for (doctest).
#include <doctest/doctest.h>

#include <cstdint>
#include <random>

#include "durer/render/TileMask.h"

using namespace durer;
using namespace durer::tiles;

TEST_CASE("tileBit numbers a pixel by its row and column in its tile's square, wherever the square lies") {
  CHECK(tileBit(0, 0) == 1);
  CHECK(tileBit(7, 0) == uint64_t(1) << 7);
  CHECK(tileBit(0, 1) == uint64_t(1) << 8);
  CHECK(tileBit(7, 7) == uint64_t(1) << 63);
  CHECK(tileBit(8 * 5 + 3, 8 * 9 + 6) == tileBit(3, 6));
}

TEST_CASE("spreadByOne: the middle tile's pixels with a set pixel of the 3x3 block within one pixel, each way") {
  std::mt19937_64 random(7);
  for (int trial = 0; trial < 4000; ++trial) {
    // Sparse masks (a pixel set in about 1 of 16, or in none of a tile) make the border cases count.
    uint64_t masks[3][3];
    for (auto& row : masks) {
      for (uint64_t& m : row) m = trial % 5 == 0 ? 0 : random() & random() & random() & random();
    }
    // The block as a 24 x 24 image: pixel (x, y) lies in tile (x / 8, y / 8) at its bit tileBit(x, y).
    const auto set = [&](int x, int y) {
      return x >= 0 && y >= 0 && x < 24 && y < 24 && (masks[y / 8][x / 8] & tileBit(x, y)) != 0;
    };
    uint64_t expected = 0;
    for (int y = 8; y < 16; ++y) {
      for (int x = 8; x < 16; ++x) {
        bool any = false;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) any = any || set(x + dx, y + dy);
        }
        if (any) expected |= tileBit(x, y);
      }
    }
    REQUIRE(spreadByOne(masks) == expected);
  }
}
