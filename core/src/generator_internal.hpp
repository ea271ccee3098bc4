#pragma once
// Pieces shared by the two stages of the gel generator (generator.cpp, generator_floc.cpp).
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

namespace gel::detail {

// Portable random numbers: mt19937_64 is fully specified by the standard (seeding included);
// the conversions below are ours, so they do not depend on the standard library.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}

  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

  // Uniform integer in [0, n), n >= 1, without modulo bias (rejection of the top remainder).
  std::uint64_t below(std::uint64_t n) {
    const std::uint64_t limit = ~std::uint64_t{0} - (~std::uint64_t{0} % n);
    std::uint64_t value;
    do value = engine_();
    while (value >= limit);
    return value % n;
  }

  // Uniformly distributed unit vector, by rejection from the square into the unit disk
  // (only +, *, sqrt: correctly rounded everywhere, unlike sin and cos).
  void direction(double& c, double& s) {
    for (;;) {
      const double u = 2.0 * uniform() - 1.0;
      const double v = 2.0 * uniform() - 1.0;
      const double r2 = u * u + v * v;
      if (r2 > 1e-12 && r2 <= 1.0) {
        const double r = std::sqrt(r2);
        c = u / r;
        s = v / r;
        return;
      }
    }
  }

 private:
  std::mt19937_64 engine_;
};

// Independent streams from one seed: floc k uses derive_seed(seed, k); the network stage uses
// derive_seed(seed, kNetworkStream). SplitMix64 finaliser of seed + (stream + 1) * golden.
inline constexpr std::uint64_t kNetworkStream = 0xFFFFFFFFull;
inline std::uint64_t derive_seed(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t z = seed + (stream + 1) * 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// A floc as the aggregation leaves it: positions relative to the centre of mass and each
// particle's orientation as the unit vector (c, s) = (cos theta, sin theta).
struct Floc {
  std::vector<double> x, y, c, s;
  std::vector<std::pair<double, double>> size_rg;  // per level from size 2: (size, mean Rg)
};

// Reaction-limited hierarchical aggregation of n particles (n a power of two, validated by
// the caller). Overlap means a gap below -tolerance.
Floc aggregate_floc(int n, std::uint64_t seed, double tolerance);

// Pairs (i < j) with gap below `tolerance` in free space, sorted; for flocs.
std::vector<std::pair<std::int32_t, std::int32_t>> touching_pairs_free(const std::vector<double>& x,
                                                                       const std::vector<double>& y,
                                                                       double tolerance);

}  // namespace gel::detail
