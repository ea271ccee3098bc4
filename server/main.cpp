// geld: the job daemon. Foreground; logs to stderr (and --log-file). SIGTERM/SIGINT: stop taking
// work, checkpoint running jobs, exit 0. Exit 2 on bad flags or configuration.
#include <pthread.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include <CLI/CLI.hpp>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <nlohmann/json.hpp>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "command_line.hpp"
#include "executor.hpp"
#include "gel_version.hpp"
#include "service.hpp"

namespace fs = std::filesystem;

namespace {

// --config FILE: `key = value` lines (TOML-like: strings in double quotes, '#' comments) or one
// JSON object; keys are the long flag names ("data-dir"; "data_dir" works too). Flags given on
// the command line win.
class ConfigFile : public CLI::ConfigTOML {
 public:
  std::vector<CLI::ConfigItem> from_config(std::istream& input) const override {
    std::stringstream buffer;
    buffer << input.rdbuf();
    const std::string text = buffer.str();
    const auto first = text.find_first_not_of(" \t\r\n");
    std::vector<CLI::ConfigItem> items;
    if (first != std::string::npos && text[first] == '{') {
      nlohmann::json json;
      try {
        json = nlohmann::json::parse(text);
      } catch (const std::exception& e) {
        throw CLI::ConfigError(std::string("config: not valid JSON: ") + e.what());
      }
      if (!json.is_object()) throw CLI::ConfigError("config: the JSON must be one object");
      for (const auto& [key, value] : json.items()) {
        CLI::ConfigItem item;
        item.name = key;
        if (value.is_array()) {
          for (const auto& v : value) item.inputs.push_back(v.is_string() ? v.get<std::string>() : v.dump());
        } else {
          item.inputs.push_back(value.is_string() ? value.get<std::string>() : value.dump());
        }
        items.push_back(std::move(item));
      }
    } else {
      std::istringstream again(text);
      items = CLI::ConfigTOML::from_config(again);
    }
    for (auto& item : items) std::replace(item.name.begin(), item.name.end(), '_', '-');
    return items;
  }
};

std::string default_data_dir() {
  if (const char* xdg = std::getenv("XDG_DATA_HOME"); xdg && *xdg) return (fs::path(xdg) / "geld").string();
  if (const char* home = std::getenv("HOME"); home && *home) {
    return (fs::path(home) / ".local" / "share" / "geld").string();
  }
  return "geld-data";
}

std::string self_dir() {
  std::error_code ec;
  auto exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : exe.parent_path().string();
}

// gelsim next to geld, in the build tree's core/, or on PATH.
std::string default_gelsim() {
  const auto dir = self_dir();
  if (!dir.empty()) {
    for (const auto& candidate : {fs::path(dir) / "gelsim", fs::path(dir) / ".." / "core" / "gelsim"}) {
      if (fs::exists(candidate)) return fs::weakly_canonical(candidate).string();
    }
  }
  return "gelsim";
}

// A secret others can read is no secret: refused, as ssh refuses a readable private key.
void require_private_file(const std::string& option, const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0)
    throw std::invalid_argument(option + ": cannot read " + path + ": " + std::strerror(errno));
  if ((info.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(info.st_mode & 07777));
    throw std::invalid_argument(option + ": " + path + " is readable by others (mode " + mode + "); chmod 600 it");
  }
}

std::string read_token(const std::string& path) {
  require_private_file("token-file", path);
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("token-file: cannot read " + path);
  std::string token;
  std::getline(in, token);
  while (!token.empty() && (token.back() == '\r' || token.back() == ' ' || token.back() == '\t')) token.pop_back();
  if (token.empty()) throw std::invalid_argument("token-file: " + path + " holds no token on its first line");
  return token;
}

// A PEM file's contents; a private key others can read is refused like a readable token.
std::string read_pem(const std::string& option, const std::string& path, bool secret) {
  if (secret) require_private_file(option, path);
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(option + ": cannot read " + path + ": " + std::strerror(errno));
  std::stringstream contents;
  contents << in.rdbuf();
  if (!in || contents.str().find("-----BEGIN ") == std::string::npos)
    throw std::invalid_argument(option + ": " + path + " is not a PEM file");
  return contents.str();
}

