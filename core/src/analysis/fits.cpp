#include "gel/analysis/fits.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

#include "gel/errors.hpp"

namespace gel::analysis {
namespace {

// A log-space fit cannot take y <= 0; such points are counted, so that a fit never hides them.
int usable_points(const std::vector<double>& x, const std::vector<double>& y, double x_min, double x_max,
                  std::vector<double>& xs, std::vector<double>& ys) {
  if (x.size() != y.size()) throw InvalidArgument("fit", "x and y differ in length");
  if (!(x_min <= x_max)) throw InvalidArgument("fit_range", "minimum above maximum");
  int dropped = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!(x[i] >= x_min && x[i] <= x_max)) continue;
    if (x[i] > 0 && y[i] > 0 && std::isfinite(x[i]) && std::isfinite(y[i])) xs.push_back(x[i]), ys.push_back(y[i]);
    else ++dropped;
  }
  return dropped;
}

template <class Fit>
void record_range(Fit& fit, const std::vector<double>& xs, double x_min, double x_max, int dropped) {
  fit.requested_min = x_min, fit.requested_max = x_max;
  fit.x_min = *std::min_element(xs.begin(), xs.end());
  fit.x_max = *std::max_element(xs.begin(), xs.end());
  fit.points = static_cast<int>(xs.size());
  fit.dropped = dropped;
}

struct Line {
  double slope = 0, intercept = 0, slope_stderr = 0, intercept_stderr = 0, rss = 0;
  bool ok = false;
};

Line ols(const std::vector<double>& u, const std::vector<double>& v) {
  Line line;
  const double n = static_cast<double>(u.size());
  if (u.size() < 2) return line;
  double mu = 0, mv = 0;
  for (std::size_t i = 0; i < u.size(); ++i) mu += u[i], mv += v[i];
  mu /= n, mv /= n;
  double suu = 0, suv = 0;
  for (std::size_t i = 0; i < u.size(); ++i) suu += (u[i] - mu) * (u[i] - mu), suv += (u[i] - mu) * (v[i] - mv);
  if (!(suu > 0)) return line;
  line.slope = suv / suu;
  line.intercept = mv - line.slope * mu;
  for (std::size_t i = 0; i < u.size(); ++i) {
    const double e = v[i] - line.intercept - line.slope * u[i];
    line.rss += e * e;
  }
  const double s2 = u.size() > 2 ? line.rss / (n - 2) : std::numeric_limits<double>::quiet_NaN();
  line.slope_stderr = std::sqrt(s2 / suu);
  line.intercept_stderr = std::sqrt(s2 * (1.0 / n + mu * mu / suu));
  line.ok = true;
  return line;
}

}  // namespace

PowerLawFit fit_power_law(const std::vector<double>& x, const std::vector<double>& y, double x_min, double x_max) {
  std::vector<double> xs, ys;
  const int dropped = usable_points(x, y, x_min, x_max, xs, ys);
  if (xs.size() < 2) throw InvalidArgument("fit_range", "fewer than 2 points with x, y > 0 in the fit range");
  std::vector<double> u(xs.size()), v(xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i) u[i] = std::log(xs[i]), v[i] = std::log(ys[i]);
  const Line line = ols(u, v);
  if (!line.ok) throw InvalidArgument("fit_range", "all points in the fit range have the same x");
  PowerLawFit fit;
  fit.exponent = line.slope;
  fit.prefactor = std::exp(line.intercept);
  fit.exponent_stderr = line.slope_stderr;
  fit.log_prefactor_stderr = line.intercept_stderr;
  record_range(fit, xs, x_min, x_max, dropped);
  fit.rms_log_residual = std::sqrt(line.rss / xs.size());
  return fit;
}

