#include "gel/system.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <utility>

#include "bonded_group.hpp"
#include "gel/bond_evaluator.hpp"
#include "gel/errors.hpp"
#include "gel/units.hpp"
#include "bond_kernels.hpp"
#include "integrator_kernels.hpp"
#include "worker_pool.hpp"
#include "rotation.hpp"

namespace gel {

namespace {

// Bit of the bond-loop template mask that says the box is periodic, so bonds carry an image
// shift. Bits 0-4 are the bond effects of effects.hpp.
constexpr unsigned kShiftBit = 1u << 5;
constexpr unsigned kBondEffectBits = kNormalSpring | kOverlapRepulsion | kSliding | kRolling | kThresholds;
constexpr std::size_t kBondVariants = 64;

// Body-frame vector b rotated into the lab frame by R(theta) = [[c, -s], [s, c]].
inline void to_lab(double c, double s, double bx, double by, double& lx, double& ly) {
  lx = c * bx - s * by;
  ly = s * bx + c * by;
}

// Lab vector v into the body frame: R(-theta) v.
inline void to_body(double c, double s, double vx, double vy, double& bx, double& by) {
  bx = c * vx + s * vy;
  by = -s * vx + c * vy;
}

std::string number(double value) {
  std::ostringstream out;
  out.precision(6);
  out << value;
  return out.str();
}

}  // namespace

BondEnergy bond_energy(const BondGeometry& g, const BondLaw& law, unsigned effects) {
  BondEnergy energy;
  if (effects & kNormalSpring) energy.normal += 0.5 * law.k_normal * g.delta * g.delta;
  if ((effects & kOverlapRepulsion) && g.delta < 0)
    energy.normal += 0.25 * law.overlap_coefficient * g.delta * g.delta * g.delta * g.delta;
  if (effects & kSliding) {
    const double ux = g.xi_jx - g.xi_ix, uy = g.xi_jy - g.xi_iy;
    const double u_n = ux * g.nx + uy * g.ny;
    const double dx = kRadius * (ux - u_n * g.nx), dy = kRadius * (uy - u_n * g.ny);
    energy.sliding = 0.5 * law.k_sliding * (dx * dx + dy * dy);
  }
  if (effects & kRolling) {
    const double phi = bending_angle(g.xi_ix * g.xi_jy - g.xi_iy * g.xi_jx);
    energy.rolling = 0.5 * law.k_rolling * phi * phi;
  }
  return energy;
}

BondForces evaluate_bond(const BondGeometry& g, const BondLaw& law, unsigned effects) {
  constexpr unsigned kTerms = kNormalSpring | kOverlapRepulsion | kSliding | kRolling;
  static constexpr auto table = []<std::size_t... kMasks>(std::index_sequence<kMasks...>) {
    return std::array<BondForces (*)(const BondGeometry&, const BondLaw&), sizeof...(kMasks)>{
        &BondEvaluator<kMasks>::evaluate...};
  }(std::make_index_sequence<kTerms + 1>{});
  return table[effects & kTerms](g, law);
}

// ---------------------------------------------------------------------------------------
// Construction

System::~System() = default;
System::System(System&&) noexcept = default;
System& System::operator=(System&&) noexcept = default;

System::System(const Configuration& config, const SimParams& params)
    : params_(params), bond_scratch_(std::make_unique<detail::BondScratch>()) {
  const std::size_t n = config.size();
  if (n == 0) throw InvalidArgument("configuration", "no particles");
  if (!(params_.dt > 0)) params_.dt = params_.dt_fraction * shortest_period(params_.bond);
  require_positive("integration.dt", params_.dt);
  require_positive("integration.skin", params_.skin);
  require_non_negative("integration.eta_factor", params_.eta_factor);
  if (params_.guard_interval <= 0) throw InvalidArgument("integration.guard_interval", "must be positive");
  if (params_.max_speed <= 0) params_.max_speed = 0.1 * kRadius / params_.dt;

  lx_ = config.lx;
  ly_ = config.ly;
  require_positive("configuration.lx", lx_);
  require_positive("configuration.ly", ly_);
  periodic_x_ = (params_.effects & kPeriodicX) != 0;
  periodic_y_ = config.periodic_y;
  if (config.has_walls() && !(params_.effects & kWalls))
    throw InvalidArgument("effects", "the configuration has walls but the 'walls' effect is off");

  x_ = config.x;
  y_ = config.y;
  orient_c_.resize(n);
  orient_s_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    orient_c_[i] = std::cos(config.theta[i]);
    orient_s_[i] = std::sin(config.theta[i]);
  }
  vx_.assign(n, 0.0);
  vy_.assign(n, 0.0);
  omega_.assign(n, 0.0);
  fx_.assign(n, 0.0);
  fy_.assign(n, 0.0);
  torque_.assign(n, 0.0);

  bonds_.reserve(config.bonds.size() + n);
  for (const BondRecord& record : config.bonds) {
    if (record.i < 0 || record.j < 0 || static_cast<std::size_t>(record.i) >= n ||
        static_cast<std::size_t>(record.j) >= n || record.i == record.j)
      throw InvalidArgument("configuration.bonds", "bond joins invalid particles");
    bonds_.push_back(Bond{record.i, record.j, record.bix, record.biy, record.bjx, record.bjy, 0.0, 0.0});
  }

  if (config.has_walls()) {
    walls_active_ = true;
    wall_bottom_ = config.wall_bottom;
    wall_top_ = config.wall_top;
    wall_.assign(n, kNoWall);
    for (std::size_t i = 0; i < n; ++i) {
      if (y_[i] - kRadius < wall_bottom_ - params_.max_overlap || y_[i] + kRadius > wall_top_ + params_.max_overlap)
        throw InvalidArgument("configuration.y[" + std::to_string(i) + "]", "particle lies outside the walls");
      const std::int8_t side = config.wall.empty() ? std::int8_t{kNoWall} : config.wall[i];
      if (side != kNoWall) {
        wall_[i] = side;
        wall_members_.push_back(static_cast<std::int32_t>(i));
        wall_offset_.push_back(y_[i] - (side == kBottomWall ? wall_bottom_ : wall_top_));
      }
    }
  }

