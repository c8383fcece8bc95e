#pragma once
// The tile kernel: 8x8-pixel tiles traced as packets of camera rays, shaded by PacketShader,
// accumulated over the samples and written to the targets. Instantiated for one precision and sphere
// method per kernel translation unit (src/kernels), each compiled once per instruction set.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <type_traits>
#include <vector>

#include "durer/math/Float.h"
#include "durer/render/Kernels.h"
#include "durer/render/PacketShader.h"
#include "durer/render/PixelSampler.h"
#include "durer/render/PixelStratum.h"
#include "durer/render/StratumControl.h"
#include "durer/render/Renderer.h"
#include "durer/render/Shading.h"

namespace durer {
namespace tiles {

// The shortest mean of a pixel's unit hit normals (relative to the hits) taken as a direction (2^-10).
constexpr double kMinMeanNormal = 1.0 / 1024;

inline RenderSettings::Region regionOf(const RenderSettings& s) {
  return s.region.width != 0 ? s.region : RenderSettings::Region{0, 0, s.width, s.height};
}

// Adaptive sampling's refining rounds from `first` samples a pixel up to `max`, each doubling them.
inline int adaptiveRounds(int first, int max) {
  int rounds = 0;
  for (int n = first; n < max; n *= 2) ++rounds;
  return rounds;
}

// The pixels a render samples: its region, widened under adaptive sampling by a margin of as many
// pixels as it has rounds (each round's marking reads a pixel's neighbours'), and one more (a pixel
// of two samples reports its error from its neighbours' means: AdaptiveSampler::residualError),
// clipped to the image.
inline RenderSettings::Region sampledRegion(const RenderSettings& s) {
  const RenderSettings::Region r = regionOf(s);
  if (s.sampler != SamplerKind::Adaptive) return r;
  const int margin = adaptiveRounds(std::min(s.minSamples, s.samplesPerPixel), s.samplesPerPixel) + 1;
  const int x0 = std::max(0, r.x - margin), y0 = std::max(0, r.y - margin);
  const int x1 = std::min(s.width, r.x + r.width + margin), y1 = std::min(s.height, r.y + r.height + margin);
  return {x0, y0, x1 - x0, y1 - y0};
}

template <typename Real, typename Methods>
class TileRenderer {
 public:
  TileRenderer(const Scene& scene, const Group<Real>& group, const CameraSpec& spec, const RenderSettings& settings,
               const RenderTargets& targets, const EffectSet& effects, const std::atomic<bool>& cancel)
      : m_group(group),
        m_camera(spec, settings.width, settings.height),
        m_shading(scene),
        m_sampler(settings.sampler, settings.samplesPerPixel, settings.seed),
        m_settings(settings),
        m_targets(targets),
        m_cancel(cancel),
        m_flat(scene, group),
        m_shader(group, settings.sphereMethod, m_shading, effects, BounceLimits{settings.maxBounces, settings.minWeight, settings.shadeBack},
                 OcclusionSettings{settings.ambientOcclusion.samples, settings.ambientOcclusion.distance, settings.seed},
                 toReal<Real>(Vec3d(scene.background())), cancel),
        m_objectOf(targets.objectId ? objectTable(group) : std::vector<int32_t>{}),
        m_needHits(targets.color != nullptr && (effects.lit || effects.bounces() || effects.colors)),
        m_needNearest(targets.objectId != nullptr || targets.materialId != nullptr),
        m_needNormals(targets.normal != nullptr || m_needNearest),
        m_shadeBack(settings.shadeBack),
        m_planarDepth(settings.depth == DepthKind::Planar),
        m_region(regionOf(settings)),
        m_firstTileX(m_region.x / kTileSize),
        m_firstTileY(m_region.y / kTileSize),
        m_tilesX((m_region.x + m_region.width + kTileSize - 1) / kTileSize - m_firstTileX),
        m_view(viewOf(group.spheres(), spec, settings, m_camera)),
        m_edgesAtSilhouettes(edgesAtSilhouettes(effects)),
        m_planeCut(m_edgesAtSilhouettes && m_group.planes().size() == 1 &&
                   (std::isfinite(m_camera.tMin()) || std::isfinite(m_camera.tMax()))) {
    if (effects.shadows) {
      std::vector<const SphereView<Real>*> views;
      const bool viewed = viewsLights(effects);
      for (const ShadingLight<Real>& light : m_shading.lights()) {
        const bool seen = light.shadows && viewed && light.viewable();
        const bool sun = light.kind == ShadingLight<Real>::Kind::Directional;
        m_lightViews.push_back(!seen ? nullptr
                               : sun ? lightViewOf(group.spheres(), -Vec3d(light.vector), settings)
                                     : pointLightViewOf(group.spheres(), Vec3d(light.vector), settings));
        views.push_back(m_lightViews.back().get());
      }
      m_shader.useLightViews(std::move(views));
    }
    if (stratifies() && targets.color != nullptr && effects.lit) {  // the strata's control (StratumControl.h)
      const ParallelProjection image = m_camera.projection();
      m_lighting.ambient = Vec3d(m_shading.ambient());
      for (const ShadingLight<Real>& light : m_shading.lights()) {
        if (light.kind != ShadingLight<Real>::Kind::Directional || m_lighting.suns == kMostControlLights) continue;
        const Vec3d toLight(light.vector);
        m_lighting.sun[m_lighting.suns++] = {glm::dot(image.horizontal, toLight), -glm::dot(image.up, toLight),
                                             -glm::dot(image.forward, toLight), Vec3d(light.color)};
      }
      m_controlExact = controlIsShading();
    }
  }

  // Whether camera rays search the scene's own spheres through the camera's view, and the shadow
  // rays toward each light casting shadows through the light's (none made where it would not pay:
  // they walk the spheres' hierarchy then). Below a light view's threshold the rays test every
  // sphere (no hierarchy is built there either).
  bool viewsSpheres() const {
    const size_t spheres = m_group.spheres().size();
    if (spheres == 0) return true;
    if (m_view == nullptr) return false;
    for (size_t l = 0; l < m_lightViews.size(); ++l) {
      const ShadingLight<Real>& light = m_shading.lights()[l];
      const bool needed = light.shadows && light.viewable() && spheres >= SphereView<Real>::kMinLightSpheres;
      if (needed && m_lightViews[l] == nullptr) return false;
    }
    return true;
  }

  // Whether the shadow rays toward the scene's lights search views of its spheres: where at most
  // SphereSet::kMostLightViews lights that views can serve cast shadows (or none does). Beyond, every
  // light's shadow rays walk the spheres' hierarchy, as an area light's and a light of some size's do.
  static bool viewsLights(const EffectSet& effects) {
    return size_t(effects.viewedLights) <= SphereSet<Real>::kMostLightViews;
  }

  // The whole image's tiles that meet the region (a region's tiles are the image's, clipped).
  int64_t tileCount() const {
    const int tilesY = (m_region.y + m_region.height + kTileSize - 1) / kTileSize - m_firstTileY;
    return static_cast<int64_t>(m_tilesX) * tilesY;
  }

  // Renders one tile; returns what it traced (nothing if cancelled before the tile finished).
  RayCounters render(int64_t tile) const {
    return renderTile(tile);
  }

  // The pixels of the region that tile `tile` covers: x0, y0, w, h.
  std::array<int, 4> tileRect(int64_t tile) const {
    const int tileX = (m_firstTileX + static_cast<int>(tile % m_tilesX)) * kTileSize;
    const int tileY = (m_firstTileY + static_cast<int>(tile / m_tilesX)) * kTileSize;
    const int x0 = std::max(tileX, m_region.x), y0 = std::max(tileY, m_region.y);
    return {x0, y0, std::min(tileX + kTileSize, m_region.x + m_region.width) - x0,
            std::min(tileY + kTileSize, m_region.y + m_region.height) - y0};
  }

  // Marks the region's pixels in [x0, x0 + w) x [y0, y0 + h) as a cancelled render left them, not
  // reached: depth and error NaN (no pixel rendered has them), colour (0, 0, 0, 0) as Blender shows
  // a tile not rendered, normal 0, ids -1, samples 0 (the outputs are not cleared before: a render
  // writes every pixel, and these held whatever their memory held, or an earlier render's in `out`).
  void markUnreached(int x0, int y0, int w, int h) const {
    const int xa = std::max(x0, m_region.x), xb = std::min(x0 + w, m_region.x + m_region.width);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (int y = std::max(y0, m_region.y); y < std::min(y0 + h, m_region.y + m_region.height); ++y) {
      for (int x = xa; x < xb; ++x) {
        const size_t i = static_cast<size_t>(y - m_region.y) * m_region.width + (x - m_region.x);
        if (m_targets.color) std::fill_n(m_targets.color + 4 * i, 4, 0.0f);
        if (m_targets.depth) m_targets.depth[i] = nan;
        if (m_targets.normal) std::fill_n(m_targets.normal + 3 * i, 3, 0.0f);
        if (m_targets.objectId) m_targets.objectId[i] = -1;
        if (m_targets.materialId) m_targets.materialId[i] = -1;
        if (m_targets.samples) m_targets.samples[i] = 0;
        if (m_targets.error) m_targets.error[i] = nan;
      }
    }
  }

  // Whether a pass reads the pixels' normals' and nearest hit's sums (the normal and id passes).
  bool needsNormals() const { return m_needNormals; }

 private:
  RayCounters renderTile(int64_t tile) const {
    const auto [x0, y0, w, h] = tileRect(tile);
    const int count = w * h;
    Accumulator acc;
    acc.clear(m_targets.color != nullptr, m_needNormals, m_needNearest || m_sampler.samplesPerPixel() > 1);
    RayCounters counters;
    RayPacket<Real> packet;
    alignas(64) Real sampleX[kPacketSize], sampleY[kPacketSize];
    alignas(64) uint64_t pixels[kPacketSize], seeds[kPacketSize];  // the pixels' linear indices and seeds
    alignas(64) uint32_t index[kPacketSize];
    alignas(64) double u[kPacketSize], v[kPacketSize], pixelX[kPacketSize], pixelY[kPacketSize];
    alignas(64) double lensU[kPacketSize], lensV[kPacketSize];
    const bool lens = m_camera.hasLens();
    // The pixels' positions, and their linear indices where a hash reads them (a centred sampler's
    // offsets read no seeds): loops of a whole tile's known width vectorise (3 % of a one-sphere
    // render as one loop of any width).
    const auto pixelsOf = [&](auto tileWidth) DURER_INLINE_LAMBDA {
      const int width = tileWidth;
      for (int row = 0, k = 0; row < h; ++row) {
        for (int col = 0; col < width; ++col, ++k) pixelX[k] = x0 + col, pixelY[k] = y0 + row;
      }
      if (m_sampler.centred() && !lens) return;
      for (int row = 0, k = 0; row < h; ++row) {
        for (int col = 0; col < width; ++col, ++k) pixels[k] = pixelIndex(x0 + col, y0 + row);
      }
    };
    w == kTileSize ? pixelsOf(std::integral_constant<int, kTileSize>()) : pixelsOf(w);
    m_sampler.pixelSeeds(pixels, count, seeds);  // none for a centred sampler: its offsets read none
    for (int s = 0; s < m_sampler.samplesPerPixel(); ++s) {
      m_sampler.offsets(seeds, count, s, u, v);
      if (m_sampler.centred()) {  // the samples lie at the pixels' centres (exact in Real): their box, known
        for (int k = 0; k < count; ++k) {
          sampleX[k] = static_cast<Real>(pixelX[k] + u[k]), sampleY[k] = static_cast<Real>(pixelY[k] + v[k]);
        }
        const Real centres[4] = {Real(x0 + 0.5), Real(x0 + w - 0.5), Real(y0 + 0.5), Real(y0 + h - 0.5)};
        std::copy(centres, centres + 4, packet.sampleBox);
      } else {
        placeSamples(pixelX, pixelY, u, v, count, sampleX, sampleY, packet.sampleBox);
      }
      if (lens) {
        std::fill(index, index + count, static_cast<uint32_t>(s));
        m_sampler.lensOffsets(pixels, index, count, lensU, lensV);
      }
      m_camera.generate(packet, sampleX, sampleY, count, lens ? lensU : nullptr, lens ? lensV : nullptr);
      packet.view = m_view.get();
      packet.tileX = x0, packet.tileY = y0, packet.tileWidth = w;
      counters.intersectionTests += m_group.template intersect<Methods>(m_settings.sphereMethod, packet, &m_cancel);
      clipToPlanes(packet, counters);
      if (m_cancel.load(std::memory_order_relaxed)) return {};
      accumulate(packet, acc, counters);
      counters.camera += count;
    }
    if (m_cancel.load(std::memory_order_relaxed)) return {};
    std::fill(acc.samples, acc.samples + count, Real(m_sampler.samplesPerPixel()));
    write(acc, x0, y0, w, h);
    return counters;
  }

