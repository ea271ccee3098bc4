#pragma once
// The threads of one run (System::set_threads). Every task of a parallel region writes its own
// outputs, so results never depend on which thread runs it or how many there are; reductions are
// combined in task order by the caller, and every task runs in the caller's floating-point mode.
// Workers spin briefly between regions (a step has several, microseconds apart) and then sleep
// on the generation counter, so an idle run costs no CPU.
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
  void worker();
  // Runs tasks of region `generation` until none is left or the region is over.
  void share(std::uint64_t generation);

  int threads_;
  std::vector<std::thread> workers_;
  // The current region, published by bumping generation_. next_task_ holds the region's
  // generation in its high 32 bits and the next task in its low 32, so that a claim made by a
  // worker that woke late for an older region fails instead of running a task of the new one.
  void (*fn_)(void*, std::size_t) = nullptr;
  void* context_ = nullptr;
  unsigned fp_mode_ = 0;  // the caller's floating-point mode (floating_point.hpp), copied into each task
  std::atomic<std::size_t> tasks_{0};
  std::atomic<std::uint64_t> next_task_{0};
  std::atomic<std::size_t> tasks_done_{0};
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<bool> quit_{false};
};

}  // namespace gel::detail
