// Extended XYZ (the dialect of ASE and OVITO): one block per frame, appended. The second line
// of a block carries the cell, the column layout and the frame's metadata as key=value pairs.
// Particles are written as the dummy species X (ASE's atomic number 0): they are colloids,
// not atoms. The cell is the periodic box L_x x L_y; y is not periodic once walls stand, and
// the walls' positions are in wall_bottom/wall_top; program holds the version string. Bonds
// have no place in XYZ: use GSD or VTU.
#include <cmath>
#include <fmt/format.h>

#include "file_output.hpp"
#include "gel/export.hpp"
#include "gel/units.hpp"
#include "gel_version.hpp"

namespace gel::exporting {
namespace {

class XyzWriter final : public FrameWriter {
 public:
  explicit XyzWriter(const std::string& path) : file_(path, true) {}

  void append(const Frame& frame) override {
    const Configuration& c = frame.configuration;
    std::string text = fmt::format("{}\n", c.size());
    text += fmt::format("Lattice=\"{:.17g} 0 0 0 {:.17g} 0 0 0 0\" Properties=species:S:1:pos:R:3:radius:R:1:theta:R:1:wall:I:1 "
                        "pbc=\"T {} F\" step={} phi={:.17g}",
                        c.lx, c.ly, c.periodic_y ? "T" : "F", frame.step, frame_phi(frame));
    if (frame.k >= 0) text += fmt::format(" k={}", frame.k);
    if (std::isfinite(frame.p)) text += fmt::format(" P={:.17g}", frame.p);
    if (c.has_walls()) text += fmt::format(" wall_bottom={:.17g} wall_top={:.17g}", c.wall_bottom, c.wall_top);
    text += fmt::format(" bonds={} units=\"length a, P F0/a^2\" program=\"gelsim {}\"\n", c.bonds.size(), program_version());
    for (std::size_t i = 0; i < c.size(); ++i)
      text += fmt::format("X {:.17g} {:.17g} 0 {:.17g} {:.17g} {}\n", c.x[i], c.y[i], kRadius, c.theta[i],
                          c.has_walls() ? int(c.wall[i]) : 0);
    file_.append(text.data(), text.size());
  }

  std::vector<std::string> files() const override { return {file_.path()}; }

 private:
  OutputFile file_;
};

}  // namespace

std::unique_ptr<FrameWriter> make_xyz_writer(const std::string& path) { return std::make_unique<XyzWriter>(path); }

}  // namespace gel::exporting
