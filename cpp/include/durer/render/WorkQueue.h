#pragma once
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <functional>

namespace durer {

// Shared between a long job, the thread that started it and whoever may cancel it.
struct JobControl {
  std::atomic<bool> cancel{false};   // in: set to stop the job early (checked per work item and inside long loops)
  std::atomic<int64_t> done{0};      // out: work items finished (runPhases: as of its latest poll)
  std::atomic<int64_t> total{0};     // out: work items in the job (a phased job: in its current phase)
  // done / total, at most 1 (a phase's counts change while others read them), 1 for no items.
  double fraction() const {
    const int64_t all = total.load(), finished = done.load();
    return all > 0 ? std::min(1.0, static_cast<double>(finished) / static_cast<double>(all)) : 1.0;
  }
};

// work(item, worker): an item of the current phase, on worker number `worker` (0, 1, ... for the
// whole job: per-worker totals need no lock).
using WorkItem = std::function<void(int64_t item, int worker)>;

// Runs a job in phases on up to `threads` workers (fewer when the system refuses more; none is a
// runtime_error). Each phase's items [0, items) are split into one contiguous share per worker, in
// worker order; a worker takes its share from the front, then the back of the largest share left
// (so a caller that lays out items by place keeps each worker on the same part of its data from
// phase to phase). When every item of a phase is done, the last worker to finish one calls next(),
// which returns the next phase's item count (0: the job is done). The workers wait for each other
// between phases on their own, so the calling thread sleeps through the whole job (adaptive
// sampling's rounds: a caller woken at each round would take a CPU from a worker). control.total
// and control.done count the current phase's items, control.done as of the latest poll() (and the
// job's end): the workers count on their own. The calling thread does no work: it calls
// poll() once first, then about every `pollMilliseconds` until the job ends. A throw from poll
// cancels the job (control.cancel), as does one from work or next; the first one thrown reaches the
// caller once every worker has stopped. Items of a phase: fewer than 2^31.
void runPhases(int64_t items, int threads, JobControl& control, const WorkItem& work,
               const std::function<int64_t()>& next, const std::function<void()>& poll, int pollMilliseconds = 10);

// One phase: work(item, worker) for item in [0, items) on up to min(threads, items) workers.
void runParallel(int64_t items, int threads, JobControl& control, const WorkItem& work,
                 const std::function<void()>& poll, int pollMilliseconds = 10);

int defaultThreadCount();  // the hardware's thread count, at least 1

// The workers a job of `items` items is given for `threads` asked: no more than it has items, at
// least one (what runParallel starts, and what per-worker totals are sized by).
inline int workersFor(int threads, int64_t items) {
  return static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(threads, items)));
}

}  // namespace durer