  rebuild_neighbours();
  // Reject what the overlap term cannot resolve: any bonded or touching pair overlapping
  // by more than the stability bound.
  auto check_pair = [&](std::int32_t i, std::int32_t j, double sx, double sy, const char* what) {
    const double dx = x_[j] + sx - x_[i], dy = y_[j] + sy - y_[i];
    const double gap = std::sqrt(dx * dx + dy * dy) - kDiameter;
    if (gap < -params_.max_overlap)
      throw InvalidArgument("configuration", std::string(what) + " particles " + std::to_string(i) + " and " +
                                                 std::to_string(j) + " overlap by " + number(-gap) +
                                                 " a, more than the overlap term can resolve (max_overlap " +
                                                 number(params_.max_overlap) + " a)");
  };
  for (const Bond& bond : bonds_) check_pair(bond.i, bond.j, bond.shift_x, bond.shift_y, "bonded");
  for (const Candidate& pair : candidates_) check_pair(pair.i, pair.j, pair.shift_x, pair.shift_y, "unbonded");
  compute_forces();
}

// ---------------------------------------------------------------------------------------
// Neighbour search: a cell list builds the unbonded pairs within 2a + skin; they are the only
// candidates for new bonds until some particle may have moved skin/2.

// Positions are never wrapped back into the periodic box during a run (only the cell index
// and the configuration written out wrap them): a wrap at each rebuild would make the rounding of
// every later bond vector depend on when the rebuilds happen, i.e. on the skin.
void System::rebuild_neighbours() {
  const std::size_t n = size();
  for (Bond& bond : bonds_) {
    bond.shift_x = periodic_x_ ? -lx_ * std::round((x_[bond.j] - x_[bond.i]) / lx_) : 0.0;
    bond.shift_y = periodic_y_ ? -ly_ * std::round((y_[bond.j] - y_[bond.i]) / ly_) : 0.0;
  }
  bond_scratch_->bonds.valid = false;

  // Bonded partners, to leave bonded pairs out of the candidates.
  std::vector<std::int32_t> degree(n + 1, 0);
  for (const Bond& bond : bonds_) {
    ++degree[bond.i + 1];
    ++degree[bond.j + 1];
  }
  for (std::size_t i = 0; i < n; ++i) degree[i + 1] += degree[i];
  std::vector<std::int32_t> partners(degree[n]);
  {
    std::vector<std::int32_t> fill(degree.begin(), degree.end() - 1);
    for (const Bond& bond : bonds_) {
      partners[fill[bond.i]++] = bond.j;
      partners[fill[bond.j]++] = bond.i;
    }
  }
  auto bonded = [&](std::int32_t i, std::int32_t j) {
    for (std::int32_t k = degree[i]; k < degree[i + 1]; ++k)
      if (partners[k] == j) return true;
    return false;
  };

  const double cutoff = kDiameter + params_.skin;
  double x_min = 0, x_span = lx_, y_min = 0, y_span = ly_;
  if (!periodic_x_) {
    const auto [lo, hi] = std::minmax_element(x_.begin(), x_.end());
    x_min = *lo;
    x_span = *hi - *lo + 1e-9;
  }
  if (!periodic_y_) {
    const auto [lo, hi] = std::minmax_element(y_.begin(), y_.end());
    y_min = *lo;
    y_span = *hi - *lo + 1e-9;
  }
  const int cells_x = std::max(1, static_cast<int>(x_span / cutoff));
  const int cells_y = std::max(1, static_cast<int>(y_span / cutoff));
  const double cell_w = x_span / cells_x, cell_h = y_span / cells_y;
  auto cell_index = [&](std::size_t i) {
    const double xi = periodic_x_ ? x_[i] - lx_ * std::floor(x_[i] / lx_) : x_[i];
    const double yi = periodic_y_ ? y_[i] - ly_ * std::floor(y_[i] / ly_) : y_[i];
    int cx = static_cast<int>((xi - x_min) / cell_w);
    int cy = static_cast<int>((yi - y_min) / cell_h);
    cx = std::clamp(cx, 0, cells_x - 1);
    cy = std::clamp(cy, 0, cells_y - 1);
    return cy * cells_x + cx;
  };
  const int cell_count = cells_x * cells_y;
  std::vector<std::int32_t> cell_start(cell_count + 1, 0), cell_of(n), members(n);
  for (std::size_t i = 0; i < n; ++i) {
    cell_of[i] = cell_index(i);
    ++cell_start[cell_of[i] + 1];
  }
  for (int c = 0; c < cell_count; ++c) cell_start[c + 1] += cell_start[c];
  {
    std::vector<std::int32_t> fill(cell_start.begin(), cell_start.end() - 1);
    for (std::size_t i = 0; i < n; ++i) members[fill[cell_of[i]]++] = static_cast<std::int32_t>(i);
  }

  candidates_.clear();
  const double cutoff_sq = cutoff * cutoff;
  for (int cy = 0; cy < cells_y; ++cy) {
    for (int cx = 0; cx < cells_x; ++cx) {
      // The distinct neighbour cells (a small periodic grid would otherwise repeat them).
      std::array<int, 9> neighbours{};
      int count = 0;
      for (int oy = -1; oy <= 1; ++oy) {
        int ny = cy + oy;
        if (ny < 0 || ny >= cells_y) {
          if (!periodic_y_) continue;
          ny = (ny + cells_y) % cells_y;
        }
        for (int ox = -1; ox <= 1; ++ox) {
          int nx = cx + ox;
          if (nx < 0 || nx >= cells_x) {
            if (!periodic_x_) continue;
            nx = (nx + cells_x) % cells_x;
          }
          const int c = ny * cells_x + nx;
          if (std::find(neighbours.begin(), neighbours.begin() + count, c) == neighbours.begin() + count)
            neighbours[count++] = c;
        }
      }
      const int home = cy * cells_x + cx;
      for (std::int32_t a = cell_start[home]; a < cell_start[home + 1]; ++a) {
        const std::int32_t i = members[a];
        for (int k = 0; k < count; ++k) {
          const int c = neighbours[k];
          for (std::int32_t b = cell_start[c]; b < cell_start[c + 1]; ++b) {
            const std::int32_t j = members[b];
            if (j <= i) continue;
            double dx = x_[j] - x_[i], dy = y_[j] - y_[i];
            const double sx = periodic_x_ ? -lx_ * std::round(dx / lx_) : 0.0;
            const double sy = periodic_y_ ? -ly_ * std::round(dy / ly_) : 0.0;
            dx += sx;
            dy += sy;
            if (dx * dx + dy * dy >= cutoff_sq) continue;
            if (bonded(i, j)) continue;
            candidates_.push_back(Candidate{i, j, sx, sy});
          }
        }
      }
    }
  }

  wall_candidates_.clear();
  if (walls_active_) {
    for (std::size_t i = 0; i < n; ++i) {
      if (wall_[i] != kNoWall) continue;
      if (y_[i] - kRadius < wall_bottom_ + params_.skin || y_[i] + kRadius > wall_top_ - params_.skin)
        wall_candidates_.push_back(static_cast<std::int32_t>(i));
    }
  }
  travel_ = 0;
  wall_travel_ = 0;
  ++rebuilds_;
}

