// The executor registry behind `geld --executor NAME`.
#include <stdexcept>

#include "executor.hpp"

namespace geld {

std::unique_ptr<Executor> make_executor(const ExecutorConfig& config) {
  if (config.name == "threads") return make_thread_executor();
  // "slurm": issue 8 adds make_slurm_executor(config) here.
  throw std::invalid_argument("executor: unknown executor '" + config.name + "' (available: threads)");
}

}  // namespace geld
