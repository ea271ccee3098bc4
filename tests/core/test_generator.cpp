// Fractal gel generator (MODEL.md "Initial configuration"; generator.hpp for the algorithm).
// Geometry is checked by brute force over all pairs (minimum image; contact distance 2a is far
// below half of every box used here), independently of the generator's cell lists.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <numeric>
#include <string>
#include <unistd.h>
#include <vector>

#include "gel/configuration.hpp"
#include "gel/errors.hpp"
#include "gel/generator.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"

namespace gel {
namespace {

constexpr double kTolerance = kDefaultContactTolerance;

gel::v1::Generator request(double lx, double ly, int n_floc, int n_clusters, std::uint64_t seed) {
  gel::v1::Generator g;
  g.set_lx(lx);
  g.set_ly(ly);
  g.set_n_floc(n_floc);
  g.set_n_clusters(n_clusters);
  g.set_seed(seed);
  return g;
}

gel::v1::Generator quick(std::uint64_t seed) {
  gel::v1::Generator g;
  g.set_preset("quick");
  g.set_seed(seed);
  return g;
}

double gap(const Configuration& c, std::int32_t i, std::int32_t j) {
  double dx, dy;
  c.separation(i, j, dx, dy);
  return std::sqrt(dx * dx + dy * dy) - kDiameter;
}

// Bit-for-bit equality of two double arrays (== would equate 0.0 and -0.0).
bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

bool same_bonds(const std::vector<BondRecord>& a, const std::vector<BondRecord>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t k = 0; k < a.size(); ++k) {
    const double ua[4] = {a[k].bix, a[k].biy, a[k].bjx, a[k].bjy};
    const double ub[4] = {b[k].bix, b[k].biy, b[k].bjx, b[k].bjy};
    if (a[k].i != b[k].i || a[k].j != b[k].j || std::memcmp(ua, ub, sizeof ua) != 0) return false;
  }
  return true;
}

// All pairs: no overlap beyond the tolerance, every bond between touching particles with its
// contact points along the line of centres, and every touching pair bonded exactly once.
void expect_contacts_consistent(const Configuration& c) {
  const std::int32_t n = static_cast<std::int32_t>(c.size());
  std::vector<std::vector<std::int32_t>> bonded(n);
  for (const BondRecord& b : c.bonds) {
    ASSERT_NE(b.i, b.j);
    bonded[b.i].push_back(b.j);
    bonded[b.j].push_back(b.i);
    EXPECT_LT(std::abs(gap(c, b.i, b.j)), kTolerance) << "bond " << b.i << "-" << b.j;
    // Lab-frame contact point on i, R(theta_i) (bix, biy), must point along n = r_j - r_i.
    double dx, dy;
    c.separation(b.i, b.j, dx, dy);
    const double r = std::hypot(dx, dy);
    const double ci = std::cos(c.theta[b.i]), si = std::sin(c.theta[b.i]);
    EXPECT_NEAR(ci * b.bix - si * b.biy, dx / r, 1e-12);
    EXPECT_NEAR(si * b.bix + ci * b.biy, dy / r, 1e-12);
  }
  int overlaps = 0, unbonded_contacts = 0, duplicates = 0;
  for (std::int32_t i = 0; i < n; ++i) {
    std::vector<std::int32_t> partners = bonded[i];
    std::sort(partners.begin(), partners.end());
    duplicates += static_cast<int>(partners.end() - std::unique(partners.begin(), partners.end()));
    for (std::int32_t j = i + 1; j < n; ++j) {
      const double g = gap(c, i, j);
      if (g < -kTolerance) ++overlaps;
      if (g < kTolerance && std::find(bonded[i].begin(), bonded[i].end(), j) == bonded[i].end()) ++unbonded_contacts;
    }
  }
  EXPECT_EQ(overlaps, 0);
  EXPECT_EQ(unbonded_contacts, 0);
  EXPECT_EQ(duplicates, 0);
}

// Number of particles reached from particle 0 through bonds.
std::size_t connected_size(const Configuration& c) {
  std::vector<std::vector<std::int32_t>> adjacency(c.size());
  for (const BondRecord& b : c.bonds) {
    adjacency[b.i].push_back(b.j);
    adjacency[b.j].push_back(b.i);
  }
  std::vector<char> seen(c.size(), 0);
  std::vector<std::int32_t> stack{0};
  seen[0] = 1;
  std::size_t count = 0;
  while (!stack.empty()) {
    const std::int32_t p = stack.back();
    stack.pop_back();
    ++count;
    for (const std::int32_t q : adjacency[p])
      if (!seen[q]) seen[q] = 1, stack.push_back(q);
  }
  return count;
}

std::string temporary_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("gel_generator_test_" + std::to_string(::getpid()) + "_" + name)).string();
}

