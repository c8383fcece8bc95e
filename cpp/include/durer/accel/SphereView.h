#pragma once
// One render's index of a sphere set by where the spheres appear on an image: the image is cut into
// cells of a camera tile (8x8 pixels), and each cell lists the spheres whose footprint
// (Camera::footprint, conservative) meets it, nearest first by a lower bound on the t at which a ray
// meets them. A camera packet then tests its cell's spheres in that order, each against the rays of
// the pixel rows it covers, and stops at the first sphere that lies beyond every ray's hit so far:
// no hierarchy walk, and the spheres hidden behind the first layer are never touched. A directional
// light's view is the same index over an orthographic image along the light, for its shadow rays; a
// point light's over six perspective images from it, the faces of a cube around it.
// Made once per camera (or light) and image, in O(spheres + entries log(entries per cell)) on the
// render's threads; the sphere set keeps the last few (SphereSet::view).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

#include "durer/HugeArray.h"
#include "durer/Inline.h"
#include "durer/accel/Bvh.h"
#include "durer/geometry/RayPacket.h"
#include "durer/geometry/Sphere.h"
#include "durer/math/Float.h"
#include "durer/math/RadixSort.h"
#include "durer/math/Vec.h"

namespace durer {

// A box of sample positions on an image, in pixels (x right, y down; see Camera).
struct SampleBox {
  double x0, x1, y0, y1;
};

// A disk on an image about where a sphere's centre appears (x, y: a sample position, in pixels):
// every sample position whose ray may meet the sphere lies within `radius` of it, and the line of
// every ray through a position within `core` of it passes inside the sphere by more than the rays'
// rounding (Camera::footprint; core <= 0: none). An infinite or NaN radius: anywhere.
struct SampleDisk {
  double x, y, radius, core;
};

// An image's frame in double (from a camera's frame as rounded to its precision), the one home of
// the map from the image plane to sample positions (Camera::generate's inverse).
struct ParallelProjection {
  Vec3d center, horizontal, up, forward;  // unit, orthonormal up to rounding
  double pixelWidth = 1, pixelHeight = 1, xOffset = 0, yOffset = 0;
  bool perspective = false;  // the image plane at distance 1 from an eye at `center`

  // A world point in the frame: along horizontal, up and forward from the centre.
  Vec3d inFrame(const Vec3d& point) const {
    Vec3d q;
    double distance;
    inFrame(point.x, point.y, point.z, q.x, q.y, q.z, distance);
    return q;
  }
  // The same of the point (x, y, z), numbers or lanes of them (DoubleLanes), and its distance from
  // the centre: glm's dot products and length, term by term.
  template <typename D>
  DURER_INLINE void inFrame(D x, D y, D z, D& qx, D& qy, D& qz, D& distance) const {
    const D dx = x - center.x, dy = y - center.y, dz = z - center.z;
    qx = dx * horizontal.x + dy * horizontal.y + dz * horizontal.z;
    qy = dx * up.x + dy * up.y + dz * up.z;
    qz = dx * forward.x + dy * forward.y + dz * forward.z;
    distance = squareRoot(dx * dx + dy * dy + dz * dz);
  }
  // The sample position (pixels: x right, y down) of image-plane position x or y (orthographic: from
  // the centre, in world units; perspective: at distance 1), of numbers or lanes.
  template <typename D>
  DURER_INLINE D sampleX(D x) const { return (x - xOffset) / pixelWidth; }
  template <typename D>
  DURER_INLINE D sampleY(D y) const { return (yOffset - y) / pixelHeight; }
  // Where a world point lies on the image, in pixels, and how deep: along the view direction
  // (orthographic) or its distance from the eye (perspective: the t of a camera ray). False for a
  // perspective image if the point lies outside the pyramid from the eye over [-1, 1]^2 of the image
  // plane (the eye's cube face along `forward`; a point on its edge lies in two faces).
  bool locate(const Vec3d& point, double& x, double& y, double& depth) const {
    const Vec3d q = inFrame(point);
    if (!perspective) {
      x = sampleX(q.x), y = sampleY(q.y), depth = q.z;
      return true;
    }
    if (!(q.z > 0 && q.z >= std::fabs(q.x) && q.z >= std::fabs(q.y))) return false;
    x = sampleX(q.x / q.z), y = sampleY(q.y / q.z), depth = glm::length(q);
    return true;
  }
};

// What a view is made for: the camera as given and the image size (a light's: its direction). Two
// renders with equal keys of the same prepared spheres share the view.
struct ViewKey {
  static constexpr int kSize = 26;
  double values[kSize] = {};
  bool light = false;  // a light's view, not a camera's
  bool operator==(const ViewKey& other) const {
    return light == other.light && std::memcmp(values, other.values, sizeof values) == 0;
  }
};

template <typename Real>
class SphereView {
 public:
  static constexpr int kCell = kTileSize;  // pixels: a camera tile, so that a tile's packet reads one cell
  // Below this many spheres shadow rays test them all faster than they read a light's view (the
  // hierarchy's threshold). A camera's view pays from one sphere: the tiles off a
  // sphere's footprint skip its test and the rays' terms (SphereSet::intersect), and the others test
  // only the rows it covers.
  static constexpr size_t kMinLightSpheres = kBvhMinPrimitives;
  // Above this many entries per sphere (spheres covering many cells) the view costs more memory
  // than the hierarchy it stands in for: not made.
  static constexpr double kMaxEntriesPerSphere = 16;

