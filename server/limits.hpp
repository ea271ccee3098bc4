#pragma once
// The daemon's bounds on what it accepts and runs (docs/api.md "Budgets and bounds").
#include <cstddef>
#include <cstdint>

namespace geld {

struct Limits {
  std::size_t max_queue = 1000;            // queued jobs
  std::int64_t max_particles = 2'000'000;  // per ensemble member
  int max_seeds = 1000;                    // ensemble members per job
  int max_watchers = 256;                  // concurrent WatchJob streams, all jobs
  int threads_per_member = 1;              // engine threads of a member whose scene leaves integration.threads 0
  // Budgets on the resources a job's scene says it will need (gel/resources.hpp), checked at
  // submission (docs/api.md "Budgets and bounds"):
  std::int64_t max_member_memory = 4ll << 30;      // one member's state [bytes]
  std::int64_t max_job_disk = 64ll << 30;          // all members' files [bytes]
  double max_job_particle_steps = 1e14;            // all members: about 280 core-hours at 1e8/s
  // What the members running at once may hold together, with geld itself [bytes]: a job is
  // admitted only if the `workers` largest members of the admitted jobs fit. 0: half the
  // machine's memory. Only where members run inside geld (the threads executor).
  std::int64_t max_memory = 0;
};

}  // namespace geld
