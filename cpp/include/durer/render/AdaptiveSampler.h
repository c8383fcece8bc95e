#pragma once
// Adaptive sampling (SamplerKind::Adaptive): the whole image is sampled in rounds. Every pixel first
// takes minSamples Sobol samples; then, between rounds, each pixel is marked from its own samples
// and its eight neighbours' (across tile borders: the state of every pixel is kept), and every marked
// pixel doubles its samples, up to samplesPerPixel. Doubling keeps a pixel's Sobol points a
// (0,m,2)-net (with a power-of-two first pass), and the two halves of its samples (the last round's
// and the ones before) two nets whose difference estimates the error of their mean.
//
// One round's estimate of a pixel's error, from two halves, has one degree of freedom a channel: a
// low one by luck would settle a pixel far from converged unless the neighbourhood and contrast
// rules below were strict enough to catch it, at the cost of many pixels that need nothing. So
// marking also averages the estimates of a pixel's rounds: the average of squares of this round's
// and the last average, scaled to this round's samples as a mean's error scales (by the ratio of the
// counts), from kHistorySamples samples on (an estimate from fewer is too unsteady to carry). A
// pixel's own error is judged the larger of its estimate and that average (a pixel stops only where
// its estimate, the error `result.error` reports, is within the target), its neighbours' by the
// average.
// A pixel is marked while
//   - its judged error, or kNeighbourWeight times the mean of the squared averages of its 3x3
//     neighbourhood (an edge a pixel's samples all missed shows in its neighbour's), exceeds
//     targetError (squared);
//   - it has fewer than kEdgeSamples samples and its samples, or it and a neighbour, differ in
//     geometry: hit against miss, or other primitives at a depth discontinuity or a crease; or the
//     camera's view of the scene's spheres shows a silhouette crossing it nearer than the farthest
//     its first samples met (TileRenderer::markSilhouettes): a sphere smaller than the samples'
//     spacing, or the sliver of one, that they and the neighbours' may all have missed; or its
//     samples all met one plane on whose part of it a light's view of the spheres shows that a
//     shadow's edge may fall (TileRenderer::markShadowEdges): a shadow's sliver likewise;
//   - it has one sample (minSamples 1), whose halves say nothing of its error (estimatedError reads
//     0), and neither does the camera's view prove it smooth nor its control describe it (below);
//   - it has fewer than kUnseenShare * contrast / targetError samples, where contrast is the RMS
//     difference of its mean colour from a neighbour's: an edge inside it covering less than about
//     1 / samples of its area may not have been seen yet, and would be off by at most about that
//     times the contrast (about half that on average: kUnseenShare).
// A pixel the camera's view proves smooth (TileRenderer::markSilhouettes: in a render whose every edge
// is a silhouette of the view's spheres, no sphere's footprint reaches it) holds none of those
// silhouettes: the edge and contrast rules weigh only its smooth neighbours for it, so that a
// sphere's edge in the next pixel does not keep it refining (beside a bright sphere, the contrast
// rule alone would take such a pixel to 32 samples), while a smooth neighbour's contrast or other
// geometry (a plane's end, a light's sharp ramp) still does, and every neighbour's errors do (the
// noise of a light's samples; a light's edge squeezed against the silhouette next door).
// In a colour render, where a camera without a lens sees spheres' silhouettes cross a pixel
// (TileRenderer::silhouetteStrata), the pixel's mean is its stratum's (PixelStratum): the mean of
// its samples inside the silhouettes' union (orthographic: up to four disks; perspective: one
// sphere's ellipse) and that of those outside, weighed by their exact shares of the pixel (a union
// filling the pixel is there for its control alone: share 1, no outside); its error
// estimate the difference of its halves' means made the same way. A part that estimate cannot see
// keeps the pixel marked while what it may put the mean off by exceeds targetError
// (unresolvedShare): one no sample has reached yet, by its share (its colour may differ by about
// 1), one whose samples all lie in one half, by its share times the spread of a colour.
// Where directional lights shine, each sample inside the stratum is taken less its control variate
// (orthographic: diskControl (StratumControl.h), the diffuse shading by the ambient light and those
// lights, no shadows, of the sphere seen there, less that shading's exact mean over the stratum's
// inside; where the disks' spheres cut through each other and a pixel may take fewer than
// kSplitSamples, that mean found on a lattice, and where the sphere seen changes inside an overlap
// and three or more disks cross the pixel, what each loses to a nearer one there, within
// kControlError of the target by its own estimate, which the pixel's error estimate adds: its
// samples cannot see it; beyond that, none;
// perspective, for a small sphere: ellipseControl, the same with
// the sphere's normal modelled as an orthographic camera would see it): the part's mean, and its
// halves', then vary only with what the control leaves out (shadows, highlights, emission, other
// lights, the perspective model's departure), and diffuse spheres lit by suns without shadows seen
// orthographically are exact from one sample. Where the control is that exactly — the render's
// shading is what it models and no sphere covers the pixel behind the disks (StratumControl::exact)
// — a pixel's samples less their controls are one colour on each part of its stratum: none of the
// rules above that look for what its samples missed marks it (the neighbourhood's errors, the
// geometric edges, the contrast: its stratum names every edge crossing it), and of its parts only
// one no sample has reached keeps it refining (unresolvedShare); it watches no sphere (its members
// are every sphere crossing it). Its inside's colour less the control is the control's mean there
// (the control is the colour itself less its mean), so its inside needs no sample either
// (StratumState::mean): it settles at the first pass once its outside is reached (docs/benchmarks.md,
// fifty-seventh to fifty-ninth rounds), or once one ray at a point of it has told its colour, one
// colour, where the first samples all fell inside (probeOutsides: sixty-fifth round), or, from one
// or two first samples, a sample of the tile off every disk (every ray meeting no sphere there sees
// one colour: sixty-eighth round). Where a
// sphere's disk covers a pixel and is seen all over it but for one member's part
// (TileRenderer::silhouetteStrata), its shading is the outside's control
// (StratumControl::covered): that stratum is exact too, its outside's colour known without a sample;
// and a pixel it covers beside its edge, with no member, which the edge rules would take to
// kEdgeSamples for its neighbours' other geometry, has for its stratum that disk filling it (share 1,
// TileRenderer::fill): it settles at the first pass (sixty-first round).
// Through an orthographic camera, a pixel also watches up to two spheres whose silhouettes cross it
// and that its first samples did not meet, but the sphere of a one-sphere stratum
// (TileRenderer::watchSilhouettes: a sliver beside the stratum's edge, an edge where two spheres'
// disks meet, or a member of the union none of whose part of it was reached), nearer than the
// farthest they met where what they met hides all beyond it over the pixel (a plane, a sphere whose
// disk covers it), at any depth where not (a deeper sphere beside the disk they all fell in): while
// no sample has met one, it keeps the pixel marked as an unseen edge would (kUnseenShare of its
// share), less for each sample that has landed inside its silhouette and met something else
// (unseenShare: evidence that it is hidden there).
// What the render reports as a pixel's error (`result.error`, the estimated RMSE) is its last
// round's estimate alone: the average leans toward the larger errors of fewer samples; a pixel of
// two samples reports how far its mean lies from its neighbours' (residualError), one whose samples
// all met one surface, that no silhouette crosses and between which and its neighbours no edge
// shows its estimate over kNetHalves (smoothlyShaded: there the halves over-state the error of
// their mean).
// A time limit stops the refining rounds (never the first pass) when spent; each worker takes its
// band's tiles worst first (the largest estimated error), so what the limit cuts matters least.
// Every pixel's state is kept until the end (TileState and Summary: 202 bytes a pixel in double, 134
// in float; in a colour render through a camera without a lens, StratumState: 345 and 293 more).
// Each round reads the state the round before left, so the image depends on the seed only, never on
// threads; a pixel's result depends on the pixels within `rounds` of it, and its reported error on
// those within one more, so a region is rendered with that margin around it (sampledRegion) and
// equals the whole render's pixels bit for bit.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include "durer/HugeArray.h"
#include "durer/render/TileMask.h"
#include "durer/render/TileRenderer.h"

namespace durer {
namespace tiles {

template <typename Real, typename Methods>
class AdaptiveSampler {
 public:
  using Tiles = TileRenderer<Real, Methods>;
  using Sums = typename Tiles::Accumulator;

  static constexpr int kEdgeSamples = 16;         // geometric edges: samples to look for what the first ones missed
  static constexpr double kDepthJump = 0.02;      // relative depth difference taken as a discontinuity
  static constexpr double kCreaseCosine = 0.9;    // normals further apart (about 25 degrees) make a crease
  static constexpr int kHistorySamples = 4;       // the fewest samples whose estimate later rounds average in
  static constexpr double kNeighbourWeight = 0.25;  // of the neighbourhood's mean squared error (its RMS: half)
  static constexpr double kUnseenShare = 0.5;     // of the contrast an unseen edge's bound, expected
  static constexpr double kPartSpread = 0.5;      // the largest standard deviation of a colour in [0, 1]
  static constexpr double kNetHalves = 2.8284271247461903;  // 2^1.5: how far a smooth colour's halves over-state (smoothlyShaded)
  // The most samples a pixel may take from which its strata split an overlap of two disks where the
  // sphere seen changes inside it exactly (diskControl), not on a lattice: that geometry costs about
  // 45 samples' worth (25 k instructions against 560 a sample), the lattice's about 7 (sixty-second
  // round), which where the target is strict must be finer, and leaves the pixel an error beside.
  static constexpr int kSplitSamples = 128;
  // Of the target, the most a stratum's control's mean found numerically (diskControl) may put a pixel's
  // colour off by: the samples cannot see it, and it adds to their error (a quarter of its square).
  static constexpr double kControlError = 0.5;
  static constexpr int kMetPrimitives = 4;        // a pixel's first samples' distinct primitives the watch is checked
                                                  // against (beyond: a sphere met may be watched until met again)

