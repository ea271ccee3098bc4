#pragma once
// Analyses of compression curves (MODEL.md "Observables" and "Fits"): energy increments and
// rupture rates per step, the split into the three regimes of the study, and ensembles.
//
// Increments: between consecutive rows k-1 and k (sorted by phi as recorded), with
// d = ln phi_k - ln phi_{k-1}:
//   stored_rate = (E_s,k - E_s,k-1) / d, dissipated_rate = (E_d,k - E_d,k-1) / d   [F0 a]
//   gamma_cause = (N_cause,k - N_cause,k-1) / (N d)          (Gamma = (1/N) dN_rup / d ln phi)
// An interval with d <= 0 (no compression between two rows) is skipped.
//
// Regimes, per interval:
//   elastic-dominant      stored increment > dissipated increment;
//   multi-mode plastic    otherwise, when normal breaks plus sliding resets make at least
//                         `multi_mode_fraction` (default 5 %) of the interval's events: the
//                         threshold keeps a stray early break from switching the regime;
//   single-mode plastic   otherwise (dissipation by rolling resets only).
// The curve is then split into three contiguous ranges in the order of the study (elastic,
// single-mode, multi-mode; any may be empty) by choosing the two boundaries that disagree with
// the fewest per-interval labels (ties: the earliest boundaries). The boundaries are reported
// as the phi where the next regime starts (the lower end of its first interval); a regime
// that is empty has no boundary of its own.
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "gel/v1/scene.pb.h"

namespace gel::analysis {

enum class Regime { kElastic = 0, kSingleModePlastic = 1, kMultiModePlastic = 2 };
const char* regime_name(Regime regime);  // "elastic", "single-mode-plastic", "multi-mode-plastic"

struct Increment {
  int row = 0;                 // index of the upper row (k)
  double phi_lo = 0, phi_hi = 0, phi_mid = 0;  // phi_mid = sqrt(phi_lo phi_hi)
  double d_ln_phi = 0;
  double stored_rate = 0, dissipated_rate = 0;              // dE / d ln phi [F0 a]
  double gamma_normal = 0, gamma_sliding = 0, gamma_rolling = 0;  // (1/N) dN / d ln phi
  double events_normal = 0, events_sliding = 0, events_rolling = 0;  // counts in the interval
};
// Throws InvalidArgument ("curve.particles") when the curve has no particle count.
std::vector<Increment> curve_increments(const gel::v1::Curve& curve);

inline constexpr double kDefaultMultiModeFraction = 0.05;
Regime classify_increment(const Increment& increment, double multi_mode_fraction = kDefaultMultiModeFraction);

struct RegimeSplit {
  std::vector<Regime> label;     // per interval, from the rule above
  std::vector<Regime> assigned;  // per interval, after the contiguous split
  int disagreements = 0;         // intervals whose label differs from the split
  std::optional<double> single_mode_start_phi;  // end of elastic-dominant
  std::optional<double> multi_mode_start_phi;   // end of single-mode plastic
  // phi ranges per regime [lo, hi]; missing when the regime is empty.
  std::optional<std::pair<double, double>> range[3];
};
RegimeSplit split_regimes(const std::vector<Increment>& increments,
                          double multi_mode_fraction = kDefaultMultiModeFraction);

// Element-wise mean and sample standard deviation (n - 1; 0 for one member) over members, up
// to the length of the shortest member.
struct MeanStd {
  std::vector<double> mean, std;
  int members = 0;
};
MeanStd mean_std(const std::vector<std::vector<double>>& members);

// The mean of profiles that each member gives on its own radii (C(r) and D_f(r): bin means of
// its pair distances, in a box whose height differs a little between seeds), so that an
// element-wise mean would average different r. Every member is interpolated, linearly in r
// (the bins are linear), onto the first member's radii inside the range all members cover;
// `grid` receives those radii.
MeanStd mean_on_common_radii(const std::vector<std::vector<double>>& radii, const std::vector<std::vector<double>>& values,
                             std::vector<double>& grid);

// Ensemble of curves of the same protocol on several seeds: rows are matched by their index k
// (the k-th equilibrium of each member's schedule; phi_0, and so every phi_k, differs a little
// between seeds, and phi is averaged like the other observables) up to the shortest member. Observables: "phi", "target_phi", "P", "P_top", "P_bot", "contact_number",
// "stored_energy", "dissipated_energy", "ruptures_normal", "ruptures_sliding",
// "ruptures_rolling", "bonds_created", per row; "phi_mid", "stored_rate", "dissipated_rate",
// "gamma_normal", "gamma_sliding", "gamma_rolling", per interval; phi_profile per row and slice.
// Throws InvalidArgument ("ensemble") with no member or when members' row indices k differ.
struct CurveEnsemble {
  int members = 0;
  std::map<std::string, MeanStd> rows;
  std::map<std::string, MeanStd> intervals;
  std::vector<MeanStd> phi_profile;  // one per row
};
CurveEnsemble curve_ensemble(const std::vector<gel::v1::Curve>& curves);

// Mean and sample std of the values present; `missing` counts the absent ones.
struct OptionalMeanStd {
  std::optional<double> mean, std;
  int present = 0, missing = 0;
};
OptionalMeanStd mean_std(const std::vector<std::optional<double>>& values);

}  // namespace gel::analysis
