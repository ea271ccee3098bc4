// gelctl logs: a job's log lines, all of them.
#include <iomanip>
#include <iostream>
#include <memory>
#include <string>

#include "command.hpp"
#include "common.hpp"

namespace {

int run_logs(gelctl::Client& client, const std::string& job_id) {
  gel::v1::GetLogsRequest request;
  request.set_job_id(job_id);
  for (;;) {
    gel::v1::GetLogsResponse response;
    auto context = client.context();
    gelctl::throw_if_failed(client.stub().GetLogs(context.get(), request, &response));
    for (const auto& line : response.lines()) {
      std::cout << gelctl::format_unix_ms(line.unix_ms()) << " " << std::left << std::setw(5) << line.level()
                << std::right << " " << line.message() << "\n";
      request.set_after_id(line.id());
    }
    // geld answers at most 1000 lines per call: a shorter answer was the last one.
    if (response.lines_size() < 1000) break;
  }
  return gelctl::kExitSuccess;
}

const gelctl::Registrar logs_registrar{
    "logs", "A job's log lines", 70, [](CLI::App& sub) -> gelctl::Runner {
      auto job_id = std::make_shared<std::string>();
      sub.add_option("job", *job_id, "Job id")->required();
      return [job_id](gelctl::Client& client) { return run_logs(client, *job_id); };
    }};

}  // namespace