TEST(Generator, SameSeedGivesIdenticalConfiguration) {
  const Configuration a = generate_gel(quick(7));
  const Configuration b = generate_gel(quick(7));
  EXPECT_TRUE(same_bits(a.x, b.x));
  EXPECT_TRUE(same_bits(a.y, b.y));
  EXPECT_TRUE(same_bits(a.theta, b.theta));
  EXPECT_TRUE(same_bonds(a.bonds, b.bonds));
}

TEST(Generator, DifferentSeedsGiveDifferentConfigurations) {
  const Configuration a = generate_gel(quick(7));
  const Configuration b = generate_gel(quick(8));
  ASSERT_EQ(a.size(), b.size());
  EXPECT_FALSE(same_bits(a.x, b.x));
  EXPECT_FALSE(same_bits(a.y, b.y));
  const Configuration fa = generate_floc(64, 7);
  const Configuration fb = generate_floc(64, 8);
  EXPECT_FALSE(same_bits(fa.x, fb.x));
}

TEST(Generator, QuickGelHasNoOverlapsAndBondsExactlyTheTouchingPairs) {
  for (std::uint64_t seed : {1, 2, 3}) {
    SCOPED_TRACE(seed);
    const Configuration c = generate_gel(quick(seed));
    ASSERT_GT(c.size(), 100u);
    expect_contacts_consistent(c);
  }
}

TEST(Generator, NetworkIsOneConnectedCluster) {
  for (std::uint64_t seed : {1, 2, 3, 4}) {
    SCOPED_TRACE(seed);
    const Configuration c = generate_gel(quick(seed));
    EXPECT_EQ(connected_size(c), c.size());
    // Rigid aggregation of rigid clusters makes a tree: a second contact in one join has
    // probability zero, so exactly N - 1 bonds connect N particles.
    EXPECT_EQ(c.bonds.size(), c.size() - 1);
  }
}

// Largest distance between two particles of the first floc (particles 0 .. n-1), with its
// coordinates unwrapped across the periodic boundaries along its bonds.
double first_floc_extent(const Configuration& c, std::int32_t n) {
  std::vector<std::vector<std::int32_t>> adjacency(n);
  for (const BondRecord& b : c.bonds)
    if (b.i < n && b.j < n) adjacency[b.i].push_back(b.j), adjacency[b.j].push_back(b.i);
  std::vector<double> ux(n), uy(n);
  std::vector<char> seen(n, 0);
  std::vector<std::int32_t> stack{0};
  seen[0] = 1;
  while (!stack.empty()) {
    const std::int32_t p = stack.back();
    stack.pop_back();
    for (const std::int32_t q : adjacency[p]) {
      if (seen[q]) continue;
      double dx, dy;
      c.separation(p, q, dx, dy);
      ux[q] = ux[p] + dx;
      uy[q] = uy[p] + dy;
      seen[q] = 1;
      stack.push_back(q);
    }
  }
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), n) << "the floc is not connected";
  double extent = 0;
  for (std::int32_t i = 0; i < n; ++i)
    for (std::int32_t j = 0; j < n; ++j) extent = std::max(extent, std::hypot(ux[i] - ux[j], uy[i] - uy[j]));
  return extent;
}

// Flocs wider than half the box: the network wraps around the periodic boundaries, so contacts
// and collisions go through images of the cluster that is moving.
TEST(Generator, FlocsLargerThanHalfTheBoxStillGiveAValidConnectedGel) {
  for (std::uint64_t seed : {1, 2}) {
    SCOPED_TRACE(seed);
    const Configuration c = generate_gel(request(50, 60, 64, 3, seed));
    EXPECT_GT(first_floc_extent(c, 64), 25.0);
    expect_contacts_consistent(c);
    EXPECT_EQ(connected_size(c), c.size());
  }
}