void System::maybe_rebuild() {
  // Two particles approach each other by at most 2 travel_, a particle and a wall by
  // travel_ + wall_travel_: both stay below the skin while this sum is below skin/2.
  if (travel_ + wall_travel_ > 0.5 * params_.skin) rebuild_neighbours();
}

// ---------------------------------------------------------------------------------------
// Bonds

void System::create_bond(std::int32_t i, std::int32_t j, double shift_x, double shift_y) {
  const double dx = x_[j] + shift_x - x_[i], dy = y_[j] + shift_y - y_[i];
  const double r = std::sqrt(dx * dx + dy * dy);
  const double nx = dx / r, ny = dy / r;
  Bond bond{i, j, 0, 0, 0, 0, shift_x, shift_y};
  to_body(orient_c_[i], orient_s_[i], nx, ny, bond.bix, bond.biy);
  to_body(orient_c_[j], orient_s_[j], -nx, -ny, bond.bjx, bond.bjy);
  bonds_.push_back(bond);
  bond_scratch_->bonds.valid = false;
  ++events_.created;
  // The bond forms at delta <= 0 (the step overshoots contact by at most v dt), so it
  // starts with a little normal energy; the ledger keeps it to close the energy balance.
  const BondGeometry g{nx, ny, r - kDiameter, nx, ny, -nx, -ny};
  ledger_.created += gel::bond_energy(g, params_.bond, params_.effects).total();
}

void System::detect_contacts() {
  const double contact_sq = kDiameter * kDiameter;
  touching_.clear();
  for (std::size_t c = 0; c < candidates_.size();) {
    const Candidate& pair = candidates_[c];
    const double dx = x_[pair.j] + pair.shift_x - x_[pair.i];
    const double dy = y_[pair.j] + pair.shift_y - y_[pair.i];
    if (dx * dx + dy * dy <= contact_sq) [[unlikely]] {
      touching_.push_back(pair);
      candidates_[c] = candidates_.back();
      candidates_.pop_back();
    } else {
      ++c;
    }
  }
  if (touching_.empty()) [[likely]]
    return;
  // The candidate list follows the cell grid, whose cells are 2a + skin wide: bonds formed in one
  // step are appended in (i, j) order instead, so that the bond order (the order in which each
  // particle's forces are summed) does not depend on the skin.
  std::sort(touching_.begin(), touching_.end(),
            [](const Candidate& a, const Candidate& b) { return a.i != b.i ? a.i < b.i : a.j < b.j; });
  for (const Candidate& pair : touching_) create_bond(pair.i, pair.j, pair.shift_x, pair.shift_y);
}

BondGeometry System::geometry(const Bond& bond) const {
  const double dx = x_[bond.j] + bond.shift_x - x_[bond.i];
  const double dy = y_[bond.j] + bond.shift_y - y_[bond.i];
  const double r = std::sqrt(dx * dx + dy * dy);
  BondGeometry g{dx / r, dy / r, r - kDiameter, 0, 0, 0, 0};
  to_lab(orient_c_[bond.i], orient_s_[bond.i], bond.bix, bond.biy, g.xi_ix, g.xi_iy);
  to_lab(orient_c_[bond.j], orient_s_[bond.j], bond.bjx, bond.bjy, g.xi_jx, g.xi_jy);
  return g;
}

double System::bond_energy(const Bond& bond) const {
  return gel::bond_energy(geometry(bond), params_.bond, params_.effects).total();
}

double System::stored_energy() const {
  double total = 0;
  for (const Bond& bond : bonds_) total += bond_energy(bond);
  return total;
}

// Slow path of the bond loop, taken only when a threshold is exceeded. Returns true when the
// bond broke (it is marked and contributes no force), false when it was reset.
bool System::handle_threshold(std::size_t b, double fn, double ft_sq, double moment, double nx, double ny) {
  Bond& bond = bonds_[b];
  const BondGeometry g = geometry(bond);
  const BondEnergy energy = gel::bond_energy(g, params_.bond, params_.effects);
  const BondLaw& law = params_.bond;
  if (fn > law.f_normal_critical) {
    ledger_.dissipated += energy.total();
    ++events_.normal;
    if (bond_marked_.size() < bonds_.size()) bond_marked_.resize(bonds_.size(), 0);
    bond_marked_[b] = 1;
    return true;
  }
  // A reset re-records both contact points at the current line of centres: d = 0, phi = 0.
  // It is one event, whichever thresholds it passed, so that rupture rates count resets: when
  // both tangential thresholds are exceeded in the same step it goes to the cause exceeded by
  // the larger factor (|F_T| / F_Sc against |M_R| / M_Rc; sliding on a tie).
  const double sliding_excess = std::sqrt(ft_sq) / law.f_sliding_critical;
  const double rolling_excess = std::abs(moment) / law.m_rolling_critical;
  if (sliding_excess >= rolling_excess) ++events_.sliding;
  else ++events_.rolling;
  ledger_.dissipated += energy.sliding + energy.rolling;
  to_body(orient_c_[bond.i], orient_s_[bond.i], nx, ny, bond.bix, bond.biy);
  to_body(orient_c_[bond.j], orient_s_[bond.j], -nx, -ny, bond.bjx, bond.bjy);
  if (bond_scratch_->bonds.valid) bond_scratch_->bonds.set(b, bond);
  return false;
}

