// gelctl watch: follow a job until it ends (the printing is shared with submit --watch).
#include <memory>
#include <string>

#include "command.hpp"
#include "common.hpp"

namespace {

struct WatchArgs {
  std::string job_id;
  bool json_lines = false;
};

const gelctl::Registrar watch_registrar{
    "watch", "Follow a job: progress bar in a terminal, lines otherwise", 40, [](CLI::App& sub) -> gelctl::Runner {
      auto args = std::make_shared<WatchArgs>();
      sub.add_option("job", args->job_id, "Job id")->required();
      sub.add_flag("--json", args->json_lines, "JSON lines (one JobUpdate per line)");
      return [args](gelctl::Client& client) { return gelctl::watch_job(client, args->job_id, args->json_lines); };
    }};

}  // namespace