TEST(Generator, PackingFractionAndSummaryMatchTheConfiguration) {
  GeneratorSummary summary;
  const Configuration c = generate_gel(request(80, 100, 32, 20, 11), &summary);
  ASSERT_EQ(c.size(), 640u);
  EXPECT_DOUBLE_EQ(c.packing_fraction(), kPi * 640 / (80.0 * 100.0));
  EXPECT_DOUBLE_EQ(summary.phi, kPi * 640 / (80.0 * 100.0));
  EXPECT_EQ(summary.particles, 640);
  EXPECT_EQ(summary.bonds, static_cast<int>(c.bonds.size()));
  EXPECT_DOUBLE_EQ(summary.mean_contact_number, 2.0 * c.bonds.size() / 640.0);
  EXPECT_GT(summary.floc_fractal_dimension, 1.2);
  EXPECT_LT(summary.floc_fractal_dimension, 2.0);
  EXPECT_GT(summary.floc_fractal_dimension_stderr, 0.0);
  EXPECT_GT(summary.walk_moves, 0);
  EXPECT_GT(summary.seconds, 0.0);
  // Positions inside the box, seed and resolved parameters recorded.
  for (std::size_t p = 0; p < c.size(); ++p) {
    EXPECT_TRUE(c.x[p] >= 0 && c.x[p] <= c.lx);
    EXPECT_TRUE(c.y[p] >= 0 && c.y[p] <= c.ly);
  }
  EXPECT_EQ(c.seed, 11u);
  EXPECT_EQ(c.generator.seed(), 11u);
  EXPECT_EQ(c.generator.n_floc(), 32);
  EXPECT_EQ(c.generator.n_clusters(), 20);
  EXPECT_EQ(c.generator.walk_step(), kDefaultWalkStep);
  EXPECT_EQ(c.generator.contact_tolerance(), kDefaultContactTolerance);
  EXPECT_EQ(c.generator.max_attempts(), kDefaultMaxAttempts);
  EXPECT_TRUE(c.periodic_y);
  EXPECT_FALSE(c.has_walls());
}

TEST(Generator, PresetsHaveThePaperSizes) {
  const gel::v1::Generator b1 = resolve_generator(generator_preset("paper-bond1"));
  EXPECT_EQ(b1.lx(), 300);
  EXPECT_EQ(b1.ly(), 500);
  EXPECT_EQ(b1.n_floc() * b1.n_clusters(), 5760);
  const gel::v1::Generator b2 = resolve_generator(generator_preset("paper-bond2"));
  EXPECT_EQ(b2.lx(), 200);
  EXPECT_EQ(b2.ly(), 500);
  EXPECT_EQ(b2.n_floc() * b2.n_clusters(), 3840);
  GeneratorSummary summary;
  const Configuration q = generate_gel(quick(1), &summary);
  EXPECT_LE(q.size(), 500u);
  EXPECT_NEAR(summary.phi, 0.12, 0.01);
  // Explicit fields override the preset.
  gel::v1::Generator g = generator_preset("paper-bond1");
  g.set_n_clusters(10);
  EXPECT_EQ(resolve_generator(g).n_clusters(), 10);
  EXPECT_EQ(resolve_generator(g).lx(), 300);
}

TEST(Generator, FlocIsCentredConnectedAndOverlapFree) {
  std::vector<std::pair<double, double>> size_rg;
  const Configuration f = generate_floc(256, 3, &size_rg);
  ASSERT_EQ(f.size(), 256u);
  double cx = 0, cy = 0;
  for (std::size_t p = 0; p < f.size(); ++p) cx += f.x[p], cy += f.y[p];
  EXPECT_NEAR(cx / 256, 0.0, 1e-9);
  EXPECT_NEAR(cy / 256, 0.0, 1e-9);
  expect_contacts_consistent(f);
  EXPECT_EQ(connected_size(f), f.size());
  // One level per doubling, sizes 2 .. 256, Rg growing; a pair has Rg = a exactly.
  ASSERT_EQ(size_rg.size(), 8u);
  EXPECT_EQ(size_rg.front().first, 2.0);
  EXPECT_NEAR(size_rg.front().second, 1.0, 1e-12);
  EXPECT_EQ(size_rg.back().first, 256.0);
  for (std::size_t k = 1; k < size_rg.size(); ++k) EXPECT_GT(size_rg[k].second, size_rg[k - 1].second);
  // The top level's Rg is that of the floc itself.
  double r2 = 0;
  for (std::size_t p = 0; p < f.size(); ++p) r2 += f.x[p] * f.x[p] + f.y[p] * f.y[p];
  EXPECT_NEAR(std::sqrt(r2 / 256), size_rg.back().second, 1e-9);
}

