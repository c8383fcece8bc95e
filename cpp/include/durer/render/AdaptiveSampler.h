#pragma once
// Adaptive sampling (SamplerKind::Adaptive): the whole image is sampled in rounds. Every pixel first
// takes minSamples Sobol samples; then, between rounds, each pixel is marked from its own samples
// and its eight neighbours' (across tile borders: the state of every pixel is kept), and every marked
// pixel doubles its samples, up to samplesPerPixel. Doubling keeps a pixel's Sobol points a
// (0,m,2)-net (with a power-of-two first pass), and the two halves of its samples (the last round's
// and the ones before) two nets whose difference estimates the error of their mean.
//
// A pixel is marked while
//   - the estimated RMS error of its colour, or the mean of the squared estimates of its 3x3
//     neighbourhood (an edge a pixel's samples all missed shows in its neighbour's), exceeds
//     targetError;
//   - it has fewer than kEdgeSamples samples and its samples, or it and a neighbour, differ in
//     geometry: hit against miss, or other primitives at a depth discontinuity or a crease;
//   - it has fewer than contrast / targetError samples, where contrast is the RMS difference of its
//     mean colour from a neighbour's: an edge inside it covering less than about 1 / samples of its
//     area may not have been seen yet, and would be off by at most about that times the contrast.
// A time limit stops the refining rounds (never the first pass) when spent; each round takes its
// tiles worst first (the largest estimated error), so what the limit cuts is what matters least.
// Every pixel's state is kept until the end (TileState: 179 bytes a pixel in double, 111 in float).
// Each round reads the state the round before left, so the image depends on the seed only, never on
// threads; a pixel's result depends on the pixels within `rounds` of it, so a region is rendered
// with that margin around it and equals the whole render's pixels bit for bit.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <mutex>
#include <vector>

#include "durer/render/TileRenderer.h"

namespace durer {
namespace tiles {

template <typename Real, SphereMethod M>
class AdaptiveSampler {
 public:
  using Tiles = TileRenderer<Real, M>;
  using Sums = typename Tiles::Accumulator;

  static constexpr int kEdgeSamples = 16;         // geometric edges: samples to look for what the first ones missed
  static constexpr double kDepthJump = 0.02;      // relative depth difference taken as a discontinuity
  static constexpr double kCreaseCosine = 0.9;    // normals further apart (about 25 degrees) make a crease

  AdaptiveSampler(const Tiles& tiles, const RenderSettings& settings, const RenderTargets& targets)
      : m_tiles(tiles),
        m_targets(targets),
        m_output(regionOf(settings)),
        m_maxSamples(settings.samplesPerPixel),
        m_firstSamples(std::min(settings.minSamples, settings.samplesPerPixel)),
        m_target(settings.targetError),
        m_timeLimit(settings.timeLimit),
        m_rounds(roundsFor(m_firstSamples, m_maxSamples)),
        m_work(workRegion(m_output, m_rounds, settings.width, settings.height)) {
    m_firstTileX = m_work.x / kTileSize, m_firstTileY = m_work.y / kTileSize;
    m_tilesX = (m_work.x + m_work.width - 1) / kTileSize - m_firstTileX + 1;
    const int tilesY = (m_work.y + m_work.height - 1) / kTileSize - m_firstTileY + 1;
    m_state.resize(static_cast<size_t>(m_tilesX) * tilesY);
    for (int ty = 0; ty < tilesY; ++ty) {
      for (int tx = 0; tx < m_tilesX; ++tx) {
        TileState& t = m_state[static_cast<size_t>(ty) * m_tilesX + tx];
        t.x0 = std::max((m_firstTileX + tx) * kTileSize, m_work.x);
        t.y0 = std::max((m_firstTileY + ty) * kTileSize, m_work.y);
        t.w = std::min((m_firstTileX + tx + 1) * kTileSize, m_work.x + m_work.width) - t.x0;
        t.h = std::min((m_firstTileY + ty + 1) * kTileSize, m_work.y + m_work.height) - t.y0;
        t.sums.clear(t.w * t.h);
        std::fill(t.add, t.add + t.w * t.h, m_firstSamples);
      }
    }
  }