  AdaptiveSampler(const Tiles& tiles, const RenderSettings& settings, const RenderTargets& targets)
      : m_tiles(tiles),
        m_targets(targets),
        m_output(regionOf(settings)),
        m_maxSamples(settings.samplesPerPixel),
        m_firstSamples(std::min(settings.minSamples, settings.samplesPerPixel)),
        m_target(settings.targetError),
        m_timeLimit(settings.timeLimit),
        m_strata(tiles.stratifies() && targets.color != nullptr),  // the strata weigh colours only
        m_rounds(adaptiveRounds(m_firstSamples, m_maxSamples)),
        m_work(sampledRegion(settings)),
        m_stride(m_work.width + 2),
        m_firstTileX(m_work.x / kTileSize),
        m_firstTileY(m_work.y / kTileSize),
        m_tilesX((m_work.x + m_work.width - 1) / kTileSize - m_firstTileX + 1),
        m_tileCount(static_cast<size_t>(m_tilesX) * ((m_work.y + m_work.height - 1) / kTileSize - m_firstTileY + 1)),
        // Left unset: each tile sets its own state and its pixels' summaries in the first pass, on
        // the worker that samples it (the last render's workers may hold these lines in their caches).
        m_state(m_tileCount),
        m_stratum(m_strata ? m_tileCount : 0),
        m_summary(static_cast<size_t>(m_stride) * (m_work.height + 2)) {
    const int rows = m_work.height + 2;
    // The ring's summaries are read as the others' (mark weighs them by `present`, without branches).
    const Summary absent{0, 0, 0, 0, 0, 0, kNoPrimitive, false, false};
    for (int x = 0; x < m_stride; ++x) m_summary[x] = m_summary[static_cast<size_t>(rows - 1) * m_stride + x] = absent;
    for (int y = 1; y < rows - 1; ++y) {
      m_summary[static_cast<size_t>(y) * m_stride] = m_summary[static_cast<size_t>(y) * m_stride + m_stride - 1] = absent;
    }
  }

  // Its work items: the tiles of the pixels it samples (the output region and its margin).
  int64_t tileCount() const { return static_cast<int64_t>(m_tileCount); }

  // Runs the rounds, then the writing of the output region, as the phases of one job on `threads`
  // workers; returns what was traced.
  RayCounters render(int threads, JobControl& control, const std::function<void()>& poll, AdaptiveStats& stats) {
    // A limit of more than a year is none: the clock's integer ticks would overflow.
    constexpr double kYear = 365.25 * 24 * 3600;
    const bool limited = m_timeLimit > 0 && m_timeLimit < kYear;
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(limited ? m_timeLimit : 0.0));
    // The time limit spares the first pass: every pixel gets its first samples.
    const auto overTime = [&](int round) { return round > 0 && limited && std::chrono::steady_clock::now() >= deadline; };
    // The round's tiles, and for each tile how many tiles around it (itself included) the round has
    // yet to sample. Written between rounds by the worker that calls `next`, read by all in a round.
    std::vector<int64_t> order(m_tileCount);
    for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int64_t>(i);
    std::vector<std::atomic<int>> pending(m_tileCount);
    std::vector<int> counts(m_tileCount);  // counted in plain integers: one locked add each cost the most
    const auto countPending = [&] {         // of the serial work between rounds, which the other workers wait for
      std::fill(counts.begin(), counts.end(), 0);
      for (const int64_t u : order) forTilesAround(static_cast<size_t>(u), [&](size_t t) { ++counts[t]; });
      for (size_t t = 0; t < m_tileCount; ++t) pending[t].store(counts[t], std::memory_order_relaxed);
    };
    countPending();
    std::atomic<int> round{0};
    std::atomic<bool> late{false}, writing{false};
    const int workers = workersFor(threads, static_cast<int64_t>(m_tileCount));
    std::vector<WorkerCounters> traced(static_cast<size_t>(workers));
    // A tile is marked for the next round as soon as every tile around it has been sampled in this
    // one (its marking reads nothing else), by the worker that sampled the last of them: no pass
    // of its own. Tiles with no sampled tile around them keep their decision: nothing to add.
    std::vector<uint8_t> written(m_tileCount, 0);  // a byte a tile: each written by one worker
    const WorkItem work = [&](int64_t i, int worker) {
      if (writing.load(std::memory_order_relaxed)) {
        writeTile(m_state[static_cast<size_t>(i)]);
        written[static_cast<size_t>(i)] = 1;
        return;
      }
      const int r = round.load(std::memory_order_relaxed);
      if (overTime(r)) {
        late = true;
        return;
      }
      const bool last = r == m_rounds;
      const int level = last ? m_maxSamples : std::min(m_maxSamples, m_firstSamples << (r + 1));
      const size_t u = static_cast<size_t>(order[static_cast<size_t>(i)]);
      if (r == 0) start(u);
      RayCounters c;
      sampleTile(m_state[u], r, c);
      if (!control.cancel.load(std::memory_order_relaxed)) {
        forTilesAround(u, [&](size_t t) {
          if (pending[t].fetch_sub(1, std::memory_order_acq_rel) == 1 && !last) mark(t, level, r);
        });
      }
      traced[static_cast<size_t>(worker)].counters += c;
    };
    // Whether another round follows the one just done: if so, its tiles are in `order`.
    const auto anotherRound = [&] {
      const int r = round.load(std::memory_order_relaxed);
      if (late.load()) stats.timeLimitReached = true;
      if (late.load() || r == m_rounds) return false;
      order = tilesToRefine(workers, limited);
      if (order.empty()) return false;
      if (overTime(r + 1)) {
        stats.timeLimitReached = true;
        return false;
      }
      round.store(r + 1, std::memory_order_relaxed);
      countPending();
      return true;
    };
    // Between phases (not after a cancel): the next round's tiles, then every tile to write.
    const std::function<int64_t()> next = [&]() -> int64_t {
      if (writing.load()) return 0;
      ++stats.rounds;
      if (anotherRound()) return static_cast<int64_t>(order.size());
      writing = true;
      return static_cast<int64_t>(m_tileCount);
    };
    JobControl rounds;  // counts the current round's tiles
    const std::function<void()> roundPoll = [&] {
      control.total = 1000;
      control.done = static_cast<int64_t>(1000 * (round.load() + rounds.fraction()) / (m_rounds + 1));
      poll();
      if (control.cancel.load()) rounds.cancel = true;
    };
    runPhases(static_cast<int64_t>(order.size()), workers, rounds, work, next, roundPoll);
    if (control.cancel.load()) {
      if (!writing.load()) ++stats.rounds;  // the round cancelled
      stats.timeLimitReached = late.load();
      for (size_t u = 0; u < m_tileCount; ++u) {  // the output's pixels no tile wrote
        if (written[u]) continue;
        const int tx = m_firstTileX + static_cast<int>(u % m_tilesX), ty = m_firstTileY + static_cast<int>(u / m_tilesX);
        m_tiles.markUnreached(tx * kTileSize, ty * kTileSize, kTileSize, kTileSize);
      }
    } else {
      summarise(stats);
    }
    RayCounters counters;
    for (const WorkerCounters& w : traced) counters += w.counters;
    return counters;
  }

 private:
  // A tile's pixels' silhouette strata, the sums of their samples inside them, and the spheres they
  // watch, and their control variates (kept only where pixels may have one: m_strata; 345 bytes a pixel in
  // double, 293 in float).
  struct StratumState {
    PixelStratum strata[kPacketSize];                     // the silhouettes crossing the pixel (PixelStratum)
    uint32_t sphere[kPacketSize];                         // its sphere, if one (Tiles::kNoSphere: none, or several)
    uint32_t watched[Tiles::kWatched][kPacketSize];       // spheres crossing it no sample has met (watchSilhouettes)
    float watchedShare[Tiles::kWatched][kPacketSize];     // the share of the pixel their silhouettes cover
    float watchedMissed[Tiles::kWatched][kPacketSize];    // samples since inside their silhouettes, none meeting them
    Real inR[kPacketSize], inG[kPacketSize], inB[kPacketSize], inA[kPacketSize];  // sums of the samples in it
    Real inside[kPacketSize];                             // their count
    Real lastInR[kPacketSize], lastInG[kPacketSize], lastInB[kPacketSize], lastInside[kPacketSize];  // of the second half
    StratumControl control[kPacketSize];  // its samples' inside control variate (StratumControl.h): read through controlOf
    Real probe[4][kPacketSize];  // the colour (r, g, b, a) a probe ray met outside its stratum (probeOutsides)
    bool probed[kPacketSize];    // whether one did
    // Whether its outside's colour is known without a sample (a cover's control, StratumControl::covered,
    // or a probe's), or it has none (share 1): set by the first pass, which has the controls at hand.
    bool outsideKnown[kPacketSize];
    bool controlled;                                      // whether a pixel of the tile has a control

    // Pixel k's mean of channel `channel` (r, g, b, a) by its stratum (PixelStratum::mean), from the
    // channel's sum over all the pixel's `count` samples and over those inside (`in`). Where no sample
    // has reached the inside of a stratum whose samples less their control are one colour there
    // (exact), that colour is the control's mean (the control is the colour itself less its mean
    // there; alpha 1), weighed by the inside's share; so is the outside's, where its cover's control
    // makes it exact too (StratumControl::covered), or where a probe ray met it (the outside of an
    // exact stratum is one colour: probeOutsides).
    Real mean(int k, int channel, Real sum, Real count, Real in) const {
      if (!(count > 0 && exact(k)) || (inside[k] > 0 && (inside[k] < count || !outsideKnown[k]))) {
        return strata[k].mean(sum, count, in, inside[k]);
      }
      const auto known = [&](const Vec3<float>& mean) { return channel < 3 ? static_cast<Real>(mean[channel]) : Real(1); };
      const Real s = static_cast<Real>(strata[k].share);
      const Real inMean = inside[k] > 0 ? in / inside[k] : known(control[k].mean);
      const Real outMean = inside[k] < count ? (sum - in) / (count - inside[k])
                           : probed[k]       ? probe[channel][k]
                                             : known(control[k].coverMean);
      return s * inMean + (1 - s) * outMean;
    }
    // Pixel k's control where the tile has controls and the pixel a stratum (silhouetteStrata writes
    // a control only with its stratum: elsewhere control[k] holds an earlier tile's); else null.
    const StratumControl* controlOf(int k) const { return controlled && strata[k].any() ? &control[k] : nullptr; }
    // Whether pixel k's samples less their control are one colour on each part of its stratum
    // (StratumControl::exact).
    bool exact(int k) const { return controlOf(k) != nullptr && control[k].exact; }
  };

