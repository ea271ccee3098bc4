// gelctl status (alias get): one job's state, sizes, times, progress, labels and the version
// string of the geld that ran it.
#include <iostream>
#include <memory>
#include <string>

#include "command.hpp"
#include "common.hpp"

namespace {

struct StatusArgs {
  std::string job_id;
  bool json_output = false;
};

void print_job(const gel::v1::Job& job) {
  using gelctl::format_number;
  using gelctl::format_unix_ms;
  std::cout << "job " << job.id() << (job.name().empty() ? "" : " (" + job.name() + ")") << ": "
            << gelctl::state_name(job.state()) << "\n";
  if (!job.error().empty()) std::cout << "  error: " << job.error() << "\n";
  std::cout << "  particles " << job.particles() << ", seeds " << job.seeds_size() << " (member " << job.member()
            << "), rows " << job.rows() << ", bond " << (job.bond_preset().empty() ? "-" : job.bond_preset()) << "\n";
  std::cout << "  created " << format_unix_ms(job.created_unix_ms()) << ", started "
            << format_unix_ms(job.started_unix_ms()) << ", finished " << format_unix_ms(job.finished_unix_ms())
            << "\n";
  if (job.state() == gel::v1::JOB_STATE_RUNNING && job.has_progress()) {
    const auto& progress = job.progress();
    std::cout << "  progress: step " << progress.k() << "/" << progress.k_total() << ", phi "
              << format_number(progress.phi()) << " -> " << format_number(progress.target_phi()) << ", P "
              << format_number(progress.p()) << ", ETA " << gelctl::format_duration(progress.remaining_seconds())
              << "\n";
  }
  for (const auto& [key, value] : job.labels()) std::cout << "  label " << key << "=" << value << "\n";
  if (!job.program_version().empty()) std::cout << "  program " << job.program_version() << "\n";
}

int run_status(gelctl::Client& client, const StatusArgs& args) {
  gel::v1::GetJobRequest request;
  request.set_job_id(args.job_id);
  gel::v1::Job job;
  auto context = client.context();
  gelctl::throw_if_failed(client.stub().GetJob(context.get(), request, &job));
  if (args.json_output) {
    std::cout << gelctl::job_json(job).dump(2) << std::endl;
  } else {
    print_job(job);
  }
  return gelctl::kExitSuccess;
}

const gelctl::Registrar status_registrar{
    "status", "A job's state and progress", 30, [](CLI::App& sub) -> gelctl::Runner {
      auto args = std::make_shared<StatusArgs>();
      sub.alias("get");
      sub.add_option("job", args->job_id, "Job id")->required();
      sub.add_flag("--json", args->json_output, "JSON output");
      return [args](gelctl::Client& client) { return run_status(client, *args); };
    }};

}  // namespace
