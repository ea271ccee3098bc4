// gelctl: the command-line client of geld. Thin: gRPC stubs and the proto messages, no engine.
// Exit codes: 0 success; 2 bad input (ours or the server's INVALID_ARGUMENT); 1 any other error
// (the gRPC status code name and the server's one-line message on stderr); 3 a watched job
// that ended failed or cancelled.
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <google/protobuf/util/json_util.h>
#include <grpcpp/grpcpp.h>
#include <nlohmann/json.hpp>

#include "gel/v1/service.grpc.pb.h"

namespace {

using gel::v1::JobState;
using json = nlohmann::json;

// Bad input on our side: exit 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// A failed call: exit 1 (2 for INVALID_ARGUMENT).
struct CallError : std::runtime_error {
  CallError(const grpc::Status& s, std::string text) : std::runtime_error(std::move(text)), status(s) {}
  grpc::Status status;
};

const char* code_name(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return "OK";
    case grpc::StatusCode::CANCELLED: return "CANCELLED";
    case grpc::StatusCode::UNKNOWN: return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS: return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED: return "PERMISSION_DENIED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED: return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE: return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED: return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL: return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS: return "DATA_LOSS";
    case grpc::StatusCode::UNAUTHENTICATED: return "UNAUTHENTICATED";
    default: return "UNKNOWN";
  }
}

void check(const grpc::Status& status) {
  if (status.ok()) return;
  std::string message = status.error_message();
  if (auto nl = message.find('\n'); nl != std::string::npos) message.resize(nl);
  throw CallError(status, std::string(code_name(status.error_code())) + ": " + message);
}

std::string state_name(JobState state) {
  switch (state) {
    case gel::v1::JOB_STATE_QUEUED: return "queued";
    case gel::v1::JOB_STATE_RUNNING: return "running";
    case gel::v1::JOB_STATE_SUCCEEDED: return "succeeded";
    case gel::v1::JOB_STATE_FAILED: return "failed";
    case gel::v1::JOB_STATE_CANCELLED: return "cancelled";
    default: return "unspecified";
  }
}

JobState parse_state(const std::string& text) {
  std::string s;
  for (char c : text) s += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (s.rfind("job_state_", 0) == 0) s = s.substr(10);
  for (auto st : {gel::v1::JOB_STATE_QUEUED, gel::v1::JOB_STATE_RUNNING, gel::v1::JOB_STATE_SUCCEEDED,
                  gel::v1::JOB_STATE_FAILED, gel::v1::JOB_STATE_CANCELLED}) {
    if (state_name(st) == s) return st;
  }
  throw UsageError("--state: unknown state '" + text + "' (queued, running, succeeded, failed, cancelled)");
}

bool is_terminal(JobState s) {
  return s == gel::v1::JOB_STATE_SUCCEEDED || s == gel::v1::JOB_STATE_FAILED || s == gel::v1::JOB_STATE_CANCELLED;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UsageError("cannot read " + path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

std::pair<std::string, std::string> split_label(const std::string& text, const std::string& option) {
  auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0) throw UsageError(option + ": '" + text + "' is not key=value");
  return {text.substr(0, eq), text.substr(eq + 1)};
}

// "1,2,5-8" -> 1 2 5 6 7 8
std::vector<std::uint64_t> parse_seeds(const std::string& text) {
  std::vector<std::uint64_t> out;
  std::stringstream in(text);
  std::string part;
  auto number = [&](const std::string& s) -> std::uint64_t {
    if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos) {
      throw UsageError("--seeds: '" + s + "' is not a non-negative integer");
    }
    return std::stoull(s);
  };
  while (std::getline(in, part, ',')) {
    if (part.empty()) continue;
    auto dash = part.find('-');
    if (dash == std::string::npos) {
      out.push_back(number(part));
    } else {
      const auto a = number(part.substr(0, dash)), b = number(part.substr(dash + 1));
      if (b < a || b - a > 100000) throw UsageError("--seeds: bad range '" + part + "'");
      for (auto s = a; s <= b; ++s) out.push_back(s);
    }
  }
  if (out.empty()) throw UsageError("--seeds: no seed in '" + text + "'");
  return out;
}