  // A disk on a light's image that holds everything a sphere may cover, relative to the first pixel
  // of an entry's cell, in 1/kUnits pixel, and the core about the same centre whose rays surely
  // meet the sphere (Camera::footprint's SampleDisk). Rounded outward and inward:
  // the centre lies within half a unit of the disk's on each axis, less than a unit away, the
  // radius is rounded up from one a unit larger and the core down from one a unit smaller. A disk
  // too large, or too far, for these bits (hundreds of pixels: spheres a hundred times the mean size
  // of a light's view's) holds every point and has no core.
  struct Disk {
    static constexpr double kUnits = 256;
    static constexpr uint16_t kEverywhere = 0xffff;
    int16_t x, y;
    uint16_t radius, core;

    // A disk rounded to units once, its centre from a view's first pixel (in 32 bits: anywhere in
    // a view), then placed in each cell its sphere covers (a whole number of units away).
    struct Quantised {
      int32_t x, y;
      uint16_t radius, core;

      // As seen from cell (cx, cy) of the view.
      Disk inCell(int cx, int cy) const {
        constexpr int64_t kCellUnits = kCell * int64_t(kUnits), kMost = std::numeric_limits<int16_t>::max();
        const int64_t dx = x - cx * kCellUnits, dy = y - cy * kCellUnits;
        if (radius == kEverywhere || dx < -kMost || dx > kMost || dy < -kMost || dy > kMost) {
          return {0, 0, kEverywhere, 0};
        }
        return {int16_t(dx), int16_t(dy), radius, core};
      }
    };
    static Quantised quantise(double x, double y, double r, double c) {
      const double qx = std::nearbyint(x * kUnits), qy = std::nearbyint(y * kUnits), qr = std::ceil(r * kUnits + 1);
      constexpr double kMost = std::numeric_limits<int32_t>::max();
      if (!(std::fabs(qx) <= kMost && std::fabs(qy) <= kMost && qr < kEverywhere)) return {0, 0, kEverywhere, 0};
      const double qc = std::floor(c * kUnits - 1);
      return {int32_t(qx), int32_t(qy), uint16_t(qr), qc > 0 ? uint16_t(std::min(qc, qr)) : uint16_t(0)};
    }
    // Whether it, grown by `grow` units, holds the point (x, y), in units from the cell's first
    // pixel (NaN: it does).
    DURER_INLINE bool holds(double x, double y, double grow = 0) const {
      const double dx = x - double(this->x), dy = y - double(this->y), r = double(radius) + grow;
      return radius == kEverywhere || !(dx * dx + dy * dy > r * r);
    }
    // Whether its core, less `shrink` units, holds it (NaN: no).
    DURER_INLINE bool coreHolds(double x, double y, double shrink = 0) const {
      const double dx = x - double(this->x), dy = y - double(this->y), c = double(core) - shrink;
      return c > 0 && dx * dx + dy * dy < c * c;
    }
  };

  struct Entry {
    uint32_t sphere;  // index in the sphere set
    float tLow;       // no ray of the cell meets it before this t (a light's view: no point nearer the light)
  };

  // How many entries ahead of its test search() fetches a sphere (its `spheres`): each test reads a
  // sphere from anywhere in the set, a miss the next test's branch on the rays' hits would keep the
  // core from reaching on its own. Cached renders of 1M and 10M spheres 13 % and 37 % quicker, a
  // new camera pose of 10M 9-20 % (4 and 16 ahead: no better).
  static constexpr uint32_t kSpheresAhead = 8;
  // Footprints asked for at once (Camera::footprints makes a camera's together).
  static constexpr int kFootprints = 8;

  // The view of `count` spheres over the cells of the pixels [x, x + width) x [y, y + height):
  // footprints(first, n, boxes, tLows, disks, seen) gives spheres first + j's sample boxes and lower
  // bounds, j < n <= kFootprints (seen[j] false: no camera ray meets it), and with `disks` their disks
  // and cores (SampleDisk; else disks is null); each array holds kFootprints. Sphere i is the
  // set's sphere `spheres[i]` (null: i), spheres in increasing order. With disks (a light's view)
  // the entries keep them (Disk) rather than their pixel spans, for occluders() only. Null if it
  // would not pay (see kMaxEntriesPerSphere).
  template <typename Footprints>
  static std::unique_ptr<SphereView> make(size_t count, const Footprints& footprints, int x, int y, int width,
                                          int height, int threads, const uint32_t* spheres = nullptr,
                                          bool disks = false);

