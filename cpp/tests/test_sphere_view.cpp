// SphereView::Disk, the disk a light's view keeps for each sphere and its core: quantised outward and
// inward, so that a point of the disk it was made from is always held and a point its core holds
// lies in the core it was made from, and tight, so that they spare the tests they are for.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "durer/accel/SphereView.h"

namespace {

using Disk = durer::SphereView<double>::Disk;

// The disk of centre (x, y), radius r and core c, in pixels from its cell's first pixel.
Disk around(double x, double y, double r, double c) { return Disk::quantise(x, y, r, c).inCell(0, 0); }

// Whether the disk made around (x, y) of radius r (core c) holds the point (px, py), all in pixels.
bool holds(double x, double y, double r, double px, double py, double c = 0) {
  return around(x, y, r, c).holds(px * Disk::kUnits, py * Disk::kUnits);
}
bool coreHolds(double x, double y, double r, double c, double px, double py) {
  return around(x, y, r, c).coreHolds(px * Disk::kUnits, py * Disk::kUnits);
}

// The spheres the test views' entries index (search() fetches them ahead of their tests).
const durer::Sphere<double> kSpheres[64] = {};

// A camera's view of one sphere seen on pixels [2, 6] x [2, 6] of a 16 x 16 image, from t = 1 on.
std::unique_ptr<durer::SphereView<double>> oneSphereView() {
  const auto footprints = [](size_t, int, durer::SampleBox* boxes, double* tLows, durer::SampleDisk*, bool* seen) {
    boxes[0] = {2, 6, 2, 6};
    tLows[0] = 1;
    seen[0] = true;
  };
  return durer::SphereView<double>::make(1, footprints, 0, 0, 16, 16, 1);
}

}  // namespace

TEST_CASE("a sun's view's disk holds every point of the disk it was made from, and little more") {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> place(-100, 108), size(0, 20), angle(0, 2 * M_PI);
  int outside = 0, farOutsideHeld = 0, coreTooWide = 0, coreTooNarrow = 0;
  for (int i = 0; i < 200000; ++i) {
    const double x = place(rng), y = place(rng), r = size(rng), a = angle(rng), core = 0.9 * r;
    const double c = std::cos(a), s = std::sin(a);
    // Just outside the core it was made from: never in the core; a fiftieth of a pixel inside: always.
    coreTooWide += coreHolds(x, y, r, core, x + core * (1 + 1e-12) * c, y + core * (1 + 1e-12) * s);
    coreTooNarrow += core > 0.02 && !coreHolds(x, y, r, core, x + (core - 0.02) * c, y + (core - 0.02) * s);
    // On the rim (rounded either way) and just inside it: always held.
    outside += !holds(x, y, r, x + r * c, y + r * s) + !holds(x, y, r, x + r * (1 - 1e-12) * c, y + r * (1 - 1e-12) * s);
    // A fiftieth of a pixel beyond the rim: never (the rounding adds less than 3/256 of a pixel).
    farOutsideHeld += holds(x, y, r, x + (r + 0.02) * c, y + (r + 0.02) * s);
  }
  CHECK(outside == 0);
  CHECK(farOutsideHeld == 0);
  CHECK(coreTooWide == 0);
  CHECK(coreTooNarrow == 0);
}

TEST_CASE("a disk too large or too far for its bits holds every point and has no core; NaN is held") {
  CHECK(!coreHolds(0, 0, 300, 299, 0, 0));
  CHECK(!coreHolds(200, 0, 1, 1, 200, 0));
  CHECK(!coreHolds(0, 0, 1, -0.5, 0, 0));   // a sphere too small for a core
  CHECK(!coreHolds(3, 4, 1, 0.5, NAN, 4));
  CHECK(coreHolds(3, 4, 1, 0.5, 3.2, 4.2));
  CHECK(holds(0, 0, 300, 1e6, -1e6));    // radius beyond 255 pixels
  CHECK(holds(200, 0, 1, -1e6, 1e6));    // centre beyond 128 pixels from the cell
  CHECK(holds(0, -129, 1, 1e6, 1e6));
  CHECK(holds(NAN, 0, 1, 1e6, 1e6));
  CHECK(holds(0, 0, NAN, 1e6, 1e6));
  CHECK(holds(3, 4, 1, NAN, 4));
  CHECK(!holds(3, 4, 1, 5, 4));          // an ordinary disk holds what it should only
  CHECK(holds(3, 4, 1, 3.5, 4.5));
  CHECK(!holds(127, -127, 200, 127, 80));
}

