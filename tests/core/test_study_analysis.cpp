// The analysis of a study (docs/study_analysis.md): ensembles of synthetic curves whose answer
// is known in closed form (planted power laws, energy crossings and rupture onsets, noise of a
// known size), so that every value and every bootstrap interval can be checked against it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "gel/analysis/run_analysis.hpp"
#include "gel/analysis/study_analysis.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"
#include "gel/generator.hpp"

namespace gel::analysis {
namespace {

constexpr int kRows = 18;  // k = 0 (the generated network) .. 17, as the paper's schedule
double phi_of(int k) { return 0.12 * std::pow(1.1, k); }

// One member's row k before it becomes a CurveRow.
struct PlantedRow {
  double p = 0, stored = 0, dissipated = 0;
  long normal = 0, sliding = 0, rolling = 0;
  bool equilibrated = true, spans = true;
};

gel::v1::Curve make_curve(const std::vector<PlantedRow>& rows, int particles = 1000) {
  gel::v1::Curve curve;
  curve.set_particles(particles);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    auto* row = curve.add_rows();
    row->set_k(static_cast<int>(k));
    row->set_phi(phi_of(static_cast<int>(k)));
    row->set_target_phi(row->phi());
    row->set_p(rows[k].p);
    row->set_p_top(rows[k].p);
    row->set_p_bot(rows[k].p);
    row->set_stored_energy(rows[k].stored);
    row->set_dissipated_energy(rows[k].dissipated);
    row->mutable_ruptures()->set_normal(rows[k].normal);
    row->mutable_ruptures()->set_sliding(rows[k].sliding);
    row->mutable_ruptures()->set_rolling(rows[k].rolling);
    row->set_equilibrated(rows[k].equilibrated);
    row->set_spans(rows[k].spans);
  }
  return curve;
}

StudyEnsembleInput ensemble(const std::string& name, const std::vector<gel::v1::Curve>& curves) {
  StudyEnsembleInput e;
  e.name = name;
  e.curves = curves;
  for (std::size_t m = 0; m < curves.size(); ++m) e.seeds.push_back(m + 1);
  return e;
}

// Members whose P = C phi^lambda times exp(sigma eps) with eps ~ N(0, 1) drawn per member and
// row; the energies keep every row elastic (stored > dissipated) and nothing ruptures.
std::vector<gel::v1::Curve> noisy_power_law_members(int members, double c, double lambda, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> eps(0, 1);
  std::vector<gel::v1::Curve> curves;
  for (int m = 0; m < members; ++m) {
    std::vector<PlantedRow> rows(kRows);
    for (int k = 1; k < kRows; ++k) {
      rows[k].p = c * std::pow(phi_of(k), lambda) * std::exp(sigma * eps(rng));
      rows[k].stored = 10.0 * k, rows[k].dissipated = 1.0 * k;
    }
    curves.push_back(make_curve(rows));
  }
  return curves;
}

double width(const Estimate& e) { return *e.hi - *e.lo; }

TEST(StudyAnalysis, PowerLawExponentIntervalHasTheOlsWidthAndShrinksWithSeeds) {
  constexpr double kC = 2.0, kLambda = 3.2, kSigma = 0.1;
  // The mean curve's ln P_k scatters with variance (e^sigma^2 - 1) / n about the law, independently
  // per row, so the OLS slope has the standard error sqrt(that / S_uu), S_uu = sum (ln phi_k -
  // mean)^2 over the fitted rows k = 1..17; a 95 % interval is about 2 x 1.96 of it wide.
  double mean_u = 0, s_uu = 0;
  for (int k = 1; k < kRows; ++k) mean_u += std::log(phi_of(k)) / (kRows - 1);
  for (int k = 1; k < kRows; ++k) s_uu += std::pow(std::log(phi_of(k)) - mean_u, 2);
  auto expected_width = [&](int n) { return 2 * 1.96 * std::sqrt((std::exp(kSigma * kSigma) - 1) / n / s_uu); };

  const auto ten = noisy_power_law_members(10, kC, kLambda, kSigma, 7);
  const auto start = std::chrono::steady_clock::now();
  const StudyAnalysis a10 = analyse_study({ensemble("ten", ten)});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << "[ timing   ] analyse_study, 10 members x " << kRows << " rows, B = 1000: " << seconds << " s\n";
  const StudyEnsembleAnalysis& e10 = a10.ensembles.at(0);
  ASSERT_TRUE(e10.power_law_all.fit.has_value());
  const Estimate& lambda10 = e10.power_law_all.fit->exponent;
  ASSERT_TRUE(lambda10.lo && lambda10.hi);
  EXPECT_EQ(lambda10.n, 10);
  EXPECT_EQ(lambda10.resamples, 1000);
  EXPECT_LE(*lambda10.lo, kLambda);
  EXPECT_GE(*lambda10.hi, kLambda);
  EXPECT_LE(*lambda10.lo, lambda10.value);
  EXPECT_GE(*lambda10.hi, lambda10.value);
  EXPECT_GT(width(lambda10), expected_width(10) / 3) << "expected about " << expected_width(10);
  EXPECT_LT(width(lambda10), expected_width(10) * 3) << "expected about " << expected_width(10);
  EXPECT_EQ(e10.power_law_all.fit->points, kRows - 1);
  // The value is the one analyse_curves fits on the same mean curve.
  const CurveAnalysis plain = analyse_curves(ten);
  ASSERT_TRUE(plain.power_law.has_value());
  EXPECT_NEAR(lambda10.value, plain.power_law->exponent, 1e-12);
  EXPECT_NEAR(e10.power_law_all.fit->prefactor.value, plain.power_law->prefactor, 1e-12);
  // Every row Estimate is a member mean over all 10 seeds.
  EXPECT_NEAR(e10.rows[5].p.value, plain.ensemble.rows.at("P").mean[5], 1e-12);
  EXPECT_EQ(e10.rows[5].p.n, 10);

  // Four times the seeds: about half the width (sqrt(9/10) / sqrt(39/40) of it from the
  // bootstrap's n - 1 over n).
  const StudyAnalysis a40 = analyse_study({ensemble("forty", noisy_power_law_members(40, kC, kLambda, kSigma, 8))});
  const Estimate& lambda40 = a40.ensembles.at(0).power_law_all.fit->exponent;
  ASSERT_TRUE(lambda40.lo && lambda40.hi);
  EXPECT_LE(*lambda40.lo, kLambda);
  EXPECT_GE(*lambda40.hi, kLambda);
  const double ratio = width(lambda40) / width(lambda10);
  EXPECT_GT(ratio, 0.35);
  EXPECT_LT(ratio, 0.7);

  // Without noise every resample has the same mean curve: the interval is the value.
  const StudyAnalysis exact = analyse_study({ensemble("exact", noisy_power_law_members(10, kC, kLambda, 0.0, 9))});
  const Estimate& lambda0 = exact.ensembles.at(0).power_law_all.fit->exponent;
  EXPECT_NEAR(lambda0.value, kLambda, 1e-9);
  ASSERT_TRUE(lambda0.lo && lambda0.hi);
  EXPECT_NEAR(*lambda0.lo, lambda0.value, 1e-12);
  EXPECT_NEAR(*lambda0.hi, lambda0.value, 1e-12);
  EXPECT_NEAR(exact.ensembles[0].power_law_all.fit->prefactor.value, kC, 1e-9);
}

// Planted regimes on rows k = 0..17: stored - dissipated = 6.75 + shift - k from k = 1 (the
// crossing 3/4 of the way from row 6 to row 7 in ln phi when shift = 0); rolling resets in
// every interval, sliding from interval 8 on, normal breaks from the interval that ends at row
// 13 (so single -> multi-mode at phi_12), and a stray burst of normal breaks in the elastic
// interval ending at row 3 that is not where normal breaks begin. P follows phi^1.5, phi^3 and
// phi^5 in the three regimes, continuous at the planted boundaries.
constexpr double kElasticExponent = 1.5, kSingleExponent = 3.0, kMultiExponent = 5.0;
double planted_elastic_end() { return std::exp(std::log(phi_of(6)) + 0.75 * std::log(1.1)); }
double planted_multi_start() { return phi_of(12); }
double planted_p(double phi) {
  const double b1 = planted_elastic_end(), b2 = planted_multi_start();
  if (phi < b1) return std::pow(phi, kElasticExponent);
  const double at_b1 = std::pow(b1, kElasticExponent);
  if (phi < b2) return at_b1 * std::pow(phi / b1, kSingleExponent);
  return at_b1 * std::pow(b2 / b1, kSingleExponent) * std::pow(phi / b2, kMultiExponent);
}

gel::v1::Curve planted_regimes(double shift = 0) {
  std::vector<PlantedRow> rows(kRows);
  for (int k = 1; k < kRows; ++k) {
    PlantedRow& r = rows[k];
    const PlantedRow& before = rows[k - 1];
    r.p = planted_p(phi_of(k));
    r.stored = 10.0 * k;
    r.dissipated = r.stored - (6.75 + shift - k);
    r.rolling = before.rolling + 50;
    r.sliding = before.sliding + (k >= 8 ? 5 : 0);
    r.normal = before.normal + (k >= 13 ? 10 : 0) + (k == 3 ? 5 : 0);
  }
  return make_curve(rows);
}

TEST(StudyAnalysis, RegimeBoundariesAndPerRegimeExponentsArePlanted) {
  const std::vector<gel::v1::Curve> members(3, planted_regimes());
  const StudyAnalysis a = analyse_study({ensemble("planted", members)});
  const StudyEnsembleAnalysis& e = a.ensembles.at(0);
  ASSERT_TRUE(e.elastic_to_plastic_phi.has_value());
  EXPECT_NEAR(e.elastic_to_plastic_phi->value, planted_elastic_end(), 1e-9);
  ASSERT_TRUE(e.single_to_multi_mode_phi.has_value());
  EXPECT_NEAR(e.single_to_multi_mode_phi->value, planted_multi_start(), 1e-12);
  // Identical members: every resample is the ensemble, the intervals are the values.
  EXPECT_NEAR(*e.elastic_to_plastic_phi->lo, e.elastic_to_plastic_phi->value, 1e-12);
  EXPECT_NEAR(*e.single_to_multi_mode_phi->hi, e.single_to_multi_mode_phi->value, 1e-12);

  const double planted[3] = {kElasticExponent, kSingleExponent, kMultiExponent};
  const std::vector<int> rows[3] = {{1, 2, 3, 4, 5, 6}, {7, 8, 9, 10, 11}, {12, 13, 14, 15, 16, 17}};
  for (int r = 0; r < 3; ++r) {
    const OptionalPowerLaw& fit = e.power_law_regime[r];
    ASSERT_TRUE(fit.fit.has_value()) << regime_name(static_cast<Regime>(r)) << ": " << fit.error;
    EXPECT_NEAR(fit.fit->exponent.value, planted[r], 1e-9) << regime_name(static_cast<Regime>(r));
    EXPECT_EQ(fit.fit->rows, rows[r]) << regime_name(static_cast<Regime>(r));
  }
  // The gel-point form is fitted below the single -> multi-mode boundary.
  ASSERT_TRUE(e.gel_point.has_value());
  EXPECT_EQ(e.gel_point->rows, (std::vector<int>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}));

