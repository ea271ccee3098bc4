#pragma once
// The thermo log of a compression run (docs/compression.md "Thermo log"): one CSV line of the
// state every N engine steps, flushed at once, so that `tail -f OUT/thermo.csv` follows a run
// the way a LAMMPS or HOOMD-blue user follows theirs. Reads the engine, never changes it.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "gel/system.hpp"

namespace gel {

// The header line (without its line end): "step [count],time [t0],k,phase,phi [1],...".
std::string thermo_header();

class ThermoLog {
 public:
  // A fresh run: creates (or empties) the file and writes the header. A resumed run
  // (resumed_at_step >= 0, the checkpoint's step): keeps the header and the lines up to that
  // step, drops the ones after it (written after the checkpoint, by the run that was
  // interrupted) and a torn last line, and appends from there, so that the file ends up as an
  // uninterrupted run's. A file that is not a thermo log of this format is refused
  // (InvalidArgument "thermo", nothing changed); a missing one is started afresh.
  ThermoLog(const std::string& path, std::int64_t every, std::int64_t resumed_at_step = -1);
  ~ThermoLog();
  ThermoLog(const ThermoLog&) = delete;
  ThermoLog& operator=(const ThermoLog&) = delete;

  // A line is due at the first look at or after each multiple of `every` steps.
  bool due(std::int64_t step) const { return step >= next_step_; }
  // Writes the line of the state now (k: the curve row being worked towards; phase as in
  // Progress) and flushes it. Once per step: a second line at the same step is skipped.
  void write(const System& system, int k, const char* phase);

 private:
  std::FILE* file_ = nullptr;
  std::string path_;
  std::int64_t every_;
  std::int64_t next_step_ = 0;
  std::int64_t last_step_ = -1;
};

}  // namespace gel