void System::remove_marked_bonds() {
  // Back to front, so that swap-removal never moves an unvisited marked bond.
  for (std::size_t b = bond_marked_.size(); b-- > 0;) {
    if (!bond_marked_[b]) continue;
    const Bond& bond = bonds_[b];
    // A broken pair may bond again when it touches again: it is a candidate from now on.
    if (params_.effects & kBondCreation) candidates_.push_back(Candidate{bond.i, bond.j, bond.shift_x, bond.shift_y});
    bonds_[b] = bonds_.back();
    bonds_.pop_back();
  }
  bond_marked_.clear();
  bond_scratch_->bonds.valid = false;
}

// Pass 2 of the bond loop (bond_kernels.hpp): one bond flagged by pass 1 evaluated exactly, with
// its thresholds, into the per-bond results. Returns true when the bond broke (it is marked and
// contributes no force).
template <unsigned kMask>
bool System::bond_force_exact(std::size_t b, double& min_delta) {
  using Evaluator = BondEvaluator<kMask & kBondEffectBits>;
  constexpr bool kCheckThresholds = (kMask & kThresholds) != 0;
  const BondLaw& law = params_.bond;
  detail::BondForceArrays& out = bond_scratch_->forces;
  const Bond& bond = bonds_[b];
  const std::int32_t i = bond.i, j = bond.j;
  double dx = x_[j] - x_[i], dy = y_[j] - y_[i];
  if constexpr ((kMask & kShiftBit) != 0) {
    dx += bond.shift_x;
    dy += bond.shift_y;
  }
  BondGeometry g = detail::line_of_centres(dx, dy);
  if constexpr (Evaluator::needs_contact_points()) {
    to_lab(orient_c_[i], orient_s_[i], bond.bix, bond.biy, g.xi_ix, g.xi_iy);
    to_lab(orient_c_[j], orient_s_[j], bond.bjx, bond.bjy, g.xi_jx, g.xi_jy);
  }
  BondForces f = Evaluator::evaluate(g, law);
  if constexpr (kCheckThresholds) {
    const double ft_sq = f.sliding_x * f.sliding_x + f.sliding_y * f.sliding_y;
    if (f.normal_force > law.f_normal_critical || ft_sq > law.f_sliding_critical * law.f_sliding_critical ||
        std::abs(f.rolling_moment) > law.m_rolling_critical) {
      if (handle_threshold(b, f.normal_force, ft_sq, f.rolling_moment, g.nx, g.ny)) {
        out.state[b] = detail::BondForceArrays::kBroken;
        return true;
      }
      f.sliding_x = f.sliding_y = f.rolling_moment = 0.0;
    }
  }
  const detail::BondOutput o = detail::bond_output(f, g);
  out.force_x[b] = o.force_x;
  out.force_y[b] = o.force_y;
  out.torque_i[b] = o.torque_i;
  out.torque_j[b] = o.torque_j;
  min_delta = std::min(min_delta, g.delta);
  return false;
}