  // Labels follow the boundaries: a row by its phi, an interval by its phi_mid.
  EXPECT_EQ(e.rows[6].regime, Regime::kElastic);
  EXPECT_EQ(e.rows[7].regime, Regime::kSingleModePlastic);
  EXPECT_EQ(e.rows[11].regime, Regime::kSingleModePlastic);
  EXPECT_EQ(e.rows[12].regime, Regime::kMultiModePlastic);  // the boundary row: the later regime
  EXPECT_FALSE(e.rows[0].regime.has_value());
  ASSERT_EQ(e.intervals.size(), static_cast<std::size_t>(kRows - 1));
  EXPECT_EQ(e.intervals[6].k, 7);
  EXPECT_EQ(e.intervals[6].regime, Regime::kElastic);  // phi_mid below the crossing at 3/4
  EXPECT_EQ(e.intervals[7].regime, Regime::kSingleModePlastic);
  EXPECT_EQ(e.intervals[11].regime, Regime::kSingleModePlastic);
  EXPECT_EQ(e.intervals[12].regime, Regime::kMultiModePlastic);
  EXPECT_NEAR(e.intervals[12].gamma_normal.value, 10 / (1000 * std::log(1.1)), 1e-12);
  EXPECT_NEAR(e.rows[13].ruptures_normal.value, 15.0 / 1000, 1e-15);  // cumulative per particle