// Reaction-limited hierarchical aggregation in 2D gives D ~ 1.53-1.55 for large clusters
// (local slopes, 256 flocs of 1024, see README); the fit over sizes 8..512 of smaller flocs
// gives ~1.51. Diffusion-limited hierarchical aggregation gives 1.42-1.45, compact objects 2.
// With 64 seeds the standard error of the pooled fit is ~0.01, so the bounds are 5 or more
// errors away from the expected value and a change of the sampling rule towards the
// diffusion-limited or compact limit fails the test.
TEST(Generator, FlocFractalDimensionLiesBetweenDiffusionLimitedAndCompact) {
  std::vector<std::pair<double, double>> pooled;
  const int seeds = 64;
  std::vector<double> per_seed;
  for (int seed = 1; seed <= seeds; ++seed) {
    std::vector<std::pair<double, double>> size_rg;
    generate_floc(512, static_cast<std::uint64_t>(seed), &size_rg);
    if (pooled.empty()) pooled.assign(size_rg.size(), {0.0, 0.0});
    for (std::size_t k = 0; k < size_rg.size(); ++k) {
      pooled[k].first = size_rg[k].first;
      pooled[k].second += size_rg[k].second / seeds;
    }
    per_seed.push_back(fit_fractal_dimension(size_rg).dimension);
  }
  const FractalFit fit = fit_fractal_dimension(pooled);
  EXPECT_EQ(fit.points, 7);  // sizes 8 .. 512
  EXPECT_GT(fit.dimension, 1.46);
  EXPECT_LT(fit.dimension, 1.62);
  EXPECT_LT(fit.standard_error, 0.03);
  const double mean = std::accumulate(per_seed.begin(), per_seed.end(), 0.0) / seeds;
  EXPECT_GT(mean, 1.46);
  EXPECT_LT(mean, 1.62);
}

TEST(Generator, FractalFitRecoversAPowerLaw) {
  std::vector<std::pair<double, double>> exact, noisy;
  for (int k = 1; k <= 8; ++k) {
    const double n = std::pow(2.0, k);
    exact.emplace_back(n, std::pow(n, 1.0 / 1.7));
    noisy.emplace_back(n, std::pow(n, 1.0 / 1.7) * (k % 2 ? 1.05 : 0.95));
  }
  const FractalFit e = fit_fractal_dimension(exact);
  EXPECT_NEAR(e.dimension, 1.7, 1e-12);
  EXPECT_NEAR(e.standard_error, 0.0, 1e-10);
  EXPECT_EQ(e.points, 6);  // sizes 8 .. 256
  const FractalFit n = fit_fractal_dimension(noisy, 2);
  EXPECT_EQ(n.points, 8);
  EXPECT_NEAR(n.dimension, 1.7, 0.1);
  EXPECT_GT(n.standard_error, 0.005);
  EXPECT_TRUE(std::isnan(fit_fractal_dimension({{8, 3.0}}).dimension));
}

void expect_invalid(const gel::v1::Generator& g, const std::string& field) {
  const auto start = std::chrono::steady_clock::now();
  try {
    generate_gel(g);
    ADD_FAILURE() << "no exception, expected one for " << field;
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), field) << e.what();
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 10.0);
}