  // Per-pixel sums over the samples of a tile, structure-of-arrays. It is also the sink the
  // accumulate functions add a packet's samples to, ray k to pixel k (AdaptiveSampler's sink maps the
  // rays to pixels its own way): the add* functions below.
 public:
  struct Accumulator {
    alignas(64) Real r[kPacketSize], g[kPacketSize], b[kPacketSize], a[kPacketSize];  // colour sums
    alignas(64) Real depth[kPacketSize];                                          // nearest t
    alignas(64) Real nx[kPacketSize], ny[kPacketSize], nz[kPacketSize];           // normal sums
    alignas(64) Real hits[kPacketSize];                                           // samples that hit
    alignas(64) Real nearestT[kPacketSize];                                       // t of the nearest hit sample
    alignas(64) Real fx[kPacketSize], fy[kPacketSize], fz[kPacketSize];           // and its normal
    alignas(64) int32_t nearestPrim[kPacketSize];                                 // and its packed primitive
    alignas(64) Real samples[kPacketSize];                                        // samples taken
    bool normals;  // whether the normals' sums are kept (set by clear: adaptive's tile states are
                   // left unset until a worker clears them)
    bool nearest;  // whether addNormal keeps the nearest hit sample: the id passes read it, and the
                   // normal pass where a pixel's samples' normals cancel (never with one sample)
    // Clears the sums (every pixel's: a tile's at the image's edge, with fewer, writes only its
    // own); the colours' only if `keepColors`, the normals' only if `keepNormals`, and the nearest
    // hit's only if `keepNearest` too: nothing reads them otherwise (clearing the normals took 8 % of
    // a depth render; the colours' 2 % of a depth render and 7 % of a depth + normal one).
    void clear(bool keepColors, bool keepNormals, bool keepNearest) {
      normals = keepNormals, nearest = keepNormals && keepNearest;
      const Real inf = std::numeric_limits<Real>::infinity();
      // A loop per kept kind: a loop with the choices inside stays scalar (2 % of a one-sphere render).
      const auto fill = [](std::initializer_list<Real*> sums, Real value) {
        for (Real* sum : sums) fillPacket(sum, value);
      };
      fill({samples}, 0), fill({depth}, inf);
      if (keepColors) fill({r, g, b, a}, 0);
      if (keepNormals) fill({nx, ny, nz, hits}, 0);
      if (nearest) fill({fx, fy, fz}, 0), fill({nearestT}, inf), fillPacket(nearestPrim, kNoPrimitive);
    }
    // Whether sample k's normal is to be added (a colour render makes none: 14 % of its time).
    bool wantsNormal(int) const { return normals; }
    void addColor(int k, Real red, Real green, Real blue, Real alpha) {
      r[k] += red, g[k] += green, b[k] += blue, a[k] += alpha;
    }
    void addColors(const Vec3<Real>* rgb, const Real* alpha, int count) {
      for (int k = 0; k < count; ++k) addColor(k, rgb[k].r, rgb[k].g, rgb[k].b, alpha[k]);
    }
    void addDepth(int k, Real t) { depth[k] = std::min(depth[k], t); }
    // Makes a hit sample of primitive `prim` at t along its ray pixel k's nearest if it is nearer than
    // those before it (the first taken among equally near ones); returns whether it did. Branch-free.
    bool addNearest(int k, bool hit, Real t, int32_t prim) {
      const bool nearer = hit & (t < nearestT[k]);
      nearestT[k] = nearer ? t : nearestT[k];
      nearestPrim[k] = nearer ? prim : nearestPrim[k];
      return nearer;
    }
    // Adds one hit sample's unit normal, at t along its ray, to pixel k (a miss adds nothing).
    void addNormal(int k, Real t, int32_t prim, Real x, Real y, Real z) {
      nx[k] += x, ny[k] += y, nz[k] += z, hits[k] += 1;
      if (!nearest) return;
      const bool nearer = addNearest(k, true, t, prim);
      fx[k] = nearer ? x : fx[k], fy[k] = nearer ? y : fy[k], fz[k] = nearer ? z : fz[k];
    }
  };

  // Pixel (x, y)'s linear index in the whole image: what its samples' hashes are keyed by
  // (PixelSampler), whatever region or tile renders it.
  uint64_t pixelIndex(int x, int y) const { return static_cast<uint64_t>(y) * m_settings.width + x; }

  // The Sobol scrambling seeds of pixel (x, y) (PixelSampler::sobolSeeds), for sobolPositions.
  void sobolSeeds(int x, int y, uint32_t& order, uint32_t& points) const {
    m_sampler.sobolSeeds(pixelIndex(x, y), order, points);
  }

  // Positions in the image of Sobol samples indices[j] of pixels (x[j], y[j]) with those seeds, for
  // j < count (up to a packet), and their box (placeSamples): several pixels' samples in one
  // vectorised loop; with a lens, their lens samples too (PixelSampler::lensOffsets; lensU and lensV
  // are left as they are without one).
  void sobolPositions(const int* x, const int* y, const uint32_t* order, const uint32_t* points,
                      const uint32_t* indices, int count, Real* sampleX, Real* sampleY, Real* box, double* lensU,
                      double* lensV) const {
    alignas(64) double u[kPacketSize], v[kPacketSize];
    PixelSampler::sobolOffsets(order, points, indices, count, u, v);
    placeSamples(x, y, u, v, count, sampleX, sampleY, box);
    if (!m_camera.hasLens()) return;
    alignas(64) uint64_t pixels[kPacketSize];
    for (int j = 0; j < count; ++j) pixels[j] = pixelIndex(x[j], y[j]);
    m_sampler.lensOffsets(pixels, indices, count, lensU, lensV);
  }

  // Traces the samples at (sampleX[j], sampleY[j]) for j < count, whose box is `box` (through the
  // lens at (lensU[j], lensV[j]), sobolPositions') as one packet and adds them to
  // `sink` (an Accumulator's interface, entry j for sample j, in order); prim[j] gets the primitive
  // sample j met and t[j] how far along its ray (inf on a miss, whatever the depth pass measures).
  // With a tileWidth, sample j lies in pixel (tileX + j % tileWidth, tileY + j / tileWidth), which
  // the camera's view culls by (RayPacket::tileWidth); 0: in no such order. False if cancelled.
  template <typename Sink>
  bool trace(const Real* sampleX, const Real* sampleY, const Real* box, const double* lensU, const double* lensV,
             int count, Sink& sink, int32_t* prim, Real* t, RayCounters& counters, int tileX = 0, int tileY = 0,
             int tileWidth = 0) const {
    RayPacket<Real> packet;
    m_camera.generate(packet, sampleX, sampleY, count, lensU, lensV);
    std::copy(box, box + 4, packet.sampleBox);
    packet.view = m_view.get();
    packet.tileX = tileX, packet.tileY = tileY, packet.tileWidth = tileWidth;
    counters.intersectionTests += m_group.template intersect<Methods>(m_settings.sphereMethod, packet, &m_cancel);
    clipToPlanes(packet, counters);
    if (m_cancel.load(std::memory_order_relaxed)) return false;
    accumulate(packet, sink, counters);
    counters.camera += count;
    std::copy(packet.prim, packet.prim + count, prim);
    for (int j = 0; j < count; ++j) {
      t[j] = packet.prim[j] != kNoPrimitive ? packet.tHit[j] : std::numeric_limits<Real>::infinity();
    }
    return true;
  }

  // Marks in crossed[k] (row by row) the pixels of the w x h tile at (x0, y0) that a silhouette of
  // the scene's own spheres crosses nearer than the farthest hit their samples met (farthest[k]: the
  // largest t, inf if one missed): the spheres of the camera's view whose footprint overlaps the
  // pixel without covering it, which the samples may have missed (adaptive sampling's geometric
  // edges, AdaptiveSampler). A footprint is the ellipse inscribed in the sphere's sample box
  // (Camera::footprint): the disk itself seen orthographically (widened by the bounds on the rays'
  // rounding, not by the rows' margin: a pixel whose closed square it misses has no sample that may
  // meet the sphere), close to the projected ellipse in perspective; through a lens, widened by the
  // sphere's blur (the rim where its blurred image may begin). Without a view (none made) nothing is
  // marked.
  // With `smooth` (not null), also marks smooth[k] for the pixels the camera's view proves hold no
  // edge of the scene's geometry: in a render whose every such edge is a silhouette of the view's
  // spheres (m_edgesAtSilhouettes), those no sphere's footprint reaches (its image, widened by the
  // bounds on the rays' rounding: Camera::footprint), and that the scene's plane, if any, does not
  // leave across them at the camera's tMin or tMax. Such a pixel sees one plane or the background,
  // and the contrast with a neighbour a disc reaches is that sphere's (adaptive sampling does not
  // look for an edge there: AdaptiveSampler::mark). Elsewhere, or in other renders, false. One walk
  // of the tile's cell makes both, each sphere's footprint once.
  void markSilhouettes(int x0, int y0, int w, int h, const float* farthest, bool* crossed, bool* smooth) const {
    if (smooth != nullptr) std::fill(smooth, smooth + w * h, m_edgesAtSilhouettes);
    if (m_view == nullptr) return;
    const bool smoothing = smooth != nullptr && m_edgesAtSilhouettes;
    const float deepest = *std::max_element(farthest, farthest + w * h);
    m_view->forCellWhile(x0, y0, [&](uint32_t i, float nearest, std::array<int, 2> rows, std::array<int, 2> columns) {
      // The view lists the cell's spheres nearest first: past the deepest hit none crosses unseen.
      const bool crossing = nearest < deepest;
      if (!crossing && !smoothing) return false;
      const auto open = [&](int k) { return !crossed[k] && nearest < farthest[k]; };
      bool any = false;  // a pixel under it still unmarked, whose samples met something beyond it
      if (crossing) forSpan(x0, y0, w, h, rows, columns, [&](int k, int, int) { any = any || open(k); });
      if (!any && !smoothing) return true;
      const Sphere<Real>& sphere = m_group.spheres().primitive(i);
      SampleBox box;
      double tLow;
      if (!m_camera.footprint(Vec3d(sphere.center), double(sphere.radius), box, tLow)) return true;
      if (seesDisks()) {  // the disk and the rounding bounds alone (kFootprintMargin: for the rows)
        constexpr double m = Camera<Real>::kFootprintMargin;
        box = {box.x0 + m, box.x1 - m, box.y0 + m, box.y1 - m};
      }
      forSpan(x0, y0, w, h, rows, columns, [&](int k, int x, int y) {
        if (smoothing) smooth[k] = smooth[k] && coverOfInscribed(box, x, y, Cover::Inside) == Cover::Outside;
        if (any && open(k)) crossed[k] = coverOfInscribed(box, x, y, Cover::Outside) == Cover::Crosses;
      });
      return true;
    });
    if (smoothing && m_planeCut) markPlaneEnds(x0, y0, w, h, smooth);
  }

  // Whether a light's view may show a shadow's edge on a plane a pixel sees (markShadowEdges).
  bool findsShadowEdges() const {
    return std::any_of(m_lightViews.begin(), m_lightViews.end(), [](const auto& view) { return view != nullptr; });
  }

