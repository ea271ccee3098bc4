#pragma once
// The engine: a 2D discrete-element system of bonded disks (MODEL.md). Particle data are
// structure-of-arrays; bonds carry their body-fixed contact points. The physics of one bond
// lives in bond_evaluator.hpp; this class owns the loops, the neighbour search, the walls and
// the bookkeeping.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "gel/bond_evaluator.hpp"
#include "gel/bond_law.hpp"
#include "gel/configuration.hpp"
#include "gel/effects.hpp"
#include "gel/v1/checkpoint.pb.h"
#include "gel/v1/scene.pb.h"

namespace gel {

namespace detail {
struct KickCoefficients;
struct KickTotals;
struct BondScratch;
struct BondBlock;
struct ExactBond;
class WorkerPool;
}

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

// The shortest natural period of one bond between two free particles (see docs/engine.md "Integrator and time
// step"): omega_max^2 = 2 max(k_N/m, k_S/m, (k_S + k_R) a^2 / I) with k_R in F0 a.
double shortest_period(const BondLaw& bond);
// The same with another moment of inertia (FIRE's own, docs/quasistatic.md).
double shortest_period(const BondLaw& bond, double inertia);

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

// FIRE relaxation to mechanical equilibrium (docs/quasistatic.md): FIRE 2.0 (Guenole et al.,
// Comput. Mater. Sci. 175, 109584, 2020) on translations and rotations, with every bond effect
// of the scene active (thresholds, resets, breaks, creation, sticking to the walls) and no drag.
struct RelaxOptions {
  // Converged when every free particle's |F| and |T|/a is below
  // max(force_tolerance * mean bond force, force_floor) and |P_top - P_bot| <= a_tolerance |P|
  // (or |P| < stress_floor).
  double force_tolerance = 1e-4;  // relative to the mean bond force
  double force_floor = 1e-9;      // absolute [F0]: unloaded networks converge to this
  double a_tolerance = 1e-2;
  double stress_floor = 1e-6;     // [F0/a^2]
  double dt_max_factor = 3;       // FIRE's largest step over the dynamics' dt (times the inertia gain)
  double max_step = 0.02;         // largest move of a particle per iteration [a]
};

// FIRE's state between chunks of iterations, so a relaxation can be checkpointed mid-way.
struct RelaxState {
  double dt = 0;            // 0: not started
  double dt_max = 0;        // FIRE's cap, lowered when steps at the cap go uphill
  double alpha = 0;
  std::int64_t n_positive = 0;
  std::int64_t n_negative = 0;
  std::int64_t iterations = 0;    // of this relaxation
  double residual = 0;            // last max(|F|, |T|/a) over free particles [F0]
  double force_scale = 0;         // last mean bond force [F0]
  double tolerance_factor = 1;    // halved while the walls stay unbalanced
  bool converged = false;
  bool stalled = false;           // gave up: FIRE kept going uphill (N_negative^max)
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
  // Changes the time step from the next step on (the compression's walk step). The speed guard
  // follows it, so that it still bounds the distance a particle moves in one step.
  void set_time_step(double dt);
  // Gershgorin's bound on the fastest normal mode of the bond network as it is now [1/t0]: the
  // largest sqrt((1 + sqrt 2) sum_c k_c / m) over free particles, k_c the stiffness of each of
  // its contacts with the cubic overlap term. Velocity Verlet is stable while it times dt <= 2.
  double fastest_contact_frequency() const;

  // Threads for the bond loop and the integrator. Results are bit-identical for any number:
  // every sum is made in the same order (bond_kernels.hpp, fixed particle blocks).
  void set_threads(int threads);
  int threads() const;

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
  // Bond b's geometry now (line of centres, gap, lab-frame contact points): with
  // evaluate_bond and bond_loads (bond_evaluator.hpp) the force it exerts, for observables
  // such as the virial stress (gel/virial_stress.hpp).
  BondGeometry bond_geometry(std::size_t b) const { return geometry(bonds_[b]); }
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
  // Bonds the pairs that touch and sticks the particles that touch a wall, now (after a move
  // outside the integrator, such as translate_wall_group), and evaluates the forces.
  void update_contacts();
  double packing_fraction() const; // pi a^2 N / (L_x height)

  // Quasi-static strain step: moves both walls to the given positions and every free particle
  // affinely along y about the centre of the gap (x, orientations and bonds unchanged). The
  // change of stored energy is booked as wall work.
  void affine_move_walls(double new_bottom, double new_top);