  // Where the members' energies cross at different rows, each resample finds its own boundary
  // and fits its own rows: the elastic exponent's interval opens although P has no noise at all.
  // Shifts centred on +0.02 put the ensemble's crossing just past row 7 and many resamples'
  // before it, where row 7 (on the phi^3 branch) leaves the elastic fit.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0, 0.3);
  std::vector<double> shifts(10);
  for (double& s : shifts) s = normal(rng);
  double mean_shift = 0;
  for (double s : shifts) mean_shift += s / 10;
  std::vector<gel::v1::Curve> scattered;
  for (double s : shifts) scattered.push_back(planted_regimes(0.25 + 0.02 + s - mean_shift));
  const StudyEnsembleAnalysis moved = analyse_study({ensemble("moved", scattered)}).ensembles.at(0);
  ASSERT_TRUE(moved.elastic_to_plastic_phi && moved.elastic_to_plastic_phi->lo);
  EXPECT_GT(moved.elastic_to_plastic_phi->value, phi_of(7));
  EXPECT_LT(*moved.elastic_to_plastic_phi->lo, phi_of(7));
  const Estimate& elastic = moved.power_law_regime[0].fit->exponent;
  ASSERT_TRUE(elastic.lo && elastic.hi);
  EXPECT_GT(width(elastic), 0.01);
  // The same crossing in every member: every resample fits the same rows, a closed interval.
  std::vector<gel::v1::Curve> held(10, planted_regimes(0.27));
  const Estimate fixed = analyse_study({ensemble("held", held)}).ensembles.at(0).power_law_regime[0].fit->exponent;
  EXPECT_NEAR(width(fixed), 0.0, 1e-12);
}

