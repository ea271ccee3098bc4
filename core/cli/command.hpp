#pragma once
// gelsim sub-commands register themselves here (one file per sub-command), so adding a
// command never touches main.cpp.
#include <functional>
#include <string>
#include <vector>

// <CLI/App.hpp>, not <CLI/CLI.hpp>: CLI11's help formatter and config-file reader (CLI/Formatter.hpp,
// CLI/Config.hpp) are inline code that every file including them compiles again (most of a
// sub-command's build time, docs/testing.md); main.cpp, which builds the App, includes them.
#include <CLI/App.hpp>

#include "gel/seed.hpp"

namespace gelsim {

// The --seed check of every sub-command that takes one: gel/seed.hpp's rule, in its words.
inline CLI::Validator seed_validator() {
  return CLI::Validator([](std::string& value) { return gel::seed_problem(value); }, "SEED");
}

struct Command {
  std::string name;
  // Adds the sub-command's options to `sub` and returns the function that runs it (its return
  // value is the process exit code).
  std::function<std::function<int()>(CLI::App& sub)> setup;
  std::string description;
};

std::vector<Command>& registry();

struct Registrar {
  Registrar(std::string name, std::string description, std::function<std::function<int()>(CLI::App&)> setup) {
    registry().push_back(Command{std::move(name), std::move(setup), std::move(description)});
  }
};

}  // namespace gelsim
