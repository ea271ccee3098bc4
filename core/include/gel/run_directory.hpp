#pragma once
// A run's output directory (gelsim compress --out DIR): what an earlier run left there, and
// clearing it. A run written over another one would leave the other's trajectory, snapshots past
// its own last row and plots beside the new curve, and the folder would read as one run.
#include <string>
#include <vector>

namespace gel {

// What a gelsim run writes that is in `dir` (curve.json, checkpoint.bin, snapshots, ..., an
// ensemble's ensemble.json and seed_<seed>), by name, sorted; empty when there is nothing (or no
// `dir`). Other files are not a run's and are not listed.
std::vector<std::string> earlier_run_outputs(const std::string& dir);

// Removes earlier_run_outputs(dir) from `dir`, nothing else, and returns their names. Throws
// InvalidArgument (field "out_dir") without removing anything unless gelsim wrote a checkpoint,
// a curve.json or an ensemble.json there: a folder named by mistake whose files only share a
// name with a run's ("snapshots", "plots") is never emptied.
std::vector<std::string> clear_earlier_run(const std::string& dir);

// The members of an ensemble's folder (gelsim compress --seeds ... --out DIR, or one ensemble of
// a gelsim study): the folders DIR/seed_<seed>, in the order of DIR/ensemble.json's seeds where
// there is one, else by seed. `finished` holds those with a curve.json (what an analysis, a plot
// or an export reads), `unfinished` the others (failed, stopped or still running). Both are
// empty when `dir` is not an ensemble's folder: it holds a curve.json itself, or no member.
struct EnsembleMembers {
  std::vector<std::string> finished, unfinished;
};
EnsembleMembers ensemble_members(const std::string& dir);

}  // namespace gel
