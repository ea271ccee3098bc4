// gelsim export: configurations out to the formats other programs read.
//   gelsim export gel.json --out gel.xyz                 # one configuration
//   gelsim export runs/b1 --out runs/b1/run.gsd          # every equilibrium snapshot of a run
//   gelsim export runs/b1 --out frames/run.pvd           # VTU frames + a ParaView collection
//   gelsim export a.pb b.pb --format xyz --out both.xyz  # several files, in the order given
//   gelsim export runs/ens --out frames/rows.gsd         # an ensemble: frames/rows_seed_<seed>.gsd per member
//   gelsim export run/trajectory.gsd --frame 3 --out f3.vtu # one frame of a GSD or XYZ file
// A run directory contributes one frame per curve row that has a snapshot, with k, phi, P, the
// steps taken and the run's bond law (so the forces are written); a configuration file
// contributes one frame at step 0, with forces when --bond names the law.
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "gel/configuration.hpp"
#include "gel/curve_io.hpp"
#include "gel/errors.hpp"
#include "gel/export.hpp"
#include "gel/run_directory.hpp"
#include "gel/system.hpp"

namespace {

struct ExportOptions {
  std::vector<std::string> inputs;
  std::string out, format, bond;
  std::int64_t frame = gel::kLastFrame;
};

std::vector<gel::exporting::Frame> frames_of(const std::string& input, const ExportOptions& o) {
  namespace fs = std::filesystem;
  std::vector<gel::exporting::Frame> frames;
  if (!fs::is_directory(input)) {
    gel::exporting::Frame frame;
    frame.configuration = gel::read_configuration(input, o.frame);
    if (!o.bond.empty()) frame.bond_law = gel::bond_preset(o.bond, "--bond");
    frames.push_back(std::move(frame));
    return frames;
  }
  const gel::v1::Curve curve = gel::read_curve(input);
  const gel::SimParams params = gel::resolve_sim_params(curve.scene());
  for (const auto& row : curve.rows()) {
    if (row.snapshot().empty()) continue;
    gel::exporting::Frame frame;
    frame.configuration = gel::read_configuration((fs::path(input) / row.snapshot()).string());
    frame.step = row.steps();
    frame.k = row.k();
    frame.phi = row.phi();
    frame.p = row.p();
    frame.bond_law = params.bond;
    frame.effects = params.effects;
    frames.push_back(std::move(frame));
  }
  if (frames.empty())
    throw gel::InvalidArgument("input", "run directory '" + input + "' has no snapshots (was it run with --no-snapshots?)");
  return frames;
}

// Writes `frames` to `out`; the files written go to stdout, their count to stderr.
void write_frames(const std::vector<gel::exporting::Frame>& frames, gel::exporting::Format format, const std::string& out) {
  using namespace gel::exporting;
  if (format == Format::kVtu && frames.size() > 1 && !out.ends_with(".pvd"))
    throw gel::InvalidArgument("out", std::to_string(frames.size()) + " frames do not fit one .vtu file: name the output .pvd "
                                          "(a ParaView collection with one .vtu per frame beside it)");
  const auto writer = open_writer(format, out);
  for (const auto& frame : frames) writer->append(frame);
  for (const auto& file : writer->files()) std::cout << file << "\n";
  std::cerr << frames.size() << " frame(s) written as " << format_name(format) << " to " << out << "\n";
}

// An ensemble's folder: one output per finished member, named after it beside --out
// (frames/rows.gsd -> frames/rows_seed_3.gsd), since its members are separate trajectories that
// a reader must not take for one.
int export_ensemble(const ExportOptions& o, const gel::EnsembleMembers& members, gel::exporting::Format format) {
  namespace fs = std::filesystem;
  for (const std::string& member : members.unfinished)
    std::cerr << "gelsim: " << member << " has no curve.json (failed, stopped or still running): not exported\n";
  if (members.finished.empty())
    throw gel::InvalidArgument("input", "'" + o.inputs[0] + "' is an ensemble's folder, but none of its members has finished "
                                        "(no seed_<seed>/curve.json)");
  const fs::path out(o.out);
  for (const std::string& member : members.finished) {
    const fs::path member_out = out.parent_path() / (out.stem().string() + "_" + fs::path(member).filename().string() +
                                                     out.extension().string());
    write_frames(frames_of(member, o), format, member_out.string());
  }
  return 0;
}

int run_export(const ExportOptions& o) {
  using namespace gel::exporting;
  const Format format = o.format.empty() ? format_from_path(o.out) : format_from_name(o.format);
  for (const auto& input : o.inputs) {
    const gel::EnsembleMembers members = gel::ensemble_members(input);
    if (members.finished.empty() && members.unfinished.empty()) continue;
    if (o.inputs.size() > 1)
      throw gel::InvalidArgument("input", "'" + input + "' is an ensemble's folder: export it on its own (one file per member, "
                                          "OUT_seed_<seed>), not into one file with other inputs");
    return export_ensemble(o, members, format);
  }
  std::vector<Frame> frames;
  for (const auto& input : o.inputs)
    for (auto& frame : frames_of(input, o)) frames.push_back(std::move(frame));
  write_frames(frames, format, o.out);
  return 0;
}

const gelsim::Registrar export_registrar{
    "export", "Write configurations or a run's snapshots as extended XYZ, GSD or VTU (OVITO, ASE, HOOMD, ParaView)",
    [](CLI::App& sub) -> std::function<int()> {
      auto o = std::make_shared<ExportOptions>();
      sub.add_option("input", o->inputs, "configuration files (.json/.pb, or a frame of .gsd/.xyz), compression run directories, or one ensemble's folder (a file per member)")->required();
      sub.add_option("--out", o->out, "output file: .xyz, .gsd, .vtu (one frame) or .pvd (VTU frames)")->required();
      sub.add_option("--format", o->format, "xyz, gsd or vtu (default: from the --out ending)");
      sub.add_option("--frame", o->frame, "the frame of a .gsd or .xyz input: 0, 1, ... or -1, -2, ... from the end (default -1, the last)");
      sub.add_option("--bond", o->bond, "bond preset (bond1, bond2) of configuration-file inputs, to write their forces (a run directory's own law is used)");
      return [o] { return run_export(*o); };
    }};

}  // namespace