// The three passes of bond_kernels.hpp. Every particle's force is the same sequence of additions
// (its bonds in bond order) for any number of threads, so results are bit-identical.
template <unsigned kMask>
void System::bond_forces() {
  constexpr unsigned kEffects = kMask & kBondEffectBits;
  constexpr bool kShift = (kMask & kShiftBit) != 0;
  constexpr bool kCheckThresholds = (kMask & kThresholds) != 0;
  const BondLaw law = params_.bond;
  detail::BondScratch& scratch = *bond_scratch_;
  detail::BondArrays& arrays = scratch.bonds;
  detail::BondForceArrays& forces = scratch.forces;
  const std::size_t bond_count = bonds_.size();
  if (!arrays.valid) arrays.assign(bonds_, size());
  if (forces.state.size() != bond_count) {
    for (auto* column : {&forces.force_x, &forces.force_y, &forces.torque_i, &forces.torque_j, &forces.delta})
      column->resize(bond_count);
    forces.state.resize(bond_count);
  }

  auto pass1 = [&](std::size_t begin, std::size_t count, double* out_fx, double* out_fy, double* out_ti, double* out_tj,
                   double* out_delta, detail::BondState* out_state) {
    detail::bond_chunk_forces<kEffects, kShift, kCheckThresholds>(arrays, begin, count, x_.data(), y_.data(),
                                                                  orient_c_.data(), orient_s_.data(), law, out_fx, out_fy,
                                                                  out_ti, out_tj, out_delta, out_state);
  };
  double min_delta = min_delta_;
  bool any_broken = false;
  const std::size_t n = size();

  if (!pool_) {
    // One thread: each chunk's passes back to back while its results are in L1, the sums as a
    // scatter in bond order, which adds to each particle in the same order as pass 3 would.
    std::fill(fx_.begin(), fx_.end(), 0.0);
    std::fill(fy_.begin(), fy_.end(), 0.0);
    std::fill(torque_.begin(), torque_.end(), 0.0);
    double* __restrict fx = fx_.data();
    double* __restrict fy = fy_.data();
    double* __restrict torque = torque_.data();
    // A separate minimum for the exact path, whose address is taken, keeps this one in a register.
    double exact_min_delta = min_delta;
    detail::BondChunkForces& chunk = scratch.chunk;
    for (std::size_t begin = 0; begin < bond_count; begin += detail::kBondChunk) {
      const std::size_t count = std::min(detail::kBondChunk, bond_count - begin);
      pass1(begin, count, chunk.force_x, chunk.force_y, chunk.torque_i, chunk.torque_j, chunk.delta, chunk.state);
      for (std::size_t k = 0; k < count; ++k) {
        if (chunk.state[k] == detail::BondForceArrays::kExact) [[unlikely]] {
          // Pass 2 writes into the all-bond arrays; this bond's results are read from there.
          const std::size_t b = begin + k;
          if (bond_force_exact<kMask>(b, exact_min_delta)) {
            any_broken = true;
            continue;
          }
          chunk.force_x[k] = forces.force_x[b];
          chunk.force_y[k] = forces.force_y[b];
          chunk.torque_i[k] = forces.torque_i[b];
          chunk.torque_j[k] = forces.torque_j[b];
        } else {
          min_delta = std::min(min_delta, chunk.delta[k]);
        }
        const std::int32_t i = arrays.i[begin + k], j = arrays.j[begin + k];
        fx[i] += chunk.force_x[k];
        fy[i] += chunk.force_y[k];
        fx[j] -= chunk.force_x[k];
        fy[j] -= chunk.force_y[k];
        torque[i] += chunk.torque_i[k];
        torque[j] += chunk.torque_j[k];
      }
    }
    min_delta_ = std::min(min_delta, exact_min_delta);
    if (any_broken) remove_marked_bonds();
    return;
  }

  // Several threads: bigger tasks than the one-thread chunks (fewer hand-outs, no L1 reuse to keep).
  constexpr std::size_t kTaskBonds = 8 * detail::kBondChunk;
  const std::size_t tasks = (bond_count + kTaskBonds - 1) / kTaskBonds;
  scratch.chunk_min_delta.resize(tasks);
  parallel(tasks, [&](std::size_t chunk) {
    const std::size_t begin = chunk * kTaskBonds, count = std::min(kTaskBonds, bond_count - begin);
    pass1(begin, count, forces.force_x.data() + begin, forces.force_y.data() + begin, forces.torque_i.data() + begin,
          forces.torque_j.data() + begin, forces.delta.data() + begin, forces.state.data() + begin);
    scratch.chunk_min_delta[chunk] = detail::common_min_delta(forces, begin, count);
  });
  for (const double chunk_min : scratch.chunk_min_delta) min_delta = std::min(min_delta, chunk_min);
  for (std::size_t b = 0; b < bond_count; ++b)
    if (forces.state[b] == detail::BondForceArrays::kExact) [[unlikely]]
      any_broken |= bond_force_exact<kMask>(b, min_delta);
  parallel((n + detail::kParticleBlock - 1) / detail::kParticleBlock, [&](std::size_t block) {
    const std::size_t begin = block * detail::kParticleBlock;
    detail::sum_bond_forces(arrays, forces, begin, std::min(n, begin + detail::kParticleBlock), fx_.data(), fy_.data(),
                            torque_.data());
  });
  min_delta_ = min_delta;
  if (any_broken) remove_marked_bonds();
}

void System::dispatch_bond_forces() {
  static constexpr auto table = []<std::size_t... kMasks>(std::index_sequence<kMasks...>) {
    return std::array<void (System::*)(), kBondVariants>{&System::bond_forces<kMasks>...};
  }(std::make_index_sequence<kBondVariants>{});
  const unsigned mask = (params_.effects & kBondEffectBits) | ((periodic_x_ || periodic_y_) ? kShiftBit : 0u);
  (this->*table[mask])();
}

// ---------------------------------------------------------------------------------------
// Forces, walls, external loads

void System::apply_external_forces() {
  double power = 0;
  for (const ExternalForce& load : external_) {
    fx_[load.i] += load.fx;
    fy_[load.i] += load.fy;
    power += load.fx * vx_[load.i] + load.fy * vy_[load.i];
  }
  external_power_ = power;
}

void System::collect_wall_forces() {
  WallStress stress;
  double power = 0;
  for (const std::int32_t i : wall_members_) {
    if (wall_[i] == kTopWall)
      stress.force_top += fy_[i];
    else
      stress.force_bottom += fy_[i];
    // Power that the wall, moving the particle, feeds into the bonds.
    power -= fx_[i] * vx_[i] + fy_[i] * vy_[i];
    // A wall particle moves with the wall: its bond forces are taken by the wall.
    fx_[i] = fy_[i] = torque_[i] = 0.0;
  }
  stress.p_top = stress.force_top / (kThickness * lx_);
  stress.p_bottom = -stress.force_bottom / (kThickness * lx_);
  stress.p = 0.5 * (stress.p_top + stress.p_bottom);
  wall_stress_ = stress;
  wall_power_ = power;
}

WallStress System::wall_stress() const { return wall_stress_; }

void System::compute_forces() {
  dispatch_bond_forces();  // writes every particle's force and torque (from zero)
  if (!external_.empty()) apply_external_forces();
  if (walls_active_) collect_wall_forces();
  forces_valid_ = true;
}

void System::impose_wall_motion() {
  for (std::size_t k = 0; k < wall_members_.size(); ++k) {
    const std::int32_t i = wall_members_[k];
    const bool top = wall_[i] == kTopWall;
    y_[i] = (top ? wall_top_ : wall_bottom_) + wall_offset_[k];
    vx_[i] = 0.0;
    vy_[i] = top ? wall_v_top_ : wall_v_bottom_;
    omega_[i] = 0.0;
  }
}

void System::attach(std::int32_t i, WallSide side) {
  // The particle's own motion is lost to the wall it sticks to.
  ledger_.absorbed_by_walls += 0.5 * kMass * (vx_[i] * vx_[i] + vy_[i] * vy_[i]) + 0.5 * kInertia * omega_[i] * omega_[i];
  wall_[i] = side;
  wall_members_.push_back(i);
  wall_offset_.push_back(y_[i] - (side == kTopWall ? wall_top_ : wall_bottom_));
  vx_[i] = 0.0;
  vy_[i] = side == kTopWall ? wall_v_top_ : wall_v_bottom_;
  omega_[i] = 0.0;
}