  // Calls test(sphere, kBegin, kEnd, all) for the spheres of the packet's cell that some ray may meet
  // before its hit so far, nearest first, with the rays [kBegin, kEnd) that may meet it (test lowers
  // their tHit): those of the pixel rows the sphere covers when the packet is laid out by pixel
  // (tileWidth; `all` false: each of them under the sphere's rows); where the rays' positions are
  // known instead (sampleX), each stretch of consecutive rays whose pixels it covers (`all` false);
  // else all of them (`all` true: any, none or some may meet it), skipping spheres off the pixel
  // rows and columns the packet's samples lie in.
  // `spheres`: those the entries index (the set's), fetched ahead of their tests.
  // Returns the ray-sphere tests made; -1 if the packet's samples fall outside the cells (then the
  // caller searches otherwise).
  template <typename Test>
  DURER_INLINE int64_t search(const RayPacket<Real>& packet, const Test& test, const Sphere<Real>* spheres) const {
    const Real* box = packet.sampleBox;
    const Real cx0 = std::floor(box[0] / kCell) - m_cellX, cx1 = std::floor(box[1] / kCell) - m_cellX;
    const Real cy0 = std::floor(box[2] / kCell) - m_cellY, cy1 = std::floor(box[3] / kCell) - m_cellY;
    if (!(cx0 >= 0 && cy0 >= 0 && cx1 < m_cellsX && cy1 < m_cellsY)) return -1;
    const bool oneCell = cx0 == cx1 && cy0 == cy1;
    const bool byRow = packet.tileWidth > 0 && oneCell;
    // Otherwise, in one cell with the rays' positions known (an adaptive round's packet: a few
    // pixels' samples, each pixel's consecutive), the runs of rays in one pixel: a sphere is tested
    // against the runs of the pixels its span covers, not against every ray of the packet.
    int runs = 0;
    alignas(64) int runBegin[kPacketSize + 1];
    alignas(64) uint8_t runRow[kPacketSize], runColumn[kPacketSize];
    if (!byRow && oneCell && packet.sampleX != nullptr) {
      const int cellRow = (m_cellY + int(cy0)) * kCell, cellColumn = (m_cellX + int(cx0)) * kCell;
      for (int k = 0, last = -1; k < packet.count; ++k) {
        const int row = int(std::floor(packet.sampleY[k])) - cellRow, column = int(std::floor(packet.sampleX[k])) - cellColumn;
        if (row * kCell + column == last) continue;
        last = row * kCell + column;
        runBegin[runs] = k, runRow[runs] = uint8_t(row), runColumn[runs] = uint8_t(column), ++runs;
      }
      runBegin[runs] = packet.count;
    }
    int64_t tested = 0;
    for (int cy = int(cy0); cy <= int(cy1); ++cy) {
      for (int cx = int(cx0); cx <= int(cx1); ++cx) {
        const size_t cell = size_t(cy) * size_t(m_cellsX) + size_t(cx);
        const int cellRow = (m_cellY + cy) * kCell;  // the image row of the cell's first pixel row
        // Laid out: pixel row y of the cell is packet row y + rowShift. Else: the cell's pixel rows
        // [firstRow, lastRow] hold the packet's samples.
        const int rowShift = cellRow - packet.tileY;
        const int rows = byRow ? packet.count / packet.tileWidth : 0;
        const int firstRow = int(std::floor(box[2])) - cellRow, lastRow = int(std::floor(box[3])) - cellRow;
        const int cellColumn = (m_cellX + cx) * kCell;
        const int firstColumn = int(std::floor(box[0])) - cellColumn, lastColumn = int(std::floor(box[1])) - cellColumn;
        Real farthest = farthestHit(packet);
        const uint32_t begin = m_first[cell], end = m_first[cell + 1];
        for (uint32_t e = begin; e < end && e < begin + kSpheresAhead; ++e) __builtin_prefetch(&spheres[m_entries[e].sphere]);
        for (uint32_t e = begin; e != end; ++e) {
          if (e + kSpheresAhead < end) __builtin_prefetch(&spheres[m_entries[e + kSpheresAhead].sphere]);
          const Entry& entry = m_entries[e];
          if (entry.tLow > farthest) break;
          if (byRow) {
            const int first = std::max(firstRowOf(m_spans[e]) + rowShift, 0);
            const int last = std::min(lastRowOf(m_spans[e]) + rowShift, rows - 1);
            if (first > last) continue;
            test(entry.sphere, first * packet.tileWidth, (last + 1) * packet.tileWidth, false);
            tested += (last - first + 1) * packet.tileWidth;
          } else if (runs > 0) {
            const uint16_t span = m_spans[e];
            if (!spanMeets(span, firstRow, lastRow, firstColumn, lastColumn)) continue;
            for (int r = 0, begin = -1; r <= runs; ++r) {  // each stretch of consecutive runs it covers
              const bool covered = r < runs && spanMeets(span, runRow[r], runRow[r], runColumn[r], runColumn[r]);
              if (covered && begin < 0) begin = runBegin[r];
              if (covered || begin < 0) continue;
              test(entry.sphere, begin, runBegin[r], false);
              tested += runBegin[r] - begin, begin = -1;
            }
          } else {
            if (!spanMeets(m_spans[e], firstRow, lastRow, firstColumn, lastColumn)) continue;
            test(entry.sphere, 0, packet.count, true);
            tested += packet.count;
          }
          farthest = farthestHit(packet);
        }
      }
    }
    return tested;
  }

