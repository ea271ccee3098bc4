// Checkpoint encoding of a System: every member that influences later steps, in order, as raw
// little-endian bytes, so that a resumed run continues bit for bit (bond and candidate order
// included, since they set the order of floating-point sums).
#include <cstring>
#include <stdexcept>
#include <type_traits>

#include "gel/system.hpp"

#include "bond_kernels.hpp"

namespace gel {
namespace {

constexpr std::uint64_t kStateMagic = 0x31657461'74736c65ULL;  // "elstate1"

class Writer {
 public:
  template <typename T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* bytes = reinterpret_cast<const char*>(&value);
    out_.append(bytes, sizeof(T));
  }
  template <typename T>
  void put_vector(const std::vector<T>& values) {
    static_assert(std::is_trivially_copyable_v<T>);
    put<std::uint64_t>(values.size());
    out_.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
  }
  std::string take() { return std::move(out_); }

 private:
  std::string out_;
};

class Reader {
 public:
  explicit Reader(const std::string& bytes) : bytes_(bytes) {}
  template <typename T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>);
    need(sizeof(T));
    T value;
    std::memcpy(&value, bytes_.data() + offset_, sizeof(T));
    offset_ += sizeof(T);
    return value;
  }
  template <typename T>
  void get_vector(std::vector<T>& values) {
    const auto count = get<std::uint64_t>();
    if (count > (bytes_.size() - offset_) / sizeof(T)) throw std::runtime_error("checkpoint state is truncated");
    values.resize(count);
    // memcpy from/to a null pointer is undefined even for zero bytes, and an
    // empty vector's data() may be null.
    if (count != 0) std::memcpy(values.data(), bytes_.data() + offset_, count * sizeof(T));
    offset_ += count * sizeof(T);
  }
  bool done() const { return offset_ == bytes_.size(); }

 private:
  void need(std::size_t n) const {
    if (offset_ + n > bytes_.size()) throw std::runtime_error("checkpoint state is truncated");
  }
  const std::string& bytes_;
  std::size_t offset_ = 0;
};

}  // namespace

std::string System::save_state() const {
  Writer w;
  w.put(kStateMagic);
  w.put(params_.bond);
  w.put(params_.effects);
  w.put(params_.dt);
  w.put(params_.dt_fraction);
  w.put(params_.eta_factor);
  w.put(params_.skin);
  w.put(params_.guard_interval);
  w.put(params_.max_overlap);
  w.put(params_.max_speed);
  w.put(lx_);
  w.put(ly_);
  w.put(periodic_x_);
  w.put(periodic_y_);
  for (const auto* v : {&x_, &y_, &orient_c_, &orient_s_, &vx_, &vy_, &omega_, &fx_, &fy_, &torque_}) w.put_vector(*v);
  w.put_vector(wall_);
  w.put_vector(bonds_);
  w.put_vector(candidates_);
  w.put_vector(wall_candidates_);
  w.put(travel_);
  w.put(wall_travel_);
  w.put(rebuilds_);
  w.put(walls_active_);
  w.put(wall_bottom_);
  w.put(wall_top_);
  w.put(wall_v_bottom_);
  w.put(wall_v_top_);
  w.put_vector(wall_members_);
  w.put_vector(wall_offset_);
  w.put(wall_stress_);
  w.put(wall_power_);
  w.put_vector(external_);
  w.put(external_power_);
  w.put(min_delta_);
  w.put(max_speed_sq_);
  w.put(time_);
  w.put(step_count_);
  w.put(events_);
  w.put(ledger_);
  w.put(forces_valid_);
  return w.take();
}

System System::load_state(const std::string& bytes) {
  Reader r(bytes);
  if (r.get<std::uint64_t>() != kStateMagic) throw std::runtime_error("not an engine state (bad magic)");
  // Build through the private default path: a one-particle placeholder, then overwrite.
  Configuration placeholder;
  placeholder.lx = placeholder.ly = 10;
  placeholder.add_particle(5, 5, 0);
  SimParams params;
  params.bond.k_normal = params.bond.k_sliding = params.bond.k_rolling = 1;
  params.bond.f_normal_critical = params.bond.f_sliding_critical = params.bond.m_rolling_critical = 1;
  System s(placeholder, params);
  s.params_.bond = r.get<BondLaw>();
  s.params_.effects = r.get<unsigned>();
  s.params_.dt = r.get<double>();
  s.params_.dt_fraction = r.get<double>();
  s.params_.eta_factor = r.get<double>();
  s.params_.skin = r.get<double>();
  s.params_.guard_interval = r.get<int>();
  s.params_.max_overlap = r.get<double>();
  s.params_.max_speed = r.get<double>();
  s.lx_ = r.get<double>();
  s.ly_ = r.get<double>();
  s.periodic_x_ = r.get<bool>();
  s.periodic_y_ = r.get<bool>();
  for (auto* v : {&s.x_, &s.y_, &s.orient_c_, &s.orient_s_, &s.vx_, &s.vy_, &s.omega_, &s.fx_, &s.fy_, &s.torque_})
    r.get_vector(*v);
  r.get_vector(s.wall_);
  r.get_vector(s.bonds_);
  s.bond_scratch_->bonds.valid = false;
  r.get_vector(s.candidates_);
  r.get_vector(s.wall_candidates_);
  s.travel_ = r.get<double>();
  s.wall_travel_ = r.get<double>();
  s.rebuilds_ = r.get<std::int64_t>();
  s.walls_active_ = r.get<bool>();
  s.wall_bottom_ = r.get<double>();
  s.wall_top_ = r.get<double>();
  s.wall_v_bottom_ = r.get<double>();
  s.wall_v_top_ = r.get<double>();
  r.get_vector(s.wall_members_);
  r.get_vector(s.wall_offset_);
  s.wall_stress_ = r.get<WallStress>();
  s.wall_power_ = r.get<double>();
  r.get_vector(s.external_);
  s.external_power_ = r.get<double>();
  s.min_delta_ = r.get<double>();
  s.max_speed_sq_ = r.get<double>();
  s.time_ = r.get<double>();
  s.step_count_ = r.get<std::int64_t>();
  s.events_ = r.get<EventCounts>();
  s.ledger_ = r.get<EnergyLedger>();
  s.forces_valid_ = r.get<bool>();
  if (!r.done()) throw std::runtime_error("checkpoint state has trailing bytes");
  const std::size_t n = s.x_.size();
  for (const auto* v : {&s.y_, &s.orient_c_, &s.orient_s_, &s.vx_, &s.vy_, &s.omega_, &s.fx_, &s.fy_, &s.torque_})
    if (v->size() != n) throw std::runtime_error("checkpoint state is inconsistent");
  for (const Bond& bond : s.bonds_)
    if (bond.i < 0 || bond.j < 0 || static_cast<std::size_t>(bond.i) >= n || static_cast<std::size_t>(bond.j) >= n)
      throw std::runtime_error("checkpoint state has an invalid bond");
  return s;
}

}  // namespace gel
