// gelctl analysis: the curve analysis geld computes for a finished job (GetAnalysis): the fits
// with the rows they used, the regime boundaries and the rows left out, or the whole JSON.
#include <iostream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "common.hpp"

namespace {

struct AnalysisArgs {
  std::string job_id;
  bool json = false;
  bool include_unequilibrated = false;
};

std::string number_or_dash(const nlohmann::json& value) {
  return value.is_number() ? gelctl::format_number(value.get<double>()) : "-";
}

void print_summary(const nlohmann::json& a) {
  std::cout << "members: " << a.at("members") << "\n";
  const auto& power_law = a.at("power_law");
  if (power_law.is_object()) {
    std::cout << "power law P = C phi^lambda: lambda = " << number_or_dash(power_law.at("exponent")) << " +- "
              << number_or_dash(power_law.at("exponent_stderr")) << ", C = " << number_or_dash(power_law.at("prefactor"))
              << " F0/a^2, phi " << number_or_dash(power_law.at("phi_min")) << " - " << number_or_dash(power_law.at("phi_max"))
              << " (" << power_law.at("points") << " rows)\n";
  } else {
    std::cout << "power law: none (" << a.value("power_law_error", std::string("no reason given")) << ")\n";
  }
  const auto& gel_point = a.at("gel_point");
  if (gel_point.is_object() && gel_point.value("at_bound", false)) {
    std::cout << "gel point: not determined (the fit put phi_g at its bound, " << number_or_dash(gel_point.at("phi_g"))
              << ": the data fix no gel point; lambda' = " << number_or_dash(gel_point.at("exponent")) << ")\n";
  } else if (gel_point.is_object()) {
    std::cout << "gel point P = C (phi - phi_g)^lambda': phi_g = " << number_or_dash(gel_point.at("phi_g")) << " +- "
              << number_or_dash(gel_point.at("phi_g_stderr")) << ", lambda' = " << number_or_dash(gel_point.at("exponent"))
              << " +- " << number_or_dash(gel_point.at("exponent_stderr")) << "\n";
  } else {
    std::cout << "gel point: none (" << a.value("gel_point_error", std::string("no reason given")) << ")\n";
  }
  const auto& regimes = a.at("regimes");
  std::cout << "single-mode plastic from phi " << number_or_dash(regimes.at("single_mode_start_phi"))
            << ", multi-mode plastic from phi " << number_or_dash(regimes.at("multi_mode_start_phi")) << "\n";
  for (const auto& row : a.at("excluded_rows"))
    std::cout << "left out k " << row.at("k") << " phi " << number_or_dash(row.at("phi")) << ": "
              << row.at("reason").get<std::string>() << "\n";
}

int run_analysis(gelctl::Client& client, const AnalysisArgs& args) {
  gel::v1::GetAnalysisRequest request;
  request.set_job_id(args.job_id);
  request.set_include_unequilibrated(args.include_unequilibrated);
  gel::v1::GetAnalysisResponse response;
  auto context = client.context();
  gelctl::throw_if_failed(client.stub().GetAnalysis(context.get(), request, &response));
  if (args.json) {
    std::cout << response.json() << "\n";
  } else {
    print_summary(nlohmann::json::parse(response.json()));
  }
  return gelctl::kExitSuccess;
}

const gelctl::Registrar analysis_registrar{
    "analysis", "Fits, regimes and rows left out of a finished job, computed by geld", 65,
    [](CLI::App& sub) -> gelctl::Runner {
      auto args = std::make_shared<AnalysisArgs>();
      sub.add_option("job", args->job_id, "Job id")->required();
      sub.add_flag("--json", args->json, "The whole analysis as JSON (rows, intervals, fits, regimes)");
      sub.add_flag("--include-unequilibrated", args->include_unequilibrated,
                   "Also fit spanning rows that did not pass the equilibrium test");
      return [args](gelctl::Client& client) { return run_analysis(client, *args); };
    }};

}  // namespace