  // A light's view (setLight, made with disks): for each ray k of the packet without a hit, calls
  // test(k, sphere, t) for the spheres of its cell whose disk holds its place on the image (grown
  // by its drift) and that reach nearer the light than its origin, nearest the origin first, until
  // test returns true (an occluder found; t > 0 where the ray surely meets the sphere from t on,
  // sureHit, else 0: the caller tests it); then the same in the light's other faces (addFace), each
  // taking the rays whose origins it holds. The rays travel toward the light: opposite the view's
  // direction, or toward a perspective view's eye. Each ray's search waits on a chain of misses
  // (its cell's bounds, the entries its binary search reads, the disks it scans down from there: a
  // shadow ray's cell is a random place in the view), so the packet's rays take each step
  // together: every ray's cell, then their bounds and entries fetched, then every binary search
  // (without branches, so that the searches overlap), then the lines their scans start on
  // fetched, then each ray's spheres in turn.
  // Returns the ray-sphere tests made.
  template <typename Test>
  int64_t occluders(const RayPacket<Real>& packet, const Test& test) const {
    int rays[kPacketSize];
    uint32_t cells[kPacketSize], ends[kPacketSize];
    double reaches[kPacketSize], nears[kPacketSize], depths[kPacketSize], xs[kPacketSize], ys[kPacketSize],
        drifts[kPacketSize];
    int n = 0;
    for (int k = 0; k < packet.count; ++k) {
      double x, y, depth, cx, cy;
      if (packet.prim[k] != kNoPrimitive || !lightCellOf(packet, k, x, y, depth, cx, cy)) continue;
      const uint32_t cell = uint32_t(size_t(cy) * size_t(m_cellsX) + size_t(cx));
      __builtin_prefetch(&m_first[cell]);
      // Spheres whose nearest depth lies beyond the origin's (widened by its rounding) cannot block it.
      const double slack = depthSlack(depth);
      rays[n] = k, cells[n] = cell, reaches[n] = depth + slack, nears[n] = depth - slack, depths[n] = depth;
      // The ray travels along the view's axis, or toward its eye: it stays at its place on the
      // image (but for its drift), and meets only spheres whose disk holds it, in the cell's units.
      xs[n] = (x - (m_cellX + cx) * kCell) * Disk::kUnits, ys[n] = (y - (m_cellY + cy) * kCell) * Disk::kUnits;
      drifts[n] = driftOf(depth);
      ++n;
    }
    for (int j = 0; j < n; ++j) {  // the entries the searches read first, and the nearest disks
      const uint32_t begin = m_first[cells[j]], end = m_first[cells[j] + 1];
      const char* entries = reinterpret_cast<const char*>(m_entries.get() + begin);
      const size_t bytes = (end - begin) * sizeof(Entry);
      for (size_t b = 0; b < std::min<size_t>(bytes, 512); b += 64) __builtin_prefetch(entries + b);
      __builtin_prefetch(m_disks.get() + begin);
    }
    for (int j = 0; j < n; ++j) ends[j] = upperBound(m_first[cells[j]], m_first[cells[j] + 1], reaches[j]);
    for (int j = 0; j < n; ++j) {  // the scans' first disks: they read from their ends down
      if (ends[j] == m_first[cells[j]]) continue;
      const char* last = reinterpret_cast<const char*>(m_disks.get() + ends[j] - 1);
      __builtin_prefetch(last);
      __builtin_prefetch(last - 64);
    }
    int64_t tested = 0;
    // The disks are read in a stream; the spheres off the ray's place never are.
    for (int j = 0; j < n; ++j) {
      const int k = rays[j];
      for (uint32_t e = ends[j]; e != m_first[cells[j]];) {
        --e;
        const double drift = driftAt(e, drifts[j]);
        if (!m_disks[e].holds(xs[j], ys[j], drift)) continue;
        const double t = sureHit(e, xs[j], ys[j], drift, nears[j], depths[j]);
        tested += t == 0;
        if (test(k, m_entries[e].sphere, t)) break;
      }
    }
    return m_nextFace ? tested + m_nextFace->occluders(packet, test) : tested;
  }

  // On a light's view: whether the edge of a sphere's shadow may cross the part of a plane that
  // world points [0, count) bound (a pixel's part of it: an image maps a plane's lines to lines, so
  // their box on the image holds the part's): whether a sphere that may lie nearer the light than
  // the farthest of them has a disk meeting that box (grown by the rays' drift, as occluders()
  // grows them) whose core does not hold all of it. On a point light's view, in the face that holds
  // every point (true where none does: a part across faces). False where the points lie beyond the
  // cells (no sphere there); true for a disk that holds every point. Conservative: a true may be a
  // part wholly lit or wholly in another sphere's shadow.
  bool shadowEdgeMayCross(const Vec3d* points, int count) const {
    double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0, farthest = -x0;
    for (int i = 0; i < count; ++i) {
      double x, y, depth;
      if (!m_light.locate(points[i], x, y, depth)) return !m_nextFace || m_nextFace->shadowEdgeMayCross(points, count);
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
      farthest = std::max(farthest, depth);
    }
    if (!(x1 - x0 < m_cellsX * kCell && y1 - y0 < m_cellsY * kCell && std::isfinite(farthest))) return true;
    const double slack = depthSlack(farthest);
    const double drift = driftOf(farthest);  // each disk grown by it at its sphere, and a unit for the box's rounding
    const int cx0 = std::max(int(std::floor(x0 / kCell)) - m_cellX, 0), cx1 = std::min(int(std::floor(x1 / kCell)) - m_cellX, m_cellsX - 1);
    const int cy0 = std::max(int(std::floor(y0 / kCell)) - m_cellY, 0), cy1 = std::min(int(std::floor(y1 / kCell)) - m_cellY, m_cellsY - 1);
    for (int cy = cy0; cy <= cy1; ++cy) {
      for (int cx = cx0; cx <= cx1; ++cx) {
        const size_t cell = size_t(cy) * size_t(m_cellsX) + size_t(cx);
        // The box in the cell's units (Disk).
        const double ux0 = (x0 - (m_cellX + cx) * kCell) * Disk::kUnits, ux1 = (x1 - (m_cellX + cx) * kCell) * Disk::kUnits;
        const double uy0 = (y0 - (m_cellY + cy) * kCell) * Disk::kUnits, uy1 = (y1 - (m_cellY + cy) * kCell) * Disk::kUnits;
        const uint32_t end = upperBound(m_first[cell], m_first[cell + 1], farthest + slack);
        for (uint32_t e = m_first[cell]; e != end; ++e) {
          const Disk& d = m_disks[e];
          const double grow = driftAt(e, drift) + 1;
          if (d.radius == Disk::kEverywhere || !std::isfinite(grow)) return true;
          const double near = std::hypot(std::clamp(double(d.x), ux0, ux1) - d.x, std::clamp(double(d.y), uy0, uy1) - d.y);
          if (!(near < double(d.radius) + grow)) continue;
          const double far = std::hypot(std::max(std::fabs(ux0 - d.x), std::fabs(ux1 - d.x)),
                                        std::max(std::fabs(uy0 - d.y), std::fabs(uy1 - d.y)));
          if (!(far < double(d.core) - grow)) return true;
        }
      }
    }
    return false;
  }

  // Calls f(sphere, tLow, rows, columns) for the spheres of the cell holding image pixel (x, y) (a
  // camera's view) that no ray of the cell meets before `before`, nearest first: the t no ray of
  // the cell meets it before, and the pixel rows and columns of the cell (each a first and last, 0
  // to 7) its footprint covers.
  template <typename F>
  void forCellOf(int x, int y, double before, const F& f) const {
    forCellWhile(x, y, [&](uint32_t sphere, float tLow, std::array<int, 2> rows, std::array<int, 2> columns) {
      if (!(double(tLow) < before)) return false;
      f(sphere, tLow, rows, columns);
      return true;
    });
  }