// Measured gels reset sliding contacts 20-50 times as often as they break bonds once both
// happen, so a share of all ruptures never marks where breaks begin; and one break in the
// plastic range that is not followed by more is not their onset either.
TEST(StudyAnalysis, NormalBreaksBeginWhereTheyGoOnHoweverManySlidingResetsThereAre) {
  std::vector<gel::v1::Curve> members;
  for (int m = 0; m < 4; ++m) {
    std::vector<PlantedRow> rows(kRows);
    for (int k = 1; k < kRows; ++k) {
      PlantedRow& r = rows[k];
      const PlantedRow& before = rows[k - 1];
      r.p = planted_p(phi_of(k));
      r.stored = 10.0 * k;
      r.dissipated = r.stored - (6.75 - k);
      r.rolling = before.rolling + 50;
      r.sliding = before.sliding + (k >= 8 ? 500 : 0);
      // A stray break ending at row 10 (in the plastic range), then breaks from row 13 on, each
      // interval's under 0.5 % of its ruptures.
      r.normal = before.normal + (k >= 13 ? 2 : 0) + (k == 10 ? 1 : 0);
    }
    members.push_back(make_curve(rows));
  }
  const StudyEnsembleAnalysis e = analyse_study({ensemble("sliding", members)}).ensembles.at(0);
  ASSERT_TRUE(e.single_to_multi_mode_phi.has_value());
  EXPECT_NEAR(e.single_to_multi_mode_phi->value, phi_of(12), 1e-12);
  EXPECT_FALSE(e.elastic_to_plastic_at_first_trusted_row);
  // A share of all ruptures asked for at the onset: 0.5 % is not reached, so there is none.
  StudyAnalysisOptions strict;
  strict.multi_mode_fraction = 0.05;
  EXPECT_FALSE(analyse_study({ensemble("sliding", members)}, strict).ensembles.at(0).single_to_multi_mode_phi.has_value());
  // Every trusted row already dissipated more than it stores: the boundary is the first trusted
  // row's phi, and the analysis says it is only an upper bound.
  for (auto& curve : members)
    for (auto& row : *curve.mutable_rows()) row.set_dissipated_energy(row.stored_energy() + 1);
  const StudyEnsembleAnalysis early = analyse_study({ensemble("early", members)}).ensembles.at(0);
  ASSERT_TRUE(early.elastic_to_plastic_phi.has_value());
  EXPECT_NEAR(early.elastic_to_plastic_phi->value, phi_of(1), 1e-12);
  EXPECT_TRUE(early.elastic_to_plastic_at_first_trusted_row);
  EXPECT_TRUE(to_json(analyse_study({ensemble("early", members)}))["ensembles"][0]["regimes"]
                  ["elastic_to_plastic_at_first_trusted_row"].get<bool>());
}