  // A tile's pixels (clipped to the work region) and what adaptive sampling keeps of them.
  struct TileState {
    int x0, y0, w, h;
    Sums sums;                                            // every sample so far
    Real lastR[kPacketSize], lastG[kPacketSize], lastB[kPacketSize];  // colour sums of the second half
    StratumState* stratum;                                // its pixels' strata (null: none may have one)
    int32_t taken[kPacketSize];                           // samples so far
    int32_t last[kPacketSize];                            // of which the last round's (the second half)
    int32_t add[kPacketSize];                             // samples the next round takes
    bool mixed[kPacketSize];  // a later sample met geometry that differs, or a silhouette may hide in it unseen
    bool uniform[kPacketSize];  // every sample met the first's primitive (or every one nothing)
    float firstNx[kPacketSize], firstNy[kPacketSize], firstNz[kPacketSize];  // the first sample's shading normal (0: none)
    uint64_t sampledBits;                                 // the pixels sampledRound sampled (TileMask.h)
    bool exact[kPacketSize];                              // exactly controlled (StratumState::exact; the first pass's)
    uint64_t exactBits;                                   // those pixels (TileMask.h)
    int sampledRound;                                     // the last round that sampled any
    float priority;                                       // the worst marked pixel's (time limit: first)
    int probes;                                           // probeOutsides' rays
    double squares, worst;                                // its output pixels' error estimates: sum of squares, largest
  };

  // What marking reads of a pixel, in one array over the work region and a ring of absent pixels
  // around it: a 3x3 neighbourhood is three short rows of one compact array (a tile's ring lies in
  // other tiles), with no bounds tests. (The first samples' normals, which only the rare crease test
  // reads, stay in the tiles.)
  struct Summary {
    float error;                    // estimated RMS error of the mean colour (its last round's)
    float averaged;                 // its rounds' estimates averaged (the file's head)
    float firstT;                   // how far along its ray the first sample met (inf: a miss)
    float meanR, meanG, meanB;      // the mean colour
    int32_t firstPrim;              // the primitive the first sample met
    bool present;                   // inside the work region
    bool smooth;                    // no sphere's footprint reaches it, where only spheres make edges (TileRenderer::markSilhouettes)
  };

  Summary& summaryAt(int x, int y) {
    return m_summary[static_cast<size_t>(y - m_work.y + 1) * m_stride + (x - m_work.x + 1)];
  }

  // Adds a sample inside pixel k's stratum to the stratum's sums (and its second half's, if `last`).
  static void addInside(TileState& t, int k, Real r, Real g, Real b, Real a, bool last) {
    StratumState& s = *t.stratum;
    s.inR[k] += r, s.inG[k] += g, s.inB[k] += b, s.inA[k] += a, s.inside[k] += 1;
    if (last) s.lastInR[k] += r, s.lastInG[k] += g, s.lastInB[k] += b, s.lastInside[k] += 1;
  }

  // For a tile with strata: marks inside[j] whether sample j, at (sampleX[j], sampleY[j]) in pixel
  // k = pixel[j] of the tile (pixel == nullptr: k = j), lies in the pixel's stratum. Where the tile's
  // strata have a control (StratumControl.h), sets correction[j] to what sample j's
  // colour is taken less (its control, TileRenderer::control: 0 outside, or without one) and
  // returns correction; else null.
  const Vec3<Real>* markInside(const TileState& t, const Real* sampleX, const Real* sampleY, const int* pixel, int count,
                               bool* inside, Vec3<Real>* correction) const {
    const StratumState& u = *t.stratum;
    for (int j = 0, end; j < count; j = end) {  // by runs of one pixel's samples (a refining round's)
      const int k = pixel ? pixel[j] : j;
      for (end = j + 1; pixel && end < count && pixel[end] == k;) ++end;
      const PixelStratum& stratum = u.strata[k];
      const StratumControl* control = u.controlOf(k);
      const bool controlled = control != nullptr && control->any(), covered = controlled && control->covered();
      for (int i = j; i < end; ++i) {
        inside[i] = stratum.contains(double(sampleX[i]), double(sampleY[i]));
        if (!u.controlled) continue;
        correction[i] = (inside[i] || covered) && controlled ? m_tiles.control(stratum, *control, double(sampleX[i]), double(sampleY[i]))
                                                             : Vec3<Real>(0);
      }
    }
    return u.controlled ? correction : nullptr;
  }

  // For a tile with strata: counts the samples at (sampleX[j], sampleY[j]) in pixel pixel[j] of the
  // tile (a pixel's samples consecutive) that lie inside the silhouette of a sphere the pixel
  // watches (each is counted before its ray is traced: one that meets the sphere ends the watch,
  // noteGeometry).
  void countWatched(TileState& t, const Real* sampleX, const Real* sampleY, const int* pixel, int count) const {
    StratumState& u = *t.stratum;
    for (int j = 0, end; j < count; j = end) {
      const int k = pixel[j];
      for (end = j + 1; end < count && pixel[end] == k;) ++end;
      for (int s = 0; s < Tiles::kWatched; ++s) {
        if (u.watched[s][k] == Tiles::kNoSphere) continue;
        const typename Tiles::ImageDisk disk = m_tiles.silhouette(u.watched[s][k]);
        for (int i = j; i < end; ++i) u.watchedMissed[s][k] += disk.contains(double(sampleX[i]), double(sampleY[i])) ? 1.0f : 0.0f;
      }
    }
  }

  // A packet's colours less their corrections (markInside), in `corrected`; without, as given.
  static const Vec3<Real>* correct(const Vec3<Real>* rgb, const Vec3<Real>* correction, int count, Vec3<Real>* corrected) {
    if (!correction) return rgb;
    for (int j = 0; j < count; ++j) corrected[j] = rgb[j] - correction[j];
    return corrected;
  }

  // Where a refining round's packet goes (TileRenderer::trace): sample j to pixel pixel[j] of the
  // tile, in order, its colour also to the pixel's last-round sums (all of a refining round's
  // samples are). The pixel's sums are then those of adding its samples one at a time, whatever the
  // packets. (No sample of a refining round is a pixel's first: its normal is kept only for the
  // passes.)
  struct PixelSink {
    TileState& t;
    const int* pixel;
    const bool* inside;  // whether sample j lies in its pixel's stratum (null: the tile has none)
    const Vec3<Real>* correction;  // what sample j's colour is taken less (markInside; null: none)
    bool normalPass;  // the normal or id passes: the pixels' normals' and nearest hit's sums are kept
    void addColor(int j, Real r, Real g, Real b, Real a) {
      const int k = pixel[j];
      if (correction) r -= correction[j].r, g -= correction[j].g, b -= correction[j].b;
      t.sums.addColor(k, r, g, b, a);
      t.lastR[k] += r, t.lastG[k] += g, t.lastB[k] += b;
      if (inside && inside[j]) addInside(t, k, r, g, b, a, true);
    }
    // The shaded path's colours: each run of one pixel's samples summed in registers (the same
    // sums, in the same order, as addColor one at a time, without a store and reload per sample).
    void addColors(const Vec3<Real>* given, const Real* alpha, int count) {
      alignas(64) Vec3<Real> corrected[kPacketSize];
      const Vec3<Real>* rgb = correct(given, correction, count, corrected);
      for (int j = 0, end; j < count; j = end) {
        const int k = pixel[j];
        Real r = t.sums.r[k], g = t.sums.g[k], b = t.sums.b[k], a = t.sums.a[k];
        Real lr = t.lastR[k], lg = t.lastG[k], lb = t.lastB[k];
        for (end = j; end < count && pixel[end] == k; ++end) {
          r += rgb[end].r, g += rgb[end].g, b += rgb[end].b, a += alpha[end];
          lr += rgb[end].r, lg += rgb[end].g, lb += rgb[end].b;
        }
        t.sums.r[k] = r, t.sums.g[k] = g, t.sums.b[k] = b, t.sums.a[k] = a;
        t.lastR[k] = lr, t.lastG[k] = lg, t.lastB[k] = lb;
      }
      for (int j = 0; inside && j < count; ++j) {
        if (inside[j]) addInside(t, pixel[j], rgb[j].r, rgb[j].g, rgb[j].b, alpha[j], true);
      }
    }
    void addDepth(int j, Real d) { t.sums.addDepth(pixel[j], d); }
    bool wantsNormal(int) const { return normalPass; }
    void addNormal(int j, Real along, int32_t prim, Real x, Real y, Real z) { t.sums.addNormal(pixel[j], along, prim, x, y, z); }
    bool addNearest(int j, bool hit, Real along, int32_t prim) { return t.sums.addNearest(pixel[j], hit, along, prim); }
  };