TEST_CASE("a disk rounded once and placed in each cell is the disk made in that cell") {
  // Centres on a 2^-20 pixel grid, so that shifting one by a cell's pixels is exact in double.
  std::mt19937_64 rng(13);
  std::uniform_int_distribution<int64_t> near(-(int64_t(200) << 20), int64_t(200) << 20);  // pixels from the cell
  std::uniform_real_distribution<double> size(0, 300);
  std::uniform_int_distribution<int> cell(0, 2047);
  constexpr int kCell = durer::SphereView<double>::kCell;
  int placedInside = 0;
  for (int i = 0; i < 100000; ++i) {
    const int cx = cell(rng), cy = cell(rng);
    const double x = cx * kCell + std::ldexp(double(near(rng)), -20), y = cy * kCell + std::ldexp(double(near(rng)), -20);
    const double r = size(rng), c = 0.9 * r;
    const Disk placed = Disk::quantise(x, y, r, c).inCell(cx, cy);
    const Disk made = around(x - cx * kCell, y - cy * kCell, r, c);
    CAPTURE(x);
    CAPTURE(y);
    REQUIRE(placed.radius == made.radius);
    REQUIRE(placed.core == made.core);
    if (made.radius != Disk::kEverywhere) {
      REQUIRE(placed.x == made.x);
      REQUIRE(placed.y == made.y);
      ++placedInside;
    }
  }
  CHECK(placedInside > 30000);  // both kinds: disks within 16 bits of their cell and disks beyond
  CHECK(Disk::quantise(1e12, 0, 1, 0.5).inCell(0, 0).radius == Disk::kEverywhere);  // beyond 32 bits
  CHECK(Disk::quantise(NAN, 0, 1, 0.5).inCell(0, 0).radius == Disk::kEverywhere);
}

TEST_CASE("a camera view searches a packet by the box of its samples, and declines one without a box") {
  const std::unique_ptr<durer::SphereView<double>> view = oneSphereView();
  durer::RayPacket<double> packet;
  packet.count = durer::kPacketSize;
  packet.tMax = std::numeric_limits<double>::infinity();
  packet.resetHits();
  int met = 0;
  const auto test = [&](uint32_t, int, int, bool) { ++met; };
  CHECK(view->search(packet, test, kSpheres) == -1);  // no box set: the caller searches otherwise
  CHECK(met == 0);
  const double box[4] = {0.5, 7.5, 0.5, 7.5};  // the first tile's pixel centres
  std::copy(box, box + 4, packet.sampleBox);
  CHECK(view->search(packet, test, kSpheres) > 0);
  CHECK(met == 1);
}

TEST_CASE("a camera view tests a sphere against the rays of the pixels its span covers, where their positions are known") {
  const std::unique_ptr<durer::SphereView<double>> view = oneSphereView();
  // An adaptive round's packet: runs of samples in pixels (0, 0), (3, 3), (4, 5), (7, 7), (5, 3).
  const int pixels[][3] = {{0, 0, 4}, {3, 3, 4}, {4, 5, 3}, {7, 7, 2}, {5, 3, 1}};  // x, y, samples
  double x[durer::kPacketSize], y[durer::kPacketSize];
  durer::RayPacket<double> packet;
  for (const auto& p : pixels) {
    for (int s = 0; s < p[2]; ++s, ++packet.count) x[packet.count] = p[0] + 0.1 + 0.2 * s, y[packet.count] = p[1] + 0.9;
  }
  packet.tMax = std::numeric_limits<double>::infinity();
  packet.resetHits();
  const double box[4] = {0.1, 7.7, 0.9, 7.9};
  std::copy(box, box + 4, packet.sampleBox);
  std::vector<std::array<int, 2>> ranges;
  const auto test = [&](uint32_t, int begin, int end, bool) { ranges.push_back({begin, end}); };
  // Without the positions: every ray.
  CHECK(view->search(packet, test, kSpheres) == 14);
  CHECK(ranges == std::vector<std::array<int, 2>>{{0, 14}});
  // With them: the runs of (3, 3) and (4, 5) together, then (5, 3)'s.
  packet.sampleX = x, packet.sampleY = y;
  ranges.clear();
  CHECK(view->search(packet, test, kSpheres) == 8);
  CHECK(ranges == std::vector<std::array<int, 2>>{{4, 11}, {13, 14}});
  // Samples over two cells: every ray again (the view searches each cell's spheres for all of them).
  x[13] = 8.5, packet.sampleBox[1] = 8.5;
  ranges.clear();
  CHECK(view->search(packet, test, kSpheres) == 14);
  CHECK(ranges == std::vector<std::array<int, 2>>{{0, 14}});
}