void System::attach_to_walls() {
  attaching_.clear();
  for (std::size_t c = 0; c < wall_candidates_.size();) {
    const std::int32_t i = wall_candidates_[c];
    if (y_[i] - kRadius <= wall_bottom_ || y_[i] + kRadius >= wall_top_) [[unlikely]] {
      attaching_.push_back(i);
      wall_candidates_[c] = wall_candidates_.back();
      wall_candidates_.pop_back();
    } else {
      ++c;
    }
  }
  if (attaching_.empty()) [[likely]]
    return;
  // In particle order, like the bonds above: the wall force is summed over wall_members_.
  std::sort(attaching_.begin(), attaching_.end());
  for (const std::int32_t i : attaching_) attach(i, y_[i] - kRadius <= wall_bottom_ ? kBottomWall : kTopWall);
}

// ---------------------------------------------------------------------------------------
// Integration: velocity Verlet with Stokes drag (the loops are in integrator_kernels.hpp).

detail::KickCoefficients System::kick_coefficients() const {
  const double dt = params_.dt;
  return {dt, 0.5 * dt / kMass, 0.5 * dt / kInertia, params_.drag_translation(), params_.drag_rotation()};
}

template <bool kDragOn>
void System::first_half_kick_and_drift() {
  const std::size_t n = size();
  const std::size_t blocks = (n + detail::kParticleBlock - 1) / detail::kParticleBlock;
  kick_totals_.resize(blocks);
  const detail::KickCoefficients k = kick_coefficients();
  parallel(blocks, [&](std::size_t block) {
    const std::size_t begin = block * detail::kParticleBlock, count = std::min(detail::kParticleBlock, n - begin);
    kick_totals_[block] = detail::kick_and_drift<kDragOn>(
        count, k, x_.data() + begin, y_.data() + begin, orient_c_.data() + begin, orient_s_.data() + begin,
        vx_.data() + begin, vy_.data() + begin, omega_.data() + begin, fx_.data() + begin, fy_.data() + begin,
        torque_.data() + begin);
  });
  // Blocks combined in order: the same sum for any number of threads.
  double max_speed_sq = 0, drag_power = 0;
  for (const detail::KickTotals& totals : kick_totals_) {
    max_speed_sq = std::max(max_speed_sq, totals.max_speed_sq);
    drag_power += totals.drag_power;
  }
  max_speed_sq_ = max_speed_sq;
  if constexpr (kDragOn) ledger_.drag += 0.5 * params_.dt * drag_power;
}

template <bool kDragOn>
void System::second_half_kick() {
  const std::size_t n = size();
  const std::size_t blocks = (n + detail::kParticleBlock - 1) / detail::kParticleBlock;
  kick_totals_.resize(blocks);
  const detail::KickCoefficients k = kick_coefficients();
  parallel(blocks, [&](std::size_t block) {
    const std::size_t begin = block * detail::kParticleBlock, count = std::min(detail::kParticleBlock, n - begin);
    kick_totals_[block].drag_power = detail::second_kick<kDragOn>(count, k, vx_.data() + begin, vy_.data() + begin,
                                                                  omega_.data() + begin, fx_.data() + begin,
                                                                  fy_.data() + begin, torque_.data() + begin);
  });
  double drag_power = 0;
  for (const detail::KickTotals& totals : kick_totals_) drag_power += totals.drag_power;
  if constexpr (kDragOn) ledger_.drag += 0.5 * params_.dt * drag_power;
}

template <class Task>
void System::parallel(std::size_t tasks, Task&& task) {
  if (pool_)
    pool_->run(tasks, task);
  else
    for (std::size_t t = 0; t < tasks; ++t) task(t);
}

void System::set_time_step(double dt) {
  require_positive("integration.dt", dt);
  if (dt == params_.dt) return;
  params_.max_speed *= params_.dt / dt;
  params_.dt = dt;
}

void System::set_threads(int threads) {
  if (threads < 1) throw InvalidArgument("threads", "must be >= 1");
  if (threads == this->threads()) return;
  pool_ = threads == 1 ? nullptr : std::make_unique<detail::WorkerPool>(threads);
}

int System::threads() const { return pool_ ? pool_->threads() : 1; }

void System::step() {
  if (!forces_valid_) compute_forces();
  const double dt = params_.dt;
  const bool drag = (params_.effects & kDrag) != 0;
  const double wall_power_before = wall_power_, external_power_before = external_power_;

  // Wall particles were given the wall's velocity and no force, so the kick leaves them on
  // the wall's path up to drag, which impose_wall_motion() removes again.
  if (drag)
    first_half_kick_and_drift<true>();
  else
    first_half_kick_and_drift<false>();
  if (!(max_speed_sq_ <= params_.max_speed * params_.max_speed)) [[unlikely]] check_stability();
  travel_ += std::sqrt(max_speed_sq_) * dt;

  if (walls_active_) {
    wall_bottom_ += wall_v_bottom_ * dt;
    wall_top_ += wall_v_top_ * dt;
    wall_travel_ += std::max(std::abs(wall_v_bottom_), std::abs(wall_v_top_)) * dt;
    impose_wall_motion();
  }
  after_drift();

  compute_forces();
  if (drag)
    second_half_kick<true>();
  else
    second_half_kick<false>();
  if (walls_active_) {
    impose_wall_motion();
    // Drag on wall particles is the wall's business, not the network's.
    if (drag) {
      const double gamma = params_.drag_translation();
      for (const std::int32_t i : wall_members_) ledger_.drag -= dt * gamma * vy_[i] * vy_[i];
    }
    ledger_.wall_work += 0.5 * dt * (wall_power_before + wall_power_);
  }
  if (!external_.empty()) {
    double power = 0;
    for (const ExternalForce& load : external_) power += load.fx * vx_[load.i] + load.fy * vy_[load.i];
    ledger_.external_work += 0.5 * dt * (external_power_before + power);
    external_power_ = power;
  }
  time_ += dt;
  ++step_count_;
  if (step_count_ % params_.guard_interval == 0) check_stability();
}

