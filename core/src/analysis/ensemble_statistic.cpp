#include "gel/analysis/ensemble_statistic.hpp"

#include <cmath>
#include <map>

namespace gel::analysis {

void mean_and_std(const std::vector<double>& values, double& mean, double& std) {
  const double n = static_cast<double>(values.size());
  double sum = 0;
  for (const double v : values) sum += v;
  mean = values.empty() ? 0.0 : sum / n;
  double squares = 0;
  for (const double v : values) squares += (v - mean) * (v - mean);
  std = values.size() > 1 ? std::sqrt(squares / (n - 1)) : 0.0;
}

std::vector<RowStatistic> ensemble_statistic(const std::vector<const gel::v1::Curve*>& members,
                                             const std::function<double(const gel::v1::CurveRow&)>& value) {
  std::map<int, std::vector<double>> by_k;
  for (const gel::v1::Curve* curve : members)
    for (const gel::v1::CurveRow& row : curve->rows()) by_k[row.k()].push_back(value(row));
  std::vector<RowStatistic> out;
  out.reserve(by_k.size());
  for (const auto& [k, values] : by_k) {
    RowStatistic s;
    s.k = k;
    s.n = static_cast<int>(values.size());
    mean_and_std(values, s.mean, s.std);
    out.push_back(s);
  }
  return out;
}

}  // namespace gel::analysis
