// Checkpoint encoding of a System: every member that influences later steps, as the versioned
// message gel.v1.EngineState (proto/gel/v1/checkpoint.proto), so that a resumed run continues
// bit for bit (bond and candidate order included, since they set the order of floating-point
// sums). Doubles travel as their 64 bits.
#include <stdexcept>

#include "gel/system.hpp"

#include "bond_kernels.hpp"

namespace gel {
namespace {

template <typename T, typename Field>
void put_list(const std::vector<T>& values, Field* field) {
  field->Reserve(static_cast<int>(values.size()));
  for (const T& value : values) field->Add(value);
}

template <typename T, typename Field>
void get_list(const Field& field, std::vector<T>& values) {
  values.assign(field.begin(), field.end());
}

// Every list of one record type must have one entry per record.
void require_same_size(std::size_t expected, std::initializer_list<int> sizes, const char* what) {
  for (const int size : sizes)
    if (static_cast<std::size_t>(size) != expected) throw std::runtime_error(std::string("checkpoint state: inconsistent ") + what);
}

}  // namespace

void System::save_state(gel::v1::EngineState& m) const {
  m.Clear();
  const BondLaw& law = params_.bond;
  m.set_k_normal(law.k_normal);
  m.set_k_sliding(law.k_sliding);
  m.set_k_rolling(law.k_rolling);
  m.set_overlap_coefficient(law.overlap_coefficient);
  m.set_f_normal_critical(law.f_normal_critical);
  m.set_f_sliding_critical(law.f_sliding_critical);
  m.set_m_rolling_critical(law.m_rolling_critical);
  m.set_effects(params_.effects);
  m.set_dt(params_.dt);
  m.set_dt_fraction(params_.dt_fraction);
  m.set_eta_factor(params_.eta_factor);
  m.set_skin(params_.skin);
  m.set_guard_interval(params_.guard_interval);
  m.set_max_overlap(params_.max_overlap);
  m.set_max_speed(params_.max_speed);
  m.set_lx(lx_);
  m.set_ly(ly_);
  m.set_periodic_x(periodic_x_);
  m.set_periodic_y(periodic_y_);

  put_list(x_, m.mutable_x());
  put_list(y_, m.mutable_y());
  put_list(orient_c_, m.mutable_orient_cos());
  put_list(orient_s_, m.mutable_orient_sin());
  put_list(vx_, m.mutable_vx());
  put_list(vy_, m.mutable_vy());
  put_list(omega_, m.mutable_omega());
  put_list(fx_, m.mutable_fx());
  put_list(fy_, m.mutable_fy());
  put_list(torque_, m.mutable_torque());
  put_list(wall_, m.mutable_wall());

  for (const Bond& bond : bonds_) {
    m.add_bond_i(bond.i);
    m.add_bond_j(bond.j);
    m.add_bond_bix(bond.bix);
    m.add_bond_biy(bond.biy);
    m.add_bond_bjx(bond.bjx);
    m.add_bond_bjy(bond.bjy);
    m.add_bond_shift_x(bond.shift_x);
    m.add_bond_shift_y(bond.shift_y);
  }
  for (const Candidate& pair : candidates_) {
    m.add_candidate_i(pair.i);
    m.add_candidate_j(pair.j);
    m.add_candidate_shift_x(pair.shift_x);
    m.add_candidate_shift_y(pair.shift_y);
  }
  put_list(wall_candidates_, m.mutable_wall_candidates());
  m.set_travel(travel_);
  m.set_wall_travel(wall_travel_);
  m.set_rebuilds(rebuilds_);

  m.set_walls_active(walls_active_);
  m.set_wall_bottom(wall_bottom_);
  m.set_wall_top(wall_top_);
  m.set_wall_v_bottom(wall_v_bottom_);
  m.set_wall_v_top(wall_v_top_);
  put_list(wall_members_, m.mutable_wall_members());
  put_list(wall_offset_, m.mutable_wall_offset());
  m.set_wall_force_top(wall_stress_.force_top);
  m.set_wall_force_bottom(wall_stress_.force_bottom);
  m.set_wall_p_top(wall_stress_.p_top);
  m.set_wall_p_bottom(wall_stress_.p_bottom);
  m.set_wall_p(wall_stress_.p);
  m.set_wall_power(wall_power_);

  for (const ExternalForce& load : external_) {
    m.add_external_i(load.i);
    m.add_external_fx(load.fx);
    m.add_external_fy(load.fy);
  }
  m.set_external_power(external_power_);

  m.set_min_delta(min_delta_);
  m.set_max_speed_sq(max_speed_sq_);
  m.set_time(time_);
  m.set_step_count(step_count_);
  m.set_breaks(events_.normal);
  m.set_sliding_resets(events_.sliding);
  m.set_rolling_resets(events_.rolling);
  m.set_bonds_created(events_.created);
  m.set_dissipated(ledger_.dissipated);
  m.set_created(ledger_.created);
  m.set_drag(ledger_.drag);
  m.set_wall_work(ledger_.wall_work);
  m.set_absorbed_by_walls(ledger_.absorbed_by_walls);
  m.set_external_work(ledger_.external_work);
  m.set_forces_valid(forces_valid_);
}

System System::load_state(const gel::v1::EngineState& m) {
  const std::size_t n = static_cast<std::size_t>(m.x_size());
  if (n == 0) throw std::runtime_error("checkpoint state: no particles");
  require_same_size(n, {m.y_size(), m.orient_cos_size(), m.orient_sin_size(), m.vx_size(), m.vy_size(), m.omega_size(),
                        m.fx_size(), m.fy_size(), m.torque_size()},
                    "particle lists");
  if (m.wall_size() != 0) require_same_size(n, {m.wall_size()}, "wall sides");
  const std::size_t bonds = static_cast<std::size_t>(m.bond_i_size());
  require_same_size(bonds, {m.bond_j_size(), m.bond_bix_size(), m.bond_biy_size(), m.bond_bjx_size(), m.bond_bjy_size(),
                            m.bond_shift_x_size(), m.bond_shift_y_size()},
                    "bond lists");
  const std::size_t candidates = static_cast<std::size_t>(m.candidate_i_size());
  require_same_size(candidates, {m.candidate_j_size(), m.candidate_shift_x_size(), m.candidate_shift_y_size()}, "candidate lists");
  require_same_size(static_cast<std::size_t>(m.wall_members_size()), {m.wall_offset_size()}, "wall member lists");
  const std::size_t loads = static_cast<std::size_t>(m.external_i_size());
  require_same_size(loads, {m.external_fx_size(), m.external_fy_size()}, "external force lists");
  auto valid_index = [n](std::int32_t i) { return i >= 0 && static_cast<std::size_t>(i) < n; };
  for (std::size_t b = 0; b < bonds; ++b)
    if (!valid_index(m.bond_i(static_cast<int>(b))) || !valid_index(m.bond_j(static_cast<int>(b))))
      throw std::runtime_error("checkpoint state has an invalid bond");
  for (std::size_t c = 0; c < candidates; ++c)
    if (!valid_index(m.candidate_i(static_cast<int>(c))) || !valid_index(m.candidate_j(static_cast<int>(c))))
      throw std::runtime_error("checkpoint state has an invalid neighbour pair");
  for (const std::int32_t i : m.wall_candidates())
    if (!valid_index(i)) throw std::runtime_error("checkpoint state has an invalid wall candidate");
  for (const std::int32_t i : m.wall_members())
    if (!valid_index(i)) throw std::runtime_error("checkpoint state has an invalid wall member");
  for (const std::int32_t i : m.external_i())
    if (!valid_index(i)) throw std::runtime_error("checkpoint state has an invalid external force");

  // Build through the private default path: a one-particle placeholder, then overwrite.
  Configuration placeholder;
  placeholder.lx = placeholder.ly = 10;
  placeholder.add_particle(5, 5, 0);
  SimParams params;
  params.bond.k_normal = params.bond.k_sliding = params.bond.k_rolling = 1;
  params.bond.f_normal_critical = params.bond.f_sliding_critical = params.bond.m_rolling_critical = 1;
  System s(placeholder, params);
  BondLaw& law = s.params_.bond;
  law.k_normal = m.k_normal();
  law.k_sliding = m.k_sliding();
  law.k_rolling = m.k_rolling();
  law.overlap_coefficient = m.overlap_coefficient();
  law.f_normal_critical = m.f_normal_critical();
  law.f_sliding_critical = m.f_sliding_critical();
  law.m_rolling_critical = m.m_rolling_critical();
  s.params_.effects = m.effects();
  s.params_.dt = m.dt();
  s.params_.dt_fraction = m.dt_fraction();
  s.params_.eta_factor = m.eta_factor();
  s.params_.skin = m.skin();
  s.params_.guard_interval = m.guard_interval();
  s.params_.max_overlap = m.max_overlap();
  s.params_.max_speed = m.max_speed();
  if (!(s.params_.dt > 0) || !(s.params_.skin > 0) || s.params_.guard_interval <= 0 || !(m.lx() > 0) || !(m.ly() > 0))
    throw std::runtime_error("checkpoint state has invalid parameters");
  s.lx_ = m.lx();
  s.ly_ = m.ly();
  s.periodic_x_ = m.periodic_x();
  s.periodic_y_ = m.periodic_y();

  get_list(m.x(), s.x_);
  get_list(m.y(), s.y_);
  get_list(m.orient_cos(), s.orient_c_);
  get_list(m.orient_sin(), s.orient_s_);
  get_list(m.vx(), s.vx_);
  get_list(m.vy(), s.vy_);
  get_list(m.omega(), s.omega_);
  get_list(m.fx(), s.fx_);
  get_list(m.fy(), s.fy_);
  get_list(m.torque(), s.torque_);
  s.wall_.clear();
  for (const std::int32_t side : m.wall()) {
    if (side != kNoWall && side != kBottomWall && side != kTopWall) throw std::runtime_error("checkpoint state has an invalid wall side");
    s.wall_.push_back(static_cast<std::int8_t>(side));
  }

  s.bonds_.resize(bonds);
  for (std::size_t b = 0; b < bonds; ++b) {
    const int k = static_cast<int>(b);
    s.bonds_[b] = Bond{m.bond_i(k),   m.bond_j(k),   m.bond_bix(k),     m.bond_biy(k),
                       m.bond_bjx(k), m.bond_bjy(k), m.bond_shift_x(k), m.bond_shift_y(k)};
  }
  s.bond_scratch_->bonds.valid = false;
  s.candidates_.resize(candidates);
  for (std::size_t c = 0; c < candidates; ++c) {
    const int k = static_cast<int>(c);
    s.candidates_[c] = Candidate{m.candidate_i(k), m.candidate_j(k), m.candidate_shift_x(k), m.candidate_shift_y(k)};
  }
  get_list(m.wall_candidates(), s.wall_candidates_);
  s.travel_ = m.travel();
  s.wall_travel_ = m.wall_travel();
  s.rebuilds_ = m.rebuilds();

  s.walls_active_ = m.walls_active();
  s.wall_bottom_ = m.wall_bottom();
  s.wall_top_ = m.wall_top();
  s.wall_v_bottom_ = m.wall_v_bottom();
  s.wall_v_top_ = m.wall_v_top();
  get_list(m.wall_members(), s.wall_members_);
  get_list(m.wall_offset(), s.wall_offset_);
  s.wall_stress_ = WallStress{m.wall_force_top(), m.wall_force_bottom(), m.wall_p_top(), m.wall_p_bottom(), m.wall_p()};
  s.wall_power_ = m.wall_power();

  s.external_.resize(loads);
  for (std::size_t e = 0; e < loads; ++e) {
    const int k = static_cast<int>(e);
    s.external_[e] = ExternalForce{m.external_i(k), m.external_fx(k), m.external_fy(k)};
  }
  s.external_power_ = m.external_power();

  s.min_delta_ = m.min_delta();
  s.max_speed_sq_ = m.max_speed_sq();
  s.time_ = m.time();
  s.step_count_ = m.step_count();
  s.events_ = EventCounts{m.breaks(), m.sliding_resets(), m.rolling_resets(), m.bonds_created()};
  s.ledger_ = EnergyLedger{m.dissipated(), m.created(), m.drag(), m.wall_work(), m.absorbed_by_walls(), m.external_work()};
  s.forces_valid_ = m.forces_valid();
  return s;
}

std::string System::save_state() const {
  gel::v1::EngineState state;
  save_state(state);
  std::string bytes;
  state.SerializeToString(&bytes);
  return bytes;
}

System System::load_state(const std::string& bytes) {
  gel::v1::EngineState state;
  if (!state.ParseFromString(bytes)) throw std::runtime_error("not an engine state");
  return load_state(state);
}

}  // namespace gel
