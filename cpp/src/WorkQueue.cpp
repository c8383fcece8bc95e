#include "durer/render/WorkQueue.h"

#include <pthread.h>

#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace durer {

namespace {

// Worker threads get a stack of their own size: secondary rays recurse once per bounce
// (PacketShader), about 30 KiB a level in double, and the default thread stack (8 MiB, 2 MiB where
// RLIMIT_STACK is unlimited) would overflow long before the validated maximum of 1,000 bounces.
// Only the pages a render touches are committed.
constexpr size_t kThreadStackBytes = size_t(64) << 20;

// A worker that waits for the others spins this long before it sleeps: a phase often ends within
// microseconds. It spins without yielding: a thread that yields in a loop stays runnable and
// cache-hot, so where the scheduler has put two workers on one CPU, an idle CPU does not take one
// of them for milliseconds (measured: renders taking twice their time, one worker doing every
// item); a thread that sleeps is woken on an idle CPU.
constexpr auto kSpin = std::chrono::microseconds(50);

inline void spinPause() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

// One job's workers and what they share.
class PhasedJob {
 public:
  PhasedJob(int64_t items, JobControl& control, const std::function<void(int64_t)>& work,
            const std::function<int64_t()>& next)
      : m_control(control), m_work(work), m_next(next), m_items(items) {
    control.total = items;
    control.done = 0;
  }

  // Starts up to `threads` workers, then lets them begin; returns how many started (0: the error).
  int start(int threads, int& error) {
    for (int w = 0; w < threads && error == 0; ++w) {
      pthread_t id;
      pthread_attr_t attributes;
      error = pthread_attr_init(&attributes);
      if (error != 0) break;
      error = pthread_attr_setstacksize(&attributes, kThreadStackBytes);
      if (error == 0) error = pthread_create(&id, &attributes, &PhasedJob::body, this);
      pthread_attr_destroy(&attributes);
      if (error == 0) m_threads.push_back(id);  // fewer workers do the work; none at all is an error
    }
    m_workers = static_cast<int>(m_threads.size());
    m_busy = m_workers;
    release(1);  // the barrier counts the workers that started: none begins before it knows them
    return m_workers;
  }

  // Until every worker has finished: poll() about every `milliseconds`; a throw cancels the job.
  void watch(const std::function<void()>& poll, int milliseconds) {
    std::unique_lock<std::mutex> lock(m_mutex);
    while (m_busy > 0) {
      m_idle.wait_for(lock, std::chrono::milliseconds(milliseconds));
      if (m_busy == 0) break;
      lock.unlock();
      try {
        poll();
      } catch (...) {
        fail(std::current_exception());
      }
      lock.lock();
    }
  }

  ~PhasedJob() {
    for (pthread_t id : m_threads) pthread_join(id, nullptr);
  }

  std::exception_ptr failure() {
    const std::lock_guard<std::mutex> lock(m_mutex);
    return m_failure;
  }

 private:
  static void* body(void* job) {
    static_cast<PhasedJob*>(job)->serve();
    return nullptr;
  }

  void serve() {
    for (uint64_t phase = 1; waitFor(phase); ++phase) {
      const int64_t items = m_items.load(std::memory_order_relaxed);
      for (int64_t item = m_nextItem++; item < items; item = m_nextItem++) {
        if (m_control.cancel.load(std::memory_order_relaxed)) break;
        try {
          m_work(item);
        } catch (...) {
          fail(std::current_exception());
          break;
        }
        m_control.done.fetch_add(1, std::memory_order_relaxed);
      }
      if (m_arrived.fetch_add(1, std::memory_order_acq_rel) + 1 == m_workers) {
        m_arrived.store(0, std::memory_order_relaxed);
        int64_t following = 0;
        try {
          if (!m_control.cancel.load()) following = m_next();
        } catch (...) {
          fail(std::current_exception());
          following = 0;
        }
        m_items.store(following, std::memory_order_relaxed);
        m_nextItem.store(0, std::memory_order_relaxed);
        if (following > 0) m_control.total = following, m_control.done = 0;
        release(following > 0 ? phase + 1 : kDone);
      }
    }
    const std::lock_guard<std::mutex> lock(m_mutex);
    if (--m_busy == 0) m_idle.notify_all();
  }

  // Waits until `phase` (true) or the end of the job (false) is released.
  bool waitFor(uint64_t phase) {
    const auto until = std::chrono::steady_clock::now() + kSpin;
    for (int i = 1;; ++i) {
      const uint64_t released = m_phase.load(std::memory_order_acquire);
      if (released == phase || released == kDone) return released == phase;
      if (i % 16 == 0 && std::chrono::steady_clock::now() >= until) break;
      spinPause();
    }
    std::unique_lock<std::mutex> lock(m_mutex);
    m_wake.wait(lock, [&] {
      const uint64_t released = m_phase.load(std::memory_order_acquire);
      return released == phase || released == kDone;
    });
    return m_phase.load(std::memory_order_acquire) == phase;
  }

  void release(uint64_t phase) {
    {
      const std::lock_guard<std::mutex> lock(m_mutex);
      m_phase.store(phase, std::memory_order_release);
    }
    m_wake.notify_all();
  }

  void fail(std::exception_ptr failure) {
    {
      const std::lock_guard<std::mutex> lock(m_mutex);
      if (!m_failure) m_failure = failure;
    }
    m_control.cancel = true;
  }

  static constexpr uint64_t kDone = ~uint64_t(0);

  JobControl& m_control;
  const std::function<void(int64_t)>& m_work;
  const std::function<int64_t()>& m_next;
  std::vector<pthread_t> m_threads;
  int m_workers = 0;
  std::atomic<int64_t> m_items;           // in the current phase
  std::atomic<int64_t> m_nextItem{0};     // the next one to take
  std::atomic<int> m_arrived{0};          // workers done with the current phase
  std::atomic<uint64_t> m_phase{0};       // released so far (kDone: the job is over)
  std::mutex m_mutex;
  std::condition_variable m_wake;         // a phase was released
  std::condition_variable m_idle;         // the last worker left
  int m_busy = 0;                         // workers not yet left (under m_mutex)
  std::exception_ptr m_failure;           // the first throw (under m_mutex)
};

}  // namespace

int defaultThreadCount() { return std::max(1u, std::thread::hardware_concurrency()); }

void runPhases(int64_t items, int threads, JobControl& control, const std::function<void(int64_t)>& work,
               const std::function<int64_t()>& next, const std::function<void()>& poll, int pollMilliseconds) {
  control.total = items;
  control.done = 0;
  poll();  // reports 0 and sees a cancel that came before the start
  std::exception_ptr failure;
  {
    PhasedJob job(items, control, work, next);
    int error = 0;
    if (job.start(std::max(1, threads), error) == 0) {
      throw std::runtime_error(std::string("threads: could not start a render thread: ") + std::strerror(error));
    }
    job.watch(poll, pollMilliseconds);
    failure = job.failure();
  }  // joins the workers
  if (failure) std::rethrow_exception(failure);
}

void runParallel(int64_t items, int threads, JobControl& control, const std::function<void(int64_t)>& work,
                 const std::function<void()>& poll, int pollMilliseconds) {
  const std::function<int64_t()> none = [] { return int64_t(0); };
  runPhases(items, static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(threads, items))), control, work, none,
            poll, pollMilliseconds);
}

}  // namespace durer