  // The first pass's sink: entry k is pixel k of the tile, and a packet's samples all have one
  // sample number, `sample`, of the pixels' last round's or not (`last`): PixelSink's sums, in
  // loops over the packet without a pixel's run to find, and the normals of every sample for the
  // passes, of each pixel's first for the crease test.
  struct FirstPassSink {
    TileState& t;
    uint32_t sample;
    bool last;
    const bool* inside;  // whether pixel k's sample lies in its stratum (null: the tile has none)
    const Vec3<Real>* correction;  // what pixel k's sample's colour is taken less (markInside; null: none)
    bool normalPass;  // the normal or id passes: the pixels' normals' and nearest hit's sums are kept
    void addColor(int k, Real r, Real g, Real b, Real a) {
      if (correction) r -= correction[k].r, g -= correction[k].g, b -= correction[k].b;
      t.sums.addColor(k, r, g, b, a);
      if (last) t.lastR[k] += r, t.lastG[k] += g, t.lastB[k] += b;
      if (inside && inside[k]) addInside(t, k, r, g, b, a, last);
    }
    void addColors(const Vec3<Real>* given, const Real* alpha, int count) {
      alignas(64) Vec3<Real> corrected[kPacketSize];
      const Vec3<Real>* rgb = correct(given, correction, count, corrected);
      for (int k = 0; k < count; ++k) t.sums.addColor(k, rgb[k].r, rgb[k].g, rgb[k].b, alpha[k]);
      for (int k = 0; inside && k < count; ++k) {
        if (inside[k]) addInside(t, k, rgb[k].r, rgb[k].g, rgb[k].b, alpha[k], last);
      }
      if (!last) return;
      for (int k = 0; k < count; ++k) t.lastR[k] += rgb[k].r, t.lastG[k] += rgb[k].g, t.lastB[k] += rgb[k].b;
    }
    void addDepth(int k, Real d) { t.sums.addDepth(k, d); }
    bool wantsNormal(int) const { return normalPass || sample == 0; }
    void addNormal(int k, Real along, int32_t prim, Real x, Real y, Real z) {
      if (normalPass) t.sums.addNormal(k, along, prim, x, y, z);
      if (sample == 0) t.firstNx[k] = float(x), t.firstNy[k] = float(y), t.firstNz[k] = float(z);
    }
    bool addNearest(int k, bool hit, Real along, int32_t prim) { return t.sums.addNearest(k, hit, along, prim); }
  };

  // The first pass: every pixel's first samples, a packet a sample number (the sample of each of
  // the tile's pixels, row by row, as the other samplers trace a tile: the camera's view culls such
  // packets by the tile's rows). A pixel's sums take its samples in their order, as in a refining
  // round; the later half of them are its last round's. False if cancelled.
  bool firstPass(TileState& t, RayCounters& counters) {
    const int count = t.w * t.h, firstOfLast = m_firstSamples - m_firstSamples / 2;
    alignas(64) Real sampleX[kPacketSize], sampleY[kPacketSize], box[4];
    alignas(64) double lensU[kPacketSize], lensV[kPacketSize];
    alignas(64) int px[kPacketSize], py[kPacketSize];
    alignas(64) uint32_t s[kPacketSize], order[kPacketSize], points[kPacketSize];  // sample numbers, seeds
    alignas(64) int32_t prim[kPacketSize];
    alignas(64) Real along[kPacketSize];
    alignas(64) float farthest[kPacketSize];  // the farthest hit of each pixel's samples (inf: a miss)
    alignas(64) bool inside[kPacketSize];
    alignas(64) Vec3<Real> correction[kPacketSize];
    alignas(64) int32_t met[kMetPrimitives][kPacketSize];  // the primitives each pixel's samples met (watchSilhouettes)
    alignas(64) int metCount[kPacketSize];                 // how many (at most kMetPrimitives are kept)
    std::fill(farthest, farthest + count, -std::numeric_limits<float>::infinity());
    std::fill(metCount, metCount + count, 0);
    for (int row = 0, k = 0; row < t.h; ++row) {
      for (int col = 0; col < t.w; ++col, ++k) {
        px[k] = t.x0 + col, py[k] = t.y0 + row;
        m_tiles.sobolSeeds(px[k], py[k], order[k], points[k]);
        t.lastR[k] = t.lastG[k] = t.lastB[k] = 0;
      }
    }
    // Whether a pixel of the tile has a stratum: only then are the sums inside read (where none has,
    // the samples add nothing to them). Whether it watches spheres: where a round may follow, through
    // an orthographic camera (watchSilhouettes).
    bool strata = false;
    const bool watch = t.stratum != nullptr && m_rounds > 0 && m_tiles.seesDisks();
    if (StratumState* u = t.stratum) {
      m_tiles.silhouetteStrata(t.x0, t.y0, t.w, t.h, u->strata, u->sphere, m_tiles.controlsStrata() ? u->control : nullptr,
                               m_maxSamples >= kSplitSamples, kControlError * m_target);
      for (auto& watched : u->watched) std::fill(watched, watched + count, Tiles::kNoSphere);  // set after the samples
      std::fill(u->probed, u->probed + count, false);
      strata = std::any_of(u->strata, u->strata + count, [](const PixelStratum& p) { return p.any(); });
      u->controlled = false;
      if (strata) {
        for (Real* sums : {u->inR, u->inG, u->inB, u->inA, u->inside, u->lastInR, u->lastInG, u->lastInB, u->lastInside}) {
          std::fill(sums, sums + count, Real(0));
        }
        for (int k = 0; m_tiles.controlsStrata() && k < count; ++k) {  // as controlOf reads them: with their strata
          u->controlled = u->controlled || (u->strata[k].any() && u->control[k].any());
        }
      }
    }
    for (int sample = 0; sample < m_firstSamples; ++sample) {
      std::fill(s, s + count, static_cast<uint32_t>(sample));
      m_tiles.sobolPositions(px, py, order, points, s, count, sampleX, sampleY, box, lensU, lensV);
      const Vec3<Real>* corrections = strata ? markInside(t, sampleX, sampleY, nullptr, count, inside, correction) : nullptr;
      FirstPassSink sink{t, static_cast<uint32_t>(sample), sample >= firstOfLast, strata ? inside : nullptr, corrections,
                         m_tiles.needsNormals()};
      if (!m_tiles.trace(sampleX, sampleY, box, lensU, lensV, count, sink, prim, along, counters, t.x0, t.y0, t.w)) {
        return false;
      }
      for (int row = 0, k = 0; row < t.h; ++row) {  // by rows: no division to find a pixel's summary
        Summary* line = &summaryAt(t.x0, t.y0 + row);
        for (int col = 0; col < t.w; ++col, ++k) noteGeometry(t, k, line[col], k, k + 1, s, prim, along);
      }
      for (int k = 0; k < count; ++k) farthest[k] = std::max(farthest[k], static_cast<float>(along[k]));
      for (int k = 0; watch && k < count; ++k) {  // for the watch (below)
        int i = 0;
        while (i < metCount[k] && met[i][k] != prim[k]) ++i;
        if (i == metCount[k] && i < kMetPrimitives) met[i][k] = prim[k], metCount[k] = i + 1;
      }
    }
    if (!probeOutsides(t, prim, counters)) return false;
    if (StratumState* u = t.stratum; u && strata) {
      for (int k = 0; k < count; ++k) {
        const StratumControl* control = u->controlOf(k);
        u->outsideKnown[k] = u->probed[k] || (control != nullptr && control->covered()) || !(u->strata[k].share < 1);
      }
    }
    // A sphere smaller than the samples' spacing, or the sliver of one, may lie between them: where
    // the camera's view says a silhouette crosses a pixel, it is an edge (mark) whatever they saw.
    // Where the view proves a pixel smooth (read by mark and a two-sample pixel's reported error).
    const bool smoothRead = m_rounds > 0 || m_firstSamples == 2;
    alignas(64) bool smooth[kPacketSize];
    m_tiles.markSilhouettes(t.x0, t.y0, t.w, t.h, farthest, t.mixed, smoothRead ? smooth : nullptr);
    if (m_rounds > 0 && m_tiles.findsShadowEdges()) {  // shadows' edges on planes, as geometry's
      alignas(64) int32_t firstPrim[kPacketSize];
      for (int row = 0, k = 0; row < t.h; ++row) {
        const Summary* line = &summaryAt(t.x0, t.y0 + row);
        for (int col = 0; col < t.w; ++col, ++k) firstPrim[k] = line[col].firstPrim;
      }
      m_tiles.markShadowEdges(t.x0, t.y0, t.w, t.h, firstPrim, t.uniform, t.mixed);
    }
    if (smoothRead) {
      for (int row = 0, k = 0; row < t.h; ++row) {
        Summary* line = &summaryAt(t.x0, t.y0 + row);
        for (int col = 0; col < t.w; ++col, ++k) line[col].smooth = smooth[k];
      }
    }
    if (StratumState* u = t.stratum; u && watch) {  // what to watch for
      const auto wasMet = [&](int k, uint32_t sphere) {
        for (int i = 0; i < metCount[k]; ++i) {
          if (met[i][k] == static_cast<int32_t>(sphere)) return true;
        }
        return false;
      };
      // One that could not matter (unseen, it would put the mean off by less than the target) is not
      // watched: its share never changes.
      const double least = m_target / kUnseenShare;
      // A sphere beyond every hit of the first samples may still show where what they met leaves
      // part of the pixel uncovered (a sphere's disk around which the samples all fell). An exactly
      // controlled pixel watches none: its members are every sphere crossing it (unseenShare).
      alignas(64) float reach[kPacketSize];
      for (int row = 0, k = 0; row < t.h; ++row) {
        for (int col = 0; col < t.w; ++col, ++k) {
          if (u->exact(k)) {
            reach[k] = -std::numeric_limits<float>::infinity();
            continue;
          }
          bool hidden = false;
          for (int i = 0; i < metCount[k] && !hidden; ++i) hidden = m_tiles.hidesBeyond(met[i][k], t.x0 + col, t.y0 + row);
          reach[k] = hidden ? farthest[k] : std::numeric_limits<float>::infinity();
        }
      }
      m_tiles.watchSilhouettes(t.x0, t.y0, t.w, t.h, reach, u->sphere, wasMet, least, u->watched, u->watchedShare);
      for (auto& missed : u->watchedMissed) std::fill(missed, missed + count, 0.0f);
    }
    // A tile without a stratum or a sphere watched (most tiles of an image of large spheres) keeps
    // none of their bookkeeping for its later samples: what it would sum is never read.
    const auto watching = [&](const StratumState& u) {
      return std::any_of(std::begin(u.watched), std::end(u.watched), [&](const uint32_t(&watched)[kPacketSize]) {
        return std::any_of(watched, watched + count, [](uint32_t sphere) { return sphere != Tiles::kNoSphere; });
      });
    };
    if (t.stratum != nullptr && !strata && !watching(*t.stratum)) t.stratum = nullptr;
    t.exactBits = 0;
    for (int row = 0, k = 0; row < t.h; ++row) {
      for (int col = 0; col < t.w; ++col, ++k) {
        t.exact[k] = t.stratum != nullptr && t.stratum->exact(k);
        t.exactBits |= t.exact[k] ? tileBit(t.x0 + col, t.y0 + row) : 0;
      }
    }
    return true;
  }

