#pragma once
// The threads of one run (System::set_threads). Every task of a parallel region writes its own
// outputs, so results never depend on which thread runs it or how many there are; reductions are
// combined in task order by the caller, and every task runs in the caller's floating-point mode.
// Workers spin briefly between regions (a step has several, microseconds apart) and then sleep
// on the generation counter, so an idle run costs no CPU.
// Each thread first takes the tasks of its own share (thread r of T: the r-th contiguous T-th of
// the tasks), then helps with the others' shares. So a block of particles is handled by the same
// thread in every region of a step while all threads run, and its positions, velocities and
// forces stay in that core's cache; with the tasks handed out first come, first served, each
// region moved about half of them to the other core (measured: the two-thread step spent twice
// the one-thread CPU time in the integrator's loop alone).
// A region ends when its tasks are done, not when every worker has looked in: a worker the OS
// has not scheduled (more threads than free cores) delays nothing, it just finds no task left.
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <thread>
#include <vector>

namespace gel::detail {

class WorkerPool {
 public:
  explicit WorkerPool(int threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int threads() const { return threads_; }

  // Calls task(t) for every t in [0, tasks), spread over the threads (the caller takes part),
  // and returns when all have returned. task must not throw.
  template <class Task>
  void run(std::size_t tasks, Task&& task) {
    if (threads_ == 1 || tasks <= 1) {
      for (std::size_t t = 0; t < tasks; ++t) task(t);
      return;
    }
    using Fn = std::remove_reference_t<Task>;
    run_erased(tasks, [](void* context, std::size_t t) { (*static_cast<Fn*>(context))(t); }, &task);
  }

 private:
  void run_erased(std::size_t tasks, void (*fn)(void*, std::size_t), void* context);
  void worker(int rank);
  // Runs tasks of region `generation`, its own share first, until none is left or the region is
  // over.
  void share(std::uint64_t generation, int rank);
  // Runs the tasks left in share `owner`; false when the region is over.
  bool drain(std::uint64_t tag, int owner);

  int threads_;
  std::vector<std::thread> workers_;
  // The current region, published by bumping generation_. Each share's cursor holds the region's
  // generation in its high 32 bits and the share's next task in its low 32, so that a claim made
  // by a worker that woke late for an older region fails instead of running a task of the new one.
  struct alignas(64) Cursor {
    std::atomic<std::uint64_t> next{0};
  };
  void (*fn_)(void*, std::size_t) = nullptr;
  void* context_ = nullptr;
  unsigned fp_mode_ = 0;  // the caller's floating-point mode (floating_point.hpp), copied into each task
  std::atomic<std::size_t> tasks_{0};
  std::vector<Cursor> cursors_;  // one per thread: its share of the region's tasks
  std::atomic<std::size_t> tasks_done_{0};
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<bool> quit_{false};
};

}  // namespace gel::detail