  // Marks crossed[k] for the pixels of the w x h tile at (x0, y0) (row by row) whose samples all
  // met one of the scene's own planes, prim[k] (uniform[k]), where a light's view of the spheres
  // (a sun's, a point or spot light's: the one its shadow rays search) shows that the edge of a
  // sphere's shadow may cross the pixel's part of that plane (the rays through its corners meet the
  // plane there; SphereView::shadowEdgeMayCross). A shadow is seen only by the samples that land
  // in it: a sliver of one that a pixel's first samples all missed would otherwise be found only
  // from the neighbours. Other receivers (spheres, triangles) and the shadows of lights without a
  // view (area lights, soft shadows, too few spheres) are not looked at.
  void markShadowEdges(int x0, int y0, int w, int h, const int32_t* prim, const bool* uniform, bool* crossed) const {
    const int32_t firstPlane = static_cast<int32_t>(m_group.spheres().size());
    const int32_t planeEnd = firstPlane + static_cast<int32_t>(m_group.planes().size());
    const auto onPlane = [&](int k) { return uniform[k] && !crossed[k] && prim[k] >= firstPlane && prim[k] < planeEnd; };
    bool any = false;
    for (int k = 0; k < w * h; ++k) any = any || onPlane(k);
    if (!any) return;
    const int columns = w + 1;
    Vec3d origin[kCorners], direction[kCorners];
    cornerRays(x0, y0, w, h, origin, direction);
    for (int row = 0, k = 0; row < h; ++row) {
      for (int column = 0; column < w; ++column, ++k) {
        if (!onPlane(k)) continue;
        const Plane<Real>& plane = m_group.planes().primitive(static_cast<size_t>(prim[k] - firstPlane));
        const Vec3d normal(plane.normal), point(plane.point);
        const int c = row * columns + column;
        Vec3d points[4];
        const int at[4] = {c, c + 1, c + columns, c + columns + 1};
        for (int i = 0; i < 4; ++i) {
          const double t = glm::dot(normal, point - origin[at[i]]) / glm::dot(normal, direction[at[i]]);
          points[i] = origin[at[i]] + t * direction[at[i]];
        }
        for (size_t l = 0; l < m_lightViews.size() && !crossed[k]; ++l) {
          if (m_lightViews[l]) crossed[k] = m_lightViews[l]->shadowEdgeMayCross(points, 4);
        }
      }
    }
  }

  // f(k, x, y) for the pixels (x, y) of the w x h tile at (x0, y0) (k: the tile's, row by row) in a
  // span of rows and columns of the tile's cell, as the camera's view gives a sphere's.
  template <typename F>
  static void forSpan(int x0, int y0, int w, int h, std::array<int, 2> rows, std::array<int, 2> columns, const F& f) {
    const int cellX = x0 / kTileSize * kTileSize, cellY = y0 / kTileSize * kTileSize;
    const int row0 = std::max(rows[0], y0 - cellY), row1 = std::min(rows[1], y0 + h - 1 - cellY);
    const int column0 = std::max(columns[0], x0 - cellX), column1 = std::min(columns[1], x0 + w - 1 - cellX);
    for (int row = row0; row <= row1; ++row) {
      for (int column = column0; column <= column1; ++column) {
        f((cellY + row - y0) * w + (cellX + column - x0), cellX + column, cellY + row);
      }
    }
  }

  // Whether pixels may have a silhouette stratum (silhouetteStrata): through a camera without a lens,
  // with a view of the scene's own spheres, whose silhouettes are then exact ellipses of the image.
  bool stratifies() const { return m_view != nullptr && !m_camera.hasLens(); }
  // Whether those silhouettes are disks (an orthographic camera's: its radius over the pixel's width
  // and height), which a stratum may unite and adaptive sampling watches (watchSilhouettes).
  bool seesDisks() const { return stratifies() && !m_camera.projection().perspective; }

  // A strata walk of the tile's cell (w x h pixels at (x0, y0)): the view's spheres nearest first,
  // each made once (make(i)) and handed with each of its span's pixels to update(sphere, i, k, x, y),
  // which returns whether pixel k's bound may have fallen (bound(k): the depth before which a sphere
  // may still change the pixel, -inf once none can). The walk ends at the first sphere whose front
  // lies beyond every pixel's bound; while any bound is infinite (`open` of them), so is the
  // farthest, and it is not looked for.
  template <typename Make, typename Bound, typename Update>
  void walkStrata(int x0, int y0, int w, int h, const Make& make, const Bound& bound, const Update& update) const {
    const double inf = std::numeric_limits<double>::infinity();
    const int count = w * h;
    double settled = inf;
    int open = count;
    m_view->forCellWhile(x0, y0, [&](uint32_t i, float tLow, std::array<int, 2> rows, std::array<int, 2> columns) {
      if (double(tLow) >= settled) return false;
      const auto sphere = make(i);
      bool changed = false;
      forSpan(x0, y0, w, h, rows, columns, [&](int k, int x, int y) {
        const bool wasOpen = bound(k) == inf;
        changed = update(sphere, i, k, x, y) || changed;
        open -= wasOpen && !(bound(k) == inf);
      });
      if (changed) {
        settled = open > 0 ? inf : -inf;
        for (int k = 0; open == 0 && k < count; ++k) settled = std::max(settled, bound(k));
      }
      return true;
    });
  }

  // Sets strata[k] (row by row) for the pixels of the w x h tile at (x0, y0), for a render that
  // stratifies(); through a perspective camera, perspectiveStrata's. Through an orthographic one:
  // the union of the silhouettes of the camera's view's spheres whose edges cross the pixel, where
  // at most PixelStratum::kMostDisks do (more, as in a dense cloud, where a union seldom leaves the
  // pixel a part outside: none), and spheres[k] its sphere where the union is one
  // sphere's silhouette (kNoSphere otherwise). Where spheres overlap or cut through each other, their
  // union's edge is still the edge between some sphere and what lies behind them all: only the edges
  // among them lie inside it, and a sphere's part of the union that no sample has reached (a small
  // sphere poking out of a large one's front, inside its silhouette) is not the union's unsampled
  // part: a sphere of several is watched as any other (watchSilhouettes: the first kWatched in the
  // view's order that no first sample met) until a sample meets it. A pixel's union leaves out the
  // spheres behind a sphere covering the whole pixel (whose surface there lies before its centre's
  // depth): their edges are hidden there, and a pixel with no sphere in front of its cover keeps
  // none. A pixel keeps none either where a sphere outside its union
  // may hide a member's edge: one whose disk overlaps the member's and reaches into the pixel, its
  // front nearer than the edge (a small sphere before a large one's rim): the edge seen is then not
  // the union's, and a part of the stratum holding colours its samples may all have missed would
  // settle the pixel on a wrong mean; but where that sphere is the pixel's cover, it cutting
  // through the members, and a control knows which sphere is seen where, it joins the members (if
  // fewer than kMostDisks, and it hides every other sphere reaching into the pixel: the members'
  // parts and its own are then all of the pixel). A union that fills the pixel (so joined, or of
  // spheres that cut through each other all over it) keeps a stratum for its control alone (share
  // 1, PixelStratum::filling), as a sphere covering a pixel may (fill). Other geometry (planes,
  // triangles, boxes, groups' spheres) and a t_min cutting into a sphere are not looked at: an edge
  // of theirs in a part only costs the stratum its gain (any exact split of the pixel keeps the
  // mean consistent). The view lists a cell's spheres by their fronts' depths: once every pixel has
  // a cover nearer than the next one's front, or too many spheres crossing it, the rest can change
  // nothing and are not read.
  // With `controls` (null unless the render controlsStrata()): each stratum's control variate too
  // (diskControl; `split`: exactly also where the sphere seen changes inside an overlap of two; a
  // control found in part numerically only within `tolerance` of the pixel's colour), written only
  // where the pixel has a stratum (its readers look at the stratum first). Where a
  // sphere covers a pixel and hides every other sphere reaching into it before its centre (each
  // one's centre behind it and the two apart, or the cover seen all over their overlap there), the
  // cover is seen all over the pixel (fill: the disk filling it may be its stratum) or all over a
  // single member's outside (diskControl's cover: the outside's control).
  void silhouetteStrata(int x0, int y0, int w, int h, PixelStratum* strata, uint32_t* spheres,
                        StratumControl* controls, bool split, double tolerance) const {
    constexpr int kMost = PixelStratum::kMostDisks;
    std::fill(strata, strata + w * h, PixelStratum{});
    std::fill(spheres, spheres + w * h, kNoSphere);
    if (!seesDisks()) return perspectiveStrata(x0, y0, w, h, strata, spheres, controls);
    const ParallelProjection image = m_camera.projection();
    const int count = w * h;
    const double inf = std::numeric_limits<double>::infinity();
    ImageDisk member[kMost][kPacketSize];  // the silhouettes whose edges cross the pixel, in the view's order
    uint32_t memberSphere[kMost][kPacketSize];
    int members[kPacketSize];
    double hidden[kPacketSize];  // the depth behind which a sphere covering the pixel hides everything
    uint32_t cover[kPacketSize];  // that sphere
    constexpr int kReached = 4;   // the spheres reaching into the pixel whose fronts lay before `hidden` when met
    uint32_t reached[kReached][kPacketSize];  // (the first kReached), and how many
    int reaching[kPacketSize];
    double deepest[kPacketSize];  // the deepest member's centre
    bool joins[kPacketSize];      // its cover cuts through a member before the member's edge (below)
    std::fill(members, members + count, 0);
    std::fill(joins, joins + count, false);
    std::fill(hidden, hidden + count, inf);
    std::fill(reaching, reaching + count, 0);
    std::fill(deepest, deepest + count, -inf);
    // A sphere can change a pixel's union or cover only if its centre lies before the cover; a pixel
    // more spheres cross than a union holds (members[k] > kMost) keeps none, whatever follows: the
    // farthest of the pixels' bounds bounds the fronts still worth reading.
    const auto bound = [&](int k) { return members[k] <= kMost ? hidden[k] : -inf; };
    walkStrata(x0, y0, w, h, [&](uint32_t i) { return imageDisk(image, i); }, bound,
               [&](const ImageDisk& d, uint32_t i, int k, int x, int y) {
                 if (!(d.q.z - d.radius < hidden[k])) return false;
                 const Cover reach = d.cover(x, y);
                 if (reach != Cover::Outside && reaching[k] < kReached) reached[reaching[k]][k] = i;
                 reaching[k] += reach != Cover::Outside;
                 if (!(d.q.z < hidden[k])) return false;
                 if (reach == Cover::Inside) {
                   hidden[k] = d.q.z, cover[k] = i;
                   return true;
                 }
                 if (reach != Cover::Crosses || members[k] > kMost) return false;
                 if (members[k] < kMost) member[members[k]][k] = d, memberSphere[members[k]][k] = i;
                 ++members[k];
                 return members[k] > kMost;  // the bound moves only with a cover or too many
               });
    double farthest = -inf;  // the deepest member kept
    for (int k = 0; k < count; ++k) {
      int n = 0;
      if (members[k] > kMost) members[k] = 0;  // too many
      for (int m = 0; m < members[k]; ++m) {
        if (!(member[m][k].q.z < hidden[k])) continue;  // behind a cover found after it
        member[n][k] = member[m][k], memberSphere[n][k] = memberSphere[m][k], ++n;
        deepest[k] = std::max(deepest[k], member[m][k].q.z);
      }
      members[k] = n;
      if (n > 0) farthest = std::max(farthest, deepest[k]);
    }
    // Another sphere whose disk overlaps a member's and reaches into the pixel, its front nearer than
    // the member's edge, may hide that edge there (a small sphere before a large one's rim): the edge
    // seen is then not the union's. The pixel's cover so may join the members instead (below).
    m_view->forCellOf(x0, y0, farthest, [&](uint32_t i, float, std::array<int, 2> rows, std::array<int, 2> columns) {
      const ImageDisk d = imageDisk(image, i);
      forSpan(x0, y0, w, h, rows, columns, [&](int k, int x, int y) {
        if (!(d.q.z - d.radius < deepest[k])) return;
        bool hides = false, own = false;
        for (int m = 0; m < members[k]; ++m) {
          const ImageDisk& c = member[m][k];
          const double dx = d.q.x - c.q.x, dy = d.q.y - c.q.y, reach = d.radius + c.radius;
          own = own || memberSphere[m][k] == i;
          hides = hides || (d.q.z - d.radius < c.q.z && dx * dx + dy * dy < reach * reach);
        }
        if (!(hides && !own && d.cover(x, y) != Cover::Outside)) return;
        if (hidden[k] < inf && i == cover[k]) {
          joins[k] = true;
        } else {
          members[k] = 0;
        }
      });
    });
    for (int row = 0, k = 0; row < h; ++row) {
      for (int column = 0; column < w; ++column, ++k) {
        const int x = x0 + column, y = y0 + row;
        // Whether the cover is seen all over the pixel but for the parts of the first `count` members:
        // every other sphere reaching into it before the cover's centre has its centre behind the
        // cover's and lies apart from the cover (so behind its front wherever both are met), or cuts
        // through it and the cover is seen all over their overlap in the pixel (seenWithin).
        const auto coverSeen = [&](int count) {
          if (!(hidden[k] < inf) || reaching[k] > kReached) return false;
          const ImageDisk c = imageDisk(image, cover[k]);
          const double aspect = c.ax / c.ay, scale = c.ax / c.radius;  // y pixels to x's; pixels a world unit
          const auto ball = [&](const ImageDisk& d) { return PixelBall{d.cx - x, (d.cy - y) * aspect, d.q.z * scale, d.ax}; };
          for (int j = 0; j < reaching[k]; ++j) {
            const uint32_t i = reached[j][k];
            bool member = false;
            for (int m = 0; m < count; ++m) member = member || memberSphere[m][k] == i;
            if (i == cover[k] || member) continue;
            const ImageDisk s = imageDisk(image, i);
            const Vec3d d = s.q - c.q;
            const double apart = s.radius + c.radius;
            if (!(s.q.z >= hidden[k] && (glm::dot(d, d) >= apart * apart || seenWithin(ball(c), ball(s), 0, 1, 0, aspect) == 1))) {
              return false;
            }
          }
          return true;
        };
        // A cover cutting through members before their edges joins them where it may (a control, room,
        // and every other sphere reaching into the pixel hidden behind it: coverSeen): their union is
        // then the pixel, and the control knows every sphere seen in it. Where not, no stratum.
        if (joins[k] && members[k] > 0) {
          const int n = members[k];
          if (!(controls && n < kMost && coverSeen(n))) continue;
          member[n][k] = imageDisk(image, cover[k]), memberSphere[n][k] = cover[k], members[k] = n + 1;
        }
        if (members[k] == 0 && controls && m_controlExact && coverSeen(0)) {
          fill(x, y, cover[k], strata[k], spheres[k], controls[k]);
          continue;
        }
        PixelStratum::Ellipse ellipses[kMost];
        for (int m = 0; m < members[k]; ++m) ellipses[m] = {member[m][k].cx, member[m][k].cy, member[m][k].ax, member[m][k].ay};
        const PixelStratum shape = PixelStratum::shaped(ellipses, members[k]);
        if (shape.disks == 0) continue;
        // The control's parts make the union's share too where they partition it (diskControl);
        // elsewhere, and without a control, the union's area does.
        StratumControl control{};
        double share = std::numeric_limits<double>::quiet_NaN();
        if (controls) {
          // A sphere covering the pixel behind one member and seen all over the rest of it
          // (coverSeen): its control over the outside too (diskControl's cover).
          const bool covered = members[k] == 1 && coverSeen(1);
          ControlMember own[kMost];
          for (int m = 0; m < shape.disks; ++m) own[m] = {diffuseOf(memberSphere[m][k]), member[m][k].q, member[m][k].radius};
          ControlMember behind{};
          PixelStratum::Ellipse behindDisk{};
          if (covered) {
            const ImageDisk d = imageDisk(image, cover[k]);
            behind = {diffuseOf(cover[k]), d.q, d.radius}, behindDisk = {d.cx, d.cy, d.ax, d.ay};
          }
          control = diskControl(x, y, shape, own, m_lighting, split, tolerance, &share, covered ? &behind : nullptr, &behindDisk);
        }
        // A union filling the pixel (one the cover joined, or members cutting through each other all
        // over it) keeps a stratum for its control alone: share 1.
        const double inUnion = std::isnan(share) ? shape.unionShare(x, y) : share;
        strata[k] = control.any() && !(static_cast<float>(inUnion) < 1) ? shape.filling() : shape.withShare(inUnion);
        if (!strata[k].any()) continue;
        if (members[k] == 1) spheres[k] = memberSphere[0][k];
        if (controls) {
          const auto before = [&] {  // every member wholly before the plane
            for (int m = 0; m < strata[k].disks; ++m) {
              if (!beforePlane(memberSphere[m][k])) return false;
            }
            return true;
          };
          // None, one colour (the plane or the background), or the cover's.
          const bool outside = strata[k].share == 1 || hidden[k] == inf || (control.covered() && beforePlane(cover[k]));
          control.exact = m_controlExact && control.any() && outside && before();
          controls[k] = control;
        }
      }
    }
  }

