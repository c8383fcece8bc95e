// Phased jobs (doctest): every item of every phase runs exactly once, next() only once a phase is
// done, as adaptive sampling's rounds need; a throw from poll, work or next cancels the job and
// reaches the caller; poll sees the progress.
#include <doctest/doctest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "durer/render/WorkQueue.h"

using namespace durer;

TEST_CASE("every item of every phase runs exactly once, and next() runs between the phases") {
  for (const int threads : {1, 2, 3, 8}) {
    const std::vector<int64_t> phases{1000, 1, 2, 0, 5};  // no items: the end of the job
    std::vector<std::vector<std::atomic<int>>> runs;
    for (const int64_t items : phases) runs.emplace_back(static_cast<size_t>(items));
    for (auto& phase : runs) for (std::atomic<int>& r : phase) r = 0;
    std::atomic<int> current{0};
    int nexts = 0;
    bool everyItemDoneBeforeNext = true;
    JobControl control;
    int polls = 0;
    runPhases(phases[0], threads, control,
              [&](int64_t item, int) { runs[static_cast<size_t>(current.load())][static_cast<size_t>(item)].fetch_add(1); },
              [&]() -> int64_t {
                ++nexts;
                for (const std::atomic<int>& r : runs[static_cast<size_t>(current.load())]) everyItemDoneBeforeNext &= r == 1;
                current.fetch_add(1);
                return phases[static_cast<size_t>(current.load())];
              },
              [&] { ++polls; });
    CHECK(nexts == 3);  // after the phases of 1000, 1 and 2 items; returning 0 ended the job
    CHECK(everyItemDoneBeforeNext);
    for (size_t p = 0; p < 3; ++p) {
      for (const std::atomic<int>& r : runs[p]) CHECK(r.load() == 1);
    }
    for (const std::atomic<int>& r : runs[4]) CHECK(r.load() == 0);  // after the end
    CHECK(polls >= 1);
  }
}

TEST_CASE("each worker takes its own share from the front, and others' from the back") {
  // Worker w's share of n items is [n w / W, n (w + 1) / W): in each share, the items its owner ran
  // are a prefix taken in order, and the ones thieves ran the rest.
  for (const int threads : {2, 3, 4}) {
    const int64_t items = 301;
    std::vector<std::atomic<int>> ranBy(static_cast<size_t>(items));
    std::vector<std::vector<int64_t>> sequence(static_cast<size_t>(threads));
    JobControl control;
    runPhases(items, threads, control,
              [&](int64_t item, int worker) {
                REQUIRE(worker >= 0);
                REQUIRE(worker < threads);
                ranBy[static_cast<size_t>(item)] = worker;
                sequence[static_cast<size_t>(worker)].push_back(item);
                for (volatile int spin = 0; spin < 2000 * (item % 7); spin = spin + 1) {
                }
              },
              [] { return int64_t(0); }, [] {});
    for (int w = 0; w < threads; ++w) {
      const int64_t begin = items * w / threads, end = items * (w + 1) / threads;
      int64_t own = begin;
      while (own < end && ranBy[static_cast<size_t>(own)] == w) ++own;
      for (int64_t i = own; i < end; ++i) CHECK(ranBy[static_cast<size_t>(i)] != w);
      std::vector<int64_t> mine;
      for (const int64_t item : sequence[static_cast<size_t>(w)]) {
        if (item >= begin && item < end) mine.push_back(item);
      }
      for (size_t k = 0; k < mine.size(); ++k) CHECK(mine[k] == begin + static_cast<int64_t>(k));
    }
  }
}

TEST_CASE("a throwing poll cancels the job and reaches the caller once the workers stopped") {
  JobControl control;
  std::atomic<int64_t> ran{0};
  int polls = 0, nexts = 0;
  const auto slowItem = [&](int64_t, int) {
    ran.fetch_add(1);
    while (!control.cancel.load()) {
    }
  };
  // The first poll comes before any item; the second, 1 ms later, throws while items spin.
  CHECK_THROWS_AS(runPhases(100, 2, control, slowItem, [&]() -> int64_t { return ++nexts, 100; },
                            [&] { if (++polls == 2) throw std::runtime_error("stop"); }, 1),
                  std::runtime_error);
  CHECK(control.cancel.load());
  CHECK(ran.load() <= 2);  // each worker stops after the item it was in
  CHECK(nexts == 0);       // no phase after a cancel
}

TEST_CASE("a throw from work or next cancels the job and reaches the caller") {
  JobControl control;
  CHECK_THROWS_AS(runPhases(50, 3, control, [](int64_t item, int) { if (item == 7) throw std::logic_error("work"); },
                            [] { return int64_t(0); }, [] {}),
                  std::logic_error);
  CHECK(control.cancel.load());
  JobControl other;
  int phase = 0;
  CHECK_THROWS_AS(runPhases(4, 2, other, [](int64_t, int) {},
                            [&]() -> int64_t { if (++phase == 2) throw std::out_of_range("next"); return 3; }, [] {}),
                  std::out_of_range);
  CHECK(phase == 2);
}

TEST_CASE("runParallel: one phase") {
  JobControl control;
  std::atomic<int64_t> sum{0};
  runParallel(64, 4, control, [&](int64_t item, int) { sum.fetch_add(item); }, [] {});
  CHECK(sum.load() == 64 * 63 / 2);
  CHECK(control.done.load() == 64);
}

TEST_CASE("poll sees the items finished so far, and the job's end sees them all") {
  JobControl control;
  std::vector<double> seen;
  std::atomic<int64_t> ran{0};
  // 40 items of 2 ms on 2 workers (~40 ms), polled every millisecond: progress moves while it runs.
  runParallel(
      40, 2, control,
      [&](int64_t, int) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        ran.fetch_add(1);
      },
      [&] {
        const int64_t before = ran.load(), done = control.done.load();
        CHECK(done <= before);  // never counts an item not yet finished
        seen.push_back(control.fraction());
      },
      1);
  CHECK(control.done.load() == 40);
  CHECK(control.fraction() == 1.0);
  CHECK(seen.front() == 0.0);
  CHECK(std::any_of(seen.begin(), seen.end(), [](double f) { return f > 0 && f < 1; }));
  CHECK(std::is_sorted(seen.begin(), seen.end()));
}

TEST_CASE("each phase counts its own items: the job ends with the last phase's count") {
  JobControl control;
  int phase = 0;
  std::vector<int64_t> totals;
  runPhases(1000, 2, control, [](int64_t, int) {},
            [&]() -> int64_t {
              ++phase;
              return phase == 1 ? 3 : phase == 2 ? 2 : 0;
            },
            [&] { totals.push_back(control.total.load()); });
  CHECK(phase == 3);
  CHECK(control.total.load() == 2);
  CHECK(control.done.load() == 2);  // not 1,005: the earlier phases' counts were reset
  CHECK(control.fraction() == 1.0);
}