  // Runs up to max_iterations FIRE iterations at fixed walls (wall velocities set to zero) and
  // returns whether the relaxation converged (state.converged). Iterations count as steps;
  // simulated time does not advance. A fresh RelaxState starts from rest.
  bool relax(RelaxState& state, const RelaxOptions& options, std::int64_t max_iterations);
  // max(|F|, |T|/a) over free particles and the mean |F_N n + F_T| over bonds [F0], of the
  // last force evaluation.
  double residual_force() const;
  double mean_bond_force() const;

  // External forces (three-point bending); work is tracked in the ledger.
  void set_external_force(std::int32_t i, double fx, double fy);
  void clear_external_forces();

  // Forces of the current configuration without advancing (for tests and checks).
  void compute_forces();

  Configuration configuration() const;
  // Full state, bit for bit (including neighbour list and bond order), for checkpoints: as the
  // versioned message of proto/gel/v1/checkpoint.proto, or that message serialised.
  void save_state(gel::v1::EngineState& state) const;
  static System load_state(const gel::v1::EngineState& state);  // throws std::runtime_error
  std::string save_state() const;
  static System load_state(const std::string& bytes);

  // Test hooks: direct state access.
  void set_velocity(std::int32_t i, double vx, double vy, double omega);
  void set_position(std::int32_t i, double x, double y);
  void set_orientation(std::int32_t i, double theta);

 private:
  template <unsigned kBondMask>
  void bond_forces();
  template <unsigned kBondMask>
  void block_bond_forces(detail::BondBlock& block);
  template <unsigned kBondMask>
  detail::ExactBond exact_bond(std::size_t b) const;
  detail::KickCoefficients kick_coefficients() const;
  template <bool kDragOn>
  void first_half_kick_and_drift();
  template <bool kDragOn>
  void second_half_kick();
  template <class Task>
  void parallel(std::size_t tasks, Task&& task);
  void dispatch_bond_forces();
  void maybe_rebuild();
  void rebuild_neighbours();
  void wrap_into_box();
  void detect_contacts();
  void attach_to_walls();
  void impose_wall_motion();
  void apply_external_forces();
  void collect_wall_forces();
  void check_stability();
  double bond_gap(const Bond& bond) const;  // surface gap delta of a bonded pair, from positions only
  void check_contact_stiffness();
  double contact_stiffness(double delta) const;  // k_N + 3 C delta^2 in compression, k_N apart
  std::vector<double> summed_contact_stiffness() const;  // per particle, over its bonds
  void find_new_contacts();
  bool handle_threshold(std::size_t b, BondEvent event, double nx, double ny);
  void create_bond(std::int32_t i, std::int32_t j, double shift_x, double shift_y);
  void attach(std::int32_t i, WallSide side);
  void remove_marked_bonds();
  double bond_energy(const Bond& bond) const;
  BondGeometry geometry(const Bond& bond) const;
  [[noreturn]] void stability_failure(const std::string& what) const;

  SimParams params_;
  double lx_ = 0, ly_ = 0;
  bool periodic_x_ = true, periodic_y_ = true;

  std::vector<double> x_, y_, orient_c_, orient_s_, vx_, vy_, omega_, fx_, fy_, torque_;
  std::vector<std::int8_t> wall_;  // WallSide per particle; empty until walls exist
  std::vector<Bond> bonds_;
  std::vector<std::uint8_t> bond_marked_;  // scratch: bonds broken this step
  // The bond loop's scratch: its mirror of bonds_ as arrays (invalidated by every change of
  // bonds_) and one chunk's forces. Never part of the saved state.
  std::unique_ptr<detail::BondScratch> bond_scratch_;
  // The run's threads (null: one). Not part of the saved state: results do not depend on it.
  std::unique_ptr<detail::WorkerPool> pool_;
  std::vector<detail::KickTotals> kick_totals_;  // per particle block, combined in order

  struct Candidate {
    std::int32_t i, j;
    double shift_x, shift_y;
  };
  std::vector<Candidate> candidates_;     // unbonded pairs within 2a + skin
  std::vector<std::int32_t> wall_candidates_;  // free particles within a + skin of a wall
  std::vector<Candidate> touching_;             // scratch: the candidates that touch this step
  std::vector<std::int32_t> attaching_;         // scratch: the free particles that reach a wall
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