  // As forCellOf, for every sphere of the cell while f returns true.
  template <typename F>
  void forCellWhile(int x, int y, const F& f) const {
    const int cx = x / kCell - m_cellX, cy = y / kCell - m_cellY;
    if (x < 0 || y < 0 || cx < 0 || cy < 0 || cx >= m_cellsX || cy >= m_cellsY) return;
    const size_t cell = size_t(cy) * size_t(m_cellsX) + size_t(cx);
    for (uint32_t e = m_first[cell]; e != m_first[cell + 1]; ++e) {
      const uint16_t span = m_spans[e];
      if (!f(m_entries[e].sphere, m_entries[e].tLow, std::array<int, 2>{firstRowOf(span), lastRowOf(span)},
             std::array<int, 2>{firstColumnOf(span), lastColumnOf(span)})) {
        return;
      }
    }
  }

  // Makes this the view from a light searched by occluders(), made over the light's image
  // (`projection` its frame): a directional light's orthographic one along the way it travels, or
  // one face of a point light's cube of perspective ones (addFace the others).
  void setLight(const ParallelProjection& projection) {
    m_light = projection;
    m_lightReach = maxAbs(projection.center);
    m_lightPixel = std::max(projection.pixelWidth, projection.pixelHeight);
    // A perspective face's plane moves by up to 1 + T² <= 3.1 times an angle (T, the tangent of a
    // direction off its axis, is at most 1.01 sqrt(2)): 4.
    const double perAngle = projection.perspective ? 4 : 1;
    m_driftUnits = perAngle * 64 * std::numeric_limits<Real>::epsilon() /
                   std::min(projection.pixelWidth, projection.pixelHeight) * Disk::kUnits;
    m_lightExtent = std::max(m_cellsX, m_cellsY) * kCell * m_lightPixel;
  }
  void addFace(std::unique_ptr<SphereView> face) {
    if (m_nextFace) {
      m_nextFace->addFace(std::move(face));
    } else {
      m_nextFace = std::move(face);
    }
  }

 private:
  // Whether a ray at (x, y) on a light's view (Disk units of entry e's cell), whose origin lies at
  // `depth` and no nearer the light than `near`, surely meets entry e's sphere: the t, in (0, the
  // ray's t there], from which it does; else 0. It does where the disk's core, less the ray's
  // `drift` (occluders), holds it and the whole sphere lies nearer the light than its origin. The
  // entry's tLow is its near side's depth (a point light's: distance d - R) less up to a float
  // unit. On a sun's view the disk's radius bounds the sphere's half depth R; on a point light's
  // face, the tangent of its half-angle, rho >= R / d, so R <= rho tLow / (1 - rho) and its far
  // side lies within tLow (1 + rho) / (1 - rho) of the light, at t = 1 - distance / depth along the
  // ray (its direction is the way to the light: the light at t = 1).
  DURER_INLINE double sureHit(uint32_t e, double x, double y, double drift, double near, double depth) const {
    const Disk& disk = m_disks[e];
    if (!disk.coreHolds(x, y, drift)) return 0;
    const double low = double(nextUp(m_entries[e].tLow)), reach = double(disk.radius) / Disk::kUnits * m_lightPixel;
    if (!m_light.perspective) {
      const double farSide = low + 2 * reach;
      return farSide < near ? near - farSide : 0;
    }
    if (!(reach < 1 && m_entries[e].tLow > 0)) return 0;
    const double farSide = low * (1 + reach) / (1 - reach);
    return farSide < near ? (near - farSide) / depth : 0;
  }

  // How far the depth of a point at `depth` on a light's view may be off by the rounding of a shadow
  // ray's origin there (occluders: a sphere whose nearest depth lies beyond it cannot block it).
  DURER_INLINE double depthSlack(double depth) const {
    return 64 * std::numeric_limits<Real>::epsilon() * (std::fabs(depth) + m_lightReach);
  }

  // A shadow ray's drift from an origin at `depth`, in Disk units, before driftAt scales it to a
  // sphere.
  DURER_INLINE double driftOf(double depth) const {
    return m_driftUnits * (m_light.perspective ? depth : std::fabs(depth) + m_lightExtent);
  }

  // A ray's drift (occluders: drifts) at entry e's sphere, in Disk units (NaN or inf where the
  // sphere reaches the light: every disk holds the ray, no core does).
  DURER_INLINE double driftAt(uint32_t e, double drift) const {
    return m_light.perspective ? drift / std::max(double(m_entries[e].tLow), 0.0) : drift;
  }

  // Where ray k's origin lies on a light's view: its image position x, y, its depth (along a sun's
  // direction, or its distance from a point light) and its cell (cx, cy). False if it lies in
  // another face of a point light's view (which searches it), or beyond the cells, which hold every
  // sphere's footprint with a cell to spare: no sphere there.
  bool lightCellOf(const RayPacket<Real>& packet, int k, double& x, double& y, double& depth, double& cx,
                   double& cy) const {
    if (!m_light.locate(Vec3d(double(packet.ox[k]), double(packet.oy[k]), double(packet.oz[k])), x, y, depth)) {
      return false;
    }
    cx = std::floor(x / kCell) - m_cellX, cy = std::floor(y / kCell) - m_cellY;
    return cx >= 0 && cy >= 0 && cx < m_cellsX && cy < m_cellsY;
  }

