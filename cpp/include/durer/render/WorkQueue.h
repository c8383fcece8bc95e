#pragma once
#include <pthread.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <vector>

namespace durer {

// Shared between a long job, the thread that started it and whoever may cancel it.
struct JobControl {
  std::atomic<bool> cancel{false};   // in: set to stop the job early (checked per work item and inside long loops)
  std::atomic<int64_t> done{0};      // out: work items finished
  int64_t total = 0;                 // out: work items in the job
  double fraction() const { return total ? static_cast<double>(done.load()) / static_cast<double>(total) : 1.0; }
};

// Worker threads kept for a sequence of jobs (adaptive sampling's rounds): starting a thread on a
// fresh stack costs about as much as a small round's work. Every worker takes part in every job.
class WorkerPool {
 public:
  // Up to `threads` workers, started by the first job: fewer when the system refuses more, none is a
  // runtime_error.
  explicit WorkerPool(int threads) : m_wanted(std::max(1, threads)) {}
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Runs work(item) for item in [0, items) on the workers, which take items in order. The calling
  // thread does no work: it calls poll() once first, then about every `pollMilliseconds` until the
  // workers finish (poll may set control.cancel or throw; a throw stops the workers, then propagates).
  void run(int64_t items, JobControl& control, const std::function<void(int64_t)>& work,
           const std::function<void()>& poll, int pollMilliseconds = 10);

 private:
  void start();
  void serve();
  bool waitForJob(uint64_t served);

  std::mutex m_mutex;
  std::condition_variable m_wake;   // a job was posted, or the pool closes
  std::condition_variable m_idle;   // the last worker left the job
  const int m_wanted;
  const std::function<void()> m_serve{[this] { serve(); }};  // every worker's body
  std::vector<pthread_t> m_threads;
  // The current job, written under m_mutex before m_jobs changes.
  const std::function<void(int64_t)>* m_work = nullptr;
  JobControl* m_control = nullptr;
  int64_t m_items = 0;
  std::atomic<int64_t> m_next{0};
  std::atomic<uint64_t> m_jobs{0};  // posted so far: a worker serves each once, in order
  size_t m_busy = 0;                // workers not yet done with the current job
  std::atomic<bool> m_closing{false};
};

// One job on a pool of its own of up to `threads` workers (no more than items).
void runParallel(int64_t items, int threads, JobControl& control, const std::function<void(int64_t)>& work,
                 const std::function<void()>& poll, int pollMilliseconds = 10);

int defaultThreadCount();  // the hardware's thread count, at least 1

}  // namespace durer
