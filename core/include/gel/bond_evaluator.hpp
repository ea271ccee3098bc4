#pragma once
// The evaluator: the physics of one bond (MODEL.md "Bonds"), from that bond's geometry only.
// It knows nothing of loops or memory layout; System::bond_forces owns those. Each term is
// compiled in only when its effect is in the mask (if constexpr), so an effect that is off
// costs nothing.
#include <cmath>

#include "gel/bond_law.hpp"
#include "gel/effects.hpp"
#include "gel/units.hpp"

namespace gel {

// Geometry of a bond: n = (r_j - r_i)/|r_j - r_i|, gap delta = |r_j - r_i| - 2a, and the
// lab-frame contact directions xi_ij (on i) and xi_ji (on j).
struct BondGeometry {
  double nx, ny;
  double delta;
  double xi_ix, xi_iy;
  double xi_jx, xi_jy;
};

// Forces and moments of one bond. Force on i is (fx, fy); on j it is opposite. The torque
// on i is rolling_moment + sliding_torque, on j it is -rolling_moment + sliding_torque.
struct BondForces {
  double normal_force = 0;   // F_N . n; positive pulls i towards j
  double sliding_x = 0;      // F_T = k_S d
  double sliding_y = 0;
  double rolling_moment = 0; // M_R on i
};

// Bending angle phi = -asin((xi_ij x xi_ji)_z). A bond resets at |phi| > phi_c (0.05 in
// both presets), so the argument almost always stays below kBendingSeriesLimit = 0.0625, where
// the odd series through x^11 is exact to 1e-16 relative (the next term is 0.017 x^13); it is
// evaluated in Estrin form because its Horner chain was the longest latency in the bond loop.
// std::asin remains the fallback for larger angles.
inline constexpr double kBendingSeriesLimit = 0.0625;

inline double bending_angle_series(double cross_z) {
  const double x = cross_z;
  const double t = x * x, t2 = t * t, t4 = t2 * t2;
  const double low = 1.0 + t * (1.0 / 6);
  const double mid = 3.0 / 40 + t * (5.0 / 112);
  const double high = 35.0 / 1152 + t * (63.0 / 2816);
  return -x * (low + t2 * mid + t4 * high);
}

inline double bending_angle(double cross_z) {
  if (std::abs(cross_z) < kBendingSeriesLimit) return bending_angle_series(cross_z);
  return -std::asin(cross_z);
}

template <unsigned kEffects>
struct BondEvaluator {
  static constexpr bool needs_normal() { return kEffects & kNormalSpring; }
  static constexpr bool needs_overlap() { return kEffects & kOverlapRepulsion; }
  static constexpr bool needs_sliding() { return kEffects & kSliding; }
  static constexpr bool needs_rolling() { return kEffects & kRolling; }
  // The contact points are only needed by the tangential springs.
  static constexpr bool needs_contact_points() { return needs_sliding() || needs_rolling(); }

  // kSeriesOnly: the bending angle from its series alone, without a branch, so that the bond
  // loop vectorises; valid while |cross| < kBendingSeriesLimit (rolling_cross tells), and the
  // loop takes the exact evaluation for the other bonds. Both give the same bits below the limit.
  template <bool kSeriesOnly = false>
  static BondForces evaluate(const BondGeometry& g, const BondLaw& law) {
    BondForces out;
    if constexpr (needs_normal()) out.normal_force = law.k_normal * g.delta;
    if constexpr (needs_overlap()) {
      // theta(-delta) delta^3 without a branch: only the overlapping part is cubed.
      const double overlap = g.delta < 0 ? g.delta : 0.0;
      out.normal_force += law.overlap_coefficient * overlap * overlap * overlap;
    }
    if constexpr (needs_sliding()) {
      // d = a { u - (u.n) n }, u = xi_ji - xi_ij
      const double ux = g.xi_jx - g.xi_ix, uy = g.xi_jy - g.xi_iy;
      const double u_n = ux * g.nx + uy * g.ny;
      out.sliding_x = law.k_sliding * kRadius * (ux - u_n * g.nx);
      out.sliding_y = law.k_sliding * kRadius * (uy - u_n * g.ny);
    }
    if constexpr (needs_rolling()) {
      const double cross = rolling_cross(g);
      out.rolling_moment = law.k_rolling * (kSeriesOnly ? bending_angle_series(cross) : bending_angle(cross));
    }
    return out;
  }

