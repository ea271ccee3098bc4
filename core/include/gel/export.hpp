#pragma once
// Configurations out to the formats other programs read (docs/gelsim.md "Data out"): extended XYZ
// (OVITO, ASE), GSD (HOOMD-blue's format; OVITO, freud, gsd.hoomd) and VTK XML unstructured
// grids (ParaView, VisIt). One writer per format, each in its own file under src/export/; all
// take the same frames so a run exports the same way whatever the target.
//
// What every format carries: positions, the orientation angle theta (as a quaternion about z
// where the format has one), the radius, wall membership (0 free, 1 bottom wall, 2 top wall)
// and, where the format has them, the bonds. GSD and VTU also carry the velocities, the
// contact forces and torques per particle and the state of every bond (BondState). Lengths
// are in units of the particle radius a.
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gel/bond_law.hpp"
#include "gel/configuration.hpp"
#include "gel/effects.hpp"

namespace gel::exporting {

// One picture of the system and what is known about when it was taken. Unknown numbers stay
// NaN (or -1 for k) and are not written.
struct Frame {
  Configuration configuration;
  std::int64_t step = 0;  // engine steps since the start of the run (GSD's configuration/step)
  int k = -1;             // compression target index, -1 when not an equilibrium row
  double phi = -1;        // packing fraction; < 0: computed from the configuration
  double p = std::numeric_limits<double>::quiet_NaN();  // P_y at this frame [F0/a^2]
  // The bond law and effects of the run, when known: the bond forces and the particles'
  // contact forces and torques are written only then (the geometry of the bonds always).
  std::optional<BondLaw> bond_law;
  unsigned effects = kAllEffects;
};

// The state of every bond of a configuration (MODEL.md "Bonds"), in bond order, computed from
// the configuration by the engine's evaluator: what a GSD or VTU frame says of each bond.
struct BondState {
  // Geometry, always: the gap delta [a], the contact points as lab-frame unit vectors xi_ij
  // (on i) and xi_ji (on j), the sliding displacement d [a] and the bending angle phi [rad].
  std::vector<double> gap;
  std::vector<double> contact_ix, contact_iy, contact_jx, contact_jy;
  std::vector<double> sliding_x, sliding_y;
  std::vector<double> bending;
  // With a bond law only (else empty): F_N . n [F0] (positive pulls i towards j), F_T [F0]
  // and the rolling moment M_R on i [F0 a].
  std::vector<double> normal_force, sliding_force_x, sliding_force_y, rolling_moment;
  bool with_forces = false;
};
BondState bond_state(const Configuration& configuration, const BondLaw* law, unsigned effects);

// The contact forces F_C and torques T_C on every particle (MODEL.md "Motion"): the bonds'
// loads summed in bond order (no drag). A wall particle's is the load it passes to its wall.
struct ParticleLoads {
  std::vector<double> fx, fy, torque;
};
// Needs a BondState with forces; empty arrays otherwise.
ParticleLoads particle_loads(const Configuration& configuration, const BondState& bonds);

enum class Format { kExtendedXyz, kGsd, kVtu };

// "xyz", "gsd" or "vtu"; throws InvalidArgument (field "format").
Format format_from_name(std::string_view name);
// From a file name's ending (.xyz/.extxyz, .gsd, .vtu/.pvd); throws InvalidArgument.
Format format_from_path(std::string_view path);
std::string_view format_name(Format format);

// Appends frames to one output. Each append leaves a complete, readable file behind, so a
// trajectory of a run that is killed is readable up to its last frame.
class FrameWriter {
 public:
  virtual ~FrameWriter() = default;
  virtual void append(const Frame& frame) = 0;
  // Files written so far (several for VTU: one .vtu per frame and the .pvd collection).
  virtual std::vector<std::string> files() const = 0;
};

// Throws InvalidArgument (field "path") when the file cannot be created.
std::unique_ptr<FrameWriter> open_writer(Format format, const std::string& path);

// GSD only: reopens a trajectory written by this program and drops every frame whose step is
// greater than `last_step` (a run resumed from a checkpoint rewrites those frames), then
// appends after the frames kept. A missing file starts a new one. *last_kept_step (if given)
// is the step of the last frame kept, -1 when none is.
std::unique_ptr<FrameWriter> reopen_gsd_trajectory(const std::string& path, std::int64_t last_step,
                                                   std::int64_t* last_kept_step = nullptr);

// Factories of the individual writers (src/export/*_writer.cpp).
std::unique_ptr<FrameWriter> make_xyz_writer(const std::string& path);
std::unique_ptr<FrameWriter> make_gsd_writer(const std::string& path, bool reopen, std::int64_t last_step,
                                             std::int64_t* last_kept_step);
std::unique_ptr<FrameWriter> make_vtu_writer(const std::string& path);

// Packing fraction of the frame: `phi` when given, else the configuration's.
double frame_phi(const Frame& frame);

}  // namespace gel::exporting
