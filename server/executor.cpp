// The executor registry behind `geld --executor NAME`.
#include <stdexcept>

#include "executor.hpp"
#include "slurm_executor.hpp"

namespace geld {

std::unique_ptr<Executor> make_executor(const ExecutorConfig& config) {
  if (config.name == "threads") return make_thread_executor();
  if (config.name == "slurm") return make_slurm_executor(config);
  throw std::invalid_argument("executor: unknown executor '" + config.name + "' (available: threads, slurm)");
}

}  // namespace geld