  // (xi_ij x xi_ji)_z, the sine of the bending angle.
  static double rolling_cross(const BondGeometry& g) { return g.xi_ix * g.xi_jy - g.xi_iy * g.xi_jx; }
};

// What one bond does to its two particles (MODEL.md "Bonds"): the force F = F_N n + F_T on i
// (on j, -F) and the torques, M_R + a n x F_T on i and -M_R + a n x F_T on j ((-a n) x (-F_T)).
struct BondLoads {
  double force_x, force_y, torque_i, torque_j;
};
[[gnu::always_inline]] inline BondLoads bond_loads(const BondForces& f, const BondGeometry& g) {
  const double sliding_torque = kRadius * (g.nx * f.sliding_y - g.ny * f.sliding_x);
  return {f.normal_force * g.nx + f.sliding_x, f.normal_force * g.ny + f.sliding_y, f.rolling_moment + sliding_torque,
          -f.rolling_moment + sliding_torque};
}

// The thresholds (MODEL.md "Bonds"): a bond breaks when F_N > F_Nc (tension only: a pressed pair
// never breaks), and resets its tangential springs when |F_T| > F_Sc or |M_R| > M_Rc. Written
// without a branch (| of the comparisons), so that the vectorised bond pass can flag the bonds
// to evaluate again exactly.
inline bool exceeds_a_threshold(const BondForces& f, const BondLaw& law) {
  const double tangential_sq = f.sliding_x * f.sliding_x + f.sliding_y * f.sliding_y;
  return (f.normal_force > law.f_normal_critical) | (tangential_sq > law.f_sliding_critical * law.f_sliding_critical) |
         (std::abs(f.rolling_moment) > law.m_rolling_critical);
}

// Which event a bond past a threshold is. A break wins; a reset is one event whichever
// tangential thresholds it passed, so that rupture rates count it once: it goes to the cause
// exceeded by the larger factor (|F_T| / F_Sc against |M_R| / M_Rc; sliding on a tie).
enum class BondEvent { kNone, kBreak, kSlidingReset, kRollingReset };
inline BondEvent threshold_event(const BondForces& f, const BondLaw& law) {
  if (!exceeds_a_threshold(f, law)) return BondEvent::kNone;
  if (f.normal_force > law.f_normal_critical) return BondEvent::kBreak;
  const double tangential_sq = f.sliding_x * f.sliding_x + f.sliding_y * f.sliding_y;
  const double sliding_excess = std::sqrt(tangential_sq) / law.f_sliding_critical;
  const double rolling_excess = std::abs(f.rolling_moment) / law.m_rolling_critical;
  return sliding_excess >= rolling_excess ? BondEvent::kSlidingReset : BondEvent::kRollingReset;
}

// The evaluator for an effect set known only at run time (bookkeeping and checks, not the
// step loop, which is instantiated per effect set).
BondForces evaluate_bond(const BondGeometry& g, const BondLaw& law, unsigned effects);

// Elastic energy stored in one bond, every term of the law (used for bookkeeping, not in the
// step loop): k_N delta^2/2 + C theta(-delta) delta^4/4 + k_S |d|^2/2 + k_R a^2 phi^2/2.
struct BondEnergy {
  double normal = 0, sliding = 0, rolling = 0;
  double total() const { return normal + sliding + rolling; }
};
BondEnergy bond_energy(const BondGeometry& g, const BondLaw& law, unsigned effects);

}  // namespace gel
