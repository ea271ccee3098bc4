// gelctl curve: a job's P_y(phi) curve as a table, CSV or JSON, optionally plotted by gelsim.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "command.hpp"
#include "common.hpp"
#include "curve_csv.hpp"

namespace {

using gelctl::format_number;
using gelctl::json;

struct CurveArgs {
  std::string job_id, out_file, png_file;
  bool csv = false, json_output = false;
};

void print_curve_table(const gel::v1::GetCurveResponse& curve, std::ostream& out) {
  if (curve.ensemble_size() > 0) {
    out << "# job " << curve.job_id() << " (" << gelctl::state_name(curve.state()) << "), ensemble of "
        << curve.members_size() << " seeds: mean +- std per phi_k\n";
    out << std::setw(3) << "k" << std::setw(4) << "n" << std::setw(22) << "phi" << std::setw(26) << "P"
        << std::setw(26) << "contact_number" << "\n";
    for (const auto& row : curve.ensemble()) {
      auto mean_std = [](const gel::v1::Stat& stat, int digits) {
        return format_number(stat.mean(), digits) + " +- " + format_number(stat.std(), 2);
      };
      out << std::setw(3) << row.k() << std::setw(4) << row.n() << std::setw(22) << mean_std(row.phi(), 5)
          << std::setw(26) << mean_std(row.p(), 5) << std::setw(26) << mean_std(row.contact_number(), 4) << "\n";
    }
    return;
  }
  for (const auto& member : curve.members()) {
    out << "# job " << curve.job_id() << " (" << gelctl::state_name(curve.state()) << "), seed " << member.seed()
        << ", " << member.curve().particles() << " particles, " << member.curve().rows_size() << " rows\n";
    out << std::setw(3) << "k" << std::setw(11) << "phi" << std::setw(11) << "target" << std::setw(13) << "P"
        << std::setw(13) << "P_top" << std::setw(13) << "P_bot" << std::setw(13) << "sigma_yy" << std::setw(8) << "z"
        << std::setw(12) << "E_stored"
        << std::setw(12) << "E_diss" << std::setw(8) << "breaks" << std::setw(4) << "eq" << "\n";
    for (const auto& row : member.curve().rows()) {
      out << std::setw(3) << row.k() << std::setw(11) << format_number(row.phi(), 5) << std::setw(11)
          << format_number(row.target_phi(), 5) << std::setw(13) << format_number(row.p(), 5) << std::setw(13)
          << format_number(row.p_top(), 5) << std::setw(13) << format_number(row.p_bot(), 5) << std::setw(13)
          << (row.has_stress() ? format_number(row.stress().yy(), 5) : "-") << std::setw(8)
          << format_number(row.contact_number(), 4) << std::setw(12) << format_number(row.stored_energy(), 4)
          << std::setw(12) << format_number(row.dissipated_energy(), 4) << std::setw(8) << row.ruptures().normal()
          << std::setw(4) << (row.equilibrated() ? "y" : "n") << "\n";
    }
  }
}

// The engine's curve table (curve.csv's columns with units), one row per member and equilibrium
// with member and seed in front; an ensemble's statistics under the same names with _std.
void print_curve_csv(const gel::v1::GetCurveResponse& curve, std::ostream& out) {
  if (curve.ensemble_size() > 0) {
    out << "k,n [count],phi [1],phi_std [1],P [F0/a^2],P_std [F0/a^2],P_top [F0/a^2],P_top_std [F0/a^2],"
           "P_bot [F0/a^2],P_bot_std [F0/a^2],contact_number [1],contact_number_std [1],"
           "stored_energy [F0 a],stored_energy_std [F0 a],dissipated_energy [F0 a],dissipated_energy_std [F0 a]\n";
    for (const auto& row : curve.ensemble()) {
      out << row.k() << "," << row.n();
      for (const auto* stat : {&row.phi(), &row.p(), &row.p_top(), &row.p_bot(), &row.contact_number(),
                               &row.stored_energy(), &row.dissipated_energy()}) {
        out << "," << gel::exact(stat->mean()) << "," << gel::exact(stat->std());
      }
      out << "\n";
    }
    return;
  }
  out << "member,seed," << gel::curve_csv_header() << "\n";
  for (const auto& member : curve.members())
    for (const auto& row : member.curve().rows())
      out << member.member() << "," << member.seed() << "," << gel::curve_csv_row(row) << "\n";
}

void write_out(const std::string& path, const std::string& text) {
  if (path.empty() || path == "-") {
    std::cout << text;
    return;
  }
  std::ofstream out(path, std::ios::binary);
  if (!out) throw gelctl::UsageError("--out: cannot write " + path);
  out << text;
}

// gelsim next to gelctl (installed side by side, or the build tree's core/), $GELSIM, or PATH.
std::string find_gelsim() {
  if (const char* from_environment = std::getenv("GELSIM"); from_environment && *from_environment)
    return from_environment;
  std::error_code error;
  const auto executable = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    for (const auto& candidate :
         {executable.parent_path() / "gelsim", executable.parent_path() / ".." / "core" / "gelsim"}) {
      if (std::filesystem::exists(candidate)) return candidate.string();
    }
  }
  return "gelsim";
}

