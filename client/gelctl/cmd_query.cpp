// gelctl query: the curves of many jobs, chosen by bond preset, labels and scene parameters.
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "common.hpp"

namespace {

struct QueryArgs {
  std::string bond_preset, state;
  std::vector<std::string> labels, wheres;
  int limit = 100;
  bool json_output = false;
};

// "field=value", "field>=x" or "field<=x" into a parameter filter of the request.
// A bound of --where as a number; anything else (std::stod's bare "stod" exception, exit 1)
// is bad input naming the option.
double where_bound(const std::string& where, const std::string& text) {
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(value))
    throw gelctl::UsageError("--where: '" + where + "': '" + text + "' is not a number");
  return value;
}

void add_parameter_filter(gel::v1::QueryCurvesRequest& request, const std::string& where) {
  auto* filter = request.add_parameters();
  std::size_t pos;
  if ((pos = where.find(">=")) != std::string::npos) {
    filter->set_field(where.substr(0, pos));
    filter->set_min(where_bound(where, where.substr(pos + 2)));
  } else if ((pos = where.find("<=")) != std::string::npos) {
    filter->set_field(where.substr(0, pos));
    filter->set_max(where_bound(where, where.substr(pos + 2)));
  } else if ((pos = where.find('=')) != std::string::npos) {
    filter->set_field(where.substr(0, pos));
    filter->set_equals(where.substr(pos + 1));
  } else {
    throw gelctl::UsageError("--where: '" + where + "' is not field=value, field>=x or field<=x");
  }
}

void print_table(const gel::v1::QueryCurvesResponse& response) {
  using gelctl::format_number;
  std::cout << std::left << std::setw(14) << "ID" << std::setw(18) << "NAME" << std::setw(8) << "BOND" << std::setw(7)
            << "SEEDS" << std::setw(6) << "ROWS" << std::setw(12) << "PHI_LAST" << "P_LAST" << std::right << "\n";
  for (const auto& entry : response.curves()) {
    const auto& job = entry.job();
    // The last point: the ensemble mean when there is one, else the only member's last row.
    double phi = NAN, p = NAN;
    if (entry.curve().ensemble_size() > 0) {
      phi = entry.curve().ensemble().rbegin()->phi().mean();
      p = entry.curve().ensemble().rbegin()->p().mean();
    } else if (entry.curve().members_size() > 0 && entry.curve().members(0).curve().rows_size() > 0) {
      const auto& rows = entry.curve().members(0).curve().rows();
      phi = rows.rbegin()->phi();
      p = rows.rbegin()->p();
    }
    std::cout << std::left << std::setw(14) << job.id() << std::setw(18) << (job.name().empty() ? "-" : job.name())
              << std::setw(8) << (job.bond_preset().empty() ? "-" : job.bond_preset()) << std::setw(7)
              << job.seeds_size() << std::setw(6) << job.rows() << std::setw(12) << format_number(phi, 5)
              << format_number(p, 5) << std::right << "\n";
  }
}

int run_query(gelctl::Client& client, const QueryArgs& args) {
  gel::v1::QueryCurvesRequest request;
  request.set_bond_preset(args.bond_preset);
  for (const auto& label : args.labels) {
    auto [key, value] = gelctl::split_label(label, "--label");
    (*request.mutable_labels())[key] = value;
  }
  for (const auto& where : args.wheres) add_parameter_filter(request, where);
  if (!args.state.empty()) request.set_state(gelctl::parse_state(args.state));
  request.set_limit(args.limit);
  gel::v1::QueryCurvesResponse response;
  auto context = client.context();
  gelctl::throw_if_failed(client.stub().QueryCurves(context.get(), request, &response));
  if (args.json_output) {
    for (const auto& entry : response.curves()) std::cout << entry.curve().json() << "\n";
  } else {
    print_table(response);
  }
  return gelctl::kExitSuccess;
}

const gelctl::Registrar query_registrar{
    "query", "Curves of many jobs: by bond preset, labels and parameters", 80, [](CLI::App& sub) -> gelctl::Runner {
      auto args = std::make_shared<QueryArgs>();
      sub.add_option("--bond-preset", args->bond_preset, "bond1, bond2");
      sub.add_option("--label", args->labels, "key=value (repeatable; all must match)");
      sub.add_option("--where", args->wheres, "field=value, field>=x or field<=x on the resolved scene (repeatable)");
      sub.add_option("--state", args->state, "Default: succeeded");
      sub.add_option("--limit", args->limit, "Jobs at most")->capture_default_str();
      sub.add_flag("--json", args->json_output, "One JSON object per line (the jobs' curves)");
      return [args](gelctl::Client& client) { return run_query(client, *args); };
    }};

}  // namespace