void System::run(std::int64_t steps) {
  for (std::int64_t k = 0; k < steps; ++k) step();
}

// ---------------------------------------------------------------------------------------
// Stability guard

void System::stability_failure(const std::string& what) const {
  throw StabilityError("step " + std::to_string(step_count_) + " (t = " + number(time_) + "): " + what +
                       "; dt = " + number(params_.dt) + " (reduce integration.dt_fraction or the load)");
}

double System::bond_gap(const Bond& bond) const {
  const double dx = x_[bond.j] + bond.shift_x - x_[bond.i], dy = y_[bond.j] + bond.shift_y - y_[bond.i];
  return std::sqrt(dx * dx + dy * dy) - kDiameter;
}

void System::check_stability() {
  const std::size_t n = size();
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i)
    sum += x_[i] + y_[i] + vx_[i] + vy_[i] + omega_[i] + fx_[i] + fy_[i] + torque_[i] + orient_c_[i];
  if (!std::isfinite(sum)) {
    const std::array<std::pair<const char*, const std::vector<double>*>, 9> fields{{
        {"x", &x_}, {"y", &y_}, {"vx", &vx_}, {"vy", &vy_}, {"omega", &omega_},
        {"fx", &fx_}, {"fy", &fy_}, {"torque", &torque_}, {"orientation", &orient_c_}}};
    for (std::size_t i = 0; i < n; ++i)
      for (const auto& [name, values] : fields)
        if (!std::isfinite((*values)[i]))
          stability_failure("particle " + std::to_string(i) + " has non-finite " + name + " = " + number((*values)[i]));
    stability_failure("state values overflow (sum of state is " + number(sum) + ")");
  }
  const double limit_sq = params_.max_speed * params_.max_speed;
  for (std::size_t i = 0; i < n; ++i) {
    const double speed_sq = std::max(vx_[i] * vx_[i] + vy_[i] * vy_[i], kRadius * kRadius * omega_[i] * omega_[i]);
    if (!(speed_sq <= limit_sq))
      stability_failure("particle " + std::to_string(i) + " moves at " + number(std::sqrt(speed_sq)) +
                        " a/t0, beyond the bound max_speed = " + number(params_.max_speed) + " a/t0");
  }
  if (min_delta_ < -params_.max_overlap) {
    for (std::size_t b = 0; b < bonds_.size(); ++b) {
      const Bond& bond = bonds_[b];
      const double gap = bond_gap(bond);
      if (gap < -params_.max_overlap)
        stability_failure("bond " + std::to_string(b) + " (particles " + std::to_string(bond.i) + "-" +
                          std::to_string(bond.j) + ") overlaps by " + number(-gap) + " a, beyond max_overlap = " +
                          number(params_.max_overlap) + " a");
    }
  }
  if (params_.effects & kOverlapRepulsion) check_contact_stiffness();
  min_delta_ = 0;
}

// The cubic term stiffens a compressed contact to k_c = k_N + 3 C delta^2, and velocity Verlet
// is unstable once omega dt > 2 for the stiffest mode. A particle pressed by several contacts
// is stiffer than any one of them. Gershgorin's bound on the dynamical matrix (a row of particle
// i holds k_c n n^T on the diagonal and -k_c n n^T off it, and n_x^2 + |n_x n_y| <= (1 + sqrt 2)/2)
// gives omega^2 <= max_i (1 + sqrt 2) sum_{c at i} k_c / m. The sum is taken only when the most
// compressed contact could reach the limit with seven such contacts (the most a disk has at
// small overlaps), so that an ordinary step pays nothing for it.
namespace {
constexpr double kGershgorinFactor = 2.414213562373095;  // 1 + sqrt 2
}

double System::contact_stiffness(double delta) const {
  const BondLaw& law = params_.bond;
  const double overlap = std::min(delta, 0.0);
  return law.k_normal + 3.0 * law.overlap_coefficient * overlap * overlap;
}

std::vector<double> System::summed_contact_stiffness() const {
  std::vector<double> summed(size(), 0.0);
  for (const Bond& bond : bonds_) {
    const double k = contact_stiffness(bond_gap(bond));
    summed[bond.i] += k;
    summed[bond.j] += k;
  }
  return summed;
}

double System::fastest_contact_frequency() const {
  const std::vector<double> summed = summed_contact_stiffness();
  double largest = 0;
  for (std::size_t i = 0; i < size(); ++i)
    if (wall_side(i) == kNoWall) largest = std::max(largest, summed[i]);  // wall particles are not integrated
  return std::sqrt(kGershgorinFactor * largest / kMass);
}

void System::check_contact_stiffness() {
  if (std::sqrt(kGershgorinFactor * 7.0 * contact_stiffness(min_delta_) / kMass) * params_.dt <= 2.0) return;
  const std::vector<double> summed = summed_contact_stiffness();
  for (std::size_t i = 0; i < size(); ++i) {
    if (wall_side(i) != kNoWall) continue;  // moved with its wall, not integrated
    const double omega_dt = std::sqrt(kGershgorinFactor * summed[i] / kMass) * params_.dt;
    if (omega_dt > 2.0)
      stability_failure("the contacts of particle " + std::to_string(i) + " (most compressed overlap " + number(-min_delta_) +
                        " a) stiffen it to " + number(summed[i]) + " F0/a: omega dt = " + number(omega_dt) +
                        " exceeds the Verlet limit 2");
  }
}

// ---------------------------------------------------------------------------------------
// Observables and state

double System::theta(std::size_t i) const { return std::atan2(orient_s_[i], orient_c_[i]); }