  // Where a refining round may follow, the first pass's probes: a pixel whose samples less their
  // control are one colour on each part of its stratum (exact), whose first samples all landed
  // inside it and whose outside no cover's control makes known would refine until a sample reaches
  // that outside while its share exceeds the target (unresolvedShare), a sliver of it taking dozens.
  // Its outside is one colour (the plane's or the background's: StratumControl::exact), which one ray
  // there tells: at a point of it (PixelStratum::outsidePoint), its colour the outside's mean until a
  // sample reaches it (StratumState::mean). A camera ray, not one of the pixel's samples (which stay
  // its Sobol points, doubling). A probe that met one of the spheres after all (a sliver the
  // members' float-rounded disks leave out) is dropped. Such a render is orthographic, its rays
  // whole lines, its geometry the view's spheres and at most one unbounded plane, lit by suns
  // alone, unshadowed (TileRenderer::controlIsShading): every ray that meets no sphere meets the
  // plane, or every one misses, and sees one colour. So where the first pass took one or two samples
  // a pixel, and a pixel of the tile with no stratum (its samples taken less no control) met no
  // sphere with all of them (uniform), their mean is every probe's colour, exactly: no point of the
  // outside is looked for and no ray traced (`met`: what each pixel's last sample met). False if
  // cancelled.
  bool probeOutsides(TileState& t, const int32_t* met, RayCounters& counters) {
    StratumState* u = t.stratum;
    if (u == nullptr || !u->controlled || m_rounds == 0) return true;
    const int count = t.w * t.h;
    const auto unreached = [&](int k) {
      return u->exact(k) && !u->control[k].covered() && u->inside[k] == Real(m_firstSamples) && 1 - double(u->strata[k].share) > m_target;
    };
    for (int k = 0; m_firstSamples <= 2 && k < count; ++k) {  // a sample that met no sphere, taken less no control
      if (u->strata[k].any() || !t.uniform[k] || m_tiles.metSphere(met[k])) continue;
      const Real samples = Real(m_firstSamples);  // x or x + x: their mean exactly x
      const Real colour[4] = {t.sums.r[k] / samples, t.sums.g[k] / samples, t.sums.b[k] / samples, t.sums.a[k] / samples};
      for (int j = 0; j < count; ++j) {
        if (!unreached(j)) continue;
        for (int c = 0; c < 4; ++c) u->probe[c][j] = colour[c];
        u->probed[j] = true;
      }
      return true;
    }
    alignas(64) Real sampleX[kPacketSize], sampleY[kPacketSize], box[4], along[kPacketSize];
    alignas(64) double offsetU[kPacketSize], offsetV[kPacketSize];
    alignas(64) int px[kPacketSize], py[kPacketSize], pixel[kPacketSize];
    alignas(64) int32_t prim[kPacketSize];
    int n = 0;
    for (int row = 0, k = 0; row < t.h; ++row) {
      for (int col = 0; col < t.w; ++col, ++k) {
        if (!unreached(k)) continue;
        px[n] = t.x0 + col, py[n] = t.y0 + row, pixel[n] = k;
        n += u->strata[k].outsidePoint(px[n], py[n], offsetU[n], offsetV[n]);
      }
    }
    if (n == 0) return true;
    placeSamples(px, py, offsetU, offsetV, n, sampleX, sampleY, box);
    ProbeSink sink{*u, pixel};
    if (!m_tiles.trace(sampleX, sampleY, box, nullptr, nullptr, n, sink, prim, along, counters)) return false;
    t.probes = n;
    for (int j = 0; j < n; ++j) u->probed[pixel[j]] = !m_tiles.metSphere(prim[j]);
    return true;
  }

  // Where probeOutsides' rays go: probe j's colour to pixel pixel[j]'s stratum state, nothing else
  // (the depth, normal and id passes are the samples').
  struct ProbeSink {
    StratumState& u;
    const int* pixel;
    void addColor(int j, Real r, Real g, Real b, Real a) {
      const int k = pixel[j];
      u.probe[0][k] = r, u.probe[1][k] = g, u.probe[2][k] = b, u.probe[3][k] = a;
    }
    void addColors(const Vec3<Real>* rgb, const Real* alpha, int count) {
      for (int j = 0; j < count; ++j) addColor(j, rgb[j].r, rgb[j].g, rgb[j].b, alpha[j]);
    }
    void addDepth(int, Real) {}
    bool wantsNormal(int) const { return false; }
    void addNormal(int, Real, int32_t, Real, Real, Real) {}
    bool addNearest(int, bool, Real, int32_t) { return false; }
  };

  // A refining round: each pixel's add[k] samples, pixel by pixel in packets of up to kPacketSize
  // rays (a pixel's samples are the most coherent rays there are; a packet's sample positions are
  // made together). All of a pixel's new samples are the last round's (its second half). False if
  // cancelled.
  bool refine(TileState& t, RayCounters& counters) {
    alignas(64) Real sampleX[kPacketSize], sampleY[kPacketSize], box[4];
    alignas(64) double lensU[kPacketSize], lensV[kPacketSize];
    alignas(64) int pixel[kPacketSize], px[kPacketSize], py[kPacketSize];
    alignas(64) uint32_t s[kPacketSize], order[kPacketSize], points[kPacketSize];  // sample numbers, seeds
    alignas(64) int32_t prim[kPacketSize];
    alignas(64) Real along[kPacketSize];
    alignas(64) bool inside[kPacketSize];
    alignas(64) Vec3<Real> correction[kPacketSize];
    PixelSink sink{t, pixel, t.stratum ? inside : nullptr, nullptr, m_tiles.needsNormals()};
    int n = 0;
    const auto flush = [&] {
      m_tiles.sobolPositions(px, py, order, points, s, n, sampleX, sampleY, box, lensU, lensV);
      if (t.stratum) {
        sink.correction = markInside(t, sampleX, sampleY, pixel, n, inside, correction);
        countWatched(t, sampleX, sampleY, pixel, n);
      }
      if (!m_tiles.trace(sampleX, sampleY, box, lensU, lensV, n, sink, prim, along, counters)) return false;
      for (int j = 0, end; j < n; j = end) {  // a pixel's samples are consecutive: one run each
        for (end = j + 1; end < n && pixel[end] == pixel[j];) ++end;
        noteGeometry(t, pixel[j], summaryAt(px[j], py[j]), j, end, s, prim, along);
      }
      n = 0;
      return true;
    };
    for (int row = 0, k = 0; row < t.h; ++row) {  // by rows: no division to find a pixel's position
      for (int col = 0; col < t.w; ++col, ++k) {
        if (t.add[k] == 0) continue;
        const int x = t.x0 + col, y = t.y0 + row;
        uint32_t pixelOrder, pixelPoints;
        m_tiles.sobolSeeds(x, y, pixelOrder, pixelPoints);
        t.lastR[k] = t.lastG[k] = t.lastB[k] = 0;
        if (StratumState* u = t.stratum) u->lastInR[k] = u->lastInG[k] = u->lastInB[k] = u->lastInside[k] = 0;
        for (int i = 0; i < t.add[k];) {  // as many of its samples as the packet has room for
          const int count = std::min(t.add[k] - i, kPacketSize - n);
          const auto index = static_cast<uint32_t>(t.taken[k] + i);
          for (int j = 0; j < count; ++j) {  // a counted loop of plain stores: vectorised
            s[n + j] = index + static_cast<uint32_t>(j), pixel[n + j] = k;
            px[n + j] = x, py[n + j] = y, order[n + j] = pixelOrder, points[n + j] = pixelPoints;
          }
          i += count, n += count;
          if (n == kPacketSize && !flush()) return false;
        }
      }
    }
    return n == 0 || flush();
  }

