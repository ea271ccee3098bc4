#pragma once
// gelctl sub-commands register themselves here (one file per sub-command), so adding a command
// never touches main.cpp.
#include <functional>
#include <string>
#include <vector>

// <CLI/App.hpp>, not <CLI/CLI.hpp>: CLI11's help formatter and config-file reader (CLI/Formatter.hpp,
// CLI/Config.hpp) are inline code that every file including them compiles again (most of a
// sub-command's build time, docs/testing.md); main.cpp, which builds the App, includes them.
#include <CLI/App.hpp>

namespace gelctl {

class Client;

// Runs a parsed sub-command against geld; its return value is the process exit code.
using Runner = std::function<int(Client& client)>;

struct Command {
  std::string name;
  std::string description;
  // Where the command appears in `gelctl --help`. Registration follows link order, which is
  // just the file names' order, so the listing order is stated here instead.
  int help_position;
  // Adds the sub-command's options to `sub` and returns what runs it.
  std::function<Runner(CLI::App& sub)> setup;
};

std::vector<Command>& registry();

struct Registrar {
  Registrar(std::string name, std::string description, int help_position,
            std::function<Runner(CLI::App& sub)> setup) {
    registry().push_back(Command{std::move(name), std::move(description), help_position, std::move(setup)});
  }
};

}  // namespace gelctl
