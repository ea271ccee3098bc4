// The analyses put together (docs/analysis.md): the structure of one configuration, the
// analysis of a set of curves (which rows a fit may use, energies in the model's unit), and of
// run directories with their snapshots and pictures.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "gel/analysis/pictures.hpp"
#include "gel/analysis/run_analysis.hpp"
#include "gel/analysis/structure.hpp"
#include "gel/configuration.hpp"
#include "gel/curve_io.hpp"
#include "analysis_samples.hpp"

namespace gel::analysis {
namespace {

TEST(Structure, AnalysisOfAGeneratedGelHasEveryPart) {
  const Configuration gel = quick_gel(1);
  const StructureAnalysis a = analyse_structure(gel);
  EXPECT_NEAR(a.phi, gel.packing_fraction(), 1e-15);
  ASSERT_TRUE(a.df_fit.has_value());
  EXPECT_GT(a.df_fit->df, 1.3);
  EXPECT_LT(a.df_fit->df, 1.8);
  EXPECT_FALSE(a.df_profile.r.empty());
  EXPECT_EQ(a.profile.phi.size(), 20u);
  const nlohmann::json j = to_json(a);
  for (const char* key : {"phi", "correlation", "fractal_dimension_profile", "fractal_dimension_fit", "xi_05"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["correlation"]["r"].size(), j["correlation"]["C"].size());
}

TEST(RunAnalysis, FitsLeaveOutRowsThatAreNotAnEquilibriumYieldStress) {
  // Rows 1-3 stopped at the wait limit with P ten times the law, row 4 did not span: a fit
  // over them would not return the planted exponent. Flagged, they stay out of it.
  gel::v1::Curve curve = planted_curve();
  for (int k : {1, 2, 3}) {
    curve.mutable_rows(k)->set_p(10 * curve.rows(k).p());
    curve.mutable_rows(k)->set_equilibrated(false);
  }
  curve.mutable_rows(4)->set_p(10 * curve.rows(4).p());
  curve.mutable_rows(4)->set_spans(false);
  const CurveAnalysis a = analyse_curves({curve}, RunAnalysisOptions{});
  ASSERT_TRUE(a.power_law.has_value());
  EXPECT_NEAR(a.power_law->exponent, 3.0, 1e-9);
  // Every left-out row is named with its reason, and the fit states the range it really used.
  ASSERT_EQ(a.excluded_rows.size(), 4u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(a.excluded_rows[i].k, i + 1);
    EXPECT_EQ(a.excluded_rows[i].reason, "not equilibrated");
  }
  EXPECT_EQ(a.excluded_rows[3].reason, "network does not span");
  EXPECT_EQ(a.fit_rows.front(), 5);
  EXPECT_DOUBLE_EQ(a.power_law->x_min, curve.rows(5).phi());
  EXPECT_DOUBLE_EQ(a.power_law->x_max, curve.rows(curve.rows_size() - 1).phi());
  EXPECT_EQ(a.power_law->points, curve.rows_size() - 5);
  EXPECT_FALSE(a.mean_curve.rows(1).equilibrated());
  EXPECT_TRUE(a.mean_curve.rows(5).equilibrated());
  // The regime split skips the intervals that touch a left-out row (rows 0-5: 5 intervals).
  ASSERT_EQ(a.increment_trusted.size(), a.increments.size());
  EXPECT_EQ(std::count(a.increment_trusted.begin(), a.increment_trusted.end(), false), 5);
  EXPECT_EQ(a.regimes.assigned.size(), a.increments.size() - 5);
  const nlohmann::json j = to_json(a);
  EXPECT_EQ(j["excluded_rows"].size(), 4u);
  EXPECT_TRUE(j["regimes"]["intervals"][0]["regime"].is_null());
  // Asked for explicitly, the unequilibrated rows come back; the one that does not span stays out.
  RunAnalysisOptions include;
  include.include_unequilibrated = true;
  const CurveAnalysis included = analyse_curves({curve}, include);
  ASSERT_EQ(included.excluded_rows.size(), 1u);
  EXPECT_EQ(included.excluded_rows[0].k, 4);
  ASSERT_TRUE(included.power_law.has_value());
  EXPECT_LT(included.power_law->exponent, 2.9);
  // Two members, one of them wait-limited at row 2: the row is out, and the reason counts members.
  gel::v1::Curve clean = planted_curve(), limited = planted_curve();
  limited.mutable_rows(2)->set_equilibrated(false);
  const CurveAnalysis pair = analyse_curves({clean, limited}, RunAnalysisOptions{});
  ASSERT_EQ(pair.excluded_rows.size(), 1u);
  EXPECT_EQ(pair.excluded_rows[0].reason, "not equilibrated in 1 of 2 members");
  // The same rows trusted: the fit is visibly off.
  for (int k : {1, 2, 3}) curve.mutable_rows(k)->set_equilibrated(true);
  curve.mutable_rows(4)->set_spans(true);
  const CurveAnalysis biased = analyse_curves({curve}, RunAnalysisOptions{});
  ASSERT_TRUE(biased.power_law.has_value());
  EXPECT_LT(biased.power_law->exponent, 2.5);
}

TEST(CurveAnalysisJson, EnergyIncrementsAlsoInTheModelsUnit) {
  // MODEL.md gives the increments dE / d ln phi in E0 = 0.025 F0 a: each interval's rates in F0 a
  // divided by that number (written here, not read from the code), for both bond sets.
  for (const char* preset : {"bond1", "bond2"}) {
    gel::v1::Curve curve = planted_curve();
    curve.mutable_scene()->mutable_bond()->set_preset(preset);
    const nlohmann::json j = to_json(analyse_curves({curve}, RunAnalysisOptions{}));
    EXPECT_NEAR(j.at("E0").get<double>(), 0.025, 1e-15) << preset;
    const auto& intervals = j.at("regimes").at("intervals");
    ASSERT_FALSE(intervals.empty());
    for (const auto& interval : intervals) {
      EXPECT_NEAR(interval.at("stored_rate_E0").get<double>(), interval.at("stored_rate").get<double>() / 0.025, 1e-9);
      EXPECT_NEAR(interval.at("dissipated_rate_E0").get<double>(), interval.at("dissipated_rate").get<double>() / 0.025, 1e-9);
    }
  }
  // Without a rolling spring there is no E0: no such fields rather than a division by zero.
  gel::v1::Curve plain = planted_curve();
  plain.mutable_scene()->clear_bond();
  const nlohmann::json j = to_json(analyse_curves({plain}, RunAnalysisOptions{}));
  EXPECT_TRUE(j.at("E0").is_null());
  for (const auto& interval : j.at("regimes").at("intervals")) EXPECT_FALSE(interval.contains("stored_rate_E0"));
}

TEST(RunAnalysis, DirectoryWithCurveAndSnapshotsGivesFitsStructureAndPictures) {
  // A run directory as the compression writes it: curve.json plus snapshots/k_NNN.pb named in
  // the rows. Two members (the same curve twice) make an ensemble with zero spread.
  const std::string dir = temp_dir("run");
  gel::v1::Curve curve = planted_curve();
  std::filesystem::create_directories(dir + "/snapshots");
  const Configuration gel = quick_gel(2);
  for (int k : {0, 15}) {
    char name[32];
    std::snprintf(name, sizeof name, "snapshots/k_%03d.pb", k);
    write_configuration(gel, dir + "/" + name);
    curve.mutable_rows(k)->set_snapshot(name);
  }
  write_curve(curve, dir);
  const RunAnalysis run = analyse_runs({dir, dir});
  ASSERT_TRUE(run.curve.power_law.has_value());
  EXPECT_NEAR(run.curve.power_law->exponent, 3.0, 1e-9);  // planted P = phi^3
  EXPECT_NEAR(run.curve.power_law->prefactor, 1.0, 1e-9);
  ASSERT_TRUE(run.curve.regimes.multi_mode_start_phi.has_value());
  EXPECT_NEAR(*run.curve.regimes.multi_mode_start_phi, curve.rows(10).phi(), 1e-12);
  ASSERT_EQ(run.structure.size(), 2u);
  EXPECT_EQ(run.structure[0].snapshots.size(), 2u);
  ASSERT_TRUE(run.structure[0].df_fit.mean.has_value());
  EXPECT_NEAR(*run.structure[0].df_fit.std, 0.0, 1e-12);
  const nlohmann::json j = to_json(run);
  EXPECT_EQ(j["structure"].size(), 2u);
  EXPECT_TRUE(j["regimes"].contains("multi_mode_start_phi"));
  if (!find_gnuplot().empty()) {
    PictureOptions options;
    options.plot_width = 300, options.plot_height = 220, options.snapshot_size = 200;
    const auto written = render_run_pictures(run, dir + "/plots", options);
    EXPECT_EQ(written.size(), 8u + 2u);  // 8 plots, 2 snapshots
    for (const auto& path : written) EXPECT_GT(std::filesystem::file_size(path), 1000u) << path;
    options.format = "pdf";
    options.snapshots = false;
    for (const auto& path : render_run_pictures(run, dir + "/plots", options)) {
      EXPECT_EQ(std::filesystem::path(path).extension(), ".pdf");
      EXPECT_EQ(file_text(path).substr(0, 5), "%PDF-") << path;
    }
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace gel::analysis
