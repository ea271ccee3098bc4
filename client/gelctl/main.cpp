// gelctl: the command-line client of geld. Thin: gRPC stubs and the proto messages, no engine.
// Exit codes: 0 success; 2 bad input (ours or the server's INVALID_ARGUMENT); 1 any other error
// (the gRPC status code name and the server's one-line message on stderr); 3 a watched job
// that ended failed or cancelled.
#include <algorithm>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <map>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "command_line.hpp"
#include "common.hpp"
#include "gel_version.hpp"

namespace gelctl {
std::vector<Command>& registry() {
  static std::vector<Command> commands;
  return commands;
}
}  // namespace gelctl

int main(int argc, char** argv) {
  using namespace gelctl;
  CLI::App app{"gelctl: submit compressions to geld, follow them and fetch their curves"};
  app.set_version_flag("--version", gel::program_version());
  app.require_subcommand(1);
  std::string server = std::getenv("GELD_SERVER") ? std::getenv("GELD_SERVER") : "127.0.0.1:50051";
  std::string token_file = std::getenv("GELD_TOKEN_FILE") ? std::getenv("GELD_TOKEN_FILE") : "";
  double timeout = 30;
  CLI::Option* server_option =
      app.add_option("--server,-s", server, "geld address host:port (env GELD_SERVER)")->capture_default_str();
  app.add_option("--token-file", token_file, "File with the bearer token (env GELD_TOKEN_FILE; or GELD_TOKEN)");
  app.add_option("--timeout", timeout, "Seconds per call (not for watch)")->capture_default_str();
  TlsFiles tls;
  if (const char* ca = std::getenv("GELD_TLS_CA")) tls.ca = ca;
  app.add_option("--tls-ca", tls.ca, "PEM CA of geld's TLS certificate: talk TLS (env GELD_TLS_CA)");
  app.add_option("--tls-cert", tls.certificate, "PEM client certificate, for a geld that requires one (mutual TLS)");
  app.add_option("--tls-key", tls.key, "PEM private key of --tls-cert");

  auto& commands = registry();
  std::stable_sort(commands.begin(), commands.end(),
                   [](const Command& a, const Command& b) { return a.help_position < b.help_position; });
  std::map<CLI::App*, Runner> runners;
  for (const auto& command : commands) {
    CLI::App* sub = app.add_subcommand(command.name, command.description);
    runners[sub] = command.setup(*sub);
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version arrive as "errors" with exit code 0.
    if (e.get_exit_code() == 0) return app.exit(e);
    const std::string command = gel::cli::command_problem(app, "gelctl");
    std::cerr << "gelctl: " << (command.empty() ? e.what() : command) << "\n";
    return kExitBadInput;
  }
  const std::string server_source = server_option->count() > 0 ? "--server" : "GELD_SERVER";

  try {
    require_host_port(server, server_source);
    Client client(server, resolve_token(token_file), timeout, tls);
    for (auto& [sub, run] : runners)
      if (sub->parsed()) return run(client);
  } catch (const UsageError& e) {
    std::cerr << "gelctl: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const CallError& e) {
    std::cerr << "gelctl: " << e.what();
    // gRPC's words ("failed to connect to all addresses") say neither which program nor how to
    // choose another address; geld's own UNAVAILABLE (shutting down) names itself.
    if (e.status.error_code() == grpc::StatusCode::UNAVAILABLE && e.status.error_message().rfind("geld ", 0) != 0)
      std::cerr << " (no geld answers at " << server << ": start geld there, or give its address with --server HOST:PORT or GELD_SERVER)";
    std::cerr << "\n";
    return e.status.error_code() == grpc::StatusCode::INVALID_ARGUMENT ? kExitBadInput : kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << "gelctl: " << e.what() << "\n";
    return kExitFailure;
  }
  return kExitSuccess;
}