  // std::upper_bound of `reach` among the entries [begin, end) by tLow (the first entry whose tLow
  // exceeds it). GCC makes the comparison a branch; a branch-free form, whose steps depend on the
  // count alone, was no quicker (docs/benchmarks.md): each step waits on its entry's load either way.
  uint32_t upperBound(uint32_t begin, uint32_t end, double reach) const {
    uint32_t low = begin, length = end - begin;
    while (length > 0) {
      const uint32_t half = length / 2, middle = low + half;
      const bool right = !(reach < double(m_entries[middle].tLow));
      low = right ? middle + 1 : low;
      length = right ? length - half - 1 : half;
    }
    return low;
  }

  // The largest t any ray of the packet may still be lowered from (NaN-free: tHit never is NaN).
  // Over the numbers' ordered bits, so that the loop vectorises (over the numbers GCC kept a serial
  // chain of 63 comparisons: 5 % of a primary render).
  DURER_INLINE static Real farthestHit(const RayPacket<Real>& packet) {
    auto farthest = orderedBits(packet.tHit[0]);
    for (int k = 1; k < packet.count; ++k) farthest = std::max(farthest, orderedBits(packet.tHit[k]));
    return fromOrderedBits<Real>(farthest);
  }

  // A sphere's pixel rows [row0, row1] and columns [column0, column1] within a cell, each 0 to 7,
  // in 12 bits: a box of its footprint's pixels that a ray's own pixel must fall in to meet it.
  static uint16_t spanOf(int row0, int row1, int column0, int column1) {
    return uint16_t(column0 << 9 | column1 << 6 | row0 << 3 | row1);
  }
  static int firstRowOf(uint16_t span) { return (span >> 3) & 7; }
  static int lastRowOf(uint16_t span) { return span & 7; }
  static int firstColumnOf(uint16_t span) { return span >> 9; }
  static int lastColumnOf(uint16_t span) { return (span >> 6) & 7; }
  // Whether a span meets the pixel rows [row0, row1] and columns [column0, column1] of its cell.
  static bool spanMeets(uint16_t span, int row0, int row1, int column0, int column1) {
    return firstRowOf(span) <= row1 && lastRowOf(span) >= row0 && firstColumnOf(span) <= column1 &&
           lastColumnOf(span) >= column0;
  }

  // A float's bits as an unsigned key in the float's order (negative below positive).
  static uint32_t orderKey(float value) {
    uint32_t bits;
    std::memcpy(&bits, &value, sizeof bits);
    return (bits & 0x80000000u) ? ~bits : (bits | 0x80000000u);
  }

  // The largest float at most `value` (a lower bound stays one when rounded); NaN: -inf.
  static float floatBelow(double value) {
    return value > -std::numeric_limits<double>::infinity() ? toRealDown<float>(value)
                                                            : -std::numeric_limits<float>::infinity();
  }

  // A sphere's part of one row of a view's cells (make()'s): its cells there and, in a camera's view,
  // its pixel rows in them and its pixel columns in the first and the last (every cell between is
  // covered whole).
  struct Part {
    uint32_t index;  // its place among the spheres make() is given
    float tLow;
    int32_t x0, x1;  // its cells in the row, from the view's first
    uint16_t span;   // rows, first cell's first column, last cell's last column (spanOf)
  };

  // One chunk of spheres' parts, row by row of cells, in the spheres' order, each row's in blocks of
  // a few large arrays (HugeArray: unset until written, in huge pages, their memory kept between
  // renders), and the entries they make in each cell: the thread of a band of rows then reads only
  // its rows' parts, and places and sorts their entries while they are in its caches, rather than
  // reading every sphere's cells and scattering entries over all its cells.
  class RowParts {
   public:
    RowParts(size_t cellsWide, size_t rows, size_t spheres)
        : m_rows(rows), m_counts(cellsWide * rows, 0), m_cellsWide(cellsWide), m_spheres(spheres) {
      // Blocks of about half a row's share of the spheres (16 to 1,024 parts): rows' last blocks
      // left part empty waste at most about the chunk's own size.
      const size_t share = spheres / std::max<size_t>(rows, 1) / 2;
      while (m_block < share && m_block < 1024) m_block *= 2;
    }
    void add(size_t row, const Part& part) {
      Row& r = m_rows[row];
      if (r.free == 0) {
        if (m_used + m_block > m_capacity) grow();
        r.blocks.push_back(&m_arenas.back()[m_used]);
        m_used += m_block;
        r.free = uint32_t(m_block);
      }
      r.blocks.back()[m_block - r.free--] = part;
      m_entries += uint64_t(part.x1 - part.x0 + 1);
      for (int32_t cx = part.x0; cx <= part.x1; ++cx) ++m_counts[row * m_cellsWide + size_t(cx)];
    }
    uint64_t entries() const { return m_entries; }
    uint32_t count(size_t cell) const { return m_counts[cell]; }  // its parts' entries in a cell
    template <typename F>
    void forRow(size_t row, const F& f) const {
      const Row& r = m_rows[row];
      for (size_t b = 0; b < r.blocks.size(); ++b) {
        const size_t n = b + 1 < r.blocks.size() ? m_block : m_block - r.free;
        for (size_t j = 0; j < n; ++j) f(r.blocks[b][j]);
      }
    }

   private:
    struct Row {
      std::vector<Part*> blocks;
      uint32_t free = 0;  // in the last block
    };
    void grow() {  // room for the chunk's spheres (a quarter more: some span two rows), then half of it more
      m_capacity = std::max(m_arenas.empty() ? m_spheres + m_spheres / 4 : (m_spheres + 1) / 2, 64 * m_block);
      m_arenas.emplace_back(m_capacity);
      m_used = 0;
    }
    std::vector<Row> m_rows;
    std::vector<uint32_t> m_counts;  // by cell, row by row
    std::vector<HugeArray<Part>> m_arenas;
    size_t m_cellsWide, m_spheres, m_block = 16, m_used = 0, m_capacity = 0;
    uint64_t m_entries = 0;  // in all rows
  };

