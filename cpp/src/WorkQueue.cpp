#include "durer/render/WorkQueue.h"

#include <sched.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <string>
#include <thread>

namespace durer {

namespace {

// Worker threads get a stack of their own size: secondary rays recurse once per bounce
// (PacketShader), about 30 KiB a level in double, and the default thread stack (8 MiB, 2 MiB where
// RLIMIT_STACK is unlimited) would overflow long before the validated maximum of 1,000 bounces.
// Only the pages a render touches are committed.
constexpr size_t kThreadStackBytes = size_t(64) << 20;

void* serveBody(void* body) {
  (*static_cast<const std::function<void()>*>(body))();
  return nullptr;
}

// pthread_create's error code (0: started).
int startThread(pthread_t& id, const std::function<void()>& body) {
  pthread_attr_t attributes;
  if (pthread_attr_init(&attributes) != 0) return EAGAIN;
  int error = pthread_attr_setstacksize(&attributes, kThreadStackBytes);
  if (error == 0) error = pthread_create(&id, &attributes, serveBody, const_cast<std::function<void()>*>(&body));
  pthread_attr_destroy(&attributes);
  return error;
}

}  // namespace

int defaultThreadCount() { return std::max(1u, std::thread::hardware_concurrency()); }

void WorkerPool::start() {
  int error = 0;
  for (int w = 0; w < m_wanted && error == 0; ++w) {
    pthread_t id;
    error = startThread(id, m_serve);
    if (error == 0) m_threads.push_back(id);  // a smaller pool does the work; none at all is an error
  }
  if (m_threads.empty()) {
    throw std::runtime_error(std::string("threads: could not start a render thread: ") + std::strerror(error));
  }
}

WorkerPool::~WorkerPool() {
  {
    std::lock_guard<std::mutex> lock(m_mutex);
    m_closing = true;
  }
  m_wake.notify_all();
  for (pthread_t id : m_threads) pthread_join(id, nullptr);
}

// True once the job after `served` is posted, false when the pool closes first. A worker yields in a
// loop for a while before it sleeps: the next round comes within microseconds, and a thread woken from
// sleep is often put on the CPU of the thread that woke it, beside its fellow worker, for milliseconds.
bool WorkerPool::waitForJob(uint64_t served) {
  constexpr auto kAwake = std::chrono::microseconds(200);
  const auto until = std::chrono::steady_clock::now() + kAwake;
  for (int i = 1;; ++i) {
    if (m_jobs.load(std::memory_order_acquire) != served) return true;
    if (m_closing.load(std::memory_order_acquire)) return false;
    if (i % 16 == 0 && std::chrono::steady_clock::now() >= until) break;
    sched_yield();
  }
  std::unique_lock<std::mutex> lock(m_mutex);
  m_wake.wait(lock, [&] { return m_closing || m_jobs != served; });
  return m_jobs != served;
}

void WorkerPool::serve() {
  for (uint64_t served = 0; waitForJob(served);) {
    served = m_jobs.load(std::memory_order_acquire);
    for (int64_t item = m_next++; item < m_items; item = m_next++) {
      if (m_control->cancel.load(std::memory_order_relaxed)) break;
      (*m_work)(item);
      m_control->done.fetch_add(1, std::memory_order_relaxed);
    }
    std::lock_guard<std::mutex> lock(m_mutex);
    if (--m_busy == 0) m_idle.notify_all();
  }
}

void WorkerPool::run(int64_t items, JobControl& control, const std::function<void(int64_t)>& work,
                     const std::function<void()>& poll, int pollMilliseconds) {
  control.total = items;
  control.done = 0;
  poll();  // reports 0 and sees a cancel that came before the start
  if (m_threads.empty()) start();
  std::unique_lock<std::mutex> lock(m_mutex);
  m_work = &work;
  m_control = &control;
  m_items = items;
  m_next = 0;
  m_busy = m_threads.size();
  ++m_jobs;
  m_wake.notify_all();
  std::exception_ptr failure;
  while (m_busy > 0) {
    m_idle.wait_for(lock, std::chrono::milliseconds(pollMilliseconds));
    if (m_busy == 0 || failure) continue;
    lock.unlock();
    try {
      poll();
    } catch (...) {
      failure = std::current_exception();
      control.cancel = true;
    }
    lock.lock();
  }
  lock.unlock();
  if (failure) std::rethrow_exception(failure);
}

void runParallel(int64_t items, int threads, JobControl& control, const std::function<void(int64_t)>& work,
                 const std::function<void()>& poll, int pollMilliseconds) {
  WorkerPool pool(static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(threads, items))));
  pool.run(items, control, work, poll, pollMilliseconds);
}

}  // namespace durer