  // For silhouetteStrata, a pixel (x, y) whose cover, sphere `sphere`, is seen all over it. Where a
  // neighbour's square lies partly outside the disk (so that its samples may meet other geometry,
  // which would keep the pixel refining to look for an edge: AdaptiveSampler::mark), and the render's
  // shading is the control's (m_controlExact) with the plane hiding none of the sphere's front, the
  // pixel's stratum is the disk filling it (share 1) and its control that sphere's (diskControl),
  // exact: its colour is the control's mean, and it settles at its first samples. Elsewhere none (a
  // disk's inner pixels, whose neighbours see its front too, settle from their samples' errors).
  void fill(int x, int y, uint32_t sphere, PixelStratum& stratum, uint32_t& own, StratumControl& control) const {
    const ImageDisk d = imageDisk(m_camera.projection(), sphere);
    const bool inner = d.contains(x - 1, y - 1) && d.contains(x + 2, y - 1) && d.contains(x - 1, y + 2) && d.contains(x + 2, y + 2);
    if (inner || !beforePlane(sphere)) return;
    const PixelStratum::Ellipse e{d.cx, d.cy, d.ax, d.ay};
    const PixelStratum filled = PixelStratum::shaped(&e, 1).filling();
    const ControlMember member{diffuseOf(sphere), d.q, d.radius};
    const StratumControl c = diskControl(x, y, filled, &member, m_lighting, false, 0);
    if (!filled.any() || !c.any()) return;
    stratum = filled, own = sphere, control = c;
    control.exact = true;
  }

  // Whether a stratum's samples inside it take a control variate (StratumControl.h): a lit colour
  // render through a camera without a lens, with a directional light.
  bool controlsStrata() const { return m_lighting.suns > 0; }

  // The control (diskControl, ellipseControl) of a sample at (x, y) inside stratum p.
  Vec3<Real> control(const PixelStratum& p, const StratumControl& c, double x, double y) const {
    const ParallelProjection image = m_camera.projection();
    return toReal<Real>(image.perspective ? ellipseControlAt(p, c, image, m_lighting, x, y) : diskControlAt(p, c, m_lighting, x, y));
  }

  // Sphere `sphere`'s diffuse colour (its material's, or its own where the spheres are coloured).
  Vec3d diffuseOf(uint32_t sphere) const {
    const auto& set = m_group.spheres();
    return Vec3d(set.colored() ? set.colors()[sphere][0] : m_shading.material(set.materials()[sphere]).diffuse);
  }

  // silhouetteStrata through a perspective camera (strata and spheres already cleared): a pixel's
  // stratum is the one sphere's silhouette whose edge crosses it in front of its cover, where only
  // one does and no other sphere reaching into the pixel has its front nearer than that edge (which
  // it might hide; no overlap test: the ellipses' is not worth its cost here). Depths are distances
  // from the eye along the rays: a sphere's silhouette lies at sqrt(|q|^2 - r^2) from it (q its
  // centre from the eye), where the rays meet it the latest of those through its image (the rest of
  // a covering sphere's image lies before it). A sphere reaching the eye's plane (its image
  // unbounded) or cut by the camera's near bound (ImageEllipse::exact) leaves the pixels it may reach
  // none; the far bound, like other geometry, is not looked at (a stratum whose edge is not the one
  // seen costs only its gain: any exact split keeps the mean consistent). With `controls`: each
  // stratum's control variate too (ellipseControl).
  void perspectiveStrata(int x0, int y0, int w, int h, PixelStratum* strata, uint32_t* spheres, StratumControl* controls) const {
    const ParallelProjection image = m_camera.projection();
    const int count = w * h;
    const double inf = std::numeric_limits<double>::infinity();
    ImageEllipse member[kPacketSize];
    uint32_t memberSphere[kPacketSize];
    int members[kPacketSize];
    double hidden[kPacketSize];  // the edge depth of the nearest sphere covering the pixel
    std::fill(members, members + count, 0);
    std::fill(hidden, hidden + count, inf);
    // A sphere can change a pixel only with its edge before the pixel's cover; one more than one
    // sphere crosses keeps none, whatever follows.
    const auto bound = [&](int k) { return members[k] <= 1 ? hidden[k] : -inf; };
    walkStrata(x0, y0, w, h, [&](uint32_t i) { return imageEllipse(image, i); }, bound,
               [&](const ImageEllipse& e, uint32_t i, int k, int x, int y) {
                 if (members[k] > 1 || !(e.tFront < hidden[k])) return false;
                 if (!e.exact) {  // an edge it shows may cross the pixel anywhere
                   members[k] = 2;
                   return true;
                 }
                 if (!(e.tEdge < hidden[k])) return false;
                 const Cover cover = e.cover(x, y);
                 if (cover == Cover::Inside) {
                   hidden[k] = e.tEdge;
                   return true;
                 }
                 if (cover != Cover::Crosses) return false;
                 if (members[k] == 0) member[k] = e, memberSphere[k] = i;
                 ++members[k];
                 return members[k] > 1;  // the bound moves only with a cover or a second
               });
    double farthest = -inf;  // the deepest edge kept
    for (int k = 0; k < count; ++k) {
      if (members[k] != 1 || !(member[k].tEdge < hidden[k])) members[k] = 0;  // more, or a cover found after it
      if (members[k] == 1) farthest = std::max(farthest, member[k].tEdge);
    }
    m_view->forCellOf(x0, y0, farthest, [&](uint32_t i, float, std::array<int, 2> rows, std::array<int, 2> columns) {
      const ImageEllipse d = imageEllipse(image, i);
      forSpan(x0, y0, w, h, rows, columns, [&](int k, int x, int y) {
        if (members[k] != 1 || memberSphere[k] == i || !(d.tFront < member[k].tEdge)) return;
        if (!d.exact || d.cover(x, y) != Cover::Outside) members[k] = 0;
      });
    });
    for (int row = 0, k = 0; row < h; ++row) {
      for (int column = 0; column < w; ++column, ++k) {
        if (members[k] != 1) continue;
        const ImageEllipse& e = member[k];
        strata[k] = PixelStratum::sheared(x0 + column, y0 + row, e.cx, e.cy, e.l11, e.l12, e.l22);
        if (strata[k].any()) spheres[k] = memberSphere[k];
        if (strata[k].any() && controls) {
          const Sphere<Real>& sphere = m_group.spheres().primitive(memberSphere[k]);
          const double sine = double(sphere.radius) / glm::length(Vec3d(sphere.center) - image.center);
          controls[k] = ellipseControl(x0 + column, y0 + row, strata[k], diffuseOf(memberSphere[k]), sine, image, m_lighting);
        }
      }
    }
  }

