#pragma once
#include <atomic>
#include <cstdint>
#include <functional>

namespace durer {

// Shared between a long job, the thread that started it and whoever may cancel it.
struct JobControl {
  std::atomic<bool> cancel{false};   // in: set to stop the job early (checked per work item and inside long loops)
  std::atomic<int64_t> done{0};      // out: work items finished
  int64_t total = 0;                 // out: work items in the job
  double fraction() const { return total ? static_cast<double>(done.load()) / static_cast<double>(total) : 1.0; }
};

// Runs work(item) for item in [0, items) on `threads` worker threads that take items in order.
// The calling thread does no work: it calls poll() once first, then about every `pollMilliseconds` until the workers
// finish (poll may set control.cancel or throw; a throw stops the workers, then propagates).
void runParallel(int64_t items, int threads, JobControl& control, const std::function<void(int64_t)>& work,
                 const std::function<void()>& poll, int pollMilliseconds = 10);

int defaultThreadCount();  // the hardware's thread count, at least 1

}  // namespace durer