  // Runs the rounds on one pool of `threads` workers, then writes the output region; returns what was traced.
  RayCounters render(int threads, JobControl& control, const std::function<void()>& poll, AdaptiveStats& stats) {
    // A limit of more than a year is none: the clock's integer ticks would overflow.
    constexpr double kYear = 365.25 * 24 * 3600;
    const bool limited = m_timeLimit > 0 && m_timeLimit < kYear;
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(limited ? m_timeLimit : 0.0));
    // The time limit spares the first pass: every pixel gets its first samples.
    const auto overTime = [&](int round) { return round > 0 && limited && std::chrono::steady_clock::now() >= deadline; };
    RayCounters counters;
    WorkerPool pool(static_cast<int>(std::min<size_t>(static_cast<size_t>(std::max(1, threads)), m_state.size())));
    std::vector<int64_t> order(m_state.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int64_t>(i);
    for (int round = 0; !order.empty(); ++round) {
      if (overTime(round)) {
        stats.timeLimitReached = true;
        break;
      }
      // A tile is marked for the next round as soon as every tile around it has been sampled in this
      // one (its marking reads nothing else), by the worker that sampled the last of them: no pass
      // of its own. Tiles with no sampled tile around them keep their decision: nothing to add.
      const bool last = round == m_rounds;
      const int level = last ? m_maxSamples : std::min(m_maxSamples, m_firstSamples << (round + 1));
      std::vector<std::atomic<int>> pending(m_state.size());
      for (std::atomic<int>& p : pending) p.store(0, std::memory_order_relaxed);
      for (TileState& t : m_state) t.priority = 0;
      for (const int64_t u : order) forTilesAround(static_cast<size_t>(u), [&](size_t t) { pending[t].fetch_add(1); });
      std::atomic<bool> late{false};
      const auto work = [&](int64_t i, RayCounters& c) {
        if (overTime(round)) {
          late = true;
          return;
        }
        const size_t u = static_cast<size_t>(order[static_cast<size_t>(i)]);
        sampleTile(m_state[u], round, c);
        if (!control.cancel.load(std::memory_order_relaxed)) {
          forTilesAround(u, [&](size_t t) {
            if (pending[t].fetch_sub(1, std::memory_order_acq_rel) == 1 && !last) mark(t, level, round);
          });
        }
      };
      counters += inParallel(static_cast<int64_t>(order.size()), pool, control, poll, round, work);
      ++stats.rounds;
      if (control.cancel.load() || late.load()) {
        stats.timeLimitReached = late.load();
        break;
      }
      if (last) break;
      order = tilesToRefine();
    }
    if (!control.cancel.load()) write(stats);
    return counters;
  }

 private:
  // A tile's pixels (clipped to the work region) and what adaptive sampling keeps of them.
  struct TileState {
    int x0 = 0, y0 = 0, w = 0, h = 0;
    Sums sums;                                            // every sample so far
    Real lastR[kPacketSize], lastG[kPacketSize], lastB[kPacketSize];  // colour sums of the last round
    int32_t taken[kPacketSize] = {};                      // samples so far
    int32_t last[kPacketSize] = {};                       // of which the last round's (the second half)
    int32_t add[kPacketSize] = {};                        // samples the next round takes
    int32_t firstPrim[kPacketSize];                       // the primitive the pixel's first sample met
    float firstT[kPacketSize];                            // and how far along its ray (inf: a miss)
    bool mixed[kPacketSize] = {};                         // a later sample met geometry that differs
    float error[kPacketSize] = {};                        // estimated RMS error of the mean colour
    float meanR[kPacketSize], meanG[kPacketSize], meanB[kPacketSize];  // the mean colour
    int sampledIn = -1;                                   // the last round that sampled the tile
    bool fresh[kPacketSize] = {};                         // the pixel took samples in that round
    float priority = 0;                                   // the worst marked pixel's (time limit: first)
  };