  // Takes each pixel's add[k] samples, then updates the pixels' counts and summaries.
  void sampleTile(TileState& t, int round, RayCounters& counters) {
    const bool first = round == 0;
    if (!(first ? firstPass(t, counters) : refine(t, counters))) return;
    // The sampled pixels' counts, error estimates and means: in the first pass, where every pixel
    // is sampled, in loops the compiler vectorises (a square root and two divisions a pixel, made one
    // pixel at a time, cost a first pass about 5 %); in a refining round, which samples a few of the
    // tile's pixels, for those alone.
    const int count = t.w * t.h;
    alignas(64) float error[kPacketSize], meanR[kPacketSize], meanG[kPacketSize], meanB[kPacketSize];
    alignas(64) bool sampled[kPacketSize];
    alignas(64) int32_t before[kPacketSize];  // samples before this round
    for (int k = 0; k < count; ++k) {
      const int32_t add = t.add[k];
      sampled[k] = add > 0, before[k] = t.taken[k];
      t.taken[k] += add;
      t.last[k] = add == 0 ? t.last[k] : first ? add / 2 : add;
      t.add[k] = 0;
      t.sums.samples[k] = static_cast<Real>(t.taken[k]);
    }
    const auto estimate = [&](int k) {
      error[k] = estimatedError(t, k);
      const Real inverse = 1 / t.sums.samples[k];
      meanR[k] = static_cast<float>(t.sums.r[k] * inverse);
      meanG[k] = static_cast<float>(t.sums.g[k] * inverse);
      meanB[k] = static_cast<float>(t.sums.b[k] * inverse);
    };
    if (first) {
      for (int k = 0; k < count; ++k) estimate(k);
    } else {
      for (int k = 0; k < count; ++k) {
        if (sampled[k]) estimate(k);
      }
    }
    for (int k = 0; t.stratum && k < count; ++k) {  // a stratum's pixels: their estimates and means by its parts
      const StratumState& u = *t.stratum;
      if (!sampled[k] || !u.strata[k].any()) continue;  // an unsampled pixel's summary stands (below)
      error[k] = static_cast<float>(withControlError(stratifiedError(t, k), controlError(t, k)));
      const Real n = t.sums.samples[k];
      meanR[k] = static_cast<float>(u.mean(k, 0, t.sums.r[k], n, u.inR[k]));
      meanG[k] = static_cast<float>(u.mean(k, 1, t.sums.g[k], n, u.inG[k]));
      meanB[k] = static_cast<float>(u.mean(k, 2, t.sums.b[k], n, u.inB[k]));
    }
    uint64_t bits = 0;
    for (int row = 0, k = 0; row < t.h; ++row) {  // by rows: no division to find a pixel's summary
      Summary* line = &summaryAt(t.x0, t.y0 + row);
      for (int col = 0; col < t.w; ++col, ++k) {
        if (!sampled[k]) continue;  // its summary is as its samples left it
        bits |= tileBit(t.x0 + col, t.y0 + row);
        Summary& p = line[col];
        // Sums that overflowed (a float render's colours saturate) leave the error unknown: infinite,
        // not the NaN of inf - inf (such a pixel is never settled before its last round, as an
        // infinite error is not).
        const float e = error[k] == error[k] ? error[k] : std::numeric_limits<float>::infinity();
        p.averaged = before[k] < kHistorySamples ? e : averagedError(e, p.averaged, before[k], t.taken[k]);
        p.error = e, p.meanR = meanR[k], p.meanG = meanG[k], p.meanB = meanB[k];
      }
    }
    t.sampledBits = bits, t.sampledRound = round;
  }

  // Sets tile u's state and its pixels' summaries for the first pass.
  void start(size_t u) {
    TileState& t = m_state[u];
    const int tx = m_firstTileX + static_cast<int>(u % m_tilesX), ty = m_firstTileY + static_cast<int>(u / m_tilesX);
    t.x0 = std::max(tx * kTileSize, m_work.x), t.y0 = std::max(ty * kTileSize, m_work.y);
    t.w = std::min((tx + 1) * kTileSize, m_work.x + m_work.width) - t.x0;
    t.h = std::min((ty + 1) * kTileSize, m_work.y + m_work.height) - t.y0;
    const int count = t.w * t.h;
    t.sums.clear(true, m_tiles.needsNormals(), true);  // colours too: the error estimates read them
    t.stratum = m_strata ? &m_stratum[u] : nullptr;  // its sums are cleared where a pixel has a stratum (firstPass)
    std::fill(t.taken, t.taken + count, 0);
    std::fill(t.last, t.last + count, 0);
    std::fill(t.add, t.add + count, m_firstSamples);
    std::fill(t.mixed, t.mixed + count, false);
    std::fill(t.exact, t.exact + count, false);
    std::fill(t.uniform, t.uniform + count, true);
    std::fill(t.firstNx, t.firstNx + count, 0.0f);
    std::fill(t.firstNy, t.firstNy + count, 0.0f);
    std::fill(t.firstNz, t.firstNz + count, 0.0f);
    t.priority = 0;
    t.sampledBits = 0, t.sampledRound = -1, t.exactBits = 0, t.probes = 0;
    for (int row = 0; row < t.h; ++row) {
      Summary* line = &summaryAt(t.x0, t.y0 + row);
      for (int col = 0; col < t.w; ++col) {
        Summary& p = line[col];
        p.error = p.averaged = p.firstT = p.meanR = p.meanG = p.meanB = 0;
        p.firstPrim = kNoPrimitive, p.present = true, p.smooth = false;
      }
    }
  }

  // Notes what samples [j0, j1) of pixel k (its summary p; sample numbers s[j], which met prim[j] at
  // along[j] on their rays) saw: the first sample's primitive and distance, and whether a later one
  // met other geometry beyond a depth discontinuity.
  void noteGeometry(TileState& t, int k, Summary& p, int j0, int j1, const uint32_t* s, const int32_t* prim,
                    const Real* along) {
    if (StratumState* u = t.stratum) {  // a watched sphere met is seen
      for (auto& watched : u->watched) {
        for (int j = j0; j < j1 && watched[k] != Tiles::kNoSphere; ++j) {
          if (prim[j] == static_cast<int32_t>(watched[k])) watched[k] = Tiles::kNoSphere;
        }
      }
    }
    int32_t firstPrim = p.firstPrim;
    float firstT = p.firstT;
    bool mixed = t.mixed[k], uniform = t.uniform[k];
    if (mixed && s[j0] > 0) return;  // nothing left to note (smoothlyShaded asks no mixed pixel)
    for (int j = j0; j < j1; ++j) {
      if (s[j] == 0) {
        firstPrim = prim[j], firstT = static_cast<float>(along[j]);
      } else if (prim[j] != firstPrim) {
        mixed = mixed || depthJump(along[j], firstT), uniform = false;
      }
    }
    p.firstPrim = firstPrim, p.firstT = firstT, t.mixed[k] = mixed, t.uniform[k] = uniform;
  }

  static bool depthJump(Real a, Real b) {
    const bool hitA = a < std::numeric_limits<Real>::infinity(), hitB = b < std::numeric_limits<Real>::infinity();
    if (hitA != hitB) return true;
    return hitA && std::abs(a - b) > static_cast<Real>(kDepthJump) * std::min(a, b);
  }

  // The RMS over the colour channels of the difference of the two halves' means, scaled to the
  // standard error of the whole mean: for a and b samples, E[(mA - mB)^2] = var (1/a + 1/b) and the
  // mean's variance is var / (a + b). Over the common denominator ab: one division.
  static float estimatedError(const TileState& t, int k) {
    const double b = t.last[k], a = t.taken[k] - b;
    const double dr = (t.sums.r[k] - t.lastR[k]) * b - t.lastR[k] * a;  // (mA - mB) ab
    const double dg = (t.sums.g[k] - t.lastG[k]) * b - t.lastG[k] * a;
    const double db = (t.sums.b[k] - t.lastB[k]) * b - t.lastB[k] * a;
    // With one sample there is nothing to compare (a or b is 0): 0, chosen without a branch (a loop
    // over pixels then vectorises). Otherwise the denominator is at least 12 and the result the plain
    // quotient's root.
    const double denominator = 3 * a * b * (a + b) * (a + b);
    const double squares = denominator == 0 ? 0.0 : dr * dr + dg * dg + db * db;
    return static_cast<float>(std::sqrt(squares / std::max(denominator, 1.0)));  // NaN: sums that overflowed
  }

  // estimatedError for a pixel whose mean is its stratum's (both parts sampled; otherwise the plain
  // mean's, and its estimate): the difference of the two halves' means, each made as the pixel's
  // is, by the stratum's parts; a part a half has no sample of takes the whole's mean of the part
  // there (it then adds nothing to the difference: nothing to compare).
  static float stratifiedError(const TileState& t, int k) {
    const StratumState& u = *t.stratum;
    const double n = double(t.sums.samples[k]), inside = double(u.inside[k]);
    const bool finite = std::isfinite(t.sums.r[k]) && std::isfinite(t.sums.g[k]) && std::isfinite(t.sums.b[k]);
    if (!(inside > 0 && inside < n && finite)) return estimatedError(t, k);  // as its mean (PixelStratum::mean)
    const double b = t.last[k], a = n - b, bIn = double(u.lastInside[k]), aIn = inside - bIn;
    if (a == 0 || b == 0) return 0;
    const double share = double(u.strata[k].share);
    // A half's mean of one channel from its sum and its part inside's, given the whole's.
    const auto half = [&](double sum, double count, double in, double countIn, double wholeIn, double wholeOut) {
      const double countOut = count - countIn;
      return share * (countIn > 0 ? in / countIn : wholeIn) + (1 - share) * (countOut > 0 ? (sum - in) / countOut : wholeOut);
    };
    const auto difference = [&](Real sum, Real last, Real in, Real lastIn) {
      const double wholeIn = double(in) / inside, wholeOut = (double(sum) - double(in)) / (n - inside);
      return half(double(sum) - double(last), a, double(in) - double(lastIn), aIn, wholeIn, wholeOut) -
             half(double(last), b, double(lastIn), bIn, wholeIn, wholeOut);
    };
    const double dr = difference(t.sums.r[k], t.lastR[k], u.inR[k], u.lastInR[k]);
    const double dg = difference(t.sums.g[k], t.lastG[k], u.inG[k], u.lastInG[k]);
    const double db = difference(t.sums.b[k], t.lastB[k], u.inB[k], u.lastInB[k]);
    return static_cast<float>(std::sqrt((dr * dr + dg * dg + db * db) * a * b / (3 * (a + b) * (a + b))));
  }

  // A pixel's estimates averaged over its rounds (the file's head): this round's estimate and the
  // average before, made from `before` of its now `taken` samples, averaged as squares.
  static float averagedError(float estimate, float averaged, int before, int taken) {
    const double e = estimate, last = averaged;
    return static_cast<float>(std::sqrt((e * e + last * last * before / taken) / 2));
  }

