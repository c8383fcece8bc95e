#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

namespace bench {

// What one tracer made of a workload's camera rays, per pixel, row-major, top row first.
struct Image {
  std::vector<float> depth;  // t along the unit camera ray; +inf on a miss
  std::vector<float> color;  // Dürer's RGBA, with a sun only
  std::vector<uint8_t> lit;  // with a sun: 1 where the hit faces the sun and nothing blocks it
  int64_t rays = 0;          // camera + shadow rays traced

  Image(int width, int height, bool withSun)
      : depth(static_cast<size_t>(width) * height),
        color(withSun ? 4 * depth.size() : 0),
        lit(withSun ? depth.size() : 0) {}
};

}  // namespace bench