  static int roundsFor(int first, int max) {
    int rounds = 0;
    for (int n = first; n < max; n *= 2) ++rounds;
    return rounds;
  }

  // The output region widened by `margin` pixels, clipped to the image.
  static RenderSettings::Region workRegion(const RenderSettings::Region& r, int margin, int width, int height) {
    const int x0 = std::max(0, r.x - margin), y0 = std::max(0, r.y - margin);
    const int x1 = std::min(width, r.x + r.width + margin), y1 = std::min(height, r.y + r.height + margin);
    return {x0, y0, x1 - x0, y1 - y0};
  }

  // Runs work(item, counters) over [0, items) with progress reported as the share of rounds done.
  template <typename Work>
  RayCounters inParallel(int64_t items, WorkerPool& pool, JobControl& control, const std::function<void()>& poll,
                         int round, const Work& work) {
    JobControl roundControl;
    RayCounters total;
    std::mutex totalMutex;
    const auto roundPoll = [&] {
      control.total = 1000;
      control.done = static_cast<int64_t>(1000 * (round + roundControl.fraction()) / (m_rounds + 1));
      poll();
      if (control.cancel.load()) roundControl.cancel = true;
    };
    pool.run(items, roundControl, [&](int64_t item) {
      RayCounters c;
      work(item, c);
      const std::lock_guard<std::mutex> lock(totalMutex);
      total += c;
    }, roundPoll);
    return total;
  }

  // Takes each pixel's add[k] samples, pixel by pixel in packets of up to kPacketSize rays: a pixel's
  // samples are the most coherent rays there are. A packet's sample positions are made together.
  void sampleTile(TileState& t, int round, RayCounters& counters) const {
    const int count = t.w * t.h;
    const bool first = round == 0;
    t.sampledIn = round;
    alignas(64) Real sampleX[kPacketSize], sampleY[kPacketSize];
    alignas(64) int pixel[kPacketSize], slot[kPacketSize], px[kPacketSize], py[kPacketSize];
    alignas(64) uint32_t s[kPacketSize], order[kPacketSize], points[kPacketSize];  // sample numbers, seeds
    alignas(64) int32_t prim[kPacketSize];
    alignas(64) Real along[kPacketSize];
    Sums one;
    int n = 0;
    const auto flush = [&] {
      m_tiles.sobolPositions(px, py, order, points, s, n, sampleX, sampleY);
      if (!m_tiles.trace(sampleX, sampleY, n, one, prim, along, counters)) return false;
      for (int j = 0, end; j < n; j = end) {  // a pixel's samples are consecutive: one run each
        for (end = j + 1; end < n && pixel[end] == pixel[j];) ++end;
        record(t, pixel[j], j, end, s, slot, first, one, prim, along);
      }
      n = 0;
      return true;
    };
    for (int k = 0; k < count; ++k) {
      if (t.add[k] == 0) continue;
      const int x = t.x0 + k % t.w, y = t.y0 + k / t.w;
      uint32_t pixelOrder, pixelPoints;
      m_tiles.sobolSeeds(x, y, pixelOrder, pixelPoints);
      for (int i = 0; i < t.add[k]; ++i) {
        s[n] = static_cast<uint32_t>(t.taken[k] + i), slot[n] = i, pixel[n] = k;
        px[n] = x, py[n] = y, order[n] = pixelOrder, points[n] = pixelPoints;
        if (++n == kPacketSize && !flush()) return;
      }
    }
    if (n > 0 && !flush()) return;
    int fresh[kPacketSize], freshCount = 0;
    for (int k = 0; k < count; ++k) {
      t.taken[k] += t.add[k];
      t.last[k] = t.add[k] == 0 ? t.last[k] : first ? t.add[k] / 2 : t.add[k];
      t.fresh[k] = t.add[k] > 0;
      fresh[freshCount] = k, freshCount += t.fresh[k];
      t.add[k] = 0;
      t.sums.samples[k] = static_cast<Real>(t.taken[k]);
    }
    for (int i = 0; i < freshCount; ++i) {  // the others' error and mean are as their samples left them
      const int k = fresh[i];
      t.error[k] = estimatedError(t, k);
      const Real inverse = 1 / t.sums.samples[k];
      t.meanR[k] = static_cast<float>(t.sums.r[k] * inverse);
      t.meanG[k] = static_cast<float>(t.sums.g[k] * inverse);
      t.meanB[k] = static_cast<float>(t.sums.b[k] * inverse);
    }
  }

