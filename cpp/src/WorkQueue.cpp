#include "durer/render/WorkQueue.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace durer {

int defaultThreadCount() { return std::max(1u, std::thread::hardware_concurrency()); }

void runParallel(int64_t items, int threads, JobControl& control, const std::function<void(int64_t)>& work,
                 const std::function<void()>& poll, int pollMilliseconds) {
  control.total = items;
  control.done = 0;
  std::atomic<int64_t> next{0};
  std::atomic<int> running{0};
  std::mutex mutex;
  std::condition_variable finished;

  poll();  // reports 0 and sees a cancel that came before the start
  const int workers = static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(threads, items)));
  running = workers;
  std::vector<std::thread> pool;
  pool.reserve(static_cast<size_t>(workers));
  for (int w = 0; w < workers; ++w) {
    pool.emplace_back([&] {
      for (int64_t item = next++; item < items; item = next++) {
        if (control.cancel.load(std::memory_order_relaxed)) break;
        work(item);
        control.done.fetch_add(1, std::memory_order_relaxed);
      }
      std::lock_guard<std::mutex> lock(mutex);
      if (--running == 0) finished.notify_all();
    });
  }

  std::exception_ptr failure;
  {
    std::unique_lock<std::mutex> lock(mutex);
    while (running > 0) {
      finished.wait_for(lock, std::chrono::milliseconds(pollMilliseconds));
      if (running == 0 || failure) continue;
      lock.unlock();
      try {
        poll();
      } catch (...) {
        failure = std::current_exception();
        control.cancel = true;
      }
      lock.lock();
    }
  }
  for (std::thread& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace durer
