#pragma once
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <functional>

namespace durer {

// Shared between a long job, the thread that started it and whoever may cancel it.
struct JobControl {
  std::atomic<bool> cancel{false};   // in: set to stop the job early (checked per work item and inside long loops)
  std::atomic<int64_t> done{0};      // out: work items finished
  std::atomic<int64_t> total{0};     // out: work items in the job (a phased job: in its current phase)
  // done / total, at most 1 (a phase's counts change while others read them), 1 for no items.
  double fraction() const {
    const int64_t all = total.load(), finished = done.load();
    return all > 0 ? std::min(1.0, static_cast<double>(finished) / static_cast<double>(all)) : 1.0;
  }
};

// Runs a job in phases on up to `threads` workers (fewer when the system refuses more; none is a
// runtime_error): work(item) for item in [0, items), the workers taking items in order; when every
// item of a phase is done, the last worker to finish one calls next(), which returns the next phase's
// item count (0: the job is done). The workers wait for each other between phases on their own, so
// the calling thread sleeps through the whole job (adaptive sampling's rounds: a caller woken at each
// round would take a CPU from a worker). control.total and control.done count the current phase's
// items. The calling thread does no work: it calls poll() once first, then about every
// `pollMilliseconds` until the job ends. A throw from poll cancels the job (control.cancel), as does
// one from work or next; the first one thrown reaches the caller once every worker has stopped.
void runPhases(int64_t items, int threads, JobControl& control, const std::function<void(int64_t)>& work,
               const std::function<int64_t()>& next, const std::function<void()>& poll, int pollMilliseconds = 10);

// One phase: work(item) for item in [0, items) on up to min(threads, items) workers.
void runParallel(int64_t items, int threads, JobControl& control, const std::function<void(int64_t)>& work,
                 const std::function<void()>& poll, int pollMilliseconds = 10);

int defaultThreadCount();  // the hardware's thread count, at least 1

}  // namespace durer
