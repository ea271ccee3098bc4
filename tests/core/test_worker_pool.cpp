// The engine's worker pool (core/src/engine/worker_pool.hpp): every task of a region runs exactly
// once, whatever the number of threads and tasks, region after region; each thread starts with
// its own share of the tasks.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <thread>
#include <vector>

#include "engine/worker_pool.hpp"

namespace gel {
namespace {

TEST(WorkerPool, EveryTaskRunsExactlyOnceForAnyThreadsAndTasks) {
  for (const int threads : {1, 2, 3, 5, 8}) {
    detail::WorkerPool pool(threads);
    for (const std::size_t tasks : {std::size_t{0}, std::size_t{1}, std::size_t{2}, std::size_t{3}, std::size_t{7},
                                    std::size_t{100}, std::size_t{1000}}) {
      // Back-to-back regions, as in a step: a late worker must never run a task twice or of
      // the wrong region.
      for (int region = 0; region < 50; ++region) {
        std::vector<std::atomic<int>> runs(tasks);
        pool.run(tasks, [&](std::size_t t) { runs[t].fetch_add(1, std::memory_order_relaxed); });
        for (std::size_t t = 0; t < tasks; ++t)
          ASSERT_EQ(runs[t].load(), 1) << threads << " threads, " << tasks << " tasks, region " << region << ", task " << t;
      }
    }
  }
}

TEST(WorkerPool, EachThreadStartsWithItsOwnShare) {
  // Two threads, 64 tasks: the caller's share is tasks 0-31, the worker's 32-63. The first
  // task each thread runs is the first of its own share (the caller waits, at most 5 s, until
  // the worker has started, so that the worker's first task is not taken from it by stealing).
  detail::WorkerPool pool(2);
  const std::thread::id caller = std::this_thread::get_id();
  std::atomic<long> caller_first{-1}, worker_first{-1};
  std::atomic<bool> caller_waited{false};
  pool.run(64, [&](std::size_t t) {
    const bool on_caller = std::this_thread::get_id() == caller;
    long expected = -1;
    (on_caller ? caller_first : worker_first).compare_exchange_strong(expected, static_cast<long>(t));
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    if (on_caller && !caller_waited.exchange(true))
      while (worker_first.load() < 0 && std::chrono::steady_clock::now() < give_up) std::this_thread::yield();
  });
  ASSERT_GE(worker_first.load(), 0) << "the worker thread never ran a task within 5 s";
  EXPECT_EQ(caller_first.load(), 0);
  EXPECT_EQ(worker_first.load(), 32);
}

}  // namespace
}  // namespace gel
