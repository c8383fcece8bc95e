// The worker pool (doctest): every item of every job runs exactly once, on a pool kept across jobs
// as adaptive sampling's rounds keep it; a poll that throws cancels the job, reaches the caller, and
// leaves the pool ready for the next job.
#include <doctest/doctest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

#include "durer/render/WorkQueue.h"

using namespace durer;

TEST_CASE("a pool kept across jobs runs every item of each exactly once") {
  WorkerPool pool(3);
  for (const int64_t items : {int64_t(0), int64_t(1), int64_t(2), int64_t(1000), int64_t(5), int64_t(37)}) {
    std::vector<std::atomic<int>> runs(static_cast<size_t>(items));
    for (std::atomic<int>& r : runs) r = 0;
    JobControl control;
    int polls = 0;
    pool.run(items, control, [&](int64_t item) { runs[static_cast<size_t>(item)].fetch_add(1); }, [&] { ++polls; });
    for (const std::atomic<int>& r : runs) CHECK(r.load() == 1);
    CHECK(control.total == items);
    CHECK(control.done.load() == items);
    CHECK(polls >= 1);
  }
}

TEST_CASE("a throwing poll cancels the job, reaches the caller, and the pool runs the next job") {
  WorkerPool pool(2);
  JobControl control;
  std::atomic<int64_t> ran{0};
  int polls = 0;
  const auto slowItem = [&](int64_t) {
    ran.fetch_add(1);
    while (!control.cancel.load()) {
    }
  };
  // The first poll comes before any item; the second, 1 ms later, throws while items spin.
  CHECK_THROWS_AS(pool.run(100, control, slowItem, [&] { if (++polls == 2) throw std::runtime_error("stop"); }, 1),
                  std::runtime_error);
  CHECK(control.cancel.load());
  CHECK(ran.load() <= 2);  // each worker stops after the item it was in

  JobControl next;
  std::atomic<int64_t> sum{0};
  pool.run(10, next, [&](int64_t item) { sum.fetch_add(item); }, [] {});
  CHECK(sum.load() == 45);
  CHECK(next.done.load() == 10);
}

TEST_CASE("runParallel: one job on a pool of its own") {
  JobControl control;
  std::atomic<int64_t> sum{0};
  runParallel(64, 4, control, [&](int64_t item) { sum.fetch_add(item); }, [] {});
  CHECK(sum.load() == 64 * 63 / 2);
  CHECK(control.done.load() == 64);
}