  // Adds samples [j0, j1) of `one` (sample numbers s[j] of pixel k, its slot[j]-th this round, which
  // met prim[j] at along[j] on its ray) to the pixel, in order: the same sums, bit for bit, as adding
  // them one at a time, with the pixel's running sums kept in registers over the run.
  void record(TileState& t, int k, int j0, int j1, const uint32_t* s, const int* slot, bool first, const Sums& one,
              const int32_t* prim, const Real* along) const {
    t.sums.addRun(k, one, j0, j1);
    // The last round's samples are the second half of the pixel's: all of a refining round's, the
    // later half of the first pass's.
    const int firstOfLast = first ? t.add[k] - t.add[k] / 2 : 0;
    Real lastR = t.lastR[k], lastG = t.lastG[k], lastB = t.lastB[k];
    int32_t firstPrim = t.firstPrim[k];
    float firstT = t.firstT[k];
    bool mixed = t.mixed[k];
    for (int j = j0; j < j1; ++j) {
      if (slot[j] == firstOfLast) lastR = lastG = lastB = 0;
      if (slot[j] >= firstOfLast) lastR += one.r[j], lastG += one.g[j], lastB += one.b[j];
      if (s[j] == 0) {
        firstPrim = prim[j], firstT = static_cast<float>(along[j]);
      } else if (prim[j] != firstPrim) {
        mixed = mixed || depthJump(along[j], firstT);
      }
    }
    t.lastR[k] = lastR, t.lastG[k] = lastG, t.lastB[k] = lastB;
    t.firstPrim[k] = firstPrim, t.firstT[k] = firstT, t.mixed[k] = mixed;
  }

  static bool depthJump(Real a, Real b) {
    const bool hitA = a < std::numeric_limits<Real>::infinity(), hitB = b < std::numeric_limits<Real>::infinity();
    if (hitA != hitB) return true;
    return hitA && std::abs(a - b) > static_cast<Real>(kDepthJump) * std::min(a, b);
  }

  // The RMS over the colour channels of the difference of the two halves' means, scaled to the
  // standard error of the whole mean: for a and b samples, E[(mA - mB)^2] = var (1/a + 1/b) and the
  // mean's variance is var / (a + b).
  static float estimatedError(const TileState& t, int k) {
    const double b = t.last[k], a = t.taken[k] - b;
    if (a == 0 || b == 0) return 0;  // one sample: nothing to compare
    const double dr = (t.sums.r[k] - t.lastR[k]) / a - t.lastR[k] / b;
    const double dg = (t.sums.g[k] - t.lastG[k]) / a - t.lastG[k] / b;
    const double db = (t.sums.b[k] - t.lastB[k]) / a - t.lastB[k] / b;
    const double squared = (dr * dr + dg * dg + db * db) / 3 * a * b / ((a + b) * (a + b));
    return static_cast<float>(std::sqrt(squared));
  }

  const TileState& tileAt(int x, int y) const {
    return m_state[static_cast<size_t>(y / kTileSize - m_firstTileY) * m_tilesX + (x / kTileSize - m_firstTileX)];
  }

  static int slotOf(const TileState& t, int x, int y) { return (y - t.y0) * t.w + (x - t.x0); }

