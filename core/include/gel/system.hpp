#pragma once
// The engine: a 2D discrete-element system of bonded disks (MODEL.md). Particle data are
// structure-of-arrays; bonds carry their body-fixed contact points. The physics of one bond
// lives in bond_evaluator.hpp; this class owns the loops, the neighbour search, the walls and
// the bookkeeping.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "gel/bond_law.hpp"
#include "gel/configuration.hpp"
#include "gel/effects.hpp"
#include "gel/v1/scene.pb.h"

namespace gel {

struct SimParams {
  BondLaw bond;
  unsigned effects = kAllEffects;
  double dt = 0;               // resolved time step [t0]
  double dt_fraction = 0.025;  // dt = dt_fraction * shortest_period(bond) unless dt is given
  double eta_factor = 0.1;     // eta / eta_cd
  double skin = 0.3;           // neighbour-list skin [a]
  int guard_interval = 16;     // steps between full stability checks
  double max_overlap = 0.5;    // overlap |delta| that stops the run [a]
  double max_speed = 0;        // speed that stops the run [a/t0]; resolved to 0.1 a / dt if 0

  // Stokes drag coefficients 6 pi eta a and 8 pi eta a^3 with eta = eta_factor * eta_cd,
  // eta_cd = sqrt(k_R m) / (3 pi a).
  double drag_translation() const;
  double drag_rotation() const;
};

// The shortest natural period of one bond between two free particles (see README "Time
// step"): omega_max^2 = 2 max(k_N/m, k_S/m, (k_S + k_R) a^2 / I) with k_R in F0 a.
double shortest_period(const BondLaw& bond);

// From a scene's bond, effects and integration messages; validates every field.
SimParams resolve_sim_params(const gel::v1::Scene& scene);

// A bond as the engine holds it. shift_x/shift_y make (r_j + shift) - r_i the minimum image.
struct Bond {
  std::int32_t i, j;
  double bix, biy;  // contact point on i, body frame
  double bjx, bjy;  // contact point on j, body frame
  double shift_x, shift_y;
};

struct EventCounts {
  std::int64_t normal = 0;   // breaks
  std::int64_t sliding = 0;  // sliding resets
  std::int64_t rolling = 0;  // rolling resets
  std::int64_t created = 0;  // bonds formed
};

// Exact energy bookkeeping: stored (bond) energy is computed on demand; these accumulate.
struct EnergyLedger {
  double dissipated = 0;         // released by breaks and resets
  double created = 0;            // stored in bonds at their formation (they form at delta <= 0)
  double drag = 0;               // removed by Stokes drag (trapezoidal in time)
  double wall_work = 0;          // done by the walls on the particles bonded to them
  double absorbed_by_walls = 0;  // kinetic energy lost when a particle sticks to a wall
  double external_work = 0;      // done by external forces
};

struct WallStress {
  double force_top = 0;     // sum of bond forces on top-wall particles, y component
  double force_bottom = 0;  // same for the bottom wall
  double p_top = 0, p_bottom = 0, p = 0;
};

class System {
 public:
  System(const Configuration& config, const SimParams& params);
  ~System();
  System(System&&) noexcept;
  System& operator=(System&&) noexcept;

  void step();
  void run(std::int64_t steps);

  std::size_t size() const { return x_.size(); }
  const SimParams& params() const { return params_; }
  double time() const { return time_; }
  std::int64_t step_count() const { return step_count_; }
  const EventCounts& events() const { return events_; }
  const EnergyLedger& energy() const { return ledger_; }
  const std::vector<Bond>& bonds() const { return bonds_; }
  double lx() const { return lx_; }
  double ly() const { return ly_; }

  // Particle state (structure of arrays). The orientation is the unit vector
  // (cos theta, sin theta) = (orient_c, orient_s).
  const std::vector<double>& x() const { return x_; }
  const std::vector<double>& y() const { return y_; }
  const std::vector<double>& vx() const { return vx_; }
  const std::vector<double>& vy() const { return vy_; }
  const std::vector<double>& omega() const { return omega_; }
  const std::vector<double>& fx() const { return fx_; }
  const std::vector<double>& fy() const { return fy_; }
  const std::vector<double>& torque() const { return torque_; }
  double theta(std::size_t i) const;
  std::int8_t wall_side(std::size_t i) const { return wall_.empty() ? std::int8_t{kNoWall} : wall_[i]; }

