// The engine's floating-point mode (core/src/engine/floating_point.hpp): subnormal numbers are
// flushed to zero inside every engine call, the caller's mode is restored after it, and the
// worker threads run each task in the caller's mode (so results cannot depend on which thread
// evaluated a bond).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <thread>
#include <vector>

#include "engine/floating_point.hpp"
#include "engine/worker_pool.hpp"
#include "gel/system.hpp"
#include "test_scenes.hpp"

namespace gel {
namespace {

#if defined(__SSE2__)
TEST(FloatingPoint, SubnormalMotionIsFlushedToZeroAndTheCallersModeRestored) {
  Configuration config;
  config.lx = config.ly = 20;
  config.add_particle(10, 10, 0);  // alone: no bond, no contact, only drag
  System system(config, bond1_params(kAllEffects));
  // Half the smallest normal double: a subnormal speed, as an isolated cluster reaches when
  // drag or FIRE slows it geometrically.
  const double subnormal = std::numeric_limits<double>::min() / 2;
  ASSERT_EQ(std::fpclassify(subnormal), FP_SUBNORMAL);
  system.set_velocity(0, subnormal, -subnormal, subnormal);
  const unsigned caller_mode = detail::floating_point_mode();
  system.step();
  EXPECT_EQ(detail::floating_point_mode(), caller_mode);
  // Without the flush, drag leaves v (1 - gamma dt) ~ 1e-308: still subnormal, not zero.
  EXPECT_EQ(system.vx()[0], 0.0);
  EXPECT_EQ(system.vy()[0], 0.0);
  EXPECT_EQ(system.omega()[0], 0.0);
  EXPECT_EQ(system.x()[0], 10.0);
}

TEST(FloatingPoint, WorkerThreadsRunEveryTaskInTheCallersMode) {
  detail::WorkerPool pool(2);
  const detail::FlushSubnormals flush;  // the caller's mode differs from a new thread's default
  const unsigned caller_mode = detail::floating_point_mode();
  const std::thread::id caller = std::this_thread::get_id();
  constexpr std::size_t kTasks = 64;
  std::vector<unsigned> task_mode(kTasks, 0);
  std::vector<char> on_worker(kTasks, 0);
  std::atomic<bool> worker_took_one{false}, caller_waited{false};
  pool.run(kTasks, [&](std::size_t t) {
    task_mode[t] = detail::floating_point_mode();
    on_worker[t] = std::this_thread::get_id() != caller;
    if (on_worker[t]) worker_took_one.store(true);
    // The caller's first task waits (at most 5 s) for the worker to take one, so that the test
    // sees a task on each thread even on a busy machine.
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    if (!on_worker[t] && !caller_waited.exchange(true))
      while (!worker_took_one.load() && std::chrono::steady_clock::now() < give_up) std::this_thread::yield();
  });
  ASSERT_TRUE(worker_took_one.load()) << "the worker thread never ran a task within 5 s";
  for (std::size_t t = 0; t < kTasks; ++t)
    EXPECT_EQ(task_mode[t], caller_mode) << "task " << t << (on_worker[t] ? " (worker)" : " (caller)");
}
#endif

}  // namespace
}  // namespace gel