GelPointFit fit_gel_point(const std::vector<double>& phi, const std::vector<double>& p, double x_min, double x_max) {
  std::vector<double> xs, ys;
  const int dropped = usable_points(phi, p, x_min, x_max, xs, ys);
  if (xs.size() < 4) throw InvalidArgument("fit_range", "the gel-point fit needs at least 4 points with phi, P > 0");
  const int n = static_cast<int>(xs.size());
  const double phi_lowest = *std::min_element(xs.begin(), xs.end());
  Eigen::VectorXd log_p(n);
  for (int i = 0; i < n; ++i) log_p[i] = std::log(ys[i]);

  // Residuals for parameters q = (ln C', phi_g, lambda'); infinite cost when phi_g >= phi_min.
  auto residuals = [&](const Eigen::Vector3d& q, Eigen::VectorXd& r) {
    r.resize(n);
    for (int i = 0; i < n; ++i) r[i] = log_p[i] - q[0] - q[2] * std::log(xs[i] - q[1]);
    return r.squaredNorm();
  };
  auto jacobian = [&](const Eigen::Vector3d& q, Eigen::MatrixXd& J) {
    J.resize(n, 3);
    for (int i = 0; i < n; ++i) {
      const double gap = xs[i] - q[1];
      J(i, 0) = -1.0;
      J(i, 1) = q[2] / gap;
      J(i, 2) = -std::log(gap);
    }
  };

  // Seed: scan phi_g over [0, phi_min) where the rest is a linear fit.
  Eigen::Vector3d best(0, 0, 0);
  double best_cost = std::numeric_limits<double>::infinity();
  constexpr int kGrid = 200;
  for (int g = 0; g < kGrid; ++g) {
    const double phi_g = phi_lowest * g / kGrid;
    std::vector<double> u(n), v(n);
    for (int i = 0; i < n; ++i) u[i] = std::log(xs[i] - phi_g), v[i] = log_p[i];
    const Line line = ols(u, v);
    if (line.ok && line.rss < best_cost) best_cost = line.rss, best = Eigen::Vector3d(line.intercept, phi_g, line.slope);
  }
  if (!std::isfinite(best_cost)) throw InvalidArgument("fit_range", "all points in the fit range have the same phi");

  GelPointFit fit;
  Eigen::Vector3d q = best;
  Eigen::VectorXd r;
  double cost = residuals(q, r);
  double damping = 1e-3;
  Eigen::MatrixXd J;
  constexpr int kMaxIterations = 200;
  for (fit.iterations = 0; fit.iterations < kMaxIterations; ++fit.iterations) {
    jacobian(q, J);
    const Eigen::Matrix3d JtJ = J.transpose() * J;
    const Eigen::Vector3d gradient = J.transpose() * r;
    bool improved = false;
    while (damping < 1e12) {
      Eigen::Matrix3d A = JtJ;
      A.diagonal() += damping * JtJ.diagonal().cwiseMax(1e-12);
      const Eigen::Vector3d step = A.ldlt().solve(-gradient);
      Eigen::Vector3d trial = q + step;
      trial[1] = std::max(trial[1], 0.0);  // projected onto phi_g >= 0: a packing fraction
      Eigen::VectorXd trial_r;
      const double trial_cost = trial[1] < phi_lowest ? residuals(trial, trial_r) : std::numeric_limits<double>::infinity();
      if (trial_cost < cost) {
        const double relative_change = (cost - trial_cost) / std::max(cost, 1e-300);
        q = trial, r = trial_r, cost = trial_cost;
        damping = std::max(damping / 10, 1e-12);
        improved = true;
        if (relative_change < 1e-12 || step.norm() < 1e-12 * (1 + q.norm())) fit.converged = true;
        break;
      }
      damping *= 10;
    }
    if (!improved) fit.converged = true;  // no downhill step left: a (local) minimum
    if (fit.converged) break;
  }
  jacobian(q, J);
  fit.prefactor = std::exp(q[0]);
  fit.phi_g = q[1];
  fit.phi_g_at_bound = q[1] <= 1e-9 || q[1] >= phi_lowest * (1 - 1e-6);
  fit.exponent = q[2];
  const Eigen::Matrix3d JtJ = J.transpose() * J;
  if (n > 3 && JtJ.fullPivLu().isInvertible()) {
    const Eigen::Matrix3d covariance = cost / (n - 3) * JtJ.inverse();
    fit.log_prefactor_stderr = std::sqrt(std::max(0.0, covariance(0, 0)));
    fit.phi_g_stderr = std::sqrt(std::max(0.0, covariance(1, 1)));
    fit.exponent_stderr = std::sqrt(std::max(0.0, covariance(2, 2)));
  } else {
    fit.log_prefactor_stderr = fit.phi_g_stderr = fit.exponent_stderr = std::numeric_limits<double>::quiet_NaN();
  }
  record_range(fit, xs, x_min, x_max, dropped);
  fit.rms_log_residual = std::sqrt(cost / n);
  return fit;
}

}  // namespace gel::analysis