TEST(Generator, ImpossibleRequestsFailAtOnceNamingTheField) {
  expect_invalid(request(100, 100, 48, 4, 1), "generator.n_floc");  // not a power of two
  expect_invalid(request(100, 100, -4, 4, 1), "generator.n_floc");
  expect_invalid(request(-100, 100, 16, 4, 1), "generator.lx");
  expect_invalid(request(100, 0, 16, 4, 1), "generator.ly");
  expect_invalid(request(100, 100, 16, -1, 1), "generator.n_clusters");
  expect_invalid(request(100, 100, 16, 0, 1), "generator.n_clusters");
  expect_invalid(request(std::nan(""), 100, 16, 4, 1), "generator.lx");
  expect_invalid(request(4, 100, 1, 4, 1), "generator.lx");  // box below three cells
  // Boxes whose grid alone would take gigabytes, and the absurd: refused by the area limit.
  expect_invalid(request(15000, 15000, 16, 4, 1), "generator.lx");
  expect_invalid(request(100, 1e308, 16, 4, 1), "generator.ly");
  expect_invalid(request(std::numeric_limits<double>::infinity(), 100, 16, 4, 1), "generator.lx");
  // Denser than any disk packing: rejected before any work.
  expect_invalid(request(20, 20, 64, 2, 1), "generator.n_clusters");
  // Possible as a packing, impossible for random placement of flocs: fails after the
  // documented number of attempts, not a hang.
  expect_invalid(request(40, 40, 16, 20, 1), "generator.n_clusters");
  // A floc wider than the box cannot be placed without touching its own image.
  expect_invalid(request(20, 20, 64, 1, 1), "generator.n_clusters");
  gel::v1::Generator bad_step = quick(1);
  bad_step.set_walk_step(-1);
  expect_invalid(bad_step, "generator.walk_step");
  gel::v1::Generator bad_tolerance = quick(1);
  bad_tolerance.set_contact_tolerance(0.5);
  expect_invalid(bad_tolerance, "generator.contact_tolerance");
  gel::v1::Generator bad_attempts = quick(1);
  bad_attempts.set_max_attempts(-3);
  expect_invalid(bad_attempts, "generator.max_attempts");
  gel::v1::Generator bad_preset;
  bad_preset.set_preset("paper-bond3");
  expect_invalid(bad_preset, "generator.preset");
  EXPECT_THROW(generate_floc(12, 1), InvalidArgument);
  EXPECT_THROW(generate_floc(0, 1), InvalidArgument);
}

TEST(Generator, WrittenConfigurationReadsBackBitIdentical) {
  const Configuration c = generate_gel(request(60, 80, 32, 8, 5));
  for (const std::string ending : {".json", ".pb"}) {
    SCOPED_TRACE(ending);
    const std::string path = temporary_path("gel" + ending);
    write_configuration(c, path);
    const Configuration r = read_configuration(path);
    std::filesystem::remove(path);
    EXPECT_EQ(r.lx, c.lx);
    EXPECT_EQ(r.ly, c.ly);
    EXPECT_EQ(r.periodic_y, c.periodic_y);
    EXPECT_TRUE(same_bits(r.x, c.x));
    EXPECT_TRUE(same_bits(r.y, c.y));
    EXPECT_TRUE(same_bits(r.theta, c.theta));
    EXPECT_TRUE(same_bonds(r.bonds, c.bonds));
    EXPECT_EQ(r.seed, c.seed);
    EXPECT_EQ(r.generator.SerializeAsString(), c.generator.SerializeAsString());
  }
}

// The engine started from the generated configuration and from the file gives the same
// trajectory: the same random kicks, then identical forces bit for bit. The kicks make the
// forces non-zero (a fresh gel is at rest: every bond at its natural length).
TEST(Generator, EngineGivesTheSameForcesForTheWrittenAndTheInMemoryGel) {
  const Configuration c = generate_gel(quick(3));
  const std::string path = temporary_path("engine.json");
  write_configuration(c, path);
  const Configuration r = read_configuration(path);
  std::filesystem::remove(path);
  SimParams params;
  params.bond = bond_preset("bond1");
  params.dt = params.dt_fraction * shortest_period(params.bond);
  System a(c, params), b(r, params);
  a.compute_forces();
  double fresh = 0;
  for (std::size_t p = 0; p < a.size(); ++p) fresh = std::max({fresh, std::abs(a.fx()[p]), std::abs(a.fy()[p])});
  EXPECT_LT(fresh, 1e-6);  // bonds at rest (gaps below the contact tolerance)
  for (std::int32_t p = 0; p < static_cast<std::int32_t>(c.size()); ++p) {
    const double v = 0.01 * std::sin(1.7 * p), w = 0.01 * std::cos(2.3 * p);
    a.set_velocity(p, v, w, v - w);
    b.set_velocity(p, v, w, v - w);
  }
  a.run(50);
  b.run(50);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_TRUE(same_bits(a.fx(), b.fx()));
  EXPECT_TRUE(same_bits(a.fy(), b.fy()));
  EXPECT_TRUE(same_bits(a.torque(), b.torque()));
  EXPECT_TRUE(same_bits(a.x(), b.x()));
  double largest = 0;
  for (std::size_t p = 0; p < a.size(); ++p) largest = std::max(largest, std::abs(a.fx()[p]));
  EXPECT_GT(largest, 1e-4);
}

}  // namespace
}  // namespace gel
