#pragma once
// The compression output folders that gelsim plot, analyze-run and export are given. A run's
// folder (it holds curve.json) stands for itself; an ensemble's folder (gelsim compress --seeds
// ... --out DIR, or OUT/<ensemble> of a gelsim study) stands for its finished members, so that
// the folder a user was handed is what they pass, not DIR/seed_*.
#include <string>
#include <vector>

namespace gelsim {

// Each input as it is, or an ensemble's folder replaced by its finished members (in the
// ensemble's order). An unfinished member is named on stderr and left out; an ensemble's folder
// with no finished member throws InvalidArgument ("dir").
std::vector<std::string> runs_of(const std::vector<std::string>& inputs);

}  // namespace gelsim