  // How far pixel k's stratified mean may be off for want of samples its error estimate can see: a
  // part of its stratum none of its samples has reached counts its share of the pixel (its colour is
  // unknown: it may be off the pixel's by about 1, a lit sphere against a dark ground), but the
  // inside of a stratum exactly controlled, whose colour is known (StratumState::mean), and its
  // outside where a cover's control or a probe tells its colour (probeOutsides); a part whose
  // samples all lie in one half (its spread is then invisible to the halves' difference) its share
  // times kPartSpread over the root of its samples (a colour in [0, 1] spreads by at most 1/2), but
  // where the samples less their control are one colour on each part (StratumControl::exact). 0
  // without a stratum, or where both halves reached both parts. (The depth, normal and id passes are
  // their samples' means: where an inside no sample reached is known, they miss its spheres, as a
  // part within the target's share would be; the passes asked for change no colour nor count.)
  static double unresolvedShare(const TileState& t, int k) {
    if (t.stratum == nullptr) return 0;
    const StratumState& u = *t.stratum;
    const double n = double(t.sums.samples[k]), inside = double(u.inside[k]);
    if (exactlyControlled(t, k)) {  // its inside known, its outside too with a cover's control or a probe's colour
      return inside == n && !u.outsideKnown[k] ? 1 - double(u.strata[k].share) : 0.0;
    }
    if (!u.strata[k].any()) return 0;
    const double share = double(u.strata[k].share), last = t.last[k], lastInside = double(u.lastInside[k]);
    const auto part = [&](double share, double samples, double inLast) {
      if (samples == 0) return share;
      return inLast == 0 || inLast == samples ? share * kPartSpread / std::sqrt(samples) : 0.0;
    };
    return part(share, inside, lastInside) + part(1 - share, n - inside, last - lastInside);
  }

  // Whether pixel k's samples less their control are one colour on each part of its stratum
  // (StratumControl::exact), as its first pass found (a byte of the tile's state: marking reads it
  // for every pixel, the stratum's state lies two cache lines away).
  static bool exactlyControlled(const TileState& t, int k) { return t.exact[k]; }

  // An error estimate with a control's error (controlError) added in quadrature. Most pixels have
  // none, and glibc's hypot is slow where hypot(e, 0) = |e| anyway.
  static double withControlError(double estimate, double control) {
    return control == 0 ? std::abs(estimate) : std::hypot(estimate, control);
  }

  // What pixel k's control's mean, found in part numerically (StratumControl::meanError), may put its
  // colour off by: its samples cannot see that, and its error estimates add it. 0 without one.
  static double controlError(const TileState& t, int k) {
    const StratumControl* control = t.stratum != nullptr ? t.stratum->controlOf(k) : nullptr;
    return control != nullptr ? double(control->meanError) : 0.0;
  }

  // What a sphere pixel k watches may put its mean off by, none of its samples having met it
  // (watchSilhouettes): its colour there is unknown, as an unsampled part's, over the share of the
  // pixel it may show in: its silhouette's share, over 1 + the samples that have landed inside the
  // silhouette since and met something else (each a point where it is hidden; with none, a sliver
  // the samples have not reached). The largest over the spheres it watches; 0 without any (or strata),
  // or where its stratum is exactly controlled (it has no cover, so every sphere crossing the pixel
  // is one of its members, whose colour the control knows: StratumState::mean).
  static double unseenShare(const TileState& t, int k) {
    if (t.stratum == nullptr || exactlyControlled(t, k)) return 0;
    const StratumState& u = *t.stratum;
    double largest = 0;
    for (int s = 0; s < Tiles::kWatched; ++s) {
      if (u.watched[s][k] == Tiles::kNoSphere) continue;
      largest = std::max(largest, kUnseenShare * double(u.watchedShare[s][k]) / (1 + double(u.watchedMissed[s][k])));
    }
    return largest;
  }

  static int slotOf(const TileState& t, int x, int y) { return (y - t.y0) * t.w + (x - t.x0); }

  // The pixels of tile `index` (as its mask's bits, TileMask.h) a pixel around which (itself
  // included) round `round` sampled.
  uint64_t freshBits(size_t index, int round) const {
    uint64_t sampled[3][3] = {};  // tiles beyond the work region's sample nothing
    const size_t tilesX = static_cast<size_t>(m_tilesX);
    forTilesAround(index, [&](size_t u) {
      const TileState& t = m_state[u];
      if (t.sampledRound == round) sampled[u / tilesX + 1 - index / tilesX][u % tilesX + 1 - index % tilesX] = t.sampledBits;
    });
    return spreadByOne(sampled);
  }

  // Decides add[k] for every pixel of tile `index` from the state the last round left. A pixel whose
  // neighbourhood the last round did not sample decides as before it: nothing to add.
  void mark(size_t index, int level, int round) {
    TileState& t = m_state[index];
    t.priority = 0;
    const uint64_t fresh = round == 0 ? ~uint64_t(0) : freshBits(index, round);
    const uint64_t sampled = t.sampledRound == round ? t.sampledBits : 0;
    for (int row = 0; row < t.h; ++row) {  // by rows: no division to find a pixel's summary
      const Summary* line = &summaryAt(t.x0, t.y0 + row);
      for (int col = 0; col < t.w; ++col) {
        const int k = row * t.w + col;
        const int taken = t.taken[k];
        const uint64_t bit = tileBit(t.x0 + col, t.y0 + row);
        // A pixel none around which (itself included) the round sampled decides as before it: its
        // error was within the target (one that was not took samples) and nothing it reads changed.
        // One exactly controlled reads only its own state (below): so unless the round sampled it.
        if (taken >= level || (fresh & bit) == 0 || ((t.exactBits & bit) != 0 && (sampled & bit) == 0)) continue;
        const Summary& self = line[col];
        const double own = std::max(self.error, self.averaged);  // its judged error (the file's head)
        double error = own, contrast = 0;
        if (own <= m_target) {
          double neighbourhood = 0;
          float largestDifference = 0;
          int around = 0;
          // A pixel whose samples less their control are one colour all over it (StratumControl::exact)
          // looks for no edge its samples missed, in it or beside it: its stratum names every edge
          // crossing it, and what its samples may not have seen yet are its stratum's parts not yet
          // reached (unresolvedShare) and the spheres it watches (unseenShare). Its neighbours'
          // errors say nothing of it either.
          const bool described = (t.exactBits & bit) != 0;
          const bool young = taken < kEdgeSamples && !described;  // an edge keeps a pixel refining only below them
          // A pixel of one sample, whose halves say nothing of its error (estimatedError reads 0), settles
          // only on its control's word (described) or where the camera's view proves it smooth: one
          // plane or the background, no edge (markSilhouettes).
          const bool alone = taken < 2 && !described && !self.smooth;
          bool edge = young && t.mixed[k];
          uint32_t others = 0;  // the neighbours weighed whose first samples met another primitive (bit 3 dy + dx + 4)
          // The 3x3 neighbourhood without branches (which of them counts is as unpredictable as the
          // image): an absent pixel adds 0 to the sum of squares, as one not counted would. (None for
          // a pixel described: it reads nothing of it, its contrast left 0.)
          for (int dy = -1; dy <= 1 && !described; ++dy) {
            for (int dx = -1; dx <= 1; ++dx) {
              const Summary& u = (&self)[dy * m_stride + dx];
              neighbourhood += u.present ? static_cast<double>(u.averaged) * u.averaged : 0.0;
              around += u.present;
              // Between a pixel the camera's view proves smooth and one it does not lies a sphere's
              // silhouette, outside the smooth one: the contrast and geometry across it are the
              // sphere's. (Its errors still count above: a light's edge or peak squeezed between the
              // silhouette and the smooth pixel shows only in the neighbour across it.)
              const bool weighed = u.present && !(self.smooth && !u.smooth);
              const float difference = colourDifference(self, u);
              largestDifference = weighed && largestDifference < difference ? difference : largestDifference;  // std::max
              others |= static_cast<uint32_t>(weighed && u.firstPrim != self.firstPrim) << (3 * dy + dx + 4);
            }
          }
          for (const int x = t.x0 + col, y = t.y0 + row; young && !edge && others != 0; others &= others - 1) {
            const int i = __builtin_ctz(others), dx = i % 3 - 1, dy = i / 3 - 1;
            edge = differ(self, x, y, (&self)[dy * m_stride + dx], x + dx, y + dy);
          }
          // The mean over the channels, divided once: a rounded division keeps the order of its operands.
          const float squaredContrast = largestDifference / 3;
          // error <= target and taken >= contrast / target, compared as squares: the roots only for a
          // pixel marked (an infinite square is never settled, as its root would not be).
          const double squaredError = described ? own * own : std::max(own * own, kNeighbourWeight * neighbourhood / around);
          const double resolved = taken * m_target / kUnseenShare;  // the contrast `taken` samples resolve
          const double inf = std::numeric_limits<double>::infinity();
          const double unresolved = std::max(unresolvedShare(t, k), unseenShare(t, k));
          if (squaredError <= m_target * m_target && squaredError < inf && !edge && !alone &&
              squaredContrast <= resolved * resolved && squaredContrast < inf && unresolved <= m_target) {
            continue;
          }
          error = std::max(std::sqrt(squaredError), unresolved), contrast = std::sqrt(squaredContrast);
        }
        t.add[k] = level - taken;
        t.priority = std::max(t.priority, static_cast<float>(std::max(error, contrast / taken)));
      }
    }
  }

  // f(t) for each tile t around tile `index` (itself included).
  template <typename F>
  void forTilesAround(size_t index, const F& f) const {
    const int tx = static_cast<int>(index % m_tilesX), ty = static_cast<int>(index / m_tilesX);
    const int tilesY = static_cast<int>(m_tileCount / m_tilesX);
    for (int y = std::max(ty - 1, 0); y <= std::min(ty + 1, tilesY - 1); ++y) {
      for (int x = std::max(tx - 1, 0); x <= std::min(tx + 1, m_tilesX - 1); ++x) f(static_cast<size_t>(y) * m_tilesX + x);
    }
  }