  // Sets watched[s][k] (s < kWatched; kNoSphere: none) for the pixels k (row by row) of the w x h
  // tile at (x0, y0) to the first kWatched spheres of the camera's view, by the view's bounds on
  // their fronts' depths (the nearest a sphere may be met anywhere in the cell: tLow), whose
  // silhouettes cross the pixel nearer than `reach`[k] (the farthest hit its samples met where what
  // they met hides all beyond it, else inf), other than its stratum's (stratum[k]) and those that
  // sphere hides there (hides), that cover more than `least` of it (shares[s][k] their share,
  // PixelStratum's), and that none of its samples met (met(k, sphere) false). Such a sphere may show
  // in a part of the pixel no sample reached (a sliver, or one sphere's edge beside another's), or
  // lie hidden there: adaptive sampling keeps the pixel refining while what it may cover unseen
  // exceeds targetError (AdaptiveSampler::unseenShare). For a render that seesDisks().
  template <typename Met>
  void watchSilhouettes(int x0, int y0, int w, int h, const float* reach, const uint32_t* stratum, const Met& met,
                        double least, uint32_t (*watched)[kPacketSize], float (*shares)[kPacketSize]) const {
    for (int s = 0; s < kWatched; ++s) std::fill(watched[s], watched[s] + w * h, kNoSphere);
    const ParallelProjection image = m_camera.projection();
    const float deepest = *std::max_element(reach, reach + w * h);
    m_view->forCellOf(x0, y0, deepest, [&](uint32_t i, float nearest, std::array<int, 2> rows, std::array<int, 2> columns) {
      const ImageDisk d = imageDisk(image, i);
      forSpan(x0, y0, w, h, rows, columns, [&](int k, int x, int y) {
        if (!(nearest < reach[k]) || stratum[k] == i || watched[kWatched - 1][k] != kNoSphere) return;
        const double boxShare = std::max(0.0, std::min(x + 1.0, d.cx + d.ax) - std::max(double(x), d.cx - d.ax)) *
                                std::max(0.0, std::min(y + 1.0, d.cy + d.ay) - std::max(double(y), d.cy - d.ay));
        if (!(boxShare > least) || d.cover(x, y) != Cover::Crosses || met(k, i)) return;
        if (stratum[k] != kNoSphere && hides(imageDisk(image, stratum[k]), d, x, y)) return;
        const float share = PixelStratum::of(x, y, d.cx, d.cy, d.ax, d.ay).share;
        if (!(share > least)) return;
        for (int s = 0; s < kWatched; ++s) {
          if (watched[s][k] == kNoSphere) {
            watched[s][k] = i, shares[s][k] = share;
            break;
          }
        }
      });
    });
  }

  // How pixel (x, y)'s square lies against the axis-aligned ellipse of centre (cx, cy) and semi-axes
  // ax, ay: in the frame where the ellipse is the unit disk, its farthest corner inside (Inside), or
  // its nearest point inside and its farthest corner outside (Crosses), or neither (Outside).
  enum class Cover { Outside, Crosses, Inside };
  static Cover coverOf(double cx, double cy, double ax, double ay, int x, int y) {
    const double u0 = (x - cx) / ax, u1 = (x + 1 - cx) / ax, v0 = (y - cy) / ay, v1 = (y + 1 - cy) / ay;
    const double nu = u0 > 0 ? u0 : u1 < 0 ? u1 : 0, nv = v0 > 0 ? v0 : v1 < 0 ? v1 : 0;
    const double fu = std::max(u0 * u0, u1 * u1), fv = std::max(v0 * v0, v1 * v1);
    if (fu + fv <= 1) return Cover::Inside;
    return nu * nu + nv * nv < 1 ? Cover::Crosses : Cover::Outside;
  }

  // How pixel (x, y)'s square lies against the ellipse inscribed in `box` (coverOf): `unbounded` for
  // a box reaching infinity (a sphere reaching a perspective eye's plane), Outside for an empty one.
  static Cover coverOfInscribed(const SampleBox& box, int x, int y, Cover unbounded) {
    const double cx = (box.x0 + box.x1) / 2, cy = (box.y0 + box.y1) / 2;
    const double ax = (box.x1 - box.x0) / 2, ay = (box.y1 - box.y0) / 2;
    if (!(std::isfinite(cx) && std::isfinite(cy) && std::isfinite(ax) && std::isfinite(ay))) return unbounded;
    if (!(ax > 0 && ay > 0)) return Cover::Outside;
    return coverOf(cx, cy, ax, ay, x, y);
  }

  static constexpr uint32_t kNoSphere = std::numeric_limits<uint32_t>::max();  // no sphere of the view
  static constexpr int kWatched = 2;  // spheres a pixel watches for (watchSilhouettes)

  // A sphere of the camera's view as an orthographic image shows it: its centre in the image's frame
  // (q.z: the depth of its silhouette's points), its radius, and its disk in pixels (centre cx, cy,
  // semi-axes ax, ay: an ellipse where pixels are not square).
  struct ImageDisk {
    Vec3d q;
    double radius, cx, cy, ax, ay;
    Cover cover(int x, int y) const { return coverOf(cx, cy, ax, ay, x, y); }
    // Whether the image point (x, y) (pixels) lies inside (in double, not as a PixelStratum rounds
    // it to float: a count of samples, not a share).
    bool contains(double x, double y) const {
      const double u = (x - cx) / ax, v = (y - cy) / ay;
      return u * u + v * v < 1;
    }
  };
  ImageDisk imageDisk(const ParallelProjection& image, uint32_t sphere) const {
    const Sphere<Real>& s = m_group.spheres().primitive(sphere);
    const Vec3d q = image.inFrame(Vec3d(s.center));
    const double r = double(s.radius);
    return {q, r, image.sampleX(q.x), image.sampleY(q.y), r / image.pixelWidth, r / image.pixelHeight};
  }

  // Sphere `sphere`'s silhouette in the image. For a render that seesDisks().
  ImageDisk silhouette(uint32_t sphere) const { return imageDisk(m_camera.projection(), sphere); }

  // Whether a sample that met primitive `prim` met one of the scene's own spheres (the camera's view's).
  bool metSphere(int32_t prim) const { return prim >= 0 && static_cast<size_t>(prim) < m_group.spheres().size(); }

  // Whether primitive `prim`, which a sample of pixel (x, y) met, is taken to hide whatever lies
  // beyond it all over the pixel: one of the top-level group's own spheres if its silhouette covers
  // the pixel; anything else (a plane is unbounded; a group's or a mesh's primitive is not looked
  // into). For a render that seesDisks().
  bool hidesBeyond(int32_t prim, int x, int y) const {
    if (prim < 0 || static_cast<size_t>(prim) >= m_group.spheres().size()) return true;
    return silhouette(static_cast<uint32_t>(prim)).cover(x, y) == Cover::Inside;
  }

  // A sphere of the camera's view as a perspective image shows it: the ellipse of the sample
  // positions whose rays' lines pass through it, a du^2 + 2 b du dv + c dv^2 < 1 about its centre
  // (cx, cy), and that form's Cholesky factor, (l11 du + l12 dv)^2 + (l22 dv)^2 (PixelStratum::sheared);
  // the distances from the eye to its nearest point and to its silhouette (along the rays that graze
  // it). `exact` false where the sphere reaches the eye's plane (its image is then no ellipse; the
  // rest unset) or the camera's near bound cuts into it (t_min, or the near plane: rays through its
  // image may meet its inside or what lies behind it, so its edge there is not its silhouette).
  struct ImageEllipse {
    double cx, cy, a, b, c, l11, l12, l22, tFront, tEdge;
    bool exact;

    double form(double du, double dv) const { return a * du * du + 2 * b * du * dv + c * dv * dv; }
    // How pixel (x, y)'s square lies against it: Inside if its farthest corner is within, Crosses if
    // its nearest point is (the centre in the square, or a side's least value of the form, where
    // the form along it is least, below 1), else Outside.
    Cover cover(int x, int y) const {
      const double du0 = x - cx, du1 = du0 + 1, dv0 = y - cy, dv1 = dv0 + 1;
      if (std::max(std::max(form(du0, dv0), form(du1, dv0)), std::max(form(du0, dv1), form(du1, dv1))) <= 1) {
        return Cover::Inside;
      }
      if (du0 <= 0 && du1 >= 0 && dv0 <= 0 && dv1 >= 0) return Cover::Crosses;
      double nearest = std::numeric_limits<double>::infinity();
      for (const double du : {du0, du1}) nearest = std::min(nearest, form(du, std::clamp(-b * du / c, dv0, dv1)));
      for (const double dv : {dv0, dv1}) nearest = std::min(nearest, form(std::clamp(-b * dv / a, du0, du1), dv));
      return nearest < 1 ? Cover::Crosses : Cover::Outside;
    }
  };
  // Sphere `sphere`'s ellipse. The sphere (centre q from the eye in the camera's frame, radius r) is
  // met by the image-plane directions (X, Y, 1) where (X qx + Y qy + qz)^2 >= (X^2 + Y^2 + 1) k^2,
  // k^2 = |q|^2 - r^2: for qz > r the ellipse about (qx, qy) qz / (qz^2 - r^2) whose form is
  // ((k^2 - qx^2) dX^2 - 2 qx qy dX dY + (k^2 - qy^2) dY^2) (qz^2 - r^2) / (r^2 k^2) < 1, here turned
  // into pixels (dX = pixelWidth du, dY = -pixelHeight dv) and factored.
  ImageEllipse imageEllipse(const ParallelProjection& image, uint32_t sphere) const {
    const Sphere<Real>& s = m_group.spheres().primitive(sphere);
    const Vec3d q = image.inFrame(Vec3d(s.center));
    const double r = double(s.radius), distance = glm::length(q);
    ImageEllipse e{};
    e.tFront = distance - r;
    const double front = (q.z - r) * (q.z + r), k2 = (distance - r) * (distance + r);  // qz^2 - r^2, k^2
    if (!(q.z > r && front > 0 && k2 > 0 && r > 0)) return e;
    const double scale = front / (r * r * k2);
    const double a = (q.y * q.y + front) * scale * image.pixelWidth * image.pixelWidth;  // k^2 - qx^2 = qy^2 + qz^2 - r^2
    const double c = (q.x * q.x + front) * scale * image.pixelHeight * image.pixelHeight;
    const double b = q.x * q.y * scale * image.pixelWidth * image.pixelHeight;  // -(-qx qy) for dY = -pixelHeight dv
    e.a = a, e.b = b, e.c = c;
    e.l11 = std::sqrt(a), e.l12 = b / e.l11, e.l22 = std::sqrt(c - e.l12 * e.l12);
    e.cx = image.sampleX(q.z * q.x / front), e.cy = image.sampleY(q.z * q.y / front);
    e.tEdge = std::sqrt(k2);
    const double nearest = m_camera.clipsAtPlanes() ? q.z - r : e.tFront;  // as the near bound measures it
    e.exact = std::isfinite(e.l11) && std::isfinite(e.l12) && std::isfinite(e.l22) && e.l11 > 0 && e.l22 > 0 &&
              std::isfinite(e.cx) && std::isfinite(e.cy) && nearest >= m_camera.tMin();
    return e;
  }

  // Whether sphere c lies in front of all of sphere w that pixel (x, y) may show: the part of the
  // pixel's square within w's disk's bounding box lies inside c's disk, and c's front surface there,
  // at its deepest (at the box's corner farthest from c's centre), is nearer than w's front, and
  // within the camera rays' search (a tMin beyond c's front would let them pass it, a tMax before
  // that surface would end them short of it). Through an orthographic camera: depth is t.
  bool hides(const ImageDisk& c, const ImageDisk& w, int x, int y) const {
    const double u0 = std::max(double(x), w.cx - w.ax), u1 = std::min(double(x + 1), w.cx + w.ax);
    const double v0 = std::max(double(y), w.cy - w.ay), v1 = std::min(double(y + 1), w.cy + w.ay);
    const double du = std::max(std::abs(u0 - c.cx), std::abs(u1 - c.cx)) / c.ax;
    const double dv = std::max(std::abs(v0 - c.cy), std::abs(v1 - c.cy)) / c.ay;
    const double reach = du * du + dv * dv;  // the farthest corner's squared distance over c's radius
    if (!(reach < 1)) return false;
    const double deepest = c.q.z - c.radius * std::sqrt(1 - reach);
    return m_camera.tMin() <= c.q.z - c.radius && deepest < m_camera.tMax() && deepest < w.q.z - w.radius;
  }

  // Writes entries [k0, k0 + count) of `acc` (count <= kPacketSize) to the region's pixels
  // [first, first + count). The colours are clamped in a loop of their own, which GCC vectorises
  // (not with the conversion to float32 in it), then converted and interleaved in another. The
  // targets are numpy buffers, never the accumulator: __restrict spares each short loop the
  // compiler's run-time overlap checks.
  void writeRow(const Accumulator& acc, int k0, int count, size_t first) const {
    // A whole tile's row (the most common) with its length known to the compiler: unrolled and
    // vectorised, with none of the variable length's branches and remainders.
    count == kTileSize ? writeRowOf<kTileSize>(acc, k0, count, first) : writeRowOf<0>(acc, k0, count, first);
  }