TEST_CASE("a packet split into its pixels' runs tests each sphere against exactly the rays of the pixels it covers") {
  // Random views of 40 spheres over a 16 x 16 image (their boxes reaching past it too) and random
  // packets of runs of one pixel's samples in one cell, pixels repeating: every ray whose position
  // lies in a sphere's box is tested against it, and only rays of the pixels the box reaches are.
  std::mt19937 rng(20261201);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<durer::SampleBox> boxes(40);
    for (durer::SampleBox& b : boxes) {
      const double x = -3 + 21 * unit(rng), y = -3 + 21 * unit(rng);
      b = {x, x + 6 * unit(rng), y, y + 6 * unit(rng)};
    }
    const auto footprints = [&](size_t first, int n, durer::SampleBox* box, double* tLow, durer::SampleDisk*, bool* seen) {
      for (int j = 0; j < n; ++j) box[j] = boxes[first + size_t(j)], tLow[j] = 1 + unit(rng), seen[j] = true;
    };
    const auto view = durer::SphereView<double>::make(boxes.size(), footprints, 0, 0, 16, 16, 1);
    REQUIRE(view != nullptr);
    const int cellX = 8 * int(2 * unit(rng)), cellY = 8 * int(2 * unit(rng));
    double x[durer::kPacketSize], y[durer::kPacketSize];
    durer::RayPacket<double> packet;
    while (packet.count < durer::kPacketSize && (packet.count == 0 || unit(rng) < 0.9)) {
      const int px = cellX + int(8 * unit(rng)), py = cellY + int(8 * unit(rng));
      for (int s = 1 + int(8 * unit(rng)); s > 0 && packet.count < durer::kPacketSize; --s, ++packet.count) {
        x[packet.count] = px + unit(rng), y[packet.count] = py + unit(rng);
      }
    }
    packet.tMax = std::numeric_limits<double>::infinity();
    packet.resetHits();
    packet.sampleBox[0] = *std::min_element(x, x + packet.count), packet.sampleBox[1] = *std::max_element(x, x + packet.count);
    packet.sampleBox[2] = *std::min_element(y, y + packet.count), packet.sampleBox[3] = *std::max_element(y, y + packet.count);
    packet.sampleX = x, packet.sampleY = y;
    std::vector<std::vector<bool>> tested(boxes.size(), std::vector<bool>(packet.count, false));
    int64_t pairs = 0;
    const auto test = [&](uint32_t i, int begin, int end, bool) {
      for (int k = begin; k < end; ++k) {
        CHECK_FALSE(tested[i][k]);
        tested[i][k] = true, ++pairs;
      }
    };
    const int64_t reported = view->search(packet, test, kSpheres);  // before `pairs` is read
    CHECK(reported == pairs);
    for (size_t i = 0; i < boxes.size(); ++i) {
      const durer::SampleBox& b = boxes[i];
      for (int k = 0; k < packet.count; ++k) {
        const bool inBox = x[k] >= b.x0 && x[k] <= b.x1 && y[k] >= b.y0 && y[k] <= b.y1;
        const bool inPixels = std::floor(x[k]) >= std::floor(b.x0) && std::floor(x[k]) <= std::floor(b.x1) &&
                              std::floor(y[k]) >= std::floor(b.y0) && std::floor(y[k]) <= std::floor(b.y1);
        if (inBox) CHECK(tested[i][k]);
        if (tested[i][k]) CHECK(inPixels);
      }
    }
  }
}

TEST_CASE("a view whose spheres would make more than kMaxEntriesPerSphere entries a sphere is not made, nor listed to the end") {
  // 8 x 8 cells of a 64 x 64 image; most entries: 16 a sphere and one a cell.
  using View = durer::SphereView<double>;
  const auto covering = [](double side, size_t& asked) {
    return [side, &asked](size_t, int n, durer::SampleBox* boxes, double* tLows, durer::SampleDisk*, bool* seen) {
      asked += size_t(n);
      for (int j = 0; j < n; ++j) boxes[j] = {1, side, 1, side}, tLows[j] = 1, seen[j] = true;
    };
  };
  size_t asked = 0;
  // Four cells each (a sphere over pixels [1, 15]^2): 4 entries a sphere, made.
  CHECK(View::make(1000, covering(15, asked), 0, 0, 64, 64, 1) != nullptr);
  CHECK(asked == 1000);
  // All 64 cells each: 64,000 entries for 1,000 spheres (at most 16,064), not made.
  asked = 0;
  CHECK(View::make(1000, covering(63, asked), 0, 0, 64, 64, 1) == nullptr);
  // 100,000 spheres over every cell: the listing stops once past the most (16 * 100,000 + 64
  // entries: 25,002 spheres), at the next block of footprints.
  asked = 0;
  CHECK(View::make(100000, covering(63, asked), 0, 0, 64, 64, 1) == nullptr);
  CHECK(asked <= 25002 + View::kFootprints);
  CHECK(asked >= 25002);
  // One sphere over every cell: 64 entries, at most 16 + 64: made.
  asked = 0;
  CHECK(View::make(1, covering(63, asked), 0, 0, 64, 64, 1) != nullptr);
}
