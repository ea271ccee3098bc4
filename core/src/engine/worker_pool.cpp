#include "worker_pool.hpp"

#include <algorithm>
#include <stdexcept>

#include "floating_point.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace gel::detail {

namespace {
inline void cpu_relax() {
#if defined(__x86_64__)
  _mm_pause();
#endif
}
// About 10-20 microseconds of spinning before a thread yields or sleeps: longer than the gaps
// between the parallel regions of a step, far shorter than a chunk of serial work.
constexpr int kSpinsBeforeSleep = 4000;
constexpr std::uint64_t kTaskBits = 32;
constexpr std::uint64_t kTaskMask = (std::uint64_t{1} << kTaskBits) - 1;
}  // namespace

WorkerPool::WorkerPool(int threads) : threads_(threads), cursors_(static_cast<std::size_t>(std::max(threads, 1))) {
  if (threads < 1) throw std::invalid_argument("threads must be >= 1");
  for (int rank = 1; rank < threads; ++rank) workers_.emplace_back([this, rank] { worker(rank); });
}

WorkerPool::~WorkerPool() {
  quit_.store(true);
  generation_.fetch_add(1);
  generation_.notify_all();
  for (auto& thread : workers_) thread.join();
}

bool WorkerPool::drain(std::uint64_t tag, int owner) {
  std::atomic<std::uint64_t>& cursor = cursors_[static_cast<std::size_t>(owner)].next;
  std::uint64_t claim = cursor.load(std::memory_order_acquire);
  for (;;) {
    if ((claim & ~kTaskMask) != tag) return false;  // another region by now
    // Share `owner` is [tasks * owner / T, tasks * (owner + 1) / T); tasks_ is read only after
    // a claim of this region was seen, so it is this region's.
    const std::size_t tasks = tasks_.load(std::memory_order_acquire);
    const std::size_t threads = static_cast<std::size_t>(threads_);
    const std::size_t begin = tasks * static_cast<std::size_t>(owner) / threads;
    const std::size_t end = tasks * static_cast<std::size_t>(owner + 1) / threads;
    const std::size_t task = begin + static_cast<std::size_t>(claim & kTaskMask);
    if (task >= end) return true;
    if (!cursor.compare_exchange_weak(claim, claim + 1, std::memory_order_acq_rel)) continue;
    // The claim succeeded, so this region cannot end before the task is done: fn_ is its own,
    // and so is the caller's floating-point mode, which every task runs in.
    set_floating_point_mode(fp_mode_);
    fn_(context_, task);
    tasks_done_.fetch_add(1, std::memory_order_release);
    claim = cursor.load(std::memory_order_acquire);
  }
}

void WorkerPool::share(std::uint64_t generation, int rank) {
  const std::uint64_t tag = (generation & kTaskMask) << kTaskBits;
  for (int k = 0; k < threads_; ++k)
    if (!drain(tag, (rank + k) % threads_)) return;
}

void WorkerPool::run_erased(std::size_t tasks, void (*fn)(void*, std::size_t), void* context) {
  if (tasks > kTaskMask) throw std::length_error("too many tasks in one parallel region");
  const std::uint64_t generation = generation_.load(std::memory_order_relaxed) + 1;
  const std::uint64_t tag = (generation & kTaskMask) << kTaskBits;
  // Closed first: a worker still holding a claim of the last region now fails its exchange, so
  // it never runs a task with the fields being rewritten below.
  for (Cursor& cursor : cursors_) cursor.next.store(tag | kTaskMask, std::memory_order_release);
  fn_ = fn;
  context_ = context;
  fp_mode_ = floating_point_mode();
  tasks_.store(tasks, std::memory_order_release);
  tasks_done_.store(0, std::memory_order_relaxed);
  for (Cursor& cursor : cursors_) cursor.next.store(tag, std::memory_order_release);
  generation_.store(generation, std::memory_order_release);
  generation_.notify_all();
  share(generation, 0);
  int spins = 0;
  while (tasks_done_.load(std::memory_order_acquire) < tasks) {
    if (++spins < kSpinsBeforeSleep)
      cpu_relax();
    else
      std::this_thread::yield();
  }
}

void WorkerPool::worker(int rank) {
  // Generation 0 is the pool's start, not a region: a worker that the OS starts only after the
  // first region was published must still take part in it (loading the counter here made such a
  // worker skip that region and leave all of it to the caller).
  std::uint64_t seen = 0;
  for (;;) {
    int spins = 0;
    std::uint64_t now = generation_.load(std::memory_order_acquire);
    while (now == seen) {
      if (++spins < kSpinsBeforeSleep)
        cpu_relax();
      else
        generation_.wait(seen);
      now = generation_.load(std::memory_order_acquire);
    }
    seen = now;
    if (quit_.load()) return;
    share(now, rank);
  }
}

}  // namespace gel::detail
