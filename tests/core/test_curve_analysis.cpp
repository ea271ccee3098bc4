// What is read off a compression curve (docs/analysis.md): energy increments and the regimes
// they split into (planted boundaries), ensembles of curves and of radial profiles, and the
// curve's JSON in the model's energy unit.
#include <cmath>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "gel/analysis/curve_analysis.hpp"
#include "gel/curve_io.hpp"
#include "gel/errors.hpp"
#include "analysis_samples.hpp"

namespace gel::analysis {
namespace {

TEST(Regimes, PlantedBoundariesAreFound) {
  const gel::v1::Curve curve = planted_curve();
  const auto increments = curve_increments(curve);
  ASSERT_EQ(increments.size(), 15u);
  EXPECT_NEAR(increments[12].gamma_normal, 10 / (1000 * std::log(1.1)), 1e-12);
  EXPECT_NEAR(increments[12].gamma_rolling, 50 / (1000 * std::log(1.1)), 1e-12);
  EXPECT_NEAR(increments[0].stored_rate, 10 / std::log(1.1), 1e-9);
  const RegimeSplit split = split_regimes(increments);
  EXPECT_EQ(split.label[7], Regime::kMultiModePlastic);  // the stray burst
  EXPECT_EQ(split.disagreements, 1);
  ASSERT_TRUE(split.single_mode_start_phi && split.multi_mode_start_phi);
  EXPECT_NEAR(*split.single_mode_start_phi, curve.rows(5).phi(), 1e-12);
  EXPECT_NEAR(*split.multi_mode_start_phi, curve.rows(10).phi(), 1e-12);
  // A purely elastic curve has no boundary.
  gel::v1::Curve elastic = curve;
  while (elastic.rows_size() > 5) elastic.mutable_rows()->RemoveLast();
  const RegimeSplit none = split_regimes(curve_increments(elastic));
  EXPECT_FALSE(none.single_mode_start_phi.has_value());
  EXPECT_FALSE(none.multi_mode_start_phi.has_value());
  EXPECT_FALSE(none.range[1].has_value());
}

TEST(Ensemble, MeanAndStdOfTwoKnownCurves) {
  gel::v1::Curve a = planted_curve(), b = planted_curve();
  for (int k = 0; k < b.rows_size(); ++k) {
    a.mutable_rows(k)->set_p(1.0 + k);
    b.mutable_rows(k)->set_p(3.0 + k);
    a.mutable_rows(k)->add_phi_profile(0.1), a.mutable_rows(k)->add_phi_profile(0.2);
    b.mutable_rows(k)->add_phi_profile(0.3), b.mutable_rows(k)->add_phi_profile(0.2);
  }
  b.mutable_rows()->RemoveLast();  // members of unequal length: the shorter one sets the rows
  const CurveEnsemble e = curve_ensemble({a, b});
  EXPECT_EQ(e.members, 2);
  const MeanStd& p = e.rows.at("P");
  ASSERT_EQ(p.mean.size(), 15u);
  for (int k = 0; k < 15; ++k) {
    EXPECT_DOUBLE_EQ(p.mean[k], 2.0 + k);
    EXPECT_NEAR(p.std[k], std::sqrt(2.0), 1e-12);
  }
  EXPECT_NEAR(e.phi_profile[3].mean[0], 0.2, 1e-12);
  EXPECT_NEAR(e.phi_profile[3].std[0], std::sqrt(0.02), 1e-12);
  EXPECT_NEAR(e.phi_profile[3].std[1], 0.0, 1e-12);
  EXPECT_EQ(e.intervals.at("gamma_rolling").mean.size(), 14u);
  const OptionalMeanStd xi = mean_std(std::vector<std::optional<double>>{4.0, std::nullopt, 6.0});
  EXPECT_EQ(xi.missing, 1);
  EXPECT_DOUBLE_EQ(*xi.mean, 5.0);
  EXPECT_NEAR(*xi.std, std::sqrt(2.0), 1e-12);
  gel::v1::Curve other = planted_curve();
  other.mutable_rows(2)->set_k(7);
  EXPECT_THROW(curve_ensemble({a, other}), InvalidArgument);
}

TEST(CurveJson, CarriesTheModelsEnergyUnit) {
  // E0 = k_R a^2 phi_c^2 / 2 with k_R a^2 = 20 F0 a and phi_c = 0.05 (MODEL.md, both bond sets):
  // 0.025 F0 a, written as a number here rather than computed from the code's tables.
  for (const char* preset : {"bond1", "bond2"}) {
    gel::v1::Curve curve = planted_curve();
    curve.mutable_scene()->mutable_bond()->set_preset(preset);
    const nlohmann::json j = curve_to_json(curve);
    ASSERT_TRUE(j.contains("E0")) << preset;
    EXPECT_NEAR(j["E0"].get<double>(), 0.025, 1e-15) << preset;
  }
}

TEST(Ensemble, ProfilesOnDifferentRadiiAreAveragedAtEqualR) {
  // Two members sample the same line C(r) = 2 + 3r on shifted radii. Element by element their
  // mean would be 3/2 too high in every bin; interpolated onto common radii it is the line
  // itself with zero spread, over the range both cover.
  const std::vector<std::vector<double>> radii = {{0.0, 1.0, 2.0, 3.0, 4.0}, {0.5, 1.5, 2.5, 3.5}};
  std::vector<std::vector<double>> values;
  for (const auto& r : radii) {
    std::vector<double> v;
    for (double x : r) v.push_back(2 + 3 * x);
    values.push_back(v);
  }
  std::vector<double> grid;
  const MeanStd m = mean_on_common_radii(radii, values, grid);
  EXPECT_EQ(grid, (std::vector<double>{1.0, 2.0, 3.0}));
  ASSERT_EQ(m.mean.size(), 3u);
  for (std::size_t i = 0; i < grid.size(); ++i) {
    EXPECT_NEAR(m.mean[i], 2 + 3 * grid[i], 1e-12);
    EXPECT_NEAR(m.std[i], 0.0, 1e-12);
  }
}

}  // namespace
}  // namespace gel::analysis
