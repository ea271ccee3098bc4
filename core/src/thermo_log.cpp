// The thermo log (thermo_log.hpp): the one writer of thermo.csv.
#include "thermo_log.hpp"

#include <cerrno>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <string_view>

#include "curve_csv.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"

namespace gel {
namespace {

// The names and units of curve.csv, so that a line and a row read alike.
constexpr const char* kHeader =
    "step [count],time [t0],k,phase,phi [1],P_top [F0/a^2],P_bot [F0/a^2],P [F0/a^2],kinetic_energy [F0 a],"
    "stored_energy [F0 a],ruptures_normal [count],ruptures_sliding [count],ruptures_rolling [count],"
    "bonds_created [count]";

[[noreturn]] void write_failed(const std::string& path) {
  throw std::runtime_error("thermo log: cannot write '" + path + "': " + std::strerror(errno));
}

// The length of the part of `text` to keep on resuming at `step`: the header and every complete
// line up to that step. Sets last_kept to the step of the last line kept (-1: none).
std::size_t kept_length(std::string_view text, std::int64_t step, std::int64_t& last_kept) {
  last_kept = -1;
  std::size_t kept = std::string_view(kHeader).size() + 1;
  while (kept < text.size()) {
    const std::size_t end = text.find('\n', kept);
    if (end == std::string_view::npos) break;  // torn by the interruption
    std::int64_t line_step = 0;
    const auto [after, error] = std::from_chars(text.data() + kept, text.data() + end, line_step);
    if (error != std::errc() || after == text.data() + end || *after != ',' || line_step > step) break;
    last_kept = line_step;
    kept = end + 1;
  }
  return kept;
}

}  // namespace

std::string thermo_header() { return kHeader; }

ThermoLog::ThermoLog(const std::string& path, std::int64_t every, std::int64_t resumed_at_step)
    : path_(path), every_(every) {
  if (every <= 0) throw InvalidArgument("thermo_every", "must be a positive number of steps");
  namespace fs = std::filesystem;
  if (!path.empty() && fs::path(path).has_parent_path()) fs::create_directories(fs::path(path).parent_path());
  if (resumed_at_step >= 0 && fs::exists(path)) {
    const std::string text = read_file(path);
    const std::string header = std::string(kHeader) + "\n";
    if (text.compare(0, header.size(), header) != 0)
      throw InvalidArgument("thermo", "'" + path + "' is not a thermo log this version writes (its first line is not "
                                          "the header of docs/compression.md \"Thermo log\"): move it away to resume");
    std::int64_t last_kept = -1;
    fs::resize_file(path, kept_length(text, resumed_at_step, last_kept));
    file_ = std::fopen(path.c_str(), "ab");
    if (!file_) write_failed(path);
    last_step_ = last_kept;
    next_step_ = last_kept < 0 ? 0 : (last_kept / every_ + 1) * every_;
    return;
  }
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) write_failed(path);
  if (std::fprintf(file_, "%s\n", kHeader) < 0 || std::fflush(file_) != 0) write_failed(path);
}

ThermoLog::~ThermoLog() {
  if (file_) std::fclose(file_);
}

void ThermoLog::write(const System& system, int k, const char* phase) {
  const std::int64_t step = system.step_count();
  if (step == last_step_) return;
  const WallStress stress = system.wall_stress();
  const EventCounts& events = system.events();
  std::string line = std::to_string(step);
  for (const std::string& cell :
       {exact(system.time()), std::to_string(k), std::string(phase), exact(system.packing_fraction()),
        exact(stress.p_top), exact(stress.p_bottom), exact(stress.p), exact(system.kinetic_energy()),
        exact(system.stored_energy()), std::to_string(events.normal), std::to_string(events.sliding),
        std::to_string(events.rolling), std::to_string(events.created)})
    line += ',' + cell;
  line += '\n';
  if (std::fputs(line.c_str(), file_) < 0 || std::fflush(file_) != 0) write_failed(path_);
  last_step_ = step;
  next_step_ = (step / every_ + 1) * every_;
}

}  // namespace gel