// OpenSSL's reason for the last failure, for a message that says more than "bad file".
std::string openssl_reason() {
  const unsigned long code = ERR_peek_last_error();
  std::string reason = code ? ERR_reason_error_string(code) ? ERR_reason_error_string(code) : "unknown error"
                            : "no PEM data";
  ERR_clear_error();
  return reason;
}

using Bio = std::unique_ptr<BIO, decltype(&BIO_free)>;
using Certificate = std::unique_ptr<X509, decltype(&X509_free)>;

Bio memory_bio(const std::string& pem) { return Bio(BIO_new_mem_buf(pem.data(), static_cast<int>(pem.size())), &BIO_free); }

// Every certificate of a PEM file (at least one); the first is the leaf of a chain.
std::vector<Certificate> read_certificates(const std::string& option, const std::string& path, const std::string& pem) {
  auto bio = memory_bio(pem);
  std::vector<Certificate> certificates;
  while (X509* certificate = PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr))
    certificates.emplace_back(certificate, &X509_free);
  // The loop ends on "no start line" after the last certificate: a failure only if it was the first,
  // or if something that looked like a certificate did not parse.
  const unsigned long code = ERR_peek_last_error();
  if (certificates.empty() || (code && ERR_GET_REASON(code) != PEM_R_NO_START_LINE))
    throw std::invalid_argument(option + ": " + path + " is not a PEM certificate (" + openssl_reason() + ")");
  ERR_clear_error();
  return certificates;
}

