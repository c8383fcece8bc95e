#pragma once
#include <cstdint>
#include <cstring>
#include <limits>

#include "durer/Inline.h"

namespace durer {

// Rays traced together, structure-of-arrays so that the per-primitive loops over rays vectorise.
// 64 rays (an 8x8 pixel tile) keep every array of a packet in L1 while a primitive list streams by.
constexpr int kPacketSize = 64;
// A camera tile's side in pixels: one packet of kPacketSize rays per sample, and a camera view's
// cell (SphereView::kCell), so that a tile's packet reads one cell.
constexpr int kTileSize = 8;
static_assert(kTileSize * kTileSize == kPacketSize, "a tile is one packet");

// Sets all kPacketSize entries of a packet's array (a packet's, or a tile's sums) to `value` in
// 64-byte stores. GCC makes a fixed-size fill of zeros `rep stos`, or calls memset for one of
// `count` entries, whose start-up costs more than the stores: memset, clearing each tile's sums,
// held 4.6 % of a one-sphere render's samples, and the render is 3 % quicker with the stores.
template <typename T>
DURER_INLINE void fillPacket(T* entries, T value) {
  typedef T Lanes __attribute__((vector_size(64)));
  const Lanes lanes = Lanes{} + value;
  for (int i = 0; i < kPacketSize; i += int(sizeof lanes / sizeof(T))) std::memcpy(entries + i, &lanes, sizeof lanes);
}

template <typename Real>
class SphereView;

// Packed index of a primitive during the search (Group packs every primitive set's indices into one range).
constexpr int32_t kNoPrimitive = -1;

template <typename Real>
struct RayPacket {
  int count = 0;                       // rays in use, <= kPacketSize
  Real tMin = 0;                       // hits with t in [tMin, tMax) count
  Real tMax = 0;
  bool commonOrigin = false;           // every ray starts at ox[0], oy[0], oz[0] (a perspective camera's)
  bool coherent = false;               // neighbouring rays of one camera tile: worth traversing together
  // The render's index of the sphere set searched by where the spheres appear (SphereView), or null:
  // for camera rays the camera's, for a light's shadow rays the light's (a sun's image, a point or
  // spot light's cube faces). Camera rays searched through a view carry the box of their sample
  // positions [x0, x1, y0, y1], set by the caller that placed them (placeSamples).
  const SphereView<Real>* view = nullptr;
  // Whether a light's view may record a hit it knows without a test (SphereView::sureHit): such hits
  // hold for the whole segment from the origin to the light, not for a part of it (Group::passInsides).
  bool sureHits = true;
  // NaN until set: a view asked to search a packet without a box finds it outside its cells and
  // declines (SphereView::search returns -1: the caller searches otherwise), never a wrong cell.
  static constexpr Real kNoBox = std::numeric_limits<Real>::quiet_NaN();
  Real sampleBox[4] = {kNoBox, kNoBox, kNoBox, kNoBox};
  // Camera rays one per pixel of the pixels [tileX, tileX + tileWidth) x [tileY, ...), row by row
  // (ray k at pixel (k % tileWidth, k / tileWidth) of them); tileWidth 0: in no such order.
  int tileX = 0, tileY = 0, tileWidth = 0;
  // Camera rays' sample positions in the image, ray k's at (sampleX[k], sampleY[k]): the arrays
  // Camera::generate made the rays from, read during the search that follows; null for other rays.
  // Where the rays are in no pixel order (tileWidth 0), the camera's view tests each sphere against
  // the rays of the pixels it covers by them (SphereView::search).
  const Real* sampleX = nullptr;
  const Real* sampleY = nullptr;
  alignas(64) Real ox[kPacketSize];    // origin, in the frame of the group searched
  alignas(64) Real oy[kPacketSize];
  alignas(64) Real oz[kPacketSize];
  alignas(64) Real dx[kPacketSize];    // direction, same frame, non-zero (any length)
  alignas(64) Real dy[kPacketSize];
  alignas(64) Real dz[kPacketSize];
  alignas(64) Real tHit[kPacketSize];  // in/out: closest t so far; starts at tMax
  alignas(64) int32_t prim[kPacketSize];  // out: packed primitive index of the closest hit, kNoPrimitive on a miss
  // With `leaving` (secondary rays off a hit of the same group: bounces, shadow rays), ray k starts
  // on packed primitive from[k] (kNoPrimitive: none), which the sphere tests may then skip where the
  // ray leaves it (SphereSet::Leaving): most such rays' walks meet their own sphere first.
  bool leaving = false;
  alignas(64) int32_t from[kPacketSize];

  void resetHits() {
    for (int k = 0; k < count; ++k) {
      tHit[k] = tMax;
      prim[k] = kNoPrimitive;
    }
  }
};

}  // namespace durer