 private:
  // Asks for the cache lines of this row of the tile after next in an output of `pixelBytes` a pixel,
  // ahead of the stores to them: the outputs were last written a whole image ago, and a tile writes
  // to more rows (8 of each output) than the hardware prefetcher follows (a render of all passes
  // took 14 % longer without, 9 % longer with one tile ahead). Integer arithmetic: the address may
  // lie past the buffer (a prefetch never faults). Rows of whole tiles only.
  template <int Length>
  static void prefetchAhead(const void* row, size_t pixelBytes) {
    if constexpr (Length == kTileSize) {
      constexpr size_t kLine = 64;
      const size_t ahead = 2 * kTileSize * pixelBytes, end = ahead + kTileSize * pixelBytes;
      for (size_t b = ahead; b < end; b += kLine) {
        __builtin_prefetch(reinterpret_cast<const void*>(reinterpret_cast<uintptr_t>(row) + b), 1);
      }
    }
  }

  // writeRow for rows of Length entries (0: any length, `count`).
  template <int Length>
  void writeRowOf(const Accumulator& acc, int k0, int varying, size_t first) const {
    const int count = Length > 0 ? Length : varying;
    const bool oneSample = std::all_of(acc.samples + k0, acc.samples + k0 + count, [](Real n) { return n == 1; });
    if (m_targets.samples) {
      for (int i = 0; i < count; ++i) m_targets.samples[first + i] = static_cast<int32_t>(acc.samples[k0 + i]);
      prefetchAhead<Length>(m_targets.samples + first, sizeof(int32_t));
    }
    if (m_targets.color) {
      // A pixel brighter than float32 holds saturates at its largest number (the sums never hold NaN).
      const Real brightest = std::numeric_limits<float>::max();
      alignas(64) Real values[4][kPacketSize];
      const auto means = [&](auto single) {  // one sample's sums are its means: no division to wait for
        for (int i = 0; i < count; ++i) {
          const int k = k0 + i;
          const Real invSpp = decltype(single)::value ? Real(1) : 1 / acc.samples[k];
          values[0][i] = std::min(acc.r[k] * invSpp, brightest);
          values[1][i] = std::min(acc.g[k] * invSpp, brightest);
          values[2][i] = std::min(acc.b[k] * invSpp, brightest);
          values[3][i] = acc.a[k] * invSpp;
        }
      };
      oneSample ? means(std::true_type{}) : means(std::false_type{});
      float* __restrict out = m_targets.color + 4 * first;
      for (int i = 0; i < count; ++i) {
        for (int c = 0; c < 4; ++c) out[4 * i + c] = static_cast<float>(values[c][i]);
      }
      prefetchAhead<Length>(out, 4 * sizeof(float));
    }
    if (m_targets.depth) {
      float* __restrict out = m_targets.depth + first;
      for (int i = 0; i < count; ++i) out[i] = static_cast<float>(acc.depth[k0 + i]);
      prefetchAhead<Length>(out, sizeof(float));
    }
    if (m_targets.normal) {
      float* __restrict out = m_targets.normal + 3 * first;
      prefetchAhead<Length>(out, 3 * sizeof(float));
      if (oneSample) {
        // One sample's normal is unit already (0 on a miss): written as it is, by a loop with no
        // root, division or select in it (the loop below would scale it by 1: the same numbers).
        for (int i = 0; i < count; ++i) {
          out[3 * i + 0] = static_cast<float>(acc.nx[k0 + i]);
          out[3 * i + 1] = static_cast<float>(acc.ny[k0 + i]);
          out[3 * i + 2] = static_cast<float>(acc.nz[k0 + i]);
        }
      } else {
        for (int i = 0; i < count; ++i) {
          const int k = k0 + i;
          // A mean of several samples' normals is renormalised (one sample's kept). Where the hit
          // samples' normals (nearly) cancel -- a thin wall seen from both sides within one pixel --
          // the mean has no direction, and the nearest hit sample's normal stands in (0 on a miss).
          const Real length = acc.samples[k] == 1 ? 1 : std::sqrt(acc.nx[k] * acc.nx[k] + acc.ny[k] * acc.ny[k] + acc.nz[k] * acc.nz[k]);
          const bool directed = length > static_cast<Real>(kMinMeanNormal) * acc.hits[k];
          const Real scale = directed ? 1 / length : 0;
          out[3 * i + 0] = static_cast<float>(directed ? acc.nx[k] * scale : acc.fx[k]);
          out[3 * i + 1] = static_cast<float>(directed ? acc.ny[k] * scale : acc.fy[k]);
          out[3 * i + 2] = static_cast<float>(directed ? acc.nz[k] * scale : acc.fz[k]);
        }
      }
    }
    // The id passes are the nearest hit sample's ids: an id is not a quantity to average.
    if (m_targets.objectId) {
      int32_t* out = m_targets.objectId + first;
      for (int i = 0; i < count; ++i) out[i] = m_objectOf[static_cast<size_t>(acc.nearestPrim[k0 + i] + 1)];
      prefetchAhead<Length>(out, sizeof(int32_t));
    }
    if (m_targets.materialId) {
      int32_t* out = m_targets.materialId + first;
      for (int i = 0; i < count; ++i) {
        const int32_t prim = acc.nearestPrim[k0 + i];
        out[i] = prim == kNoPrimitive ? -1 : m_flat.primMaterial[static_cast<size_t>(prim + 1)];
      }
      prefetchAhead<Length>(out, sizeof(int32_t));
    }
  }

  // Colour of every material without lights, the background last; material of each primitive.
  struct FlatTable {
    std::vector<Real> r, g, b, a;       // by material id; index materials: the background
    std::vector<int32_t> primMaterial;  // by packed primitive index + 1; entry 0 (a miss): the background
    FlatTable(const Scene& scene, const Group<Real>& group) {
      for (const Material& m : scene.materials()) {
        r.push_back(static_cast<Real>(m.diffuse.r + m.emission.r));
        g.push_back(static_cast<Real>(m.diffuse.g + m.emission.g));
        b.push_back(static_cast<Real>(m.diffuse.b + m.emission.b));
        a.push_back(1);
      }
      const Vec4d& bg = scene.background();  // premultiplied, as a pixel sees it (Scene::setBackground)
      r.push_back(static_cast<Real>(bg.r * bg.a));
      g.push_back(static_cast<Real>(bg.g * bg.a));
      b.push_back(static_cast<Real>(bg.b * bg.a));
      a.push_back(static_cast<Real>(bg.a));
      primMaterial.push_back(static_cast<int32_t>(scene.materials().size()));
      group.appendMaterials(primMaterial);
    }
  };

  // The object id of every packed primitive, by packed index + 1, with -1 (a miss) first.
  static std::vector<int32_t> objectTable(const Group<Real>& group) {
    std::vector<int32_t> table{-1};
    group.appendObjectIds(table);
    return table;
  }

  // Adds one sample per ray of the packet to `acc` (an Accumulator, or a sink with its add* functions).
  template <typename Sink>
  void accumulate(const RayPacket<Real>& packet, Sink& acc, RayCounters& counters) const {
    if (!m_needHits) {  // flat colours, depth and normals: no hit records
      // Whether every ray met the same primitive (or none): most tiles of a primary render, whose
      // colour and normals then come from one primitive's fields, with no fetch per ray.
      int others = 0;  // an integer count, not a bool: the reduction then vectorises
      for (int k = 1; k < packet.count; ++k) others += packet.prim[k] != packet.prim[0] ? 1 : 0;
      const bool uniform = others == 0;
      accumulateFlat(packet, uniform, acc);
      if (m_targets.normal) {
        accumulateNormals(packet, uniform, acc);
      } else if (m_needNearest) {
        for (int k = 0; k < packet.count; ++k) {
          acc.addNearest(k, packet.prim[k] != kNoPrimitive, packet.tHit[k], packet.prim[k]);
        }
      }
      return;
    }
    HitRecords<Real, kPacketSize> hits;
    const auto make = [&](int k, const auto& f) { hits.make(k, f); };
    if (!m_group.makeUniformHits(packet, make)) {
      for (int k = 0; k < packet.count; ++k) make(k, [&] { return m_group.hit(packet, k); });
    }
    for (int k = 0; k < packet.count; ++k) {
      if (!hits[k].isHit()) continue;
      if (m_targets.depth) acc.addDepth(k, m_planarDepth ? hits[k].t * planarScale(packet, k) : hits[k].t);
      if (!acc.wantsNormal(k)) continue;
      const Vec3<Real> n = m_shader.shadingNormal(hits[k], Vec3<Real>(packet.dx[k], packet.dy[k], packet.dz[k]));
      acc.addNormal(k, hits[k].t, packet.prim[k], n.x, n.y, n.z);
    }
    alignas(64) Vec3<Real> rgb[kPacketSize];
    alignas(64) Real weights[kPacketSize];
    std::fill(weights, weights + packet.count, Real(1));
    m_shader.shade(packet, hits.data(), weights, 0, rgb, counters);
    alignas(64) Real alpha[kPacketSize];
    const Real coverage = m_flat.a.back();  // the background's alpha: a miss's colour premultiplied by it
    for (int k = 0; k < packet.count; ++k) {
      alpha[k] = hits[k].isHit() ? Real(1) : coverage;
      if (!hits[k].isHit()) rgb[k] = rgb[k] * coverage;
    }
    acc.addColors(rgb, alpha, packet.count);
  }

  // Normals of the packet's hits: those on the top-level group's own spheres and planes in one loop
  // without a hit record per ray (SphereSet::normal, a plane's own), the others through their hit
  // records; each turned by shadingNormal's rule. A packet whose rays all met one sphere or plane
  // (`uniform`) takes a loop over its one primitive, which vectorises. Otherwise a branch per ray:
  // a branch-free loop that made both kinds' normals for every ray (GCC kept it scalar), and one
  // that fetched each ray's sphere and plane by index (GCC's gathers: 8 % slower), took longer.
  template <typename Sink>
  void accumulateNormals(const RayPacket<Real>& packet, bool uniform, Sink& acc) const {
    const int32_t sphereCount = static_cast<int32_t>(m_group.spheres().size());
    const int32_t ownEnd = sphereCount + static_cast<int32_t>(m_group.planes().size());
    const int32_t first = packet.prim[0];
    if (uniform && first == kNoPrimitive) return;  // the background's: a miss adds nothing
    if (uniform && first < ownEnd) {  // one sphere's or plane's: the normals made in a loop that vectorises
      alignas(64) Real nx[kPacketSize], ny[kPacketSize], nz[kPacketSize];
      if (first < sphereCount) {
        const auto& spheres = m_group.spheres();
        for (int k = 0; k < packet.count; ++k) {
          const Vec3<Real> d(packet.dx[k], packet.dy[k], packet.dz[k]);
          const Vec3<Real> n = shadingNormal(spheres.normal(packet, k, static_cast<size_t>(first)), d, m_shadeBack);
          nx[k] = n.x, ny[k] = n.y, nz[k] = n.z;
        }
      } else {
        const Vec3<Real> normal = m_group.planes().primitive(static_cast<size_t>(first - sphereCount)).normal;
        for (int k = 0; k < packet.count; ++k) {
          const Vec3<Real> n = shadingNormal(normal, Vec3<Real>(packet.dx[k], packet.dy[k], packet.dz[k]), m_shadeBack);
          nx[k] = n.x, ny[k] = n.y, nz[k] = n.z;
        }
      }
      for (int k = 0; k < packet.count; ++k) acc.addNormal(k, packet.tHit[k], first, nx[k], ny[k], nz[k]);
      return;
    }
    for (int k = 0; k < packet.count; ++k) {
      const int32_t prim = packet.prim[k];
      if (prim == kNoPrimitive || prim >= ownEnd) continue;  // a miss adds nothing
      const Vec3<Real> normal = prim < sphereCount
                                    ? m_group.spheres().normal(packet, k, static_cast<size_t>(prim))
                                    : m_group.planes().primitive(static_cast<size_t>(prim - sphereCount)).normal;
      const Vec3<Real> n = shadingNormal(normal, Vec3<Real>(packet.dx[k], packet.dy[k], packet.dz[k]), m_shadeBack);
      acc.addNormal(k, packet.tHit[k], prim, n.x, n.y, n.z);
    }
    for (int k = 0; k < packet.count; ++k) {
      if (packet.prim[k] < ownEnd) continue;
      const Vec3<Real> n =
          shadingNormal(m_group.hit(packet, k), Vec3<Real>(packet.dx[k], packet.dy[k], packet.dz[k]), m_shadeBack);
      acc.addNormal(k, packet.tHit[k], packet.prim[k], n.x, n.y, n.z);
    }
  }

