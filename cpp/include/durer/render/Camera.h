#pragma once
#include <algorithm>
#include <cmath>

#include "durer/Options.h"
#include "durer/accel/SphereView.h"
#include "durer/geometry/RayPacket.h"
#include "durer/math/Float.h"
#include "durer/math/Vec.h"
#include "durer/scene/Limits.h"

namespace durer {

// A camera as the user states it. direction and up need not be unit or orthogonal: the frame is
// horizontal = normalize(direction × up), up' = horizontal × direction (the 6.837 construction).
struct CameraSpec {
  Projection projection = Projection::Orthographic;
  Vec3d center{0};         // world space: the eye (perspective) or the image centre (orthographic)
  Vec3d direction{0, 0, -1};
  Vec3d up{0, 1, 0};
  double size = 1;         // orthographic: world-space extent of the fitted dimension; perspective: its field of view, degrees
  Fit fit = Fit::Auto;
  double shiftX = 0;       // image-plane offset in units of the fitted extent, right
  double shiftY = 0;       // likewise, up
  double pixelAspect = 1;  // a pixel's height / width on the image plane (Blender's pixel aspect y / x)
  double tMin = 0;         // camera rays count hits with t in [tMin, tMax), t in world units
  double tMax = 0;
  // Perspective: tMin and tMax bound the distance along the view axis, not along each ray (planes,
  // Blender's clip range); t stays along the ray.
  bool clipPlanes = false;
};

void validate(const CameraSpec& spec);  // throws std::invalid_argument naming the field

// The image plane's pixel pitch and the position of sample (0, 0) on it (at distance 1 for
// perspective), in double: Camera<Real> rounds them to its precision.
struct ImageWindow {
  double pixelWidth, pixelHeight, xOffset, yOffset;
};
ImageWindow imageWindow(const CameraSpec& spec, int width, int height);

// Throws std::invalid_argument naming the camera's fields unless its rays fit `limits`: the
// origins (orthographic: the window around the centre) and, for a perspective camera, the window at
// unit distance. Returns the largest |coordinate| of the rays' origins.
double requireRaysWithin(const CameraSpec& spec, int width, int height, const NumericLimits& limits);

// A camera set up for one image size. Sample positions are in pixels: x right from the left edge,
// y down from the top edge, so pixel (i, j)'s centre is (i + 0.5, j + 0.5). Directions are unit,
// so t is a distance.
template <typename Real>
class Camera {
 public:
  Camera(const CameraSpec& spec, int width, int height);

  void generate(RayPacket<Real>& packet, const Real* sampleX, const Real* sampleY, int count) const;

  // Where camera rays may meet the sphere (center, radius): the box [x0, x1] x [y0, y1] of the
  // sample positions (pixels, as generate takes them) whose rays may meet it, and a lower bound on
  // the t they would meet it at. False if no camera ray can meet it. Conservative for the rays
  // generate makes in Real and the robust sphere test's roots (widened by bounds on both roundings
  // and by 1/64 pixel); infinite ends where the sphere reaches the plane of a perspective eye.
  // With `disk`, also the disk about its centre's position that holds the box's positions that may
  // meet it, and its core: the positions whose ray lines pass through the sphere, shrunk by the
  // same bounds and margin (an orthographic camera: the sphere's own disk; a perspective one: the
  // disks about the projected centre that hold its projected ellipse and lie within it).
  bool footprint(const Vec3d& center, double radius, SampleBox& box, double& tLow, SampleDisk* disk = nullptr) const;

  // The frame and image window in double, as rounded to Real (where a point lies on the image).
  ParallelProjection projection() const {
    return {Vec3d(m_center), Vec3d(m_horizontal), Vec3d(m_up), Vec3d(m_forward), m_pixelWidth, m_pixelHeight,
            m_xOffset, m_yOffset, m_perspective};
  }

  // Whether hits must lie between the near and far planes (CameraSpec::clipPlanes, perspective):
  // the search's [tMin, tMax) along each ray holds them, and clip() keeps only them.
  bool clipsAtPlanes() const { return m_clipPlanes; }

  // Ray k of a packet this camera generated, searched (tHit, prim): a miss if its hit lies beyond the
  // far plane; true if it lies before the near plane, which only rays off the axis can meet (the
  // search counts t from tMin along the ray), and `tMin` is then where the ray crosses that plane.
  bool clip(RayPacket<Real>& packet, int k, Real& tMin) const {
    if (packet.prim[k] == kNoPrimitive) return false;
    const Real scale = planarScale(packet.dx[k], packet.dy[k], packet.dz[k]);
    const Real depth = packet.tHit[k] * scale;
    if (!(depth < m_far)) {
      packet.prim[k] = kNoPrimitive;
      packet.tHit[k] = packet.tMax;
      return false;
    }
    tMin = m_near / scale;
    return depth < m_near && tMin > packet.tHit[k];
  }

