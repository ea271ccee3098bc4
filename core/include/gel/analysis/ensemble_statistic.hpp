#pragma once
// The one ensemble statistic of the product: geld's GetCurve, gelsim's ensemble summary and the
// curve analyses all take their per-row means from here, so that with members of unequal length
// (one failed, or still running) they cannot average different sets at the same row and each
// says which rule it used.
#include <functional>
#include <string>
#include <vector>

#include "gel/v1/scene.pb.h"

namespace gel::analysis {

// Named in every output that shows these numbers.
inline constexpr const char* kEnsembleRule =
    "mean and sample standard deviation (n - 1; 0 for n = 1) over the members that reached row k; n per row";
// The analyses fit and split regimes on equal sets: they keep the rows every member reached.
inline constexpr const char* kCompleteRowsRule =
    "mean and sample standard deviation (n - 1; 0 for n = 1) over the members that reached row k; "
    "only the rows every member reached";

struct RowStatistic {
  int k = 0;          // the rows' k (rows are matched by it)
  int n = 0;          // members that reached row k
  double mean = 0, std = 0;
};

// Per k in increasing order: the statistic of value(row) over the members that have a row with
// that k, summed in member order (so a complete row gives the same bits as an element-wise mean
// over all members).
std::vector<RowStatistic> ensemble_statistic(const std::vector<const gel::v1::Curve*>& members,
                                             const std::function<double(const gel::v1::CurveRow&)>& value);

// Mean and sample standard deviation of values, in order (the formula of ensemble_statistic).
void mean_and_std(const std::vector<double>& values, double& mean, double& std);

}  // namespace gel::analysis