  // Unlit colour and depth need no hit record: a branch-free table lookup per ray.
  template <typename Sink>
  void accumulateFlat(const RayPacket<Real>& packet, bool uniform, Sink& acc) const {
    const Real inf = std::numeric_limits<Real>::infinity();
    if (m_planarDepth) {
      for (int k = 0; k < packet.count; ++k) {
        const Real t = packet.tHit[k] * planarScale(packet, k);
        acc.addDepth(k, packet.prim[k] != kNoPrimitive ? t : inf);
      }
    } else {
      for (int k = 0; k < packet.count; ++k) {
        acc.addDepth(k, packet.prim[k] != kNoPrimitive ? packet.tHit[k] : inf);
      }
    }
    if (!m_targets.color) return;  // a depth (or normal) render computes t and nothing else
    const int32_t* materialOf = m_flat.primMaterial.data() + 1;  // materialOf[kNoPrimitive]: the background
    if (uniform) {
      const size_t m = static_cast<size_t>(materialOf[packet.prim[0]]);
      const Real r = m_flat.r[m], g = m_flat.g[m], b = m_flat.b[m], a = m_flat.a[m];
      for (int k = 0; k < packet.count; ++k) acc.addColor(k, r, g, b, a);
      return;
    }
    for (int k = 0; k < packet.count; ++k) {
      const size_t m = static_cast<size_t>(materialOf[packet.prim[k]]);
      acc.addColor(k, m_flat.r[m], m_flat.g[m], m_flat.b[m], m_flat.a[m]);
    }
  }

  // Camera rays searched: with a camera that clips at planes (Blender's clip range), hits beyond
  // the far plane missed, and each ray whose hit lies before the near plane searched again from
  // where it crosses that plane (one ray at a time: only rays off the axis, near the eye, meet one).
  void clipToPlanes(RayPacket<Real>& packet, RayCounters& counters) const {
    if (!m_camera.clipsAtPlanes()) return;
    for (int k = 0; k < packet.count; ++k) {
      Real tMin;
      if (!m_camera.clip(packet, k, tMin)) continue;
      RayPacket<Real> ray;
      ray.count = 1;
      ray.tMin = tMin, ray.tMax = packet.tMax;
      ray.ox[0] = packet.ox[k], ray.oy[0] = packet.oy[k], ray.oz[0] = packet.oz[k];
      ray.dx[0] = packet.dx[k], ray.dy[0] = packet.dy[k], ray.dz[0] = packet.dz[k];
      counters.intersectionTests += m_group.template intersect<Methods>(m_settings.sphereMethod, ray, &m_cancel);
      packet.tHit[k] = ray.tHit[0], packet.prim[k] = ray.prim[0];
      m_camera.clip(packet, k, tMin);  // the far plane, for the hit found beyond the near one
    }
  }

  Real planarScale(const RayPacket<Real>& packet, int k) const {
    return m_camera.planarScale(packet.dx[k], packet.dy[k], packet.dz[k]);
  }

  // A view's cells take ~0.15 bytes a pixel, whatever the region rendered: above this many pixels
  // (a 16384 x 16384 image's view: ~40 MB) a render of a region sees through a view of the pixels it
  // samples (sampledRegion: adaptive sampling's margin too).
  static constexpr int64_t kMostWholeViewPixels = int64_t(1) << 28;

  // The view of the scene's own spheres for this camera over the whole image (SphereView), shared
  // with the renders before of the same camera and size, whatever their regions (a distributed
  // render's tiles, an adaptive render's margins); of the pixels a render samples in a huge image (a tile of a
  // gigapixel poster: the whole image's took 9.5 GB at 262144²). Rays outside a view's cells search
  // the hierarchy: the same hits.
  static std::shared_ptr<const SphereView<Real>> viewOf(const SphereSet<Real>& spheres, const CameraSpec& spec,
                                                        const RenderSettings& settings, const Camera<Real>& camera) {
    if (spheres.size() == 0) return nullptr;  // a camera's view pays from one sphere (SphereView::kMinLightSpheres)
    // A perspective camera's rays searched from t < 0 also run backwards from the eye, where no
    // footprint on its image looks.
    if (spec.projection == Projection::Perspective && spec.tMin < 0) return nullptr;
    if (camera.hasLens() && meanLensBlur(spheres, camera, settings) > kMostLensBlurPixels) return nullptr;
    const bool whole = int64_t(settings.width) * settings.height <= kMostWholeViewPixels;
    const RenderSettings::Region seen = whole ? RenderSettings::Region{0, 0, settings.width, settings.height}
                                              : sampledRegion(settings);
    const ViewKey key{{double(spec.projection), spec.center.x, spec.center.y, spec.center.z, spec.direction.x,
                       spec.direction.y, spec.direction.z, spec.up.x, spec.up.y, spec.up.z, spec.size, double(spec.fit),
                       spec.shiftX, spec.shiftY, spec.pixelAspect, spec.tMin, spec.tMax, double(settings.width),
                       double(settings.height), double(seen.x), double(seen.y), double(seen.width),
                       double(seen.height), spec.apertureRadius, spec.focusDistance, spec.apertureRatio}};
    return spheres.view(key, [&] {
      return std::shared_ptr<const SphereView<Real>>(viewThrough(spheres, camera, seen, settings));
    });
  }

  // A lens widens each sphere's footprint in the camera's view by its blur (Camera::footprint): past a
  // few pixels on average the cells list so many spheres that the rays test more of them than a walk
  // of the hierarchy does (1M spheres at 1080p, depth only: the view 1.4x faster at a mean blur of 2
  // pixels, even at 3.4, 1.4x slower at 4.8; docs/benchmarks.md, depth of field).
  static constexpr double kMostLensBlurPixels = 3;

  // The mean of the spheres' blur radii through the camera's lens (Camera::lensBlur), over up to
  // 1,024 of them spread through the set, each at most the image's width plus height (a footprint
  // wider than the image costs no more).
  static double meanLensBlur(const SphereSet<Real>& spheres, const Camera<Real>& camera,
                             const RenderSettings& settings) {
    const size_t count = spheres.size(), step = (count + 1023) / 1024;
    const double image = double(settings.width) + double(settings.height);
    double sum = 0;
    size_t taken = 0;
    for (size_t i = 0; i < count; i += step, ++taken) {
      const Sphere<Real>& sphere = spheres.primitive(i);
      sum += std::min(camera.lensBlur(Vec3d(sphere.center), double(sphere.radius)), image);
    }
    return sum / double(taken);
  }

  // The view of `spheres` over the pixels `seen` of the image seen through `camera`, on the render's
  // threads (of the spheres listed in `only`, in increasing order, if given). `disks`: a light's,
  // keeping each sphere's disk and core (SphereView::make).
  static std::unique_ptr<SphereView<Real>> viewThrough(const SphereSet<Real>& spheres, const Camera<Real>& camera,
                                                       const RenderSettings::Region& seen,
                                                       const RenderSettings& settings,
                                                       const std::vector<uint32_t>* only = nullptr,
                                                       bool disks = false) {
    constexpr int kFootprints = SphereView<Real>::kFootprints;
    const auto footprints = [&](size_t first, int n, SampleBox* boxes, double* tLows, SampleDisk* disks, bool* seen) {
      Vec3d centers[kFootprints];
      double radii[kFootprints];
      for (int j = 0; j < kFootprints; ++j) {  // lanes past n repeat the first
        const size_t i = first + size_t(j < n ? j : 0);
        const Sphere<Real>& sphere = spheres.primitive(only ? (*only)[i] : i);
        centers[j] = Vec3d(sphere.center), radii[j] = double(sphere.radius);
      }
      camera.footprints(n, centers, radii, boxes, tLows, disks, seen);
    };
    const int threads = settings.threads > 0 ? settings.threads : defaultThreadCount();
    const size_t count = only ? only->size() : spheres.size();
    return SphereView<Real>::make(count, footprints, seen.x, seen.y, seen.width, seen.height, threads,
                                  only ? only->data() : nullptr, disks);
  }

  // A light view's cells are this many mean sphere radii across (at the spheres' mean distance from
  // a point light).
  static constexpr double kRadiiPerCell = 4;

  // The view of the scene's own spheres from a directional light travelling along `direction`, for
  // its shadow rays (SphereView::occluders): an orthographic image along it over the spheres' bounds
  // with a cell to spare, its cells four mean radii across (at most 2048 a side).
  static std::shared_ptr<const SphereView<Real>> lightViewOf(const SphereSet<Real>& spheres, const Vec3d& direction,
                                                             const RenderSettings& settings) {
    constexpr double kMaxCellsAcross = 2048;
    if (spheres.size() < SphereView<Real>::kMinLightSpheres) return nullptr;
    const ViewKey key{{direction.x, direction.y, direction.z}, true};
    return spheres.view(key, [&]() -> std::shared_ptr<const SphereView<Real>> {
      constexpr Real inf = std::numeric_limits<Real>::infinity();
      Vec3<Real> lo(inf), hi(-inf);
      spheres.bounds(lo, hi);
      double radii = 0;
      for (size_t i = 0; i < spheres.size(); ++i) radii += double(spheres.primitive(i).radius);
      const double across = glm::length(Vec3d(hi) - Vec3d(lo));
      const double cell = std::max(kRadiiPerCell * radii / double(spheres.size()), across / kMaxCellsAcross);
      if (!(std::isfinite(across) && cell > 0)) return nullptr;
      const int cells = int(std::ceil(across / cell)) + 2;
      CameraSpec spec;
      spec.projection = Projection::Orthographic;
      spec.center = 0.5 * (Vec3d(lo) + Vec3d(hi));
      spec.direction = direction;
      const Vec3d a = absolute(direction);
      spec.up = a.x <= a.y && a.x <= a.z ? Vec3d(1, 0, 0) : a.y <= a.z ? Vec3d(0, 1, 0) : Vec3d(0, 0, 1);
      spec.size = cells * cell;
      spec.tMin = -std::numeric_limits<double>::infinity();
      spec.tMax = std::numeric_limits<double>::infinity();
      const int pixels = cells * SphereView<Real>::kCell;
      const Camera<Real> light(spec, pixels, pixels);
      // Its footprints are squares around disks: a shadow ray tests the spheres whose disk holds it,
      // and is blocked without a test by one whose core holds it and that lies wholly before it.
      std::unique_ptr<SphereView<Real>> view = viewThrough(spheres, light, {0, 0, pixels, pixels}, settings, nullptr, true);
      if (view) view->setLight(light.projection());
      return view;
    });
  }