  // Energies.
  double stored_energy() const;   // elastic energy of all bonds
  double kinetic_energy() const;  // of the free (non-wall) particles
  double max_speed() const;       // largest |v| and a|omega| of free particles
  double mean_contact_number() const;

  // Walls (MODEL.md "Walls and boundaries").
  bool has_walls() const { return walls_active_; }
  // Replaces the periodic y boundary with two walls touching the lowest and highest
  // particle; removes the bonds that crossed it; the touching particles stick.
  void install_walls();
  void set_wall_velocities(double v_bottom, double v_top);  // along +y
  double wall_bottom() const { return wall_bottom_; }
  double wall_top() const { return wall_top_; }
  double wall_velocity_bottom() const { return wall_v_bottom_; }
  double wall_velocity_top() const { return wall_v_top_; }
  // Rigid translation along y of every particle stuck to the given wall and of the wall
  // (quasi-static approach shortcut).
  void translate_wall_group(WallSide side, double dy);
  WallStress wall_stress() const;  // from the last force evaluation
  double packing_fraction() const; // pi a^2 N / (L_x height)

  // External forces (three-point bending); work is tracked in the ledger.
  void set_external_force(std::int32_t i, double fx, double fy);
  void clear_external_forces();

  // Forces of the current configuration without advancing (for tests and checks).
  void compute_forces();

  Configuration configuration() const;
  // Full state, bit for bit (including neighbour list and bond order), for checkpoints.
  std::string save_state() const;
  static System load_state(const std::string& bytes);

  // Test hooks: direct state access.
  void set_velocity(std::int32_t i, double vx, double vy, double omega);
  void set_position(std::int32_t i, double x, double y);
  void set_orientation(std::int32_t i, double theta);

 private:
  template <unsigned kBondMask>
  void bond_forces();
  template <bool kDragOn>
  void first_half_kick_and_drift();
  template <bool kDragOn>
  void second_half_kick();
  void dispatch_bond_forces();
  void maybe_rebuild();
  void rebuild_neighbours();
  void detect_contacts();
  void attach_to_walls();
  void impose_wall_motion();
  void apply_external_forces();
  void collect_wall_forces();
  void check_stability();
  bool handle_threshold(std::size_t b, double fn, double ft_sq, double moment, double nx, double ny);
  void create_bond(std::int32_t i, std::int32_t j, double shift_x, double shift_y);
  void attach(std::int32_t i, WallSide side);
  void remove_marked_bonds();
  double bond_energy(const Bond& bond) const;
  [[noreturn]] void stability_failure(const std::string& what) const;

  SimParams params_;
  double lx_ = 0, ly_ = 0;
  bool periodic_x_ = true, periodic_y_ = true;

  std::vector<double> x_, y_, orient_c_, orient_s_, vx_, vy_, omega_, fx_, fy_, torque_;
  std::vector<std::int8_t> wall_;  // WallSide per particle; empty until walls exist
  std::vector<Bond> bonds_;
  std::vector<std::uint8_t> bond_marked_;  // scratch: bonds broken this step

  struct Candidate {
    std::int32_t i, j;
    double shift_x, shift_y;
  };
  std::vector<Candidate> candidates_;     // unbonded pairs within 2a + skin
  std::vector<std::int32_t> wall_candidates_;  // free particles within a + skin of a wall
  std::vector<double> ref_x_, ref_y_;     // positions at the last rebuild (unused: see travel_)
  double travel_ = 0;                     // bound on displacement since the last rebuild
  double wall_travel_ = 0;
  std::int64_t rebuilds_ = 0;

  bool walls_active_ = false;
  double wall_bottom_ = 0, wall_top_ = 0, wall_v_bottom_ = 0, wall_v_top_ = 0;
  std::vector<std::int32_t> wall_members_;  // particles stuck to a wall
  std::vector<double> wall_offset_;         // y - wall position, per member
  WallStress wall_stress_;
  double wall_power_ = 0;  // last -sum F.v of wall particles, for the trapezoidal work

  struct ExternalForce {
    std::int32_t i;
    double fx, fy;
  };
  std::vector<ExternalForce> external_;
  double external_power_ = 0;

  double min_delta_ = 0;   // most negative gap seen since the last guard check
  double max_speed_sq_ = 0;
  double time_ = 0;
  std::int64_t step_count_ = 0;
  EventCounts events_;
  EnergyLedger ledger_;
  bool forces_valid_ = false;

 public:
  std::int64_t neighbour_rebuilds() const { return rebuilds_; }
};

}  // namespace gel
