#include "run_inputs.hpp"

#include <iostream>

#include "gel/errors.hpp"
#include "gel/run_directory.hpp"

namespace gelsim {

std::vector<std::string> runs_of(const std::vector<std::string>& inputs) {
  std::vector<std::string> runs;
  for (const std::string& input : inputs) {
    const gel::EnsembleMembers members = gel::ensemble_members(input);
    if (members.finished.empty() && members.unfinished.empty()) {
      runs.push_back(input);
      continue;
    }
    for (const std::string& member : members.unfinished)
      std::cerr << "gelsim: " << member << " has no curve.json (failed, stopped or still running): left out\n";
    if (members.finished.empty())
      throw gel::InvalidArgument("dir", "'" + input + "' is an ensemble's folder, but none of its " +
                                            std::to_string(members.unfinished.size()) +
                                            " members has finished (no seed_<seed>/curve.json): resume it with gelsim "
                                            "compress --resume " + input);
    runs.insert(runs.end(), members.finished.begin(), members.finished.end());
  }
  return runs;
}

}  // namespace gelsim