TEST(StudyAnalysis, BootstrapIntervalOfAMeanCoversTheTrueMean) {
  // 400 experiments of 10 normal draws: how often the row mean's interval holds the true mean.
  // The percentile bootstrap of a mean is about mean +- 1.96 s sqrt((n-1)/n) / sqrt(n), which at
  // n = 10 covers with P(|t_9| < 1.86) = 0.90 rather than 0.95 (it knows no Student t). 400
  // experiments measure that to +- 0.015 (one binomial sd): [0.85, 0.96] is 0.90 +- 3 sd and still
  // fails an interval one third too narrow (coverage 0.78) or a nominal 99 % one (0.97).
  constexpr double kMean = 5.0, kSd = 1.0;
  constexpr int kExperiments = 400, kMembers = 10;
  std::mt19937_64 rng(2024);
  std::normal_distribution<double> draw(kMean, kSd);
  int covered = 0;
  for (int x = 0; x < kExperiments; ++x) {
    std::vector<gel::v1::Curve> members;
    for (int m = 0; m < kMembers; ++m) {
      std::vector<PlantedRow> rows(2);
      rows[1].p = draw(rng);
      members.push_back(make_curve(rows));
    }
    StudyAnalysisOptions options;
    options.bootstrap_seed = static_cast<std::uint64_t>(x) + 1;
    const Estimate p = analyse_study({ensemble("draws", members)}, options).ensembles.at(0).rows.at(1).p;
    ASSERT_TRUE(p.lo && p.hi);
    covered += *p.lo <= kMean && kMean <= *p.hi;
  }
  const double coverage = static_cast<double>(covered) / kExperiments;
  std::cout << "[ coverage ] " << coverage << "\n";
  EXPECT_GE(coverage, 0.85);
  EXPECT_LE(coverage, 0.96);
}

std::string field_of(const std::function<void()>& call) {
  try {
    call();
  } catch (const InvalidArgument& error) {
    return error.field();
  }
  return "(no error)";
}

