// gelsim: the engine without the service. Every bad argument or input exits non-zero with a
// one-line message on stderr.
#include <exception>
#include <iostream>
#include <map>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "command_line.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"

namespace gelsim {
std::vector<Command>& registry() {
  static std::vector<Command> commands;
  return commands;
}
}  // namespace gelsim

int main(int argc, char** argv) {
  CLI::App app{"gelsim: 2D discrete-element simulation of colloidal gel compression"};
  app.set_version_flag("--version", gel::program_version());
  app.require_subcommand(1);
  std::map<CLI::App*, std::function<int()>> runners;
  for (const auto& command : gelsim::registry()) {
    CLI::App* sub = app.add_subcommand(command.name, command.description);
    runners[sub] = command.setup(*sub);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    const std::string command = gel::cli::command_problem(app, "gelsim");
    std::cerr << "gelsim: " << (command.empty() ? e.what() : command) << "\n";
    return 2;
  }
  try {
    for (auto& [sub, run] : runners)
      if (sub->parsed()) return run();
  } catch (const gel::InvalidArgument& e) {
    std::cerr << "gelsim: invalid argument: " << e.what() << "\n";
    return 2;
  } catch (const gel::StabilityError& e) {
    std::cerr << "gelsim: " << gel::kInstabilityPrefix << e.what() << "\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "gelsim: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