// "compression.steps=4" into a JSON object (numbers, true/false and null bare; else strings).
void set_path(json& root, const std::string& assignment) {
  auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) throw UsageError("--set: '" + assignment + "' is not field=value");
  const std::string path = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  json value = json::parse(text, nullptr, false);
  if (value.is_discarded() || value.is_object() || value.is_array()) value = text;
  json* node = &root;
  std::stringstream in(path);
  std::string key;
  std::vector<std::string> keys;
  while (std::getline(in, key, '.')) keys.push_back(key);
  for (std::size_t i = 0; i + 1 < keys.size(); ++i) {
    if (!(*node)[keys[i]].is_object()) (*node)[keys[i]] = json::object();
    node = &(*node)[keys[i]];
  }
  (*node)[keys.back()] = value;
}

std::string fmt_seconds(double s) {
  if (!(s >= 0) || !std::isfinite(s)) return "?";
  char buf[32];
  if (s < 60) {
    std::snprintf(buf, sizeof buf, "%.0fs", s);
  } else if (s < 3600) {
    std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%dh%02dm", static_cast<int>(s) / 3600, (static_cast<int>(s) % 3600) / 60);
  }
  return buf;
}

std::string fmt(double v, int precision = 4) {
  std::ostringstream out;
  out << std::setprecision(precision) << v;
  return out.str();
}