  // The view of the scene's own spheres from a point (or spot) light at `position`, for its shadow
  // rays: perspective views from it over the six faces of a cube around it (cubeFace), chained
  // (SphereView::addFace), each made from the spheres that may reach into its face (byFace) and
  // keeping each one's disk about its centre's point and core, as a sun's view does; a
  // face's cells four mean radii across at the spheres' mean distance from the light (at most 1024
  // a side: six faces' cell bounds take at most 24 MB).
  static std::shared_ptr<const SphereView<Real>> pointLightViewOf(const SphereSet<Real>& spheres,
                                                                  const Vec3d& position,
                                                                  const RenderSettings& settings) {
    constexpr double kMaxCellsAcross = 1024;
    if (spheres.size() < SphereView<Real>::kMinLightSpheres) return nullptr;
    const ViewKey key{{position.x, position.y, position.z, 1}, true};
    return spheres.view(key, [&]() -> std::shared_ptr<const SphereView<Real>> {
      double radii = 0, distances = 0;
      for (size_t i = 0; i < spheres.size(); ++i) {
        const Sphere<Real>& sphere = spheres.primitive(i);
        radii += double(sphere.radius), distances += glm::length(Vec3d(sphere.center) - position);
      }
      const double cell = kRadiiPerCell * radii / distances;  // at distance 1
      if (!(std::isfinite(cell) && cell > 0)) return nullptr;
      const int pixels = int(std::min(std::ceil(2 * kCubeHalfWidth / cell), kMaxCellsAcross)) * SphereView<Real>::kCell;
      const std::array<std::vector<uint32_t>, 6> faces = byFace(spheres, position, 2 * kCubeHalfWidth / pixels);
      std::unique_ptr<SphereView<Real>> first;
      for (int face = 0; face < 6; ++face) {
        const Camera<Real> eye = cubeFace(position, face, pixels);
        std::unique_ptr<SphereView<Real>> view = viewThrough(spheres, eye, {0, 0, pixels, pixels}, settings, &faces[face], true);
        if (!view) return nullptr;
        view->setLight(eye.projection());
        if (first) {
          first->addFace(std::move(view));
        } else {
          first = std::move(view);
        }
      }
      return first;
    });
  }

  // A cube face's image plane at distance 1 spans [-1.01, 1.01]^2: a little more than its face, so
  // that a point on a face's edge lies on its image.
  static constexpr double kCubeHalfWidth = 1.01;

  // The perspective camera from `position` over face `face` of a cube around it (+x, -x, +y, -y,
  // +z, -z), on a pixels x pixels image.
  static Camera<Real> cubeFace(const Vec3d& position, int face, int pixels) {
    CameraSpec spec;
    spec.projection = Projection::Perspective;
    spec.center = position;
    spec.direction = Vec3d(0);
    spec.direction[face / 2] = face % 2 == 0 ? 1 : -1;
    spec.up = face / 2 == 2 ? Vec3d(0, 1, 0) : Vec3d(0, 0, 1);
    spec.size = 2 * std::atan(kCubeHalfWidth) * 180 / kPi;
    spec.tMin = 0;
    spec.tMax = std::numeric_limits<double>::infinity();
    return Camera<Real>(spec, pixels, pixels);
  }

  // Each cube face's spheres, in increasing order: those that may reach into the pyramid from
  // `position` over its image (a sphere lies in one to three), so that a face reads its own and not
  // every sphere. Widened well beyond the footprints' rounding bounds and margin: the angle of a
  // pixel (`pixelAngle`) at the sphere's distance and more.
  static std::array<std::vector<uint32_t>, 6> byFace(const SphereSet<Real>& spheres, const Vec3d& position,
                                                     double pixelAngle) {
    std::array<std::vector<uint32_t>, 6> faces;
    const double slack = pixelAngle + 1e-3;
    for (size_t i = 0; i < spheres.size(); ++i) {
      const Sphere<Real>& sphere = spheres.primitive(i);
      const Vec3d q = Vec3d(sphere.center) - position;
      const double reach = double(sphere.radius) + slack * glm::length(q);
      for (int face = 0; face < 6; ++face) {
        const int axis = face / 2;
        const double along = face % 2 == 0 ? q[axis] : -q[axis];
        const double across = std::max(std::fabs(q[(axis + 1) % 3]), std::fabs(q[(axis + 2) % 3]));
        if (!(along + reach < (across - reach) / kCubeHalfWidth)) faces[size_t(face)].push_back(uint32_t(i));
      }
    }
    return faces;
  }

  // Whether the strata's controls are the colour itself, up to a constant, wherever their spheres
  // show (StratumControl::exact, where also each member lies before the plane: beforePlane): the
  // image's every edge is a silhouette of the view's spheres
  // (m_edgesAtSilhouettes) and the camera cuts nothing (no tMin or tMax: neither the plane nor a
  // sphere ends in view), so a stratum's members are all the silhouettes crossing its pixel in front
  // of its cover; the lights are the suns the controls model; the materials diffuse (no emission,
  // highlights, mirrors or glass). Then the one plane, or the background, is one colour across a
  // pixel too (an orthographic camera sees the plane along parallel rays).
  // (Every light one of m_lighting's suns: all directional, none past kMostControlLights.)
  bool controlIsShading() const {
    if (!m_edgesAtSilhouettes || std::isfinite(m_camera.tMin()) || std::isfinite(m_camera.tMax())) return false;
    if (size_t(m_lighting.suns) != m_shading.lights().size()) return false;
    const Vec3<Real> none(0);
    for (const MaterialIn<Real>& m : m_shading.materials()) {
      if (m.emission != none || m.specular != none || m.reflective != none || m.transparent != none) return false;
    }
    return true;
  }

  // Whether the front of sphere i (the half the camera's parallel rays meet first) lies wholly on
  // the side of the scene's plane that they come from, so that the plane hides none of its disk:
  // its centre at least r sqrt(1 - cos^2) before the plane, cos the plane's normal's along the rays
  // (the front's lowest point over the plane lies on its rim, the silhouette's circle). Or there is
  // no plane, or the rays run along it (it is never seen).
  bool beforePlane(uint32_t i) const {
    if (m_group.planes().size() == 0) return true;
    const Plane<Real>& plane = m_group.planes().primitive(0);
    const Sphere<Real>& sphere = m_group.spheres().primitive(i);
    const Vec3d normal(plane.normal);
    const double toward = glm::dot(normal, m_camera.projection().forward);
    if (toward == 0) return true;
    const double above = glm::dot(normal, Vec3d(sphere.center) - Vec3d(plane.point));
    return (toward < 0 ? above : -above) >= double(sphere.radius) * std::sqrt(std::max(0.0, 1 - toward * toward));
  }

  // Whether every edge of this render's image is a silhouette of the camera's view's spheres
  // (markSilhouettes): through a camera that seesDisks(), the scene's geometry is its own spheres (all in
  // the view) and at most one unbounded plane, and nothing in its shading changes abruptly — no
  // shadows, mirrors (nor an area light a mirror shows without bounces), refraction or ambient
  // occlusion (its rays' noise), no spot light's hard edge (blend 0). The plane's own edges, where it
  // leaves [tMin, tMax), are looked for per pixel; softer changes (a spot's ramp, a light near the
  // plane) are left to the smooth neighbours' rules (AdaptiveSampler::mark).
  bool edgesAtSilhouettes(const EffectSet& effects) const {
    if (!seesDisks() || effects.shadows || effects.bounces() || effects.mirroredLights || effects.occlusion) return false;
    const Group<Real>& g = m_group;
    if (g.triangles().size() != 0 || g.boxes().size() != 0 || !g.instances().empty()) return false;
    if (g.planes().size() > 1 || (g.planes().size() == 1 && g.planes().primitive(0).bounded)) return false;
    for (const ShadingLight<Real>& light : m_shading.lights()) {
      if (effects.lit && light.kind == ShadingLight<Real>::Kind::Spot && !(light.blend > 0)) return false;
    }
    return true;
  }

  static constexpr int kCorners = (kTileSize + 1) * (kTileSize + 1);  // a tile's pixels' corners

  // The camera rays through the corners of the w x h tile at (x0, y0)'s pixels, (w + 1) a row, row
  // by row, in double (as the camera makes them in Real).
  void cornerRays(int x0, int y0, int w, int h, Vec3d* origin, Vec3d* direction) const {
    const int columns = w + 1, corners = columns * (h + 1);  // at most 81: two packets
    for (int first = 0; first < corners; first += kPacketSize) {
      const int count = std::min(kPacketSize, corners - first);
      alignas(64) Real x[kPacketSize], y[kPacketSize];
      for (int j = 0; j < count; ++j) x[j] = Real(x0 + (first + j) % columns), y[j] = Real(y0 + (first + j) / columns);
      RayPacket<Real> packet;
      m_camera.generate(packet, x, y, count);
      for (int j = 0; j < count; ++j) {
        origin[first + j] = Vec3d(packet.ox[j], packet.oy[j], packet.oz[j]);
        direction[first + j] = Vec3d(packet.dx[j], packet.dy[j], packet.dz[j]);
      }
    }
  }

  // Clears smooth[k] for the pixels of the w x h tile at (x0, y0) in which the scene's one plane may
  // leave the camera's [tMin, tMax) (m_planeCut): where the depths at which the rays through the
  // pixel's corners meet it, widened by 1/64 pixel and by the rounding of those rays and of the
  // render's own, straddle tMin or tMax. Orthographic rays are parallel, from points of a plane:
  // the depth is affine across a pixel. A plane the rays run along (infinite or NaN depths) is never
  // seen there: no edge.
  void markPlaneEnds(int x0, int y0, int w, int h, bool* smooth) const {
    const Plane<Real>& plane = m_group.planes().primitive(0);
    const Vec3d normal(plane.normal), point(plane.point);
    const int columns = w + 1, corners = columns * (h + 1);
    Vec3d origin[kCorners], direction[kCorners];
    cornerRays(x0, y0, w, h, origin, direction);
    double depth[kCorners], slack[kCorners];
    for (int j = 0; j < corners; ++j) {
      const Vec3d &o = origin[j], &d = direction[j];
      const double along = glm::dot(normal, d), t = glm::dot(normal, point - o) / along;
      depth[j] = t;
      // The plane test's rounding in Real, and that of origins between the corners.
      slack[j] = 64 * std::numeric_limits<Real>::epsilon() * ((maxAbs(o) + maxAbs(point)) / std::fabs(along) + std::fabs(t));
    }
    const double tMin = m_camera.tMin(), tMax = m_camera.tMax();
    for (int row = 0, k = 0; row < h; ++row) {
      for (int column = 0; column < w; ++column, ++k) {
        const int c = row * columns + column;
        const double d[4] = {depth[c], depth[c + 1], depth[c + columns], depth[c + columns + 1]};
        const double e = std::max({slack[c], slack[c + 1], slack[c + columns], slack[c + columns + 1]});
        if (!std::all_of(d, d + 4, [](double t) { return std::isfinite(t); })) continue;
        const double low = *std::min_element(d, d + 4), high = *std::max_element(d, d + 4);
        const double reach = (high - low) / 64 + e;
        const auto straddles = [&](double bound) { return std::isfinite(bound) && low - reach <= bound && bound <= high + reach; };
        if (straddles(tMin) || straddles(tMax)) smooth[k] = false;
      }
    }
  }

  void write(const Accumulator& acc, int x0, int y0, int w, int h) const {
    for (int row = 0; row < h; ++row) {
      writeRow(acc, row * w, w, static_cast<size_t>(y0 + row - m_region.y) * m_region.width + (x0 - m_region.x));
    }
  }

  const Group<Real>& m_group;
  Camera<Real> m_camera;
  Shading<Real> m_shading;
  PixelSampler m_sampler;
  const RenderSettings& m_settings;
  RenderTargets m_targets;
  const std::atomic<bool>& m_cancel;
  FlatTable m_flat;
  PacketShader<Real, Methods> m_shader;
  std::vector<int32_t> m_objectOf;  // object id by packed primitive index + 1 (-1: a miss); with the object id pass
  bool m_needHits;   // colour needs hit records: lights, secondary rays or primitives' own colours
  bool m_needNearest;  // the id passes: the nearest hit sample's primitive, normals or not
  bool m_needNormals;  // the normal or id passes: the normals' and nearest hit's sums
  bool m_shadeBack;
  bool m_planarDepth;  // depth along the view axis, not along the ray
  RenderSettings::Region m_region;
  int m_firstTileX, m_firstTileY;
  int m_tilesX;
  std::shared_ptr<const SphereView<Real>> m_view;  // of the scene's own spheres; null: none made
  bool m_edgesAtSilhouettes;                      // every edge a silhouette of the view's spheres (markSilhouettes)
  bool m_planeCut;                                // and the scene's plane may end at tMin or tMax (markPlaneEnds)
  std::vector<std::shared_ptr<const SphereView<Real>>> m_lightViews;  // from each light (Shading's order)
  ControlLighting m_lighting;  // the light the strata's controls model (StratumControl.h; no suns: none)
  bool m_controlExact = false;  // and that light and the materials are the render's shading (controlIsShading)
};

}  // namespace tiles

}  // namespace durer
