// gelsim export: configurations out to the formats other programs read.
//   gelsim export gel.json --out gel.xyz                 # one configuration
//   gelsim export runs/b1 --out runs/b1/run.gsd          # every equilibrium snapshot of a run
//   gelsim export runs/b1 --out frames/run.pvd           # VTU frames + a ParaView collection
//   gelsim export a.pb b.pb --format xyz --out both.xyz  # several files, in the order given
// A run directory contributes one frame per curve row that has a snapshot, with k, phi, P and
// the steps taken; a configuration file contributes one frame at step 0.
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

namespace {

struct ExportOptions {
  std::vector<std::string> inputs;
  std::string out, format;
};

std::vector<gel::exporting::Frame> frames_of(const std::string& input) {
  namespace fs = std::filesystem;
  std::vector<gel::exporting::Frame> frames;
  if (!fs::is_directory(input)) {
    gel::exporting::Frame frame;
    frame.configuration = gel::read_configuration(input);
    frames.push_back(std::move(frame));
    return frames;
  }
  const gel::v1::Curve curve = gel::read_curve(input);
  for (const auto& row : curve.rows()) {
    if (row.snapshot().empty()) continue;
    gel::exporting::Frame frame;
    frame.configuration = gel::read_configuration((fs::path(input) / row.snapshot()).string());
    frame.step = row.steps();
    frame.k = row.k();
    frame.phi = row.phi();
    frame.p = row.p();
    frames.push_back(std::move(frame));
  }
  if (frames.empty())
    throw gel::InvalidArgument("input", "run directory '" + input + "' has no snapshots (was it run with --no-snapshots?)");
  return frames;
}

int run_export(const ExportOptions& o) {
  using namespace gel::exporting;
  const Format format = o.format.empty() ? format_from_path(o.out) : format_from_name(o.format);
  std::vector<Frame> frames;
  for (const auto& input : o.inputs)
    for (auto& frame : frames_of(input)) frames.push_back(std::move(frame));
  if (format == Format::kVtu && frames.size() > 1 && !o.out.ends_with(".pvd"))
    throw gel::InvalidArgument("out", std::to_string(frames.size()) + " frames do not fit one .vtu file: name the output .pvd "
                                          "(a ParaView collection with one .vtu per frame beside it)");
  const auto writer = open_writer(format, o.out);
  for (const auto& frame : frames) writer->append(frame);
  for (const auto& file : writer->files()) std::cout << file << "\n";
  std::cerr << frames.size() << " frame(s) written as " << format_name(format) << "\n";
  return 0;
}

const gelsim::Registrar export_registrar{
    "export", "Write configurations or a run's snapshots as extended XYZ, GSD or VTU (OVITO, ASE, HOOMD, ParaView)",
    [](CLI::App& sub) -> std::function<int()> {
      auto o = std::make_shared<ExportOptions>();
      sub.add_option("input", o->inputs, "configuration files (.json/.pb) or compression run directories")->required();
      sub.add_option("--out", o->out, "output file: .xyz, .gsd, .vtu (one frame) or .pvd (VTU frames)")->required();
      sub.add_option("--format", o->format, "xyz, gsd or vtu (default: from the --out ending)");
      return [o] { return run_export(*o); };
    }};

}  // namespace