  // Sorts entries [begin, end), placed in the spheres' order, nearest first (their tLow, then
  // the sphere), with their spans or disks; the vectors are scratch space.
  void sortCell(uint32_t begin, uint32_t end, std::vector<uint64_t>& order, std::vector<uint64_t>& scratch,
                std::vector<Entry>& entries, std::vector<uint16_t>& spans, std::vector<Disk>& disks);

  int m_cellX = 0, m_cellY = 0;       // the first cell's column and row in the image's cells
  int m_cellsX = 0, m_cellsY = 0;
  std::vector<uint32_t> m_first;      // cell c's entries: [m_first[c], m_first[c + 1]), cells row by row
  HugeArray<Entry> m_entries;
  HugeArray<uint16_t> m_spans;        // the pixel rows and columns of its cell entry e's sphere covers (spanOf)
  HugeArray<Disk> m_disks;            // instead, a view made with disks: entry e's sphere's disk
  bool m_withDisks = false;
  ParallelProjection m_light;         // a light's view: its image
  double m_lightReach = 0;            // ... the largest coordinate of its centre
  double m_lightPixel = 0;            // ... its pixels' larger side, in world units
  // ... and how far a ray may drift off its place on the image: its direction is rounded to Real
  // apart from the view's (a sun's) or from the way through the eye (a point light's) by a few units
  // in the last place, so it passes a sphere off by 64 epsilons of the way it came. On a sun's view
  // that way is less than its depth's magnitude and the image's width together (the spheres'
  // bounds); seen from a point light, the offset at a sphere is an angle of at most that of its
  // depth at the sphere's distance (its entry's tLow). In Disk units: m_driftUnits a unit of way, or
  // of depth over tLow. The footprints' slack holds the rounding of rays that start among the
  // spheres; these may start far beyond them (or far beyond a sphere near the light).
  double m_driftUnits = 0, m_lightExtent = 0;
  std::unique_ptr<SphereView> m_nextFace;  // a point light's view: its next face
};

template <typename Real>
template <typename Footprints>
std::unique_ptr<SphereView<Real>> SphereView<Real>::make(size_t count, const Footprints& footprints, int x, int y,
                                                         int width, int height, int threads, const uint32_t* spheres,
                                                         bool disks) {
  auto view = std::make_unique<SphereView>();
  view->m_withDisks = disks;
  view->m_cellX = x / kCell, view->m_cellY = y / kCell;
  view->m_cellsX = (x + width + kCell - 1) / kCell - view->m_cellX;
  view->m_cellsY = (y + height + kCell - 1) / kCell - view->m_cellY;
  const size_t cellsWide = size_t(view->m_cellsX), cellsHigh = size_t(view->m_cellsY);
  // Each chunk of spheres lists its spheres' parts row by row of cells (RowParts); a light's view
  // keeps each sphere's disk (rounded once, centres from the view's first cell) by its place.
  HugeArray<typename Disk::Quantised> rounds(disks ? count : 0);
  const size_t chunks = chunksFor(count, threads);
  std::vector<RowParts> parts;
  parts.reserve(chunks);
  for (size_t k = 0; k < chunks; ++k) parts.emplace_back(cellsWide, cellsHigh, count / chunks + 1);
  // The most entries a view may have; a chunk past it alone stops listing (no view: spheres large on
  // the image, whose parts would otherwise take memory in proportion to the rows they span).
  const double most = std::min(kMaxEntriesPerSphere * double(count) + double(cellsWide) * double(cellsHigh),
                               double(std::numeric_limits<uint32_t>::max() - 1));
  forChunks(count, chunks, [&](size_t chunk, size_t begin, size_t end) {
    RowParts& own = parts[chunk];
    SampleBox boxes[kFootprints];
    SampleDisk diskOf[kFootprints] = {};  // zeroed: GCC cannot tell that a light's view's are written
    double tLowOf[kFootprints];
    bool seen[kFootprints];
    for (size_t i = begin; i < end && double(own.entries()) <= most; ++i) {
      const size_t j = (i - begin) % kFootprints;
      if (j == 0) footprints(i, int(std::min<size_t>(kFootprints, end - i)), boxes, tLowOf, disks ? diskOf : nullptr, seen);
      if (!seen[j]) continue;
      const SampleBox& box = boxes[j];
      // Cell coordinates relative to the view's first cell, clamped to it (in double: infinite
      // ends and huge boxes stay ordered).
      const double x0 = std::max(std::floor(box.x0 / kCell) - view->m_cellX, 0.0);
      const double x1 = std::min(std::floor(box.x1 / kCell) - view->m_cellX, double(cellsWide) - 1);
      const double y0 = std::max(std::floor(box.y0 / kCell) - view->m_cellY, 0.0);
      const double y1 = std::min(std::floor(box.y1 / kCell) - view->m_cellY, double(cellsHigh) - 1);
      if (!(x0 <= x1 && y0 <= y1)) continue;
      const double firstRow = y0 * kCell, lastRow = y1 * kCell + kCell - 1;
      const double firstColumn = x0 * kCell, lastColumn = x1 * kCell + kCell - 1;
      const auto within = [](double pixel, double first, double last, double cellStart) {
        return std::clamp(int(std::clamp(pixel, first, last) - cellStart), 0, kCell - 1);
      };
      // Its pixel rows in its first and last cell rows, and columns in its first and last cells
      // (every cell between is covered whole); a light's view keeps its disk instead.
      int row0 = 0, row1 = 0, column0 = 0, column1 = 0;
      if (disks) {
        const SampleDisk& disk = diskOf[j];
        rounds[i] = Disk::quantise(disk.x - view->m_cellX * kCell, disk.y - view->m_cellY * kCell, disk.radius,
                                   disk.core);
      } else {
        row0 = within(std::floor(box.y0) - view->m_cellY * kCell, firstRow, lastRow, firstRow);
        row1 = within(std::floor(box.y1) - view->m_cellY * kCell, firstRow, lastRow, y1 * kCell);
        column0 = within(std::floor(box.x0) - view->m_cellX * kCell, firstColumn, lastColumn, firstColumn);
        column1 = within(std::floor(box.x1) - view->m_cellX * kCell, firstColumn, lastColumn, x1 * kCell);
      }
      const float tLow = floatBelow(tLowOf[j]);
      for (int32_t cy = int32_t(y0); cy <= int32_t(y1); ++cy) {
        const uint16_t span = spanOf(cy == int32_t(y0) ? row0 : 0, cy == int32_t(y1) ? row1 : kCell - 1, column0, column1);
        own.add(size_t(cy), {uint32_t(i), tLow, int32_t(x0), int32_t(x1), span});
      }
    }
  });
  // Where each row's entries begin: rows in order, each row's cells in order.
  std::vector<uint64_t> rowStart(cellsHigh + 1, 0);
  for (size_t cy = 0; cy < cellsHigh; ++cy) {
    rowStart[cy + 1] = rowStart[cy];
    for (size_t cell = cy * cellsWide; cell < (cy + 1) * cellsWide; ++cell) {
      for (const RowParts& own : parts) rowStart[cy + 1] += own.count(cell);
    }
  }
  const uint64_t total = rowStart[cellsHigh];
  if (double(total) > most) return nullptr;
  // Entries cell by cell, each thread for a band of cell rows (its own cells, so no two threads write
  // the same): each cell's begin where the chunks' counts before it say, its entries placed in the
  // spheres' order (the chunks' in turn), then sorted nearest first while they are in the caches. As
  // many bands as the entries pay threads for (parallelChunks' rule): a few spheres' view is made on
  // this thread alone.
  std::vector<uint32_t>& first = view->m_first;
  first.assign(cellsWide * cellsHigh + 1, uint32_t(total));
  view->m_entries = HugeArray<Entry>(total);
  view->m_disks = HugeArray<Disk>(disks ? total : 0);
  view->m_spans = HugeArray<uint16_t>(disks ? 0 : total);
  const size_t bands = std::min(chunksFor(size_t(total) + count, threads), cellsHigh);
  forChunks(cellsHigh, bands, [&](size_t, size_t rowBegin, size_t rowEnd) {
    std::vector<uint32_t> next(cellsWide);
    std::vector<uint64_t> order, scratch;
    std::vector<Entry> cellEntries;
    std::vector<uint16_t> cellSpans;
    std::vector<Disk> cellDisks;
    for (size_t cy = rowBegin; cy < rowEnd; ++cy) {
      uint32_t at = uint32_t(rowStart[cy]);
      for (size_t cx = 0; cx < cellsWide; ++cx) {
        first[cy * cellsWide + cx] = next[cx] = at;
        for (const RowParts& own : parts) at += own.count(cy * cellsWide + cx);
      }
      for (const RowParts& own : parts) {
        own.forRow(cy, [&](const Part& part) {
          const uint32_t sphere = spheres ? spheres[part.index] : part.index;
          for (int32_t cx = part.x0; cx <= part.x1; ++cx) {
            const uint32_t e = next[size_t(cx)]++;
            view->m_entries[e] = {sphere, part.tLow};
            if (disks) {
              view->m_disks[e] = rounds[part.index].inCell(cx, int(cy));
            } else {
              const uint16_t span = part.span;
              view->m_spans[e] = spanOf(firstRowOf(span), lastRowOf(span), cx == part.x0 ? firstColumnOf(span) : 0,
                                        cx == part.x1 ? lastColumnOf(span) : kCell - 1);
            }
          }
        });
      }
      for (size_t cx = 0; cx < cellsWide; ++cx) {
        view->sortCell(first[cy * cellsWide + cx], next[cx], order, scratch, cellEntries, cellSpans, cellDisks);
      }
    }
  });
  return view;
}

template <typename Real>
void SphereView<Real>::sortCell(uint32_t begin, uint32_t end, std::vector<uint64_t>& order,
                                std::vector<uint64_t>& scratch, std::vector<Entry>& entries,
                                std::vector<uint16_t>& spans, std::vector<Disk>& disks) {
  if (end - begin < 2) return;
  // Placed in the spheres' order, so (key, place) sorts equal bounds by sphere: one order for any threads.
  order.clear();
  for (uint32_t e = begin; e < end; ++e) order.push_back(uint64_t(orderKey(m_entries[e].tLow)) << 32 | (e - begin));
  // Deep cells (many spheres behind each other: a dense cloud's, ~700 a cell at 10M spheres) by
  // bytes, whose passes do not branch on the keys; std::sort's comparisons mispredict about every
  // other one.
  constexpr uint32_t kRadixFrom = 64;
  if (end - begin < kRadixFrom) {
    std::sort(order.begin(), order.end());
  } else {
    radixSortByHigh32(order, scratch);
  }
  entries.assign(m_entries.get() + begin, m_entries.get() + end);
  if (m_withDisks) {
    disks.assign(m_disks.get() + begin, m_disks.get() + end);
  } else {
    spans.assign(m_spans.get() + begin, m_spans.get() + end);
  }
  for (uint32_t j = 0; j < end - begin; ++j) {
    const uint32_t from = uint32_t(order[j]);
    m_entries[begin + j] = entries[from];
    if (m_withDisks) {
      m_disks[begin + j] = disks[from];
    } else {
      m_spans[begin + j] = spans[from];
    }
  }
}

}  // namespace durer
