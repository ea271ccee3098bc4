// The one ensemble statistic (gel/analysis/ensemble_statistic.hpp) on members of unequal length,
// against the arithmetic written out, and the analyses' use of it: the same bits on the rows
// every member reached, no row where one is missing, and the rule named in the output.
#include <gtest/gtest.h>

#include <cmath>

#include "gel/analysis/curve_analysis.hpp"
#include "gel/analysis/ensemble_statistic.hpp"
#include "gel/analysis/run_analysis.hpp"

namespace gel::analysis {
namespace {

gel::v1::Curve member(const std::vector<double>& pressures) {
  gel::v1::Curve curve;
  curve.set_particles(256);
  for (std::size_t k = 0; k < pressures.size(); ++k) {
    gel::v1::CurveRow* row = curve.add_rows();
    row->set_k(static_cast<int>(k));
    row->set_phi(0.1 * static_cast<double>(k + 1));
    row->set_target_phi(row->phi());
    row->set_p(pressures[k]);
    row->set_equilibrated(true);
    row->set_spans(true);
  }
  return curve;
}

TEST(EnsembleStatistic, AveragesTheMembersThatReachedEachRow) {
  // Three members; the second stopped after row 1 (failed, or still running).
  const std::vector<gel::v1::Curve> curves = {member({1, 2, 4}), member({3, 6}), member({5, 10, 8})};
  std::vector<const gel::v1::Curve*> members;
  for (const auto& c : curves) members.push_back(&c);
  const auto p = ensemble_statistic(members, [](const gel::v1::CurveRow& row) { return row.p(); });
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p[0].k, 0);
  EXPECT_EQ(p[0].n, 3);
  EXPECT_DOUBLE_EQ(p[0].mean, 3.0);  // (1 + 3 + 5) / 3
  EXPECT_DOUBLE_EQ(p[0].std, 2.0);   // sqrt((4 + 0 + 4) / 2)
  EXPECT_EQ(p[1].n, 3);
  EXPECT_DOUBLE_EQ(p[1].mean, 6.0);
  EXPECT_DOUBLE_EQ(p[1].std, 4.0);   // sqrt((16 + 0 + 16) / 2)
  EXPECT_EQ(p[2].k, 2);
  EXPECT_EQ(p[2].n, 2);              // the second member never reached it
  EXPECT_DOUBLE_EQ(p[2].mean, 6.0);  // (4 + 8) / 2
  EXPECT_DOUBLE_EQ(p[2].std, std::sqrt(8.0));
  // One member: the mean is its value, the spread 0.
  const auto one = ensemble_statistic({&curves[1]}, [](const gel::v1::CurveRow& row) { return row.p(); });
  ASSERT_EQ(one.size(), 2u);
  EXPECT_EQ(one[1].n, 1);
  EXPECT_EQ(one[1].mean, 6.0);
  EXPECT_EQ(one[1].std, 0.0);
}

TEST(EnsembleStatistic, TheAnalysesKeepOnlyTheRowsEveryMemberReachedWithTheSameBits) {
  const std::vector<gel::v1::Curve> curves = {member({1e-3, 2.5e-2, 0.4}), member({3.1e-3, 6.7e-2}),
                                              member({5.3e-3, 1.01e-2, 0.8})};
  std::vector<const gel::v1::Curve*> members;
  for (const auto& c : curves) members.push_back(&c);
  const auto p = ensemble_statistic(members, [](const gel::v1::CurveRow& row) { return row.p(); });
  const CurveEnsemble ensemble = curve_ensemble(curves);
  const MeanStd& analysed = ensemble.rows.at("P");
  ASSERT_EQ(analysed.mean.size(), 2u) << "row 2 lacks a member";
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(analysed.mean[k], p[k].mean) << k;
    EXPECT_EQ(analysed.std[k], p[k].std) << k;
  }
  // The analysis's JSON says which rule made its rows.
  RunAnalysisOptions options;
  const nlohmann::json json = to_json(analyse_curves(curves, options));
  EXPECT_EQ(json.at("ensemble_rule"), kCompleteRowsRule);
}

}  // namespace
}  // namespace gel::analysis