  // Whether two pixels see different geometry: their first samples met other primitives, one of
  // them nothing, or both at a depth discontinuity or a crease.
  // (Pixels a at (ax, ay) and b at (bx, by).)
  bool differ(const Summary& a, int ax, int ay, const Summary& b, int bx, int by) const {
    if (a.firstPrim == b.firstPrim) return false;
    if (depthJump(a.firstT, b.firstT)) return true;
    const Vec3d na = firstNormal(ax, ay), nb = firstNormal(bx, by);
    const double la = glm::dot(na, na), lb = glm::dot(nb, nb);
    return la > 0 && lb > 0 && glm::dot(na, nb) < kCreaseCosine * std::sqrt(la * lb);  // no normal made: no crease test
  }

  // The first sample's shading normal of pixel (x, y) of the work region, from its tile.
  Vec3d firstNormal(int x, int y) const {
    const TileState& t = m_state[static_cast<size_t>(y / kTileSize - m_firstTileY) * m_tilesX + (x / kTileSize - m_firstTileX)];
    const int k = slotOf(t, x, y);
    return Vec3d(double(t.firstNx[k]), double(t.firstNy[k]), double(t.firstNz[k]));
  }

  // The sum over the colour channels of the squared difference of two pixels' mean colours: three
  // times the square of their RMS difference.
  static float colourDifference(const Summary& a, const Summary& b) {
    const float dr = a.meanR - b.meanR, dg = a.meanG - b.meanG, db = a.meanB - b.meanB;
    return dr * dr + dg * dg + db * db;
  }

  // The tiles with pixels to refine, in the order of the image, so that each of the `workers`
  // shares runPhases makes is a band of the image, which its worker's caches hold from the rounds
  // before, its tiles in the order they lie in memory. With a time limit, each share the worst first
  // (what the limit cuts is the least needed); without, that order cost a render 4-7 % at 640x360
  // and 1080p (the state's reads jump across the band).
  std::vector<int64_t> tilesToRefine(int workers, bool limited) const {
    std::vector<int64_t> order;
    for (size_t i = 0; i < m_tileCount; ++i) {
      const TileState& t = m_state[i];
      int32_t any = 0;  // the counts' bits together (none is negative): a loop without exits, vectorised
      for (int k = 0; k < t.w * t.h; ++k) any |= t.add[k];
      if (any > 0) order.push_back(static_cast<int64_t>(i));
    }
    const auto n = static_cast<int64_t>(order.size());
    for (int64_t w = 0; limited && w < workers; ++w) {
      std::stable_sort(order.begin() + n * w / workers, order.begin() + n * (w + 1) / workers, [&](int64_t a, int64_t b) {
        return m_state[static_cast<size_t>(a)].priority > m_state[static_cast<size_t>(b)].priority;
      });
    }
    return order;
  }

  // Writes the tile's pixels of the output region and their error estimates; keeps the sum of the
  // estimates' squares and the largest for summarise().
  void writeTile(TileState& t) {
    const RenderSettings::Region& r = m_output;
    double squares = 0, worst = 0;
    const int x0 = std::max(t.x0, r.x), x1 = std::min(t.x0 + t.w, r.x + r.width);
    for (int y = std::max(t.y0, r.y); y < std::min(t.y0 + t.h, r.y + r.height) && x0 < x1; ++y) {
      const size_t first = static_cast<size_t>(y - r.y) * r.width + (x0 - r.x);
      const int k0 = slotOf(t, x0, y);
      for (int k = k0; t.stratum && k < k0 + x1 - x0; ++k) {  // a stratum's pixels: their means by its parts, as sums
        const StratumState& u = *t.stratum;
        if (!u.strata[k].any()) continue;
        const Real n = t.sums.samples[k];
        t.sums.r[k] = u.mean(k, 0, t.sums.r[k], n, u.inR[k]) * n;
        t.sums.g[k] = u.mean(k, 1, t.sums.g[k], n, u.inG[k]) * n;
        t.sums.b[k] = u.mean(k, 2, t.sums.b[k], n, u.inB[k]) * n;
        t.sums.a[k] = u.mean(k, 3, t.sums.a[k], n, u.inA[k]) * n;
      }
      m_tiles.writeRow(t.sums, k0, x1 - x0, first);
      for (int i = 0; i < x1 - x0; ++i) {
        const Summary& p = summaryAt(x0 + i, y);
        // (A pixel whose control is its colour reports its halves' estimate at two samples too: its
        // neighbours' means say nothing of its own.)
        const bool two = t.taken[k0 + i] == 2 && !exactlyControlled(t, k0 + i);
        const double e = two ? withControlError(residualError(p), controlError(t, k0 + i))
                             : smoothlyShaded(t, k0 + i, p) ? p.error / kNetHalves : p.error;
        squares += e * e, worst = std::max(worst, e);
        if (m_targets.error) m_targets.error[first + i] = static_cast<float>(e);
      }
    }
    t.squares = squares, t.worst = worst;
  }

  // The error a pixel of two samples reports. Its halves are one sample each, whose difference
  // measures how the colour changes across the pixel as much as its mean's error, though the two
  // points of a net cancel a gradient's part of that error (on the showcase's smooth pixels the
  // halves' estimate was 2.5x their measured RMS error). Instead: how far its mean lies from the mean
  // of its n neighbours across edges (the 4 present), whose expected square in a smooth region is
  // its squared error times 1 + 1/n (as many samples' error each), and where a gradient cancels. A
  // pixel its view proves smooth (TileRenderer::markSilhouettes), which may settle at two samples beside
  // a sphere's edge, compares itself with the opposite pairs of its neighbours that are smooth too
  // (no silhouette lies between them; a pair keeps a gradient cancelling), else reports its halves'
  // estimate.
  float residualError(const Summary& self) const {
    double r = 0, g = 0, b = 0;
    int n = 0;
    if (self.smooth) {
      for (const int step : {1, m_stride}) {
        const Summary &u = (&self)[-step], &v = (&self)[step];
        if (!(u.present && v.present && u.smooth && v.smooth)) continue;
        r += u.meanR + v.meanR, g += u.meanG + v.meanG, b += u.meanB + v.meanB, n += 2;
      }
    } else {
      for (const Summary* u : {&self - 1, &self + 1, &self - m_stride, &self + m_stride}) {
        if (!u->present) continue;
        r += u->meanR, g += u->meanG, b += u->meanB, ++n;
      }
    }
    if (n == 0) return self.error;
    const double dr = self.meanR - r / n, dg = self.meanG - g / n, db = self.meanB - b / n;
    return static_cast<float>(std::sqrt((dr * dr + dg * dg + db * db) / (3 * (1 + 1.0 / n))));
  }

  // Whether pixel k's halves' estimate is read as a smooth colour's, which it over-states: its
  // samples all met one primitive (or all nothing), no geometry or silhouette marked it (mixed), its
  // mean lies from its neighbours' (residualError) within kNetHalves times that estimate (a smooth
  // colour's curvature and noise stay within it, a specular highlight's too; an edge's jump between
  // them, a shadow's or a reflection's, reads many times more), and its halves are the
  // equal blocks of Sobol points before and after the middle, each a scrambled net and the two
  // together a net of twice the points. Where the colour varies smoothly, each half's error is about
  // 2^1.5 times the whole's (a net's error falls as n^-1.5 there) and the two halves' are opposite,
  // so their difference, scaled as independent samples' are (estimatedError), reads about 2^1.5
  // times the whole's error (measured: 3.1x on the showcase's sphere interiors at four samples, 2.4x
  // at eight). Marking keeps the estimate as it is (it errs toward more samples); the error reported
  // for such a pixel is divided by kNetHalves. A shadow's, a reflection's or a light's edge on one
  // primitive, whose halves over-state the error by about 2^0.75 only, shows as the neighbours'
  // disagreement (a review measured such pixels reporting 0.4 of their error without that test;
  // with it, random scenes with shadows and mirrors report 0.73-1.38 of their measured RMSE, as
  // before this division, and a lit sphere's interior 1.0-1.3 where it read 2.2-3.2).
  bool smoothlyShaded(const TileState& t, int k, const Summary& p) const {
    const int taken = t.taken[k];
    return t.uniform[k] && !t.mixed[k] && !(t.stratum && t.stratum->strata[k].any()) && taken >= 4 &&
           (taken & (taken - 1)) == 0 && 2 * t.last[k] == taken && residualError(p) <= kNetHalves * p.error;
  }

  // The image's estimated RMS error and worst pixel, from the tiles' (in tile order: the same sums
  // on any number of threads), and the probes traced (as the rays are, a region's margin's too).
  void summarise(AdaptiveStats& stats) const {
    const RenderSettings::Region& r = m_output;
    double squares = 0, worst = 0;
    for (size_t u = 0; u < m_tileCount; ++u) {
      squares += m_state[u].squares, worst = std::max(worst, m_state[u].worst), stats.probes += m_state[u].probes;
    }
    stats.estimatedRmse = std::sqrt(squares / (static_cast<double>(r.width) * r.height));
    stats.estimatedWorst = worst;
  }

  const Tiles& m_tiles;
  RenderTargets m_targets;
  RenderSettings::Region m_output;  // the pixels written
  int m_maxSamples, m_firstSamples;
  double m_target, m_timeLimit;
  bool m_strata;                    // whether pixels may have a silhouette stratum: a colour render through
                                    // TileRenderer::stratifies() (the strata's sums are kept only then)
  int m_rounds;                     // refining rounds at most
  RenderSettings::Region m_work;    // the pixels sampled: the output and its margin
  int m_stride;                     // of m_summary's rows
  int m_firstTileX, m_firstTileY, m_tilesX;
  size_t m_tileCount;
  HugeArray<TileState> m_state;           // by tile, row by row
  HugeArray<StratumState> m_stratum;      // by tile, where pixels may have a stratum (m_strata)
  HugeArray<Summary> m_summary;           // the work region's pixels and a ring around them, row by row
};

}  // namespace tiles
}  // namespace durer