  // What mark() reads of a pixel, for the pixels of a tile and the ring around it: gathered once
  // per tile, so that the nine-pixel neighbourhoods read one small array instead of the tiles around.
  struct Neighbour {
    Real nx, ny, nz;                              // normal sums
    float error, firstT, meanR, meanG, meanB;
    int32_t firstPrim;
    bool present;                                 // inside the work region
    bool fresh;                                   // took samples in the round marked from
  };
  static constexpr int kGridWidth = kTileSize + 2;

  // grid[(y - t.y0 + 1) * kGridWidth + (x - t.x0 + 1)]: pixel (x, y) of t or of the ring around it.
  void gather(const TileState& t, int round, Neighbour* grid) const {
    for (int y = t.y0 - 1; y <= t.y0 + t.h; ++y) {
      for (int x = t.x0 - 1; x <= t.x0 + t.w; ++x) {
        Neighbour& n = grid[(y - t.y0 + 1) * kGridWidth + (x - t.x0 + 1)];
        n.present = x >= m_work.x && x < m_work.x + m_work.width && y >= m_work.y && y < m_work.y + m_work.height;
        n.fresh = false;
        if (!n.present) continue;
        const TileState& u = tileAt(x, y);
        const int q = slotOf(u, x, y);
        n.nx = u.sums.nx[q], n.ny = u.sums.ny[q], n.nz = u.sums.nz[q];
        n.error = u.error[q], n.firstT = u.firstT[q];
        n.meanR = u.meanR[q], n.meanG = u.meanG[q], n.meanB = u.meanB[q];
        n.firstPrim = u.firstPrim[q];
        n.fresh = u.sampledIn == round && u.fresh[q];
      }
    }
  }

  // Decides add[k] for every pixel of tile `index` from the state the last round left. A pixel whose
  // neighbourhood the last round did not sample decides as before it: nothing to add.
  void mark(size_t index, int level, int round) {
    TileState& t = m_state[index];
    Neighbour grid[kGridWidth * kGridWidth];
    bool gathered = false;  // only once a pixel looks at its neighbours
    for (int k = 0; k < t.w * t.h; ++k) {
      const int taken = t.taken[k];
      if (taken >= level) continue;
      const double own = t.error[k];
      double error = own, contrast = 0;
      if (own <= m_target) {
        if (!gathered) gather(t, round, grid), gathered = true;
        const Neighbour& self = grid[(k / t.w + 1) * kGridWidth + k % t.w + 1];
        bool fresh = false;
        forAround(self, [&](const Neighbour& u) { fresh = fresh || u.fresh; });
        if (!fresh) continue;
        double neighbourhood = 0;
        float squaredContrast = 0;
        int around = 0;
        bool edge = t.mixed[k];
        forAround(self, [&](const Neighbour& u) {
          neighbourhood += static_cast<double>(u.error) * u.error;
          ++around;
          edge = edge || differ(self, u);
          squaredContrast = std::max(squaredContrast, squaredColourDifference(self, u));
        });
        contrast = std::sqrt(squaredContrast);  // one root: the largest difference's
        error = std::sqrt(std::max(own * own, neighbourhood / around));
        if (error <= m_target && taken >= std::max(edge ? double(kEdgeSamples) : 0.0, contrast / m_target)) continue;
      }
      t.add[k] = level - taken;
      t.priority = std::max(t.priority, static_cast<float>(std::max(error, contrast / taken)));
    }
  }