// gRPC reported every TLS file problem as "cannot listen on HOST:PORT", which named neither the
// option nor the file: each is checked here first, as gRPC will read it.
void check_tls_files(const std::string& cert_path, const std::string& cert_pem, const std::string& key_path,
                     const std::string& key_pem, const std::string& ca_path, const std::string& ca_pem) {
  ERR_clear_error();
  const auto chain = read_certificates("tls-cert", cert_path, cert_pem);
  auto bio = memory_bio(key_pem);
  // No passphrase callback that prompts: geld runs unattended and gRPC takes no passphrase.
  auto no_passphrase = [](char*, int, int, void*) { return 0; };
  std::unique_ptr<EVP_PKEY, decltype(&EVP_PKEY_free)> key(PEM_read_bio_PrivateKey(bio.get(), nullptr, no_passphrase, nullptr),
                                                          &EVP_PKEY_free);
  if (!key) {
    const bool encrypted = key_pem.find("ENCRYPTED") != std::string::npos;
    const std::string reason = openssl_reason();
    throw std::invalid_argument("tls-key: " + key_path + (encrypted ? " is an encrypted private key; geld needs it unencrypted"
                                                                   : " is not a PEM private key (" + reason + ")"));
  }
  if (X509_check_private_key(chain.front().get(), key.get()) != 1) {
    ERR_clear_error();
    throw std::invalid_argument("tls-key: " + key_path + " does not match the certificate in " + cert_path +
                                " (--tls-cert)");
  }
  if (!ca_path.empty()) read_certificates("tls-client-ca", ca_path, ca_pem);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"geld: the gelsim job daemon (compressions of colloidal gels as jobs over gRPC)"};
  app.set_version_flag("--version", gel::program_version());
  app.config_formatter(std::make_shared<ConfigFile>());
  app.set_config("--config", "", "Configuration file: 'key = value' lines or a JSON object; keys are flag names");

  std::string listen = "127.0.0.1:50051";
  std::string token_file, data_dir, db_path, log_level = "info", log_file;
  std::string executor_name = "threads", gelsim;
  int workers = 0;
  double disk_full_retry = 10;
  geld::Limits limits;
  app.add_option("--listen", listen, "host:port to listen on; a non-loopback address needs --token-file")
      ->capture_default_str();
  app.add_option("--token-file", token_file, "File whose first line is the bearer token every call must carry");
  std::string tls_cert, tls_key, tls_client_ca;
  app.add_option("--tls-cert", tls_cert, "PEM certificate (chain) of this server: serve TLS instead of plain text");
  app.add_option("--tls-key", tls_key, "PEM private key of --tls-cert (must not be readable by others)");
  app.add_option("--tls-client-ca", tls_client_ca, "PEM CA certificate(s): require client certificates signed by them (mutual TLS)");
  app.add_option("--data-dir", data_dir, "Data directory (SQLite store and the jobs' files); default " +
                                             default_data_dir());
  app.add_option("--db", db_path, "SQLite file; default DATA_DIR/geld.sqlite");
  app.add_option("--workers", workers, "Jobs run at once (threads) or members followed (slurm); 0: cores")
      ->capture_default_str()
      ->check(gel::cli::non_negative(workers));
  app.add_option("--disk-full-retry", disk_full_retry,
                 "Seconds between retries of a member paused by a full disk (it resumes from its checkpoint)")
      ->capture_default_str()
      ->check(gel::cli::positive(disk_full_retry));
  app.add_option("--executor", executor_name, "Who runs the jobs: threads or slurm")->capture_default_str();
  app.add_option("--gelsim", gelsim, "gelsim binary for executors that run it as a process");
  app.add_option("--max-queue", limits.max_queue, "Queued jobs at most")
      ->capture_default_str()
      ->check(gel::cli::positive(limits.max_queue));
  app.add_option("--max-particles", limits.max_particles, "Particles per ensemble member at most")
      ->capture_default_str()
      ->check(gel::cli::positive(limits.max_particles));
  app.add_option("--max-seeds", limits.max_seeds, "Ensemble members per job at most")
      ->capture_default_str()
      ->check(gel::cli::positive(limits.max_seeds));
  app.add_option("--threads-per-member", limits.threads_per_member,
                 "Engine threads of each member whose scene does not set integration.threads (results are bit-identical for any number)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1024));
  app.add_option("--max-watchers", limits.max_watchers, "Concurrent WatchJob streams at most")
      ->capture_default_str()
      ->check(gel::cli::positive(limits.max_watchers));
  // Budgets on what a job's scene says it will need (docs/api.md "Budgets and bounds"); sizes
  // take a unit (4GiB, 500MB, bytes without one).
  app.add_option("--max-member-memory", limits.max_member_memory, "Estimated memory of one ensemble member at most")
      ->capture_default_str()
      ->transform(CLI::AsSizeValue(false))
      ->check(gel::cli::positive(limits.max_member_memory));
  app.add_option("--max-memory", limits.max_memory,
                 "Estimated memory of the members that may run at once, with geld, at most (threads executor); 0: half the machine's")
      ->capture_default_str()
      ->transform(CLI::AsSizeValue(false))
      ->check(gel::cli::non_negative(limits.max_memory));
  app.add_option("--max-job-disk", limits.max_job_disk, "Estimated files of all of a job's members at most")
      ->capture_default_str()
      ->transform(CLI::AsSizeValue(false))
      ->check(gel::cli::positive(limits.max_job_disk));
  app.add_option("--max-job-particle-steps", limits.max_job_particle_steps,
                 "Particles x steps of all of a job's members at most (1e8 a second on one core)")
      ->capture_default_str()
      ->check(gel::cli::positive(limits.max_job_particle_steps));
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, critical, off")->capture_default_str();
  app.add_option("--log-file", log_file, "Also append log lines to this file");
  // Executor settings: --slurm-KEY VALUE reaches the slurm executor as settings[KEY].
  std::map<std::string, std::string> slurm_settings;
  const std::pair<const char*, const char*> slurm_keys[] = {
      {"shared-dir", "Directory shared with the compute nodes (slurm executor)"},
      {"gelsim", "gelsim's path on the compute nodes (slurm executor)"},
      {"sbatch-args", "Extra sbatch arguments, split on spaces (slurm executor)"},
      {"max-requeues", "Resubmissions after TIMEOUT/NODE_FAIL (slurm executor)"},
      {"poll-interval", "Seconds between polls of squeue and progress files (slurm executor)"},
      {"bin-dir", "Directory of sbatch/squeue/scancel/scontrol (slurm executor)"},
  };
  std::map<std::string, CLI::Option*> slurm_options;
  for (const auto& [key, help] : slurm_keys) {
    slurm_options[key] = app.add_option(std::string("--slurm-") + key, slurm_settings[key], help);
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::cerr << "geld: " << e.what() << "\n";
    return 2;
  }

  // Logging.
  try {
    std::vector<spdlog::sink_ptr> sinks{std::make_shared<spdlog::sinks::stderr_color_sink_mt>()};
    if (!log_file.empty()) sinks.push_back(std::make_shared<spdlog::sinks::basic_file_sink_mt>(log_file, false));
    auto logger = std::make_shared<spdlog::logger>("geld", sinks.begin(), sinks.end());
    const auto level = spdlog::level::from_str(log_level);
    if (level == spdlog::level::off && log_level != "off") throw std::invalid_argument("log-level: unknown level " + log_level);
    logger->set_level(level);
    logger->flush_on(spdlog::level::info);
    spdlog::set_default_logger(logger);
  } catch (const std::exception& e) {
    std::cerr << "geld: " << e.what() << "\n";
    return 2;
  }

  geld::DaemonOptions options;
  options.listen = listen;
  options.manager.data_dir = data_dir.empty() ? default_data_dir() : data_dir;
  options.manager.db_path = db_path;
  options.manager.workers = workers;
  options.manager.disk_full_retry_seconds = disk_full_retry;
  options.manager.limits = limits;
  geld::ExecutorConfig executor_config;
  executor_config.name = executor_name;
  executor_config.gelsim_path = gelsim.empty() ? default_gelsim() : gelsim;
  // The store and the jobs' files are the user's data: not readable by other users of the
  // machine, however geld was started (the systemd unit sets the same with UMask=).
  ::umask(077);

  try {
    if (!token_file.empty()) options.token = read_token(token_file);
    if (tls_cert.empty() != tls_key.empty()) throw std::invalid_argument("tls: --tls-cert and --tls-key go together");
    if (!tls_client_ca.empty() && tls_cert.empty()) throw std::invalid_argument("tls-client-ca: needs --tls-cert and --tls-key");
    if (!tls_cert.empty()) {
      options.tls.certificate_chain = read_pem("tls-cert", tls_cert, false);
      options.tls.private_key = read_pem("tls-key", tls_key, true);
      if (!tls_client_ca.empty()) options.tls.client_ca = read_pem("tls-client-ca", tls_client_ca, false);
      check_tls_files(tls_cert, options.tls.certificate_chain, tls_key, options.tls.private_key, tls_client_ca,
                      options.tls.client_ca);
    }
    fs::create_directories(options.manager.data_dir);
    executor_config.data_dir = fs::absolute(options.manager.data_dir).string();
    for (const auto& [key, option] : slurm_options) {
      if (option->count() > 0) executor_config.settings[key] = slurm_settings[key];
    }
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 2;
  }

  // Signals go to a waiting thread (this one), never into the middle of the workers.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  signal(SIGPIPE, SIG_IGN);

  std::unique_ptr<geld::Daemon> daemon;
  try {
    std::shared_ptr<geld::Executor> executor = geld::make_executor(executor_config);
    daemon = std::make_unique<geld::Daemon>(options, geld::make_gelcore_adapter(), executor);
    spdlog::info("geld {}: data dir {}, executor {}", gel::program_version(), options.manager.data_dir, executor->name());
    daemon->start();
  } catch (const std::invalid_argument& e) {
    spdlog::critical("{}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::critical("cannot start: {}", e.what());
    return 1;
  }
  std::cout << "geld listening on " << daemon->address() << std::endl;

  int received = 0;
  sigwait(&signals, &received);
  spdlog::info("{}: stopping (running jobs checkpoint and resume on the next start)",
               received == SIGTERM ? "SIGTERM" : "SIGINT");
  daemon->shutdown();
  daemon.reset();
  spdlog::shutdown();
  return 0;
}
