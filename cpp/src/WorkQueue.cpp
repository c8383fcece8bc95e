#include "durer/render/WorkQueue.h"

#include <pthread.h>
#include <sys/mman.h>
#include <unistd.h>

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

// Worker stacks kept from job to job, a guard page below each: glibc caches up to 40 MiB of thread
// stacks and unmaps larger ones when their thread ends, and mapping and unmapping two 64 MiB
// stacks took ~150 us a job here (unmapping touched pages interrupts the other CPUs to flush their
// TLBs) -- 3 % of a small adaptive render, half of a 64x64 one. As many are kept as the machine
// has CPUs (a job with more workers unmaps the rest); a kept stack keeps the pages renders touched.
class StackPool {
 public:
  // A stack's lowest usable address (kThreadStackBytes above it), or nullptr if none can be mapped.
  void* acquire() {
    {
      const std::lock_guard<std::mutex> lock(m_mutex);
      if (!m_free.empty()) {
        void* stack = m_free.back();
        m_free.pop_back();
        return stack;
      }
    }
    const size_t guard = guardBytes();
    void* mapped = mmap(nullptr, guard + kThreadStackBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_STACK, -1, 0);
    if (mapped == MAP_FAILED) return nullptr;
    if (mprotect(mapped, guard, PROT_NONE) != 0) {
      munmap(mapped, guard + kThreadStackBytes);
      return nullptr;
    }
    return static_cast<char*>(mapped) + guard;
  }
  void release(void* stack) {
    {
      const std::lock_guard<std::mutex> lock(m_mutex);
      if (m_free.size() < static_cast<size_t>(defaultThreadCount())) return m_free.push_back(stack);
    }
    munmap(static_cast<char*>(stack) - guardBytes(), guardBytes() + kThreadStackBytes);
  }

 private:
  static size_t guardBytes() { return static_cast<size_t>(sysconf(_SC_PAGESIZE)); }

  std::mutex m_mutex;
  std::vector<void*> m_free;
};

StackPool& stacks() {
  static StackPool* pool = new StackPool;  // never destroyed: workers of a job still running at exit may hold stacks
  return *pool;
}

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

int64_t checked(int64_t items) {
  if (items >= (int64_t(1) << 31)) throw std::length_error("runPhases: 2^31 items or more in a phase");
  return items;
}

// One job's workers and what they share.
class PhasedJob {
 public:
  PhasedJob(JobControl& control, const WorkItem& work, const std::function<int64_t()>& next)
      : m_control(control), m_work(work), m_next(next) {}