  // f(u) for the pixels u of the work region around `self` (itself included), row by row, in a gathered grid.
  template <typename F>
  static void forAround(const Neighbour& self, const F& f) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const Neighbour& u = (&self)[dy * kGridWidth + dx];
        if (u.present) f(u);
      }
    }
  }

  // f(t) for each tile t around tile `index` (itself included).
  template <typename F>
  void forTilesAround(size_t index, const F& f) const {
    const int tx = static_cast<int>(index % m_tilesX), ty = static_cast<int>(index / m_tilesX);
    const int tilesY = static_cast<int>(m_state.size() / m_tilesX);
    for (int y = std::max(ty - 1, 0); y <= std::min(ty + 1, tilesY - 1); ++y) {
      for (int x = std::max(tx - 1, 0); x <= std::min(tx + 1, m_tilesX - 1); ++x) f(static_cast<size_t>(y) * m_tilesX + x);
    }
  }

  // Whether two pixels see different geometry: their first samples met other primitives, one of
  // them nothing, or both at a depth discontinuity or a crease.
  static bool differ(const Neighbour& a, const Neighbour& b) {
    if (a.firstPrim == b.firstPrim) return false;
    if (depthJump(a.firstT, b.firstT)) return true;
    const double dot = double(a.nx) * b.nx + double(a.ny) * b.ny + double(a.nz) * b.nz;
    const double la = double(a.nx) * a.nx + double(a.ny) * a.ny + double(a.nz) * a.nz;
    const double lb = double(b.nx) * b.nx + double(b.ny) * b.ny + double(b.nz) * b.nz;
    return la > 0 && lb > 0 && dot < kCreaseCosine * std::sqrt(la * lb);  // no normals summed: no crease test
  }

  // The mean over the colour channels of the squared difference of two pixels' mean colours: the
  // square of their RMS difference.
  static float squaredColourDifference(const Neighbour& a, const Neighbour& b) {
    const float dr = a.meanR - b.meanR, dg = a.meanG - b.meanG, db = a.meanB - b.meanB;
    return (dr * dr + dg * dg + db * db) / 3;
  }

  // The tiles with pixels to refine, the worst first (what a time limit cuts is the least needed).
  std::vector<int64_t> tilesToRefine() const {
    std::vector<int64_t> order;
    for (size_t i = 0; i < m_state.size(); ++i) {
      const TileState& t = m_state[i];
      if (std::any_of(t.add, t.add + t.w * t.h, [](int32_t a) { return a > 0; })) order.push_back(static_cast<int64_t>(i));
    }
    std::stable_sort(order.begin(), order.end(), [&](int64_t a, int64_t b) {
      return m_state[static_cast<size_t>(a)].priority > m_state[static_cast<size_t>(b)].priority;
    });
    return order;
  }

  // Writes the output region's pixels, their error estimates, and the image's summary of them.
  void write(AdaptiveStats& stats) const {
    const RenderSettings::Region& r = m_output;
    double squares = 0, worst = 0;
    for (const TileState& t : m_state) {
      const int x0 = std::max(t.x0, r.x), x1 = std::min(t.x0 + t.w, r.x + r.width);
      for (int y = std::max(t.y0, r.y); y < std::min(t.y0 + t.h, r.y + r.height); ++y) {
        if (x0 >= x1) break;
        const size_t first = static_cast<size_t>(y - r.y) * r.width + (x0 - r.x);
        const int k0 = slotOf(t, x0, y);
        m_tiles.writeRow(t.sums, k0, x1 - x0, first);
        for (int i = 0; i < x1 - x0; ++i) {
          const double e = t.error[k0 + i];
          squares += e * e, worst = std::max(worst, e);
          if (m_targets.error) m_targets.error[first + i] = static_cast<float>(e);
        }
      }
    }
    stats.estimatedRmse = std::sqrt(squares / (static_cast<double>(r.width) * r.height));
    stats.estimatedWorst = worst;
  }

  const Tiles& m_tiles;
  RenderTargets m_targets;
  RenderSettings::Region m_output;  // the pixels written
  int m_maxSamples, m_firstSamples;
  double m_target, m_timeLimit;
  int m_rounds;                     // refining rounds at most: the margin a region is rendered with
  RenderSettings::Region m_work;    // the pixels sampled: the output and its margin
  int m_firstTileX = 0, m_firstTileY = 0, m_tilesX = 0;
  std::vector<TileState> m_state;
};

}  // namespace tiles
}  // namespace durer
