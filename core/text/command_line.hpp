#pragma once
// What every program's command line (gelsim, geld, gelctl) says when an argument is wrong, in
// the product's words rather than CLI11's.
#include <cmath>
#include <sstream>
#include <string>
#include <type_traits>

// <CLI/App.hpp>, not <CLI/CLI.hpp>: see core/cli/command.hpp.
#include <CLI/App.hpp>

namespace gel::cli {

// A number of type T above `lowest` (or at least it, when `inclusive`), finite. CLI11's
// PositiveNumber and NonNegativeNumber quote their upper bound, the largest double (a 309-digit
// number), when the text is not a number at all ("geld --workers abc").
template <typename T>
CLI::Validator number_from(T lowest, bool inclusive) {
  std::ostringstream bound;
  bound << (inclusive ? ">= " : "> ") << lowest;
  const std::string wanted = std::string(std::is_integral_v<T> ? "a whole number " : "a number ") + bound.str();
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        T value{};
        bool fits = CLI::detail::lexical_cast(text, value) && (inclusive ? value >= lowest : value > lowest);
        if constexpr (std::is_floating_point_v<T>) fits = fits && std::isfinite(value);
        return fits ? std::string() : "must be " + wanted + ", got '" + text + "'";
      },
      std::is_integral_v<T> ? "INT" : "NUMBER");
}
// The checks of an option bound to `variable`, in its type: ->check(gel::cli::positive(workers)).
template <typename T>
CLI::Validator positive(const T& /*variable*/) {
  return number_from<T>(0, false);
}
template <typename T>
CLI::Validator non_negative(const T& /*variable*/) {
  return number_from<T>(0, true);
}

// The message for a command line that names no known sub-command: CLI11 says "A subcommand is
// required" for `gelctl frobnicate` too, without the word the user typed or the ones it knows.
// Empty when a sub-command was found (the parse error is about something else).
inline std::string command_problem(const CLI::App& app, const std::string& program) {
  if (!app.get_subcommands().empty()) return "";
  std::string known;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
    known += (known.empty() ? "" : ", ") + sub->get_name();
  for (const std::string& word : app.remaining())
    if (!word.empty() && word[0] != '-')
      return "unknown command '" + word + "': the commands are " + known + " (" + program + " --help says what each does)";
  return "a command is required: " + known + " (" + program + " --help says what each does)";
}

}  // namespace gel::cli
