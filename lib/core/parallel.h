// Minimal deterministic parallel loop: work items are independent and write
// to their own outputs, so the result does not depend on the thread count.
#pragma once
#include <algorithm>
#include <atomic>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace svbrdf {

// Number of worker threads to use: `requested` if > 0, else hardware concurrency.
inline int ResolveThreads(int requested) {
  if (requested > 0) return requested;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : static_cast<int>(hw);
}

// Calls fn(i) for i in [0, n) on `threads` threads, in chunks of `grain`.
// The first exception thrown by any worker is rethrown on the caller.
inline void ParallelFor(long n, int threads, const std::function<void(long)>& fn, long grain = 1) {
  threads = std::max(1, std::min<int>(ResolveThreads(threads), static_cast<int>((n + grain - 1) / std::max(1L, grain))));
  if (threads <= 1) {
    for (long i = 0; i < n; ++i) fn(i);
    return;
  }
  std::atomic<long> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&] {
    for (;;) {
      const long begin = next.fetch_add(grain);
      if (begin >= n) return;
      const long end = std::min(n, begin + grain);
      try {
        for (long i = begin; i < end; ++i) fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        next = n;
        return;
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

// Lowers the calling thread's scheduling priority (nice +10) for the rest of
// its life, so that it runs on cycles the other threads leave idle: for
// speculative work beside work that is needed anyway. Linux keeps nice per
// thread (threads it starts inherit it); elsewhere, and where the system
// refuses, nothing changes. Only for threads that end with their work (a
// ParallelFor worker): priority once lowered is not raised again.
inline void LowerThisThreadsPriority() {
#if defined(__linux__)
  const id_t tid = static_cast<id_t>(syscall(SYS_gettid));
  (void)setpriority(PRIO_PROCESS, tid, std::min(19, getpriority(PRIO_PROCESS, tid) + 10));
#endif
}

}  // namespace svbrdf