std::string ms_time(std::int64_t ms) {
  if (ms <= 0) return "-";
  std::time_t t = ms / 1000;
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

json job_json(const gel::v1::Job& job) {
  json j;
  j["id"] = job.id();
  j["name"] = job.name();
  j["state"] = state_name(job.state());
  j["labels"] = json::object();
  for (const auto& [k, v] : job.labels()) j["labels"][k] = v;
  j["seeds"] = std::vector<std::uint64_t>(job.seeds().begin(), job.seeds().end());
  j["particles"] = job.particles();
  j["bond_preset"] = job.bond_preset();
  j["created"] = ms_time(job.created_unix_ms());
  j["started"] = ms_time(job.started_unix_ms());
  j["finished"] = ms_time(job.finished_unix_ms());
  j["error"] = job.error();
  j["member"] = job.member();
  j["rows"] = job.rows();
  j["out_dir"] = job.out_dir();
  if (job.has_progress()) {
    const auto& p = job.progress();
    j["progress"] = {{"k", p.k()},
                     {"k_total", p.k_total()},
                     {"phi", p.phi()},
                     {"target_phi", p.target_phi()},
                     {"P", p.p()},
                     {"elapsed_seconds", p.elapsed_seconds()},
                     {"remaining_seconds", p.remaining_seconds()},
                     {"phase", p.phase()}};
    if (p.relax_iterations() > 0) {
      j["progress"]["residual_force"] = p.residual_force();
      j["progress"]["residual_target"] = p.residual_target();
      j["progress"]["relax_iterations"] = p.relax_iterations();
    }
  }
  std::string scene;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  if (google::protobuf::util::MessageToJsonString(job.scene(), &scene, options).ok()) j["scene"] = json::parse(scene);
  return j;
}

class Client {
 public:
  Client(const std::string& server, std::string token, double timeout)
      : token_(std::move(token)), timeout_(timeout) {
    grpc::ChannelArguments args;
    args.SetMaxReceiveMessageSize(256 * 1024 * 1024);
    channel_ = grpc::CreateCustomChannel(server, grpc::InsecureChannelCredentials(), args);
    stub_ = gel::v1::GelService::NewStub(channel_);
  }

  std::unique_ptr<grpc::ClientContext> context(bool deadline = true) const {
    auto ctx = std::make_unique<grpc::ClientContext>();
    if (!token_.empty()) ctx->AddMetadata("authorization", "Bearer " + token_);
    if (deadline && timeout_ > 0) {
      ctx->set_deadline(std::chrono::system_clock::now() +
                        std::chrono::milliseconds(static_cast<std::int64_t>(timeout_ * 1000)));
    }
    return ctx;
  }
  gel::v1::GelService::Stub& stub() { return *stub_; }

 private:
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<gel::v1::GelService::Stub> stub_;
  std::string token_;
  double timeout_;
};

// ---- watch ---------------------------------------------------------------------------------

class WatchPrinter {
 public:
  explicit WatchPrinter(bool json_lines) : json_(json_lines), tty_(!json_lines && isatty(STDOUT_FILENO)) {}

  void update(const gel::v1::JobUpdate& u) {
    using K = gel::v1::JobUpdate;
    if (json_) {
      std::string line;
      google::protobuf::util::JsonPrintOptions options;
      options.preserve_proto_field_names = true;
      (void)google::protobuf::util::MessageToJsonString(u, &line, options);
      std::cout << line << std::endl;
      if (u.kind() == K::SNAPSHOT || u.kind() == K::STATE) state_ = u.job().state();
      return;
    }
    switch (u.kind()) {
      case K::SNAPSHOT:
      case K::STATE: {
        const auto& job = u.job();
        state_ = job.state();
        members_ = job.seeds_size();
        clear_bar();
        std::cout << job.id() << ": " << state_name(job.state());
        if (u.kind() == K::SNAPSHOT) {
          std::cout << " (" << job.particles() << " particles, " << job.seeds_size() << " seed"
                    << (job.seeds_size() == 1 ? "" : "s") << ", " << job.rows() << " rows so far)";
        }
        if (!job.error().empty()) std::cout << ": " << job.error();
        std::cout << std::endl;
        break;
      }
      case K::ROW: {
        const auto& r = u.row();
        clear_bar();
        std::cout << "  " << member_tag(u) << "k " << std::setw(2) << r.k() << "  phi " << fmt(r.phi(), 5) << "  P "
                  << fmt(r.p(), 5) << "  P_top " << fmt(r.p_top(), 4) << "  P_bot " << fmt(r.p_bot(), 4) << "  z "
                  << fmt(r.contact_number(), 4) << (r.equilibrated() ? "" : "  (max wait)") << std::endl;
        break;
      }
      case K::PROGRESS: {
        const auto& p = u.progress();
        const auto now = std::chrono::steady_clock::now();
        if (!tty_ && now - last_line_ < std::chrono::seconds(2)) break;
        last_line_ = now;
        std::ostringstream line;
        line << member_tag(u) << (p.phase().empty() ? "" : p.phase() + " ") << "phi " << fmt(p.phi(), 4) << " -> "
             << fmt(p.target_phi(), 4) << "  step " << p.k() << "/" << p.k_total() << "  P " << fmt(p.p(), 4)
             << "  elapsed " << fmt_seconds(p.elapsed_seconds()) << "  ETA " << fmt_seconds(p.remaining_seconds());
        // Quasi-static runs: show the relaxation converging.
        if (p.relax_iterations() > 0)
          line << "  residual " << fmt(p.residual_force(), 3) << " (target " << fmt(p.residual_target(), 3) << ", "
               << p.relax_iterations() << " it)";
        if (tty_) {
          const int width = 24;
          const double frac = p.k_total() > 0 ? std::clamp((p.k() - 1.0) / p.k_total(), 0.0, 1.0) : 0.0;
          const int fill = static_cast<int>(frac * width);
          std::cout << "\r\033[K[" << std::string(fill, '#') << std::string(width - fill, '.') << "] " << line.str()
                    << std::flush;
          bar_ = true;
        } else {
          std::cout << "  " << line.str() << std::endl;
        }
        break;
      }
      case K::LOG:
        clear_bar();
        std::cout << "  log: " << u.message() << std::endl;
        break;
      default:
        break;
    }
  }
  void finish() { clear_bar(); }
  JobState state() const { return state_; }

 private:
  std::string member_tag(const gel::v1::JobUpdate& u) const {
    return members_ > 1 ? "[seed " + std::to_string(u.seed()) + "] " : "";
  }
  void clear_bar() {
    if (bar_) std::cout << "\r\033[K" << std::flush;
    bar_ = false;
  }
  bool json_;
  bool tty_;
  bool bar_ = false;
  int members_ = 1;
  JobState state_ = gel::v1::JOB_STATE_UNSPECIFIED;
  std::chrono::steady_clock::time_point last_line_{};
};

int watch(Client& client, const std::string& id, bool json_lines) {
  gel::v1::WatchJobRequest request;
  request.set_job_id(id);
  auto ctx = client.context(false);
  auto reader = client.stub().WatchJob(ctx.get(), request);
  WatchPrinter printer(json_lines);
  gel::v1::JobUpdate update;
  while (reader->Read(&update)) printer.update(update);
  printer.finish();
  check(reader->Finish());
  if (printer.state() == gel::v1::JOB_STATE_SUCCEEDED) return 0;
  if (is_terminal(printer.state())) return 3;
  return 0;
}

// ---- curve ---------------------------------------------------------------------------------

void print_curve_table(const gel::v1::GetCurveResponse& c, std::ostream& out) {
  if (c.ensemble_size() > 0) {
    out << "# job " << c.job_id() << " (" << state_name(c.state()) << "), ensemble of " << c.members_size()
        << " seeds: mean +- std per phi_k\n";
    out << std::setw(3) << "k" << std::setw(4) << "n" << std::setw(22) << "phi" << std::setw(26) << "P"
        << std::setw(26) << "contact_number" << "\n";
    for (const auto& r : c.ensemble()) {
      auto stat = [](const gel::v1::Stat& s, int p) { return fmt(s.mean(), p) + " +- " + fmt(s.std(), 2); };
      out << std::setw(3) << r.k() << std::setw(4) << r.n() << std::setw(22) << stat(r.phi(), 5) << std::setw(26)
          << stat(r.p(), 5) << std::setw(26) << stat(r.contact_number(), 4) << "\n";
    }
    return;
  }
  for (const auto& m : c.members()) {
    out << "# job " << c.job_id() << " (" << state_name(c.state()) << "), seed " << m.seed() << ", "
        << m.curve().particles() << " particles, " << m.curve().rows_size() << " rows\n";
    out << std::setw(3) << "k" << std::setw(11) << "phi" << std::setw(11) << "target" << std::setw(13) << "P"
        << std::setw(13) << "P_top" << std::setw(13) << "P_bot" << std::setw(8) << "z" << std::setw(12) << "E_stored"
        << std::setw(12) << "E_diss" << std::setw(8) << "breaks" << std::setw(4) << "eq" << "\n";
    for (const auto& r : m.curve().rows()) {
      out << std::setw(3) << r.k() << std::setw(11) << fmt(r.phi(), 5) << std::setw(11) << fmt(r.target_phi(), 5)
          << std::setw(13) << fmt(r.p(), 5) << std::setw(13) << fmt(r.p_top(), 5) << std::setw(13)
          << fmt(r.p_bot(), 5) << std::setw(8) << fmt(r.contact_number(), 4) << std::setw(12)
          << fmt(r.stored_energy(), 4) << std::setw(12) << fmt(r.dissipated_energy(), 4) << std::setw(8)
          << r.ruptures().normal() << std::setw(4) << (r.equilibrated() ? "y" : "n") << "\n";
    }
  }
}

void print_curve_csv(const gel::v1::GetCurveResponse& c, std::ostream& out) {
  out << std::setprecision(17);
  if (c.ensemble_size() > 0) {
    out << "k,n,phi,phi_std,P,P_std,P_top,P_top_std,P_bot,P_bot_std,contact_number,contact_number_std,"
           "stored_energy,stored_energy_std,dissipated_energy,dissipated_energy_std\n";
    for (const auto& r : c.ensemble()) {
      out << r.k() << "," << r.n();
      for (const auto* s : {&r.phi(), &r.p(), &r.p_top(), &r.p_bot(), &r.contact_number(), &r.stored_energy(),
                            &r.dissipated_energy()}) {
        out << "," << s->mean() << "," << s->std();
      }
      out << "\n";
    }
    return;
  }
  out << "seed,k,phi,target_phi,P,P_top,P_bot,contact_number,stored_energy,dissipated_energy,breaks_normal,"
         "sliding_resets,rolling_resets,bonds_created,equilibrated,steps,sim_time,wall_seconds\n";
  for (const auto& m : c.members()) {
    for (const auto& r : m.curve().rows()) {
      out << m.seed() << "," << r.k() << "," << r.phi() << "," << r.target_phi() << "," << r.p() << "," << r.p_top()
          << "," << r.p_bot() << "," << r.contact_number() << "," << r.stored_energy() << ","
          << r.dissipated_energy() << "," << r.ruptures().normal() << "," << r.ruptures().sliding() << ","
          << r.ruptures().rolling() << "," << r.ruptures().created() << "," << (r.equilibrated() ? 1 : 0) << ","
          << r.steps() << "," << r.sim_time() << "," << r.wall_seconds() << "\n";
    }
  }
}

void write_out(const std::string& path, const std::string& text) {
  if (path.empty() || path == "-") {
    std::cout << text;
    return;
  }
  std::ofstream out(path, std::ios::binary);
  if (!out) throw UsageError("--out: cannot write " + path);
  out << text;
}

// gelsim next to gelctl (installed side by side, or the build tree's core/), $GELSIM, or PATH.
std::string find_gelsim() {
  if (const char* env = std::getenv("GELSIM"); env && *env) return env;
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    for (const auto& candidate : {exe.parent_path() / "gelsim", exe.parent_path() / ".." / "core" / "gelsim"}) {
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
    for (const auto& m : whole["members"]) curves.push_back(m);
  } else {
    curves.push_back(whole);
  }
  std::string pattern = (std::filesystem::temp_directory_path() / "gelctl-plot.XXXXXX").string();
  if (!mkdtemp(pattern.data())) throw std::runtime_error("--png: cannot create a temporary directory");
  const std::filesystem::path tmp = pattern;
  std::vector<std::string> args{find_gelsim(), "plot"};
  for (std::size_t i = 0; i < curves.size(); ++i) {
    const auto dir = tmp / ("m" + std::to_string(i));
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "curve.json") << curves[i].dump();
    args.push_back(dir.string());
  }
  for (const char* extra : {"--no-snapshots", "--out"}) args.emplace_back(extra);
  args.push_back((tmp / "plots").string());
  std::cout.flush();
  std::fflush(nullptr);  // the child must not write our buffered output again
  const pid_t pid = fork();
  if (pid == 0) {
    if (!freopen("/dev/null", "w", stdout)) _exit(127);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execvp(argv[0], argv.data());
    _exit(127);
  }
  int status = -1;
  if (pid > 0) waitpid(pid, &status, 0);
  const auto picture = tmp / "plots" / "pressure.png";
  const bool ok = pid > 0 && WIFEXITED(status) && WEXITSTATUS(status) == 0 && std::filesystem::exists(picture);
  if (ok) std::filesystem::copy_file(picture, path, std::filesystem::copy_options::overwrite_existing);
  std::error_code ec;
  std::filesystem::remove_all(tmp, ec);
  if (!ok) throw std::runtime_error("--png: `" + args[0] + " plot` failed (set GELSIM to gelsim's path)");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"gelctl: submit compressions to geld, follow them and fetch their curves"};
  app.require_subcommand(1);
  std::string server = std::getenv("GELD_SERVER") ? std::getenv("GELD_SERVER") : "127.0.0.1:50051";
  std::string token_file = std::getenv("GELD_TOKEN_FILE") ? std::getenv("GELD_TOKEN_FILE") : "";
  double timeout = 30;
  app.add_option("--server,-s", server, "geld address host:port (env GELD_SERVER)")->capture_default_str();
  app.add_option("--token-file", token_file, "File with the bearer token (env GELD_TOKEN_FILE; or GELD_TOKEN)");
  app.add_option("--timeout", timeout, "Seconds per call (not for watch)")->capture_default_str();

  // submit
  auto* submit = app.add_subcommand("submit", "Submit a compression job; prints its id on the first line");
  std::string preset, scene_file, seeds_text, name, fidelity;
  std::vector<std::uint64_t> seed_list;
  std::vector<std::string> labels, sets;
  bool submit_watch = false, submit_json = false;
  auto* preset_opt = submit->add_option("--preset", preset, "Scene preset: quick, paper-bond1, paper-bond2");
  auto* scene_opt = submit->add_option("--scene", scene_file, "Scene JSON file (gel.v1.Scene)");
  preset_opt->excludes(scene_opt);
  submit->add_option("--seed", seed_list, "Seed (repeatable)");
  submit->add_option("--seeds", seeds_text, "Ensemble seeds: 1,2,3 or 1-10");
  submit->add_option("--name", name, "Job name");
  submit->add_option("--label", labels, "key=value (repeatable)");
  submit->add_option("--fidelity", fidelity, "compression.fidelity: fast, default, paper, quasistatic");
  submit->add_option("--set", sets, "Override a scene field: dotted.name=value (repeatable)");
  submit->add_flag("--watch,-w", submit_watch, "Follow the job until it ends");
  submit->add_flag("--json", submit_json, "Print the job as JSON (and JSON lines while watching)");

  // list
  auto* list = app.add_subcommand("list", "List jobs, newest first");
  std::string list_state, list_label, list_name, page_token;
  int page_size = 50;
  bool list_all = false, list_json = false;
  list->add_option("--state", list_state, "queued, running, succeeded, failed, cancelled");
  list->add_option("--label", list_label, "key=value or key");
  list->add_option("--name", list_name, "Exact name");
  list->add_option("--page-size", page_size, "Jobs per page")->capture_default_str();
  list->add_option("--page-token", page_token, "Page token from a previous list");
  list->add_flag("--all", list_all, "Fetch every page");
  list->add_flag("--json", list_json, "JSON output");

  std::string job_id;
  bool json_out = false;
  auto* status = app.add_subcommand("status", "A job's state and progress");
  status->alias("get");
  status->add_option("job", job_id, "Job id")->required();
  status->add_flag("--json", json_out, "JSON output");

  auto* watch_cmd = app.add_subcommand("watch", "Follow a job: progress bar in a terminal, lines otherwise");
  watch_cmd->add_option("job", job_id, "Job id")->required();
  watch_cmd->add_flag("--json", json_out, "JSON lines (one JobUpdate per line)");

  auto* cancel = app.add_subcommand("cancel", "Cancel a queued or running job");
  cancel->add_option("job", job_id, "Job id")->required();

  auto* curve = app.add_subcommand("curve", "A job's P_y(phi) curve (ensembles: mean and std per phi_k)");
  bool csv = false;
  std::string out_file, png_file;
  curve->add_option("job", job_id, "Job id")->required();
  auto* csv_flag = curve->add_flag("--csv", csv, "CSV");
  auto* json_flag = curve->add_flag("--json", json_out, "One JSON object with a rows list");
  csv_flag->excludes(json_flag);
  curve->add_option("--out,-o", out_file, "Write to this file instead of stdout");
  curve->add_option("--png", png_file, "Also plot to this PNG (needs gelsim plot)");

  auto* logs = app.add_subcommand("logs", "A job's log lines");
  logs->add_option("job", job_id, "Job id")->required();

  auto* query = app.add_subcommand("query", "Curves of many jobs: by bond preset, labels and parameters");
  std::string bond_preset, query_state;
  std::vector<std::string> query_labels, wheres;
  int limit = 100;
  query->add_option("--bond-preset", bond_preset, "bond1, bond2");
  query->add_option("--label", query_labels, "key=value (repeatable; all must match)");
  query->add_option("--where", wheres, "field=value, field>=x or field<=x on the resolved scene (repeatable)");
  query->add_option("--state", query_state, "Default: succeeded");
  query->add_option("--limit", limit, "Jobs at most")->capture_default_str();
  query->add_flag("--json", json_out, "One JSON object per line (the jobs' curves)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::cerr << "gelctl: " << e.what() << "\n";
    return 2;
  }

  try {
    std::string token;
    if (!token_file.empty()) {
      std::istringstream in(read_file(token_file));
      std::getline(in, token);
      while (!token.empty() && std::isspace(static_cast<unsigned char>(token.back()))) token.pop_back();
    } else if (const char* t = std::getenv("GELD_TOKEN")) {
      token = t;
    }
    Client client(server, token, timeout);

    if (submit->parsed()) {
      if (preset.empty() && scene_file.empty()) throw UsageError("submit: give --preset NAME or --scene FILE.json");
      gel::v1::SubmitJobRequest request;
      json scene = json::object();
      if (!scene_file.empty()) {
        scene = json::parse(read_file(scene_file), nullptr, false);
        if (scene.is_discarded() || !scene.is_object()) {
          // Not ours to judge further: the server names the problem.
          request.set_scene_json(read_file(scene_file));
        }
      } else {
        scene["preset"] = preset;
      }
      if (!request.scene_json().empty() && (!fidelity.empty() || !sets.empty())) {
        throw UsageError("--scene: " + scene_file + " is not a JSON object, cannot apply overrides");
      }
      if (request.scene_json().empty()) {
        if (!fidelity.empty()) set_path(scene, "compression.fidelity=" + fidelity);
        for (const auto& s : sets) set_path(scene, s);
        request.set_scene_json(scene.dump());
      }
      for (auto s : seed_list) request.add_seeds(s);
      if (!seeds_text.empty()) {
        for (auto s : parse_seeds(seeds_text)) request.add_seeds(s);
      }
      request.set_name(name);
      for (const auto& l : labels) {
        auto [k, v] = split_label(l, "--label");
        (*request.mutable_labels())[k] = v;
      }
      gel::v1::SubmitJobResponse response;
      auto ctx = client.context();
      check(client.stub().SubmitJob(ctx.get(), request, &response));
      std::cout << response.job_id() << std::endl;
      if (submit_json && !submit_watch) std::cout << job_json(response.job()).dump(2) << std::endl;
      if (submit_watch) return watch(client, response.job_id(), submit_json);
      return 0;
    }

    if (list->parsed()) {
      gel::v1::ListJobsRequest request;
      if (!list_state.empty()) request.set_state(parse_state(list_state));
      request.set_label(list_label);
      request.set_name(list_name);
      request.set_page_size(page_size);
      request.set_page_token(page_token);
      json all = json::array();
      bool header = false;
      for (;;) {
        gel::v1::ListJobsResponse response;
        auto ctx = client.context();
        check(client.stub().ListJobs(ctx.get(), request, &response));
        for (const auto& job : response.jobs()) {
          if (list_json) {
            all.push_back(job_json(job));
            continue;
          }
          if (!header) {
            std::cout << std::left << std::setw(14) << "ID" << std::setw(11) << "STATE" << std::setw(18) << "NAME"
                      << std::setw(7) << "SEEDS" << std::setw(10) << "PARTICLES" << std::setw(6) << "ROWS"
                      << "CREATED" << std::right << "\n";
            header = true;
          }
          std::cout << std::left << std::setw(14) << job.id() << std::setw(11) << state_name(job.state())
                    << std::setw(18) << (job.name().empty() ? "-" : job.name()) << std::setw(7) << job.seeds_size()
                    << std::setw(10) << job.particles() << std::setw(6) << job.rows()
                    << ms_time(job.created_unix_ms()) << std::right << "\n";
        }
        if (response.next_page_token().empty()) break;
        if (!list_all) {
          if (!list_json) std::cout << "next page: --page-token " << response.next_page_token() << "\n";
          break;
        }
        request.set_page_token(response.next_page_token());
      }
      if (list_json) std::cout << all.dump(2) << std::endl;
      return 0;
    }

    if (status->parsed()) {
      gel::v1::GetJobRequest request;
      request.set_job_id(job_id);
      gel::v1::Job job;
      auto ctx = client.context();
      check(client.stub().GetJob(ctx.get(), request, &job));
      if (json_out) {
        std::cout << job_json(job).dump(2) << std::endl;
        return 0;
      }
      std::cout << "job " << job.id() << (job.name().empty() ? "" : " (" + job.name() + ")") << ": "
                << state_name(job.state()) << "\n";
      if (!job.error().empty()) std::cout << "  error: " << job.error() << "\n";
      std::cout << "  particles " << job.particles() << ", seeds " << job.seeds_size() << " (member " << job.member()
                << "), rows " << job.rows() << ", bond " << (job.bond_preset().empty() ? "-" : job.bond_preset())
                << "\n";
      std::cout << "  created " << ms_time(job.created_unix_ms()) << ", started " << ms_time(job.started_unix_ms())
                << ", finished " << ms_time(job.finished_unix_ms()) << "\n";
      if (job.state() == gel::v1::JOB_STATE_RUNNING && job.has_progress()) {
        const auto& p = job.progress();
        std::cout << "  progress: step " << p.k() << "/" << p.k_total() << ", phi " << fmt(p.phi()) << " -> "
                  << fmt(p.target_phi()) << ", P " << fmt(p.p()) << ", ETA " << fmt_seconds(p.remaining_seconds())
                  << "\n";
      }
      for (const auto& [k, v] : job.labels()) std::cout << "  label " << k << "=" << v << "\n";
      return 0;
    }

    if (watch_cmd->parsed()) return watch(client, job_id, json_out);

    if (cancel->parsed()) {
      gel::v1::CancelJobRequest request;
      request.set_job_id(job_id);
      gel::v1::Job job;
      auto ctx = client.context();
      check(client.stub().CancelJob(ctx.get(), request, &job));
      std::cout << job.id() << ": " << state_name(job.state()) << (job.state() == gel::v1::JOB_STATE_RUNNING ? " (stopping)" : "")
                << std::endl;
      return 0;
    }

    if (curve->parsed()) {
      gel::v1::GetCurveRequest request;
      request.set_job_id(job_id);
      gel::v1::GetCurveResponse response;
      auto ctx = client.context();
      check(client.stub().GetCurve(ctx.get(), request, &response));
      std::ostringstream out;
      if (json_out) {
        out << response.json() << "\n";
      } else if (csv) {
        print_curve_csv(response, out);
      } else {
        print_curve_table(response, out);
      }
      write_out(out_file, out.str());
      if (!png_file.empty()) plot_png(response, png_file);
      return 0;
    }

    if (logs->parsed()) {
      gel::v1::GetLogsRequest request;
      request.set_job_id(job_id);
      for (;;) {
        gel::v1::GetLogsResponse response;
        auto ctx = client.context();
        check(client.stub().GetLogs(ctx.get(), request, &response));
        for (const auto& line : response.lines()) {
          std::cout << ms_time(line.unix_ms()) << " " << std::left << std::setw(5) << line.level() << std::right << " "
                    << line.message() << "\n";
          request.set_after_id(line.id());
        }
        if (response.lines_size() < 1000) break;
      }
      return 0;
    }

    if (query->parsed()) {
      gel::v1::QueryCurvesRequest request;
      request.set_bond_preset(bond_preset);
      for (const auto& l : query_labels) {
        auto [k, v] = split_label(l, "--label");
        (*request.mutable_labels())[k] = v;
      }
      for (const auto& w : wheres) {
        auto* p = request.add_parameters();
        std::size_t pos;
        if ((pos = w.find(">=")) != std::string::npos) {
          p->set_field(w.substr(0, pos));
          p->set_min(std::stod(w.substr(pos + 2)));
        } else if ((pos = w.find("<=")) != std::string::npos) {
          p->set_field(w.substr(0, pos));
          p->set_max(std::stod(w.substr(pos + 2)));
        } else if ((pos = w.find('=')) != std::string::npos) {
          p->set_field(w.substr(0, pos));
          p->set_equals(w.substr(pos + 1));
        } else {
          throw UsageError("--where: '" + w + "' is not field=value, field>=x or field<=x");
        }
      }
      if (!query_state.empty()) request.set_state(parse_state(query_state));
      request.set_limit(limit);
      gel::v1::QueryCurvesResponse response;
      auto ctx = client.context();
      check(client.stub().QueryCurves(ctx.get(), request, &response));
      if (json_out) {
        for (const auto& e : response.curves()) std::cout << e.curve().json() << "\n";
        return 0;
      }
      std::cout << std::left << std::setw(14) << "ID" << std::setw(18) << "NAME" << std::setw(8) << "BOND"
                << std::setw(7) << "SEEDS" << std::setw(6) << "ROWS" << std::setw(12) << "PHI_LAST" << "P_LAST"
                << std::right << "\n";
      for (const auto& e : response.curves()) {
        const auto& job = e.job();
        double phi = NAN, p = NAN;
        if (e.curve().ensemble_size() > 0) {
          phi = e.curve().ensemble().rbegin()->phi().mean();
          p = e.curve().ensemble().rbegin()->p().mean();
        } else if (e.curve().members_size() > 0 && e.curve().members(0).curve().rows_size() > 0) {
          const auto& rows = e.curve().members(0).curve().rows();
          phi = rows.rbegin()->phi();
          p = rows.rbegin()->p();
        }
        std::cout << std::left << std::setw(14) << job.id() << std::setw(18) << (job.name().empty() ? "-" : job.name())
                  << std::setw(8) << (job.bond_preset().empty() ? "-" : job.bond_preset()) << std::setw(7)
                  << job.seeds_size() << std::setw(6) << job.rows() << std::setw(12) << fmt(phi, 5) << fmt(p, 5)
                  << std::right << "\n";
      }
      return 0;
    }
  } catch (const UsageError& e) {
    std::cerr << "gelctl: " << e.what() << "\n";
    return 2;
  } catch (const CallError& e) {
    std::cerr << "gelctl: " << e.what() << "\n";
    return e.status.error_code() == grpc::StatusCode::INVALID_ARGUMENT ? 2 : 1;
  } catch (const std::exception& e) {
    std::cerr << "gelctl: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