  // The factor that turns t along a unit camera ray with direction (dx, dy, dz) into the distance
  // along the view axis: the cosine to it for perspective rays, exactly 1 for orthographic ones.
  Real planarScale(Real dx, Real dy, Real dz) const {
    return m_perspective ? dx * m_forward.x + dy * m_forward.y + dz * m_forward.z : Real(1);
  }

 private:
  // An orthographic footprint's half width in world units: the radius and the rounding bounds.
  double orthographicReach(const ParallelProjection& image, const Vec3d& q, double radius) const;
  // A perspective footprint's disk (footprint's), from the sphere's centre q in the frame, its
  // distance and radius grown and shrunk by the rounding bounds.
  static SampleDisk perspectiveDisk(const ParallelProjection& image, const Vec3d& q, double distance, double grown,
                                    double shrunk);

  bool m_perspective;
  int m_width, m_height;
  Vec3<Real> m_center, m_forward, m_horizontal, m_up;  // unit, orthonormal frame
  Real m_pixelWidth, m_pixelHeight;                    // image-plane units per pixel (at distance 1 for perspective)
  Real m_xOffset, m_yOffset;                           // image-plane position of sample (0, 0)
  Real m_tMin, m_tMax;   // the search's range along each ray
  bool m_clipPlanes;
  Real m_near, m_far;    // clipsAtPlanes(): the planes' distances along the view axis
};

// Inline so that render kernels can inline (and clone) it.
template <typename Real>
inline void Camera<Real>::generate(RayPacket<Real>& packet, const Real* sampleX, const Real* sampleY, int count) const {
  packet.count = count;
  packet.tMin = m_tMin;
  packet.tMax = m_tMax;
  packet.commonOrigin = m_perspective;
  packet.coherent = true;
  packet.view = nullptr;
  packet.tileWidth = 0;
  // The samples' box, over their bits: image positions are >= +0.
  auto x0 = nonNegativeBits(sampleX[0]), x1 = x0, y0 = nonNegativeBits(sampleY[0]), y1 = y0;
  for (int k = 1; k < count; ++k) {
    x0 = std::min(x0, nonNegativeBits(sampleX[k])), x1 = std::max(x1, nonNegativeBits(sampleX[k]));
    y0 = std::min(y0, nonNegativeBits(sampleY[k])), y1 = std::max(y1, nonNegativeBits(sampleY[k]));
  }
  packet.sampleBox[0] = fromNonNegativeBits<Real>(x0), packet.sampleBox[1] = fromNonNegativeBits<Real>(x1);
  packet.sampleBox[2] = fromNonNegativeBits<Real>(y0), packet.sampleBox[3] = fromNonNegativeBits<Real>(y1);
  // Plain component arithmetic so that the loop vectorises.
  const Vec3<Real> c = m_center, f = m_forward, h = m_horizontal, u = m_up;
  if (m_perspective) {
    for (int k = 0; k < count; ++k) {
      const Real x = sampleX[k] * m_pixelWidth + m_xOffset;
      const Real y = m_yOffset - sampleY[k] * m_pixelHeight;
      const Real dx = f.x + x * h.x + y * u.x, dy = f.y + x * h.y + y * u.y, dz = f.z + x * h.z + y * u.z;
      const Real inv = 1 / std::sqrt(dx * dx + dy * dy + dz * dz);
      packet.ox[k] = c.x, packet.oy[k] = c.y, packet.oz[k] = c.z;
      packet.dx[k] = dx * inv, packet.dy[k] = dy * inv, packet.dz[k] = dz * inv;
    }
  } else {
    for (int k = 0; k < count; ++k) {
      const Real x = sampleX[k] * m_pixelWidth + m_xOffset;
      const Real y = m_yOffset - sampleY[k] * m_pixelHeight;
      packet.ox[k] = c.x + x * h.x + y * u.x, packet.oy[k] = c.y + x * h.y + y * u.y;
      packet.oz[k] = c.z + x * h.z + y * u.z;
      packet.dx[k] = f.x, packet.dy[k] = f.y, packet.dz[k] = f.z;
    }
  }
}

}  // namespace durer