// --png: the members' curves as run directories, `gelsim plot` on them (an ensemble when
// several), and its P_y(phi) picture copied to `path`.
void plot_png(const gel::v1::GetCurveResponse& response, const std::string& path) {
  const json whole = json::parse(response.json());
  std::vector<json> curves;
  if (whole.contains("members")) {
    for (const auto& member : whole["members"]) curves.push_back(member);
  } else {
    curves.push_back(whole);
  }
  std::string pattern = (std::filesystem::temp_directory_path() / "gelctl-plot.XXXXXX").string();
  if (!mkdtemp(pattern.data())) throw std::runtime_error("--png: cannot create a temporary directory");
  const std::filesystem::path scratch = pattern;
  std::vector<std::string> args{find_gelsim(), "plot"};
  for (std::size_t i = 0; i < curves.size(); ++i) {
    const auto run_dir = scratch / ("m" + std::to_string(i));
    std::filesystem::create_directories(run_dir);
    std::ofstream(run_dir / "curve.json") << curves[i].dump();
    args.push_back(run_dir.string());
  }
  for (const char* extra : {"--no-snapshots", "--out"}) args.emplace_back(extra);
  args.push_back((scratch / "plots").string());
  std::cout.flush();
  std::fflush(nullptr);  // the child must not write our buffered output again
  const pid_t pid = fork();
  if (pid == 0) {
    if (!freopen("/dev/null", "w", stdout)) _exit(127);
    std::vector<char*> argv;
    for (auto& arg : args) argv.push_back(arg.data());
    argv.push_back(nullptr);
    execvp(argv[0], argv.data());
    _exit(127);
  }
  int status = -1;
  if (pid > 0) waitpid(pid, &status, 0);
  const auto picture = scratch / "plots" / "pressure.png";
  const bool plotted = pid > 0 && WIFEXITED(status) && WEXITSTATUS(status) == 0 && std::filesystem::exists(picture);
  if (plotted) std::filesystem::copy_file(picture, path, std::filesystem::copy_options::overwrite_existing);
  std::error_code ignored;
  std::filesystem::remove_all(scratch, ignored);
  if (!plotted) throw std::runtime_error("--png: `" + args[0] + " plot` failed (set GELSIM to gelsim's path)");
}

int run_curve(gelctl::Client& client, const CurveArgs& args) {
  gel::v1::GetCurveRequest request;
  request.set_job_id(args.job_id);
  gel::v1::GetCurveResponse response;
  auto context = client.context();
  gelctl::throw_if_failed(client.stub().GetCurve(context.get(), request, &response));
  std::ostringstream out;
  if (args.json_output) {
    out << response.json() << "\n";
  } else if (args.csv) {
    print_curve_csv(response, out);
  } else {
    print_curve_table(response, out);
  }
  write_out(args.out_file, out.str());
  if (!args.png_file.empty()) plot_png(response, args.png_file);
  return gelctl::kExitSuccess;
}

const gelctl::Registrar curve_registrar{
    "curve", "A job's P_y(phi) curve (ensembles: mean and std per phi_k)", 60, [](CLI::App& sub) -> gelctl::Runner {
      auto args = std::make_shared<CurveArgs>();
      sub.add_option("job", args->job_id, "Job id")->required();
      auto* csv = sub.add_flag("--csv", args->csv, "CSV");
      auto* json_output = sub.add_flag("--json", args->json_output, "One JSON object with a rows list");
      csv->excludes(json_output);
      sub.add_option("--out,-o", args->out_file, "Write to this file instead of stdout");
      sub.add_option("--png", args->png_file, "Also plot to this PNG (needs gelsim plot)");
      return [args](gelctl::Client& client) { return run_curve(client, *args); };
    }};

}  // namespace
