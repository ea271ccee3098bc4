// gelctl list: jobs, newest first, filtered by state, label or name; one page or --all.
#include <iomanip>
#include <iostream>
#include <memory>
#include <string>

#include "command.hpp"
#include "common.hpp"

namespace {

struct ListArgs {
  std::string state, label, name, page_token;
  int page_size = 50;
  bool all_pages = false, json_output = false;
};

void print_header() {
  std::cout << std::left << std::setw(14) << "ID" << std::setw(11) << "STATE" << std::setw(18) << "NAME" << std::setw(7)
            << "SEEDS" << std::setw(10) << "PARTICLES" << std::setw(6) << "ROWS" << "CREATED" << std::right << "\n";
}

void print_row(const gel::v1::Job& job) {
  std::cout << std::left << std::setw(14) << job.id() << std::setw(11) << gelctl::state_name(job.state())
            << std::setw(18) << (job.name().empty() ? "-" : job.name()) << std::setw(7) << job.seeds_size()
            << std::setw(10) << job.particles() << std::setw(6) << job.rows()
            << gelctl::format_unix_ms(job.created_unix_ms()) << std::right << "\n";
}

int run_list(gelctl::Client& client, const ListArgs& args) {
  gel::v1::ListJobsRequest request;
  if (!args.state.empty()) request.set_state(gelctl::parse_state(args.state));
  request.set_label(args.label);
  request.set_name(args.name);
  request.set_page_size(args.page_size);
  request.set_page_token(args.page_token);
  gelctl::json jobs = gelctl::json::array();
  bool header_printed = false;
  for (;;) {
    gel::v1::ListJobsResponse response;
    auto context = client.context();
    gelctl::throw_if_failed(client.stub().ListJobs(context.get(), request, &response));
    for (const auto& job : response.jobs()) {
      if (args.json_output) {
        jobs.push_back(gelctl::job_json(job));
        continue;
      }
      // The header comes with the first job: an empty list prints nothing.
      if (!header_printed) {
        print_header();
        header_printed = true;
      }
      print_row(job);
    }
    if (response.next_page_token().empty()) break;
    if (!args.all_pages) {
      if (!args.json_output) std::cout << "next page: --page-token " << response.next_page_token() << "\n";
      break;
    }
    request.set_page_token(response.next_page_token());
  }
  if (args.json_output) std::cout << jobs.dump(2) << std::endl;
  return gelctl::kExitSuccess;
}

const gelctl::Registrar list_registrar{
    "list", "List jobs, newest first", 20, [](CLI::App& sub) -> gelctl::Runner {
      auto args = std::make_shared<ListArgs>();
      sub.add_option("--state", args->state, "queued, running, succeeded, failed, cancelled");
      sub.add_option("--label", args->label, "key=value or key");
      sub.add_option("--name", args->name, "Exact name");
      sub.add_option("--page-size", args->page_size, "Jobs per page")->capture_default_str();
      sub.add_option("--page-token", args->page_token, "Page token from a previous list");
      sub.add_flag("--all", args->all_pages, "Fetch every page");
      sub.add_flag("--json", args->json_output, "JSON output");
      return [args](gelctl::Client& client) { return run_list(client, *args); };
    }};

}  // namespace
