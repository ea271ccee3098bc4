#pragma once
// Fits of compression curves (MODEL.md "Fits").
//
// Power law y = C x^lambda: ordinary least squares of ln y on ln x over the points with
// x_min <= x <= x_max and x, y > 0 (equal weights in log space, i.e. equal relative errors,
// which is how the scatter of P_y between seeds behaves). The standard errors are the usual
// OLS ones from the residual scatter, s^2 = RSS / (n - 2): they are honest when the points
// scatter independently around a power law, and they say nothing about systematic curvature
// (check the residual rms for that).
//
// Gel-point form P = C' (phi - phi_g)^lambda': nonlinear least squares on the same log scale,
// r_i = ln P_i - ln C' - lambda' ln(phi_i - phi_g), over (ln C', phi_g, lambda') by
// Levenberg-Marquardt (the normal equations solved with Eigen's LDLT). Start: for phi_g on a
// grid in [0, phi_min) the problem is linear in (ln C', lambda'); the best grid point seeds the
// iteration. phi_g is kept in [0, smallest fitted phi): a step below 0 is projected onto 0, one
// that crosses the smallest phi is rejected. When the optimum lies on that boundary
// (phi_g_at_bound) the data do not determine a gel point and the standard errors, from
// s^2 (J^T J)^-1 at the optimum, do not apply.
#include <vector>

namespace gel::analysis {

struct PowerLawFit {
  double prefactor = 0;          // C
  double exponent = 0;           // lambda
  double exponent_stderr = 0;    // NaN with 2 points
  double log_prefactor_stderr = 0;
  double x_min = 0, x_max = 0;   // range of the points used (smallest and largest fitted x)
  double requested_min = 0, requested_max = 0;  // the range asked for
  int points = 0;
  int dropped = 0;               // points in the requested range left out: y <= 0 or not finite
  double rms_log_residual = 0;
};
// Throws InvalidArgument ("fit_range") with fewer than 2 usable points or a single x.
PowerLawFit fit_power_law(const std::vector<double>& x, const std::vector<double>& y, double x_min, double x_max);

struct GelPointFit {
  double prefactor = 0;        // C'
  double phi_g = 0;
  double exponent = 0;         // lambda'
  double log_prefactor_stderr = 0, phi_g_stderr = 0, exponent_stderr = 0;
  double x_min = 0, x_max = 0;   // range of the points used
  double requested_min = 0, requested_max = 0;
  int points = 0;
  int dropped = 0;               // as in PowerLawFit
  int iterations = 0;
  bool converged = false;
  bool phi_g_at_bound = false;
  double rms_log_residual = 0;
};
// Throws InvalidArgument ("fit_range") with fewer than 4 usable points.
GelPointFit fit_gel_point(const std::vector<double>& phi, const std::vector<double>& p, double x_min, double x_max);

}  // namespace gel::analysis