TEST(StudyAnalysis, UntrustedRowsStayOutOfTheFitsAndFewSeedsGiveNoInterval) {
  // Four members on P = phi^3 exactly; at row 3 every member reads ten times the law and one of
  // them stopped at the wait limit: the row is listed and the fit is the planted law without it.
  std::vector<gel::v1::Curve> members = noisy_power_law_members(4, 1.0, 3.0, 0.0, 1);
  for (auto& c : members) c.mutable_rows(3)->set_p(10 * c.rows(3).p());
  members[2].mutable_rows(3)->set_equilibrated(false);
  const StudyEnsembleAnalysis e = analyse_study({ensemble("limited", members)}).ensembles.at(0);
  ASSERT_EQ(e.excluded_rows.size(), 1u);
  EXPECT_EQ(e.excluded_rows[0].k, 3);
  EXPECT_EQ(e.excluded_rows[0].reason, "not equilibrated in 1 of 4 members");
  EXPECT_FALSE(e.rows[3].trusted);
  EXPECT_EQ(e.rows[3].equilibrated_members, 3);
  EXPECT_EQ(e.rows[3].spanning_members, 4);
  EXPECT_FALSE(e.rows[0].trusted);  // the initial state never enters a fit
  EXPECT_TRUE(e.rows[4].trusted);
  ASSERT_TRUE(e.power_law_all.fit.has_value());
  EXPECT_NEAR(e.power_law_all.fit->exponent.value, 3.0, 1e-9);
  EXPECT_EQ(e.power_law_all.fit->points, kRows - 2);
  const auto& fitted = e.power_law_all.fit->rows;
  EXPECT_EQ(std::count(fitted.begin(), fitted.end(), 3), 0);
  EXPECT_EQ(std::count(fitted.begin(), fitted.end(), 0), 0);
  ASSERT_TRUE(e.gel_point.has_value());
  EXPECT_EQ(std::count(e.gel_point->rows.begin(), e.gel_point->rows.end(), 3), 0);
  EXPECT_FALSE(e.intervals[2].trusted);  // rows 2-3
  EXPECT_FALSE(e.intervals[3].trusted);  // rows 3-4
  EXPECT_FALSE(e.intervals[3].regime.has_value());
  EXPECT_TRUE(e.intervals[0].trusted);  // rows 0-1: the generated network is a defined start
  const nlohmann::json j = to_json(analyse_study({ensemble("limited", members)}));
  EXPECT_EQ(j["ensembles"][0]["excluded_rows"][0]["k"], 3);
  EXPECT_TRUE(j["ensembles"][0]["intervals"][3]["regime"].is_null());
  // Asked for, the row comes back and biases the fit.
  StudyAnalysisOptions include;
  include.include_unequilibrated = true;
  const StudyEnsembleAnalysis with = analyse_study({ensemble("limited", members)}, include).ensembles.at(0);
  EXPECT_TRUE(with.excluded_rows.empty());
  EXPECT_TRUE(with.rows[3].trusted);
  EXPECT_GT(std::abs(with.power_law_all.fit->exponent.value - 3.0), 0.05);

  // Two seeds: values, no intervals.
  const std::vector<gel::v1::Curve> two = noisy_power_law_members(2, 1.0, 3.0, 0.1, 2);
  const StudyAnalysis pair = analyse_study({ensemble("pair", two)});
  const StudyEnsembleAnalysis& p = pair.ensembles.at(0);
  EXPECT_EQ(p.rows[5].p.n, 2);
  EXPECT_FALSE(p.rows[5].p.lo.has_value());
  EXPECT_FALSE(p.power_law_all.fit->exponent.hi.has_value());
  EXPECT_EQ(p.power_law_all.fit->exponent.resamples, 0);
  const nlohmann::json pj = to_json(pair)["ensembles"][0];
  EXPECT_TRUE(pj["rows"][5]["P"]["lo"].is_null());
  EXPECT_TRUE(pj["power_law"]["all"]["exponent"]["hi"].is_null());
  EXPECT_EQ(pj["power_law"]["all"]["exponent"]["n"], 2);
  EXPECT_TRUE(pj["power_law"]["elastic"].is_object());  // every row elastic
  EXPECT_TRUE(pj["power_law"]["single_mode_plastic"].is_null());
  EXPECT_FALSE(pj["power_law"]["single_mode_plastic_error"].get<std::string>().empty());
  EXPECT_TRUE(pj["regimes"]["elastic_to_plastic_phi"].is_null());

  // Errors name the field.
  const StudyEnsembleInput ok = ensemble("a", two);
  EXPECT_EQ(field_of([] { analyse_study({}); }), "ensembles");
  EXPECT_EQ(field_of([] { analyse_study({ensemble("empty", {})}); }), "ensembles[0].curves");
  StudyEnsembleInput short_seeds = ok;
  short_seeds.seeds.pop_back();
  EXPECT_EQ(field_of([&] { analyse_study({short_seeds}); }), "ensembles[0].seeds");
  EXPECT_EQ(field_of([&] { analyse_study({ok, ok}); }), "ensembles[1].name");
  StudyEnsembleInput short_dirs = ok;
  short_dirs.dirs = {"/nonexistent"};
  EXPECT_EQ(field_of([&] { analyse_study({short_dirs}); }), "ensembles[0].dirs");
  StudyEnsembleInput other_rows = ensemble("b", two);
  other_rows.curves[1].mutable_rows(2)->set_k(9);
  EXPECT_EQ(field_of([&] { analyse_study({ok, other_rows}); }), "ensembles[1].curves");
  StudyAnalysisOptions negative;
  negative.bootstrap_samples = -1;
  EXPECT_EQ(field_of([&] { analyse_study({ok}, negative); }), "bootstrap_samples");
}