double System::kinetic_energy() const {
  double energy = 0;
  for (std::size_t i = 0; i < size(); ++i) {
    if (wall_side(i) != kNoWall) continue;
    energy += 0.5 * kMass * (vx_[i] * vx_[i] + vy_[i] * vy_[i]) + 0.5 * kInertia * omega_[i] * omega_[i];
  }
  return energy;
}

double System::max_speed() const {
  double speed_sq = 0;
  for (std::size_t i = 0; i < size(); ++i) {
    if (wall_side(i) != kNoWall) continue;
    speed_sq = std::max({speed_sq, vx_[i] * vx_[i] + vy_[i] * vy_[i], kRadius * kRadius * omega_[i] * omega_[i]});
  }
  return std::sqrt(speed_sq);
}

double System::mean_contact_number() const { return 2.0 * static_cast<double>(bonds_.size()) / static_cast<double>(size()); }

double System::packing_fraction() const {
  const double height = walls_active_ ? wall_top_ - wall_bottom_ : ly_;
  return kPi * kRadius * kRadius * static_cast<double>(size()) / (lx_ * height);
}

void System::set_wall_velocities(double v_bottom, double v_top) {
  require_finite("v_bottom", v_bottom);
  require_finite("v_top", v_top);
  wall_v_bottom_ = v_bottom;
  wall_v_top_ = v_top;
  if (walls_active_) {
    impose_wall_motion();
    forces_valid_ = false;
  }
}

void System::install_walls() {
  if (walls_active_) throw std::logic_error("walls are already installed");
  if (!(params_.effects & kWalls)) throw InvalidArgument("effects", "walls need the 'walls' effect");
  // Into the box first, so that the bonds across y = 0 are those whose shift is not 0.
  wrap_into_box();
  rebuild_neighbours();
  if (periodic_y_) {
    for (std::size_t b = bonds_.size(); b-- > 0;) {
      if (bonds_[b].shift_y == 0.0) continue;
      ledger_.dissipated += bond_energy(bonds_[b]);
      bonds_[b] = bonds_.back();
      bonds_.pop_back();
      bond_scratch_->bonds.valid = false;
    }
  }
  periodic_y_ = false;
  walls_active_ = true;
  const auto [lo, hi] = std::minmax_element(y_.begin(), y_.end());
  wall_bottom_ = *lo - kRadius;
  wall_top_ = *hi + kRadius;
  wall_.assign(size(), kNoWall);
  wall_members_.clear();
  wall_offset_.clear();
  for (std::size_t i = 0; i < size(); ++i) {
    if (y_[i] - kRadius <= wall_bottom_) attach(static_cast<std::int32_t>(i), kBottomWall);
    else if (y_[i] + kRadius >= wall_top_) attach(static_cast<std::int32_t>(i), kTopWall);
  }
  rebuild_neighbours();
  forces_valid_ = false;
  compute_forces();
}

void System::translate_wall_group(WallSide side, double dy) {
  if (!walls_active_) throw std::logic_error("no walls");
  require_finite("dy", dy);
  // The group is every particle connected through bonds to the wall's particles, short of the
  // other wall's.
  const WallSide other = side == kTopWall ? kBottomWall : kTopWall;
  const std::vector<char> in_group = bonded_group(
      size(), bonds_, [&](std::size_t i) { return wall_[i] == side; }, [&](std::size_t i) { return wall_[i] == other; });
  for (std::size_t i = 0; i < size(); ++i)
    if (in_group[i] && wall_[i] == kNoWall) y_[i] += dy;
  if (side == kTopWall)
    wall_top_ += dy;
  else
    wall_bottom_ += dy;
  impose_wall_motion();
  rebuild_neighbours();
  forces_valid_ = false;
}

void System::set_external_force(std::int32_t i, double fx, double fy) {
  if (i < 0 || static_cast<std::size_t>(i) >= size()) throw InvalidArgument("particle", "no such particle");
  require_finite("force.x", fx);
  require_finite("force.y", fy);
  for (ExternalForce& load : external_)
    if (load.i == i) {
      load.fx = fx;
      load.fy = fy;
      forces_valid_ = false;
      return;
    }
  external_.push_back(ExternalForce{i, fx, fy});
  forces_valid_ = false;
}

void System::clear_external_forces() {
  external_.clear();
  external_power_ = 0;
  forces_valid_ = false;
}

void System::set_velocity(std::int32_t i, double vx, double vy, double omega) {
  vx_[i] = vx;
  vy_[i] = vy;
  omega_[i] = omega;
  forces_valid_ = false;
}

void System::set_position(std::int32_t i, double x, double y) {
  x_[i] = x;
  y_[i] = y;
  rebuild_neighbours();
  forces_valid_ = false;
}

void System::set_orientation(std::int32_t i, double theta) {
  orient_c_[i] = std::cos(theta);
  orient_s_[i] = std::sin(theta);
  forces_valid_ = false;
}

namespace {
void wrap_into(std::vector<double>& coordinates, double length) {
  for (double& c : coordinates) c -= length * std::floor(c / length);
}
}  // namespace

void System::wrap_into_box() {
  if (periodic_x_) wrap_into(x_, lx_);
  if (periodic_y_) wrap_into(y_, ly_);
}

Configuration System::configuration() const {
  Configuration config;
  config.lx = lx_;
  config.ly = ly_;
  config.periodic_y = periodic_y_;
  config.x = x_;
  config.y = y_;
  if (periodic_x_) wrap_into(config.x, lx_);
  if (periodic_y_) wrap_into(config.y, ly_);
  config.theta.resize(size());
  for (std::size_t i = 0; i < size(); ++i) config.theta[i] = theta(i);
  config.bonds.reserve(bonds_.size());
  for (const Bond& bond : bonds_)
    config.bonds.push_back(BondRecord{bond.i, bond.j, bond.bix, bond.biy, bond.bjx, bond.bjy});
  if (walls_active_) {
    config.wall = wall_;
    config.wall_bottom = wall_bottom_;
    config.wall_top = wall_top_;
  }
  return config;
}

}  // namespace gel
