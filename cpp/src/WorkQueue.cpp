#include "durer/render/WorkQueue.h"

#include <pthread.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace durer {

namespace {

// Worker threads get a stack of their own size: secondary rays recurse once per bounce
// (PacketShader), about 30 KiB a level in double, and the default thread stack (8 MiB, 2 MiB where
// RLIMIT_STACK is unlimited) would overflow long before the validated maximum of 1,000 bounces.
// Only the pages a render touches are committed.
constexpr size_t kThreadStackBytes = size_t(64) << 20;

void* runBody(void* body) {
  (*static_cast<const std::function<void()>*>(body))();
  return nullptr;
}

// pthread_create's error code (0: started).
int startThread(pthread_t& id, const std::function<void()>& body) {
  pthread_attr_t attributes;
  if (pthread_attr_init(&attributes) != 0) return EAGAIN;
  int error = pthread_attr_setstacksize(&attributes, kThreadStackBytes);
  if (error == 0) error = pthread_create(&id, &attributes, runBody, const_cast<std::function<void()>*>(&body));
  pthread_attr_destroy(&attributes);
  return error;
}

}  // namespace

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
  const std::function<void()> body = [&] {
    for (int64_t item = next++; item < items; item = next++) {
      if (control.cancel.load(std::memory_order_relaxed)) break;
      work(item);
      control.done.fetch_add(1, std::memory_order_relaxed);
    }
    std::lock_guard<std::mutex> lock(mutex);
    if (--running == 0) finished.notify_all();
  };
  std::vector<pthread_t> pool;
  int error = 0;
  for (int w = 0; w < workers && error == 0; ++w) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      ++running;  // before the thread exists: it may finish before pthread_create returns
    }
    pthread_t id;
    error = startThread(id, body);
    if (error == 0) {
      pool.push_back(id);
    } else {
      std::lock_guard<std::mutex> lock(mutex);
      --running;  // a smaller pool does the work; none at all is an error (below)
    }
  }
  if (pool.empty()) {
    throw std::runtime_error(std::string("threads: could not start a render thread: ") + std::strerror(error));
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
  for (pthread_t id : pool) pthread_join(id, nullptr);
  if (failure) std::rethrow_exception(failure);
}

}  // namespace durer