TEST(StudyAnalysis, SameInputGivesTheSameTextAndEnsemblesDoNotInfluenceEachOther) {
  const StudyEnsembleInput a = ensemble("bond1", noisy_power_law_members(5, 1.0, 3.0, 0.1, 3));
  StudyEnsembleInput b = ensemble("bond2", std::vector<gel::v1::Curve>(5, planted_regimes()));
  for (int m = 0; m < 5; ++m) b.curves[m].mutable_rows(9)->set_p(b.curves[m].rows(9).p() * (1 + 0.05 * m));
  StudyAnalysisOptions options;
  options.bootstrap_samples = 300;
  const std::string once = to_json(analyse_study({a, b}, options)).dump();
  const std::string again = to_json(analyse_study({a, b}, options)).dump();
  EXPECT_EQ(once, again);
  const nlohmann::json j = nlohmann::json::parse(once);
  EXPECT_EQ(j["format"], "gel.study-analysis.v1");
  EXPECT_EQ(j["bootstrap_samples"], 300);
  EXPECT_DOUBLE_EQ(j["confidence"].get<double>(), 0.95);
  EXPECT_EQ(j["ensembles"][1]["name"], "bond2");
  EXPECT_EQ(j["ensembles"][0]["seeds"], nlohmann::json({1, 2, 3, 4, 5}));
  EXPECT_EQ(j["ensembles"][0]["particles"], 1000);
  for (const char* key : {"rows", "intervals", "excluded_rows", "regimes", "power_law", "gel_point", "xi_05", "xi_power_law",
                          "fractal_dimension_initial", "structure_seconds"})
    EXPECT_TRUE(j["ensembles"][0].contains(key)) << key;
  EXPECT_TRUE(j["ensembles"][1]["regimes"]["rule"].is_string());
  // An ensemble's resamples are its own: alone or after another, the same numbers.
  EXPECT_EQ(to_json(analyse_study({b}, options))["ensembles"][0].dump(), j["ensembles"][1].dump());
  // The seed is used: another seed, other intervals.
  options.bootstrap_seed = 2;
  EXPECT_NE(to_json(analyse_study({a, b}, options)).dump(), once);
}

std::string temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("gel_study_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "snapshots");
  return dir.string();
}