  // Starts up to `threads` workers, then lets them begin on the first phase's `items`; returns how
  // many started (0: the error).
  int start(int threads, int64_t items, int& error) {
    m_workerIds.resize(static_cast<size_t>(threads));
    m_shares = std::vector<Share>(static_cast<size_t>(threads));
    for (int w = 0; w < threads && error == 0; ++w) {
      m_workerIds[static_cast<size_t>(w)] = {this, w};
      void* stack = stacks().acquire();
      if (stack == nullptr) {
        error = ENOMEM;
        break;
      }
      pthread_t id;
      pthread_attr_t attributes;
      error = pthread_attr_init(&attributes);
      if (error == 0) {
        error = pthread_attr_setstack(&attributes, stack, kThreadStackBytes);
        if (error == 0) error = pthread_create(&id, &attributes, &PhasedJob::body, &m_workerIds[static_cast<size_t>(w)]);
        pthread_attr_destroy(&attributes);
      }
      if (error == 0) {
        m_threads.push_back(id);  // fewer workers do the work; none at all is an error
        m_stacks.push_back(stack);
      } else {
        stacks().release(stack);
      }
    }
    m_workers = static_cast<int>(m_threads.size());
    m_busy = m_workers;
    share(items);
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
      publish();
      try {
        poll();
      } catch (...) {
        fail(std::current_exception());
      }
      lock.lock();
    }
    publish();
  }

  ~PhasedJob() {
    for (pthread_t id : m_threads) pthread_join(id, nullptr);
    for (void* stack : m_stacks) stacks().release(stack);
  }

  std::exception_ptr failure() {
    const std::lock_guard<std::mutex> lock(m_mutex);
    return m_failure;
  }

 private:
  struct WorkerId {
    PhasedJob* job;
    int index;
  };

  static void* body(void* id) {
    const WorkerId& worker = *static_cast<const WorkerId*>(id);
    worker.job->serve(worker.index);
    return nullptr;
  }

  void serve(int worker) {
    for (uint64_t phase = 1; waitFor(phase); ++phase) {
      for (int64_t item = take(worker); item >= 0; item = take(worker)) {
        if (m_control.cancel.load(std::memory_order_relaxed)) break;
        try {
          m_work(item, worker);
        } catch (...) {
          fail(std::current_exception());
          break;
        }
        std::atomic<int64_t>& finished = m_shares[static_cast<size_t>(worker)].finished;
        finished.store(finished.load(std::memory_order_relaxed) + 1, std::memory_order_release);
      }
      if (m_arrived.fetch_add(1, std::memory_order_acq_rel) + 1 == m_workers) {
        m_arrived.store(0, std::memory_order_relaxed);
        int64_t following = 0;
        try {
          if (!m_control.cancel.load()) following = checked(m_next());
        } catch (...) {
          fail(std::current_exception());
          following = 0;
        }
        share(following);
        if (following > 0) {
          for (Share& s : m_shares) s.finished.store(0, std::memory_order_relaxed);
          m_control.total = following, m_control.done = 0;
        }
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

  // A worker's share of the phase's items: [front, back), packed in one word so that its owner
  // (from the front) and a thief (from the back) take items with one compare-and-swap each; and the
  // items the worker finished in the phase, its own or taken, counted by it alone (the phase's last
  // worker resets every count for the next phase). The workers count on their own cache lines and
  // the watching thread adds the counts up for control.done: one counter shared by the workers, its
  // line passed between the CPUs at every item (a tile), took 12 % of a two-thread render of one
  // sphere (docs/benchmarks.md).
  struct alignas(64) Share {
    std::atomic<uint64_t> ends{0};
    std::atomic<int64_t> finished{0};
  };

  // control.done from the workers' counts (a phase's last worker resets them as it shares the next
  // phase's items: a count read meanwhile may mix the two phases, which fraction() bounds).
  void publish() {
    int64_t finished = 0;
    for (const Share& s : m_shares) finished += s.finished.load(std::memory_order_acquire);  // after the items' work
    m_control.done.store(finished, std::memory_order_relaxed);
  }
  static uint64_t pack(uint64_t front, uint64_t back) { return front | back << 32; }

  void share(int64_t items) {
    const auto workers = static_cast<int64_t>(m_workers);
    for (int64_t w = 0; w < workers; ++w) {
      m_shares[static_cast<size_t>(w)].ends.store(pack(static_cast<uint64_t>(items * w / workers),
                                                      static_cast<uint64_t>(items * (w + 1) / workers)),
                                                 std::memory_order_relaxed);
    }
  }

  // The worker's next item: from the front of its share, else from the back of the largest share
  // left; -1 when none is left.
  int64_t take(int worker) {
    std::atomic<uint64_t>& own = m_shares[static_cast<size_t>(worker)].ends;
    for (uint64_t ends = own.load(std::memory_order_relaxed);;) {
      const uint64_t front = ends & 0xffffffffu, back = ends >> 32;
      if (front >= back) break;
      if (own.compare_exchange_weak(ends, pack(front + 1, back), std::memory_order_relaxed)) return static_cast<int64_t>(front);
    }
    for (;;) {
      Share* victim = nullptr;
      uint64_t most = 0, seen = 0;
      for (Share& s : m_shares) {
        const uint64_t ends = s.ends.load(std::memory_order_relaxed), front = ends & 0xffffffffu, back = ends >> 32;
        if (back > front && back - front > most) most = back - front, victim = &s, seen = ends;
      }
      if (victim == nullptr) return -1;
      const uint64_t back = seen >> 32;
      if (victim->ends.compare_exchange_weak(seen, pack(seen & 0xffffffffu, back - 1), std::memory_order_relaxed)) {
        return static_cast<int64_t>(back - 1);
      }
    }
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
  const WorkItem& m_work;
  const std::function<int64_t()>& m_next;
  std::vector<pthread_t> m_threads;
  std::vector<void*> m_stacks;            // the threads', returned to the pool once they have ended
  std::vector<WorkerId> m_workerIds;
  int m_workers = 0;
  std::vector<Share> m_shares;            // of the current phase's items, by worker
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

void runPhases(int64_t items, int threads, JobControl& control, const WorkItem& work,
               const std::function<int64_t()>& next, const std::function<void()>& poll, int pollMilliseconds) {
  checked(items);
  control.total = items;
  control.done = 0;
  poll();  // reports 0 and sees a cancel that came before the start
  std::exception_ptr failure;
  {
    PhasedJob job(control, work, next);
    int error = 0;
    if (job.start(std::max(1, threads), items, error) == 0) {
      throw std::runtime_error(std::string("threads: could not start a render thread: ") + std::strerror(error));
    }
    job.watch(poll, pollMilliseconds);
    failure = job.failure();
  }  // joins the workers
  if (failure) std::rethrow_exception(failure);
}

void runParallel(int64_t items, int threads, JobControl& control, const WorkItem& work,
                 const std::function<void()>& poll, int pollMilliseconds) {
  const std::function<int64_t()> none = [] { return int64_t(0); };
  runPhases(items, workersFor(threads, items), control, work, none, poll, pollMilliseconds);
}

}  // namespace durer
