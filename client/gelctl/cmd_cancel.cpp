// gelctl cancel: stop a queued or running job.
#include <iostream>
#include <memory>
#include <string>

#include "command.hpp"
#include "common.hpp"

namespace {

int run_cancel(gelctl::Client& client, const std::string& job_id) {
  gel::v1::CancelJobRequest request;
  request.set_job_id(job_id);
  gel::v1::Job job;
  auto context = client.context();
  gelctl::throw_if_failed(client.stub().CancelJob(context.get(), request, &job));
  // A running job is only told to stop: it ends after this call returns.
  std::cout << job.id() << ": " << gelctl::state_name(job.state())
            << (job.state() == gel::v1::JOB_STATE_RUNNING ? " (stopping)" : "") << std::endl;
  return gelctl::kExitSuccess;
}

const gelctl::Registrar cancel_registrar{
    "cancel", "Cancel a queued or running job", 50, [](CLI::App& sub) -> gelctl::Runner {
      auto job_id = std::make_shared<std::string>();
      sub.add_option("job", *job_id, "Job id")->required();
      return [job_id](gelctl::Client& client) { return run_cancel(client, *job_id); };
    }};

}  // namespace