TEST(StudyAnalysis, SnapshotsGiveXiAndTheInitialFractalDimensionPerMember) {
  // Three member directories with the engine's own snapshots of a generated gel at rows 0, 8,
  // 12 and 17; the third member has no snapshot at row 8, so that row's xi rests on 2 members.
  std::vector<gel::v1::Curve> curves = noisy_power_law_members(3, 1.0, 3.0, 0.05, 4);
  std::vector<std::string> dirs;
  for (int m = 0; m < 3; ++m) {
    const std::string dir = temp_dir("member" + std::to_string(m));
    // The quick gel at twice its clusters (phi 0.24): in its small box the density fluctuation
    // of the quick gel itself stays above 0.5 up to the largest boxes, so it has no xi.
    gel::v1::Generator g;
    g.set_preset("quick");
    g.set_n_clusters(32);
    g.set_seed(static_cast<std::uint64_t>(m) + 1);
    const Configuration network = generate_gel(g);
    for (int k : {0, 8, 12, 17}) {
      if (m == 2 && k == 8) continue;
      char name[32];
      std::snprintf(name, sizeof name, "snapshots/k_%03d.pb", k);
      write_configuration(network, dir + "/" + name);
      curves[m].mutable_rows(k)->set_snapshot(name);
    }
    dirs.push_back(dir);
  }
  StudyEnsembleInput input = ensemble("structured", curves);
  input.dirs = dirs;
  StudyAnalysisOptions options;
  options.bootstrap_samples = 200;
  const StudyEnsembleAnalysis e = analyse_study({input}, options).ensembles.at(0);
  ASSERT_TRUE(e.fractal_dimension_initial.has_value());
  EXPECT_EQ(e.fractal_dimension_initial->n, 3);
  EXPECT_GT(e.fractal_dimension_initial->value, 1.3);
  EXPECT_LT(e.fractal_dimension_initial->value, 1.9);
  ASSERT_TRUE(e.fractal_dimension_initial->lo && e.fractal_dimension_initial->hi);
  EXPECT_LE(*e.fractal_dimension_initial->lo, e.fractal_dimension_initial->value);
  EXPECT_GE(*e.fractal_dimension_initial->hi, e.fractal_dimension_initial->value);
  ASSERT_EQ(e.xi_05.size(), 4u);
  EXPECT_EQ(e.xi_05[0].k, 0);
  EXPECT_EQ(e.xi_05[1].k, 8);
  EXPECT_EQ(e.xi_05[0].xi.n, 3);
  EXPECT_EQ(e.xi_05[1].xi.n, 2);
  EXPECT_FALSE(e.xi_05[1].xi.lo.has_value());  // 2 members: no interval
  EXPECT_TRUE(e.xi_05[3].xi.lo.has_value());
  EXPECT_GT(e.xi_05[0].xi.value, 1.0);
  EXPECT_NEAR(e.xi_05[0].phi, e.rows[0].phi.value, 1e-15);
  // The same networks at rows 0, 12 and 17: the same xi, so the power law over the rows where
  // every member has xi (not row 8) is flat.
  EXPECT_NEAR(e.xi_05[3].xi.value, e.xi_05[0].xi.value, 1e-12);
  ASSERT_TRUE(e.xi_power_law.fit.has_value()) << e.xi_power_law.error;
  EXPECT_EQ(e.xi_power_law.fit->rows, (std::vector<int>{0, 12, 17}));
  EXPECT_NEAR(e.xi_power_law.fit->exponent.value, 0.0, 1e-9);
  EXPECT_EQ(e.xi_power_law.fit->exponent.n, 3);
  EXPECT_GT(e.structure_seconds, 0.0);
  const nlohmann::json j = to_json(analyse_study({input}, options))["ensembles"][0];
  EXPECT_EQ(j["xi_05"].size(), 4u);
  EXPECT_EQ(j["xi_05"][1]["xi"]["n"], 2);
  EXPECT_EQ(j["fractal_dimension_initial"]["n"], 3);
  EXPECT_EQ(j["xi_power_law"]["points"], 3);
  // Without directories there is no structure at all.
  input.dirs.clear();
  const StudyEnsembleAnalysis bare = analyse_study({input}, options).ensembles.at(0);
  EXPECT_TRUE(bare.xi_05.empty());
  EXPECT_FALSE(bare.fractal_dimension_initial.has_value());
  EXPECT_FALSE(bare.xi_power_law.fit.has_value());
  const nlohmann::json bj = to_json(analyse_study({input}, options))["ensembles"][0];
  EXPECT_TRUE(bj["xi_05"].empty());
  EXPECT_TRUE(bj["xi_power_law"].is_null());
  EXPECT_TRUE(bj["fractal_dimension_initial"].is_null());
  for (const auto& dir : dirs) std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace gel::analysis
