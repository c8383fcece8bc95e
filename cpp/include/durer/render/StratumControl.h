#pragma once
// A pixel stratum's control variate (adaptive sampling: AdaptiveSampler, TileRenderer::silhouetteStrata).
// Where spheres' silhouettes cross a pixel, its samples inside them are weighed by their exact share
// (PixelStratum); each is also taken less a control variate: a model of the spheres' diffuse
// shading there, a function of the sample's position alone, less that model's exact mean over the
// pixel's part. The mean of what is left estimates the part's mean without bias whatever the
// shading, and varies only with what the model leaves out. Its geometry is out of line
// (src/StratumControl.cpp): it is made once a stratum pixel, and does not depend on the kernels'
// precision.
#include <cstdint>

#include "durer/math/Vec.h"
#include "durer/render/PixelStratum.h"

namespace durer {

struct ParallelProjection;

// The directional lights a control reads (the first), and the largest sine of a sphere's angular
// radius, seen from a perspective camera, for which its silhouette's strata take a control
// (ellipseControl): its model of the normal departs from the sphere's by about that sine, and
// beyond it the control may add more spread than it removes (docs/benchmarks.md, fifty-sixth round).
inline constexpr int kMostControlLights = 8;
// The largest radius (pixels) of the disks whose control's parts make their stratum's share (diskControl).
inline constexpr double kMostPartsShareRadius = 16;
inline constexpr double kMostControlSine = 0.1;
// The lattices (points a side) on which diskControl finds, where it does not split exactly, what
// members lose to nearer ones whose fronts cut through theirs: the coarsest, then twice as fine while
// that misses its tolerance, up to the finest.
inline constexpr int kLostGrid = 8;
inline constexpr int kFinestLostGrid = 32;
// The lattice on which diskControl first finds the mean of the shading of the sphere seen over a
// union's part (seenMean), finer than kLostGrid: over the whole part a coarser one's estimate errs
// large (from 8 points a side, the edge scene's estimated RMSE read 1.33-1.49 times its measured; from
// 16, 0.95-1.14), and the fewest of its points inside the union it takes that mean from (fewer, and a
// sliver may lie between them).
inline constexpr int kSeenGrid = 16;
inline constexpr int kLeastSeenPoints = 8;

// The light a control models: the ambient light and the directional lights, each as the unit
// direction toward it (a, b, c) in the camera's frame (x right, y down, toward the camera) and its
// colour (linear RGB).
struct ControlLighting {
  struct Sun {
    double a, b, c;
    Vec3d color;
  };
  Vec3d ambient{0};
  Sun sun[kMostControlLights];
  int suns = 0;
};

// A stratum's control variate: at a sample, the shading of the member seen there, the one whose
// front is nearest (depth[i] less its radius times w, in pixel units: depth[i] its centre's depth less
// the first member's) of those whose disks hold it, less `mean` (linear RGB). A member's shading,
// where the sphere's front has unit normal (u, v, w) in the disk's frame (x right, y down, toward the
// camera; through a perspective camera, the model's axes: ellipseAxes): kd[i] times the ambient
// light plus the sum over the directional lights l of its bit lights[i] of the light's colour times
// its cosine there, max(0, (a_l, b_l, c_l) · (u, v, w)). None where every kd is 0.
struct StratumControl {
  Vec3<float> kd[PixelStratum::kMostDisks];
  uint8_t lights[PixelStratum::kMostDisks];
  float depth[PixelStratum::kMostDisks];
  // Whether the samples less the control are one constant on each part of the pixel: the render's
  // shading is what the control models (TileRenderer::controlIsShading), the plane cuts or hides none
  // of the members (TileRenderer::beforePlane), and outside them lies the plane or the background (one
  // colour), or the cover, whose control this is too (covered()).
  bool exact;
  Vec3<float> mean;
  // The estimated RMS error (over the channels) by which `mean`, found in part numerically
  // (diskControl), puts the pixel's colour off (`mean` times the stratum's share); 0 where exact.
  float meanError;
  // Where a sphere's disk covers the pixel behind a one-disk stratum, that sphere seen all over the
  // stratum's outside (its cover: diskControl's `cover`), a sample outside takes the cover's shading
  // less its mean there: the cover's diffuse colour (0: none), the lights that reach it, its disk
  // (centre and semi-axes' inverses, pixels, rounded to float as a PixelStratum's members) and that
  // mean.
  Vec3<float> coverKd;
  uint8_t coverLights;
  float coverCx, coverCy, coverInverseAx, coverInverseAy;
  Vec3<float> coverMean;
  bool any() const {
    bool some = false;  // without exits: read for every sample inside a stratum
    for (const Vec3<float>& c : kd) some = some || c != Vec3<float>(0);
    return some;
  }
  bool covered() const { return coverKd != Vec3<float>(0); }
};

// A member of an orthographic stratum as its control reads it: the sphere's diffuse colour, its
// centre in the camera's frame (across, up, depth) and its radius.
struct ControlMember {
  Vec3d kd, centre;
  double radius;
};

// The control variate of pixel (x, y)'s orthographic stratum p, whose members' disks are
// members[i]: each member's diffuse shading by the ambient light and by the directional lights that
// reach its part of the pixel (kd times the ambient light plus each light's colour times max(0, N ·
// L), no shadows), where it is the sphere seen (the nearest front), less the mean of that over the
// stratum's inside. Its mean is exact geometry: each member's shading over its disk's part of the
// pixel (UnitDiskPart's area and integrals of the normal, in the pixel's units; where a light's
// terminator crosses the part, the integral of its clamped cosine), less its shading over the part
// of that where another is seen. Where disks overlap in the pixel, the members are ranked by which
// is seen there: of two spheres apart in space, the one whose centre is nearer; of two that cut
// through each other, the one in front all over their overlap within the pixel (seenWithin); a
// member then loses the part nearer members' disks cover (ClippedDiskPart; two nearer ones by
// inclusion and exclusion). Where the one seen changes inside the overlap (the projection of the arc
// where their fronts meet crosses it), with two members: each loses the part of the overlap where
// the other is seen, which that arc bounds (its fans integrated in the arc's parameter), if `split`.
// With three or more, or without `split` (or where the pairs' ranks disagree, or a member has more
// than two nearer ones overlapping it), what each loses where another is seen is found numerically
// instead (the midpoint rule on a kLostGrid lattice over the overlaps' box in the pixel, estimating
// its own error: meanError), where that error is within `tolerance` (finer lattices otherwise, up to
// kFinestLostGrid; beyond, none: 0 asks for exact geometry only). Before all that, where members cut
// through each other and not `split`: the mean of the shading of the member seen over the union's
// part is found on the lattice itself (the midpoint rule over the box the disks span in the pixel
// from kSeenGrid points a side, the mean of the points inside the union, its error estimated as
// above, cpp/tests/test_stratum_control.cpp), where that is within `tolerance` — a fraction of the
// exact parts' cost, which is most of a first pass's where such spheres abound (docs/benchmarks.md,
// sixty-fourth round). A function of a sample's position
// alone whose mean over the inside is 0: the inside's mean of the samples' colours less their
// controls estimates the colours' mean without bias whatever the shading. Where the shading is
// that (diffuse spheres lit by suns, no shadows), a sample's colour less its control is the mean all
// over the inside: exact from one sample. Left: emission, shadows, highlights, other lights, ambient
// occlusion, samples that met something else, which the samples estimate.
// With `cover` (its disk `coverDisk`, pixels), a sphere whose disk covers the pixel behind a
// one-member stratum, no other reaching into it before the cover's centre: where the member is seen
// before it all over the member's part (spheres apart in space, or seenWithin), also the cover's
// control over the outside (StratumControl::covered): its shading there less its exact mean over
// the pixel's square less the member's part, both in the cover's frame (UnitDiskPart,
// ClippedDiskPart).
// p's share is not read (p may be PixelStratum::shaped's). With `share`, sets *share to the union's
// share of the pixel as the members' parts make it, where they partition it along circles and the
// pixel's sides (no split) and no member's radius exceeds kMostPartsShareRadius: p.unionShare's, to
// 1e-13 of the pixel, at no further cost; where found numerically, p.unionShare's; NaN elsewhere.
StratumControl diskControl(int x, int y, const PixelStratum& p, const ControlMember* members, const ControlLighting& light,
                           bool split, double tolerance, double* share = nullptr, const ControlMember* cover = nullptr,
                           const PixelStratum::Ellipse* coverDisk = nullptr);

// diskControl's control of a sample at (x, y) of stratum p's pixel: inside, as diskControl's; outside,
// the cover's where the control has one (StratumControl::covered), else 0.
Vec3d diskControlAt(const PixelStratum& p, const StratumControl& c, const ControlLighting& light, double x, double y);

// A sphere in a frame of pixel units: across, down (in units of the pixels' width: the strata's
// frame for several disks, PixelStratum::of) and depth along the view (farther greater), and radius.
struct PixelBall {
  double x, y, z, r;
};

// Whether the disks of two spheres (PixelBall) overlap within the rectangle [x0, x1] x [y0, y1], and
// if so a point (px, py) of that overlap: where it reaches a side, the middle of the side's stretch
// inside both disks; else it lies inside the rectangle, and so does its middle (between the circles'
// crossings, or the smaller disk's centre).
bool overlapWithin(const PixelBall& a, const PixelBall& b, double x0, double x1, double y0, double y1, double& px, double& py);

// Which of two spheres that cut through each other (or one of which holds the other) is seen all over
// their disks' overlap within the rectangle [x0, x1] x [y0, y1] (in their frame): 1 the first, 2 the
// second, 3 none (their disks do not overlap there), 0 neither (the one seen changes there). The
// fronts meet on the arc of their intersection circle that lies before both centres' depths; seen
// orthographically, an arc of an ellipse inside the overlap, where the sphere seen changes. Where it
// crosses none of the rectangle's sides and its midpoint lies outside it (to 1e-9 of a pixel), one
// sphere is seen all over the overlap there: the one whose front is nearer at a point of it.
int seenWithin(const PixelBall& a, const PixelBall& b, double x0, double x1, double y0, double y1);

// The control variate (kd[0], lights[0] and mean) of pixel (x, y)'s stratum p through a perspective
// camera (`image`), the silhouette of a sphere of diffuse colour kd whose angular radius's sine is
// `sine` (none beyond kMostControlSine): as diskControl's of one disk, the sphere's diffuse shading
// by the ambient light and the directional lights, no shadows, less its mean over the part, with the
// sphere's normal at a sample taken as a disk's through an orthographic camera would be, in the
// ellipse's own frame (ellipseAxes): the part's mean of that is exact geometry (UnitDiskPart of the
// pixel's square in the frame, a parallelogram), whatever the true normal there, which a small
// sphere's follows closely; what the two differ by the samples estimate, with shadows and the rest.
StratumControl ellipseControl(int x, int y, const PixelStratum& p, const Vec3d& kd, double sine, const ParallelProjection& image,
                              const ControlLighting& light);

// ellipseControl's control of a sample at (x, y) inside stratum p.
Vec3d ellipseControlAt(const PixelStratum& p, const StratumControl& c, const ParallelProjection& image, const ControlLighting& light,
                       double x, double y);

// The axes (in the lights' frame: x right, y down, toward the camera) along which a perspective
// stratum's ellipse frame (PixelStratum::frame: u, v across the unit disk, w = sqrt(1 - u^2 - v^2))
// turns a sphere's normal, as an orthographic camera looking along the ray through the ellipse's
// centre would see it: w toward the camera along that ray, u and v toward where the rays through the
// frame's (1, 0) and (0, 1) pass it (unit, each square to that ray). The normal a model reads at
// (u, v): u axes[0] + v axes[1] + w axes[2].
void ellipseAxes(const PixelStratum& p, const ParallelProjection& image, Vec3d* axes);

}  // namespace durer
