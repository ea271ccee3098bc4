#pragma once
// Density fluctuations between boxes, the correlation length xi^(0.5), and the packing-fraction
// profile phi(y) (MODEL.md "Structure analysis" and "Observables").
//
// Delta rho(l) / <rho>: the region is tiled by non-overlapping square boxes of side l (whole
// pixels, mx = round(l / hx) by my = round(l / hy), tiles from the lower-left corner, a
// remainder strip narrower than a box left out); the solid fraction of each box is one sample,
// and the ratio is the population standard deviation of the samples over their mean. Box
// sizes: geometric from l_min (default 1 a: half a particle diameter, where the ratio is near
// its single-pixel value sqrt((1 - <rho>)/<rho>)) by a factor 2^(1/4) up to l_max (default
// half the smaller side of the region, so there are at least 4 boxes), sizes that round to the
// same pixel box counted once.
//
// xi^(0.5): the first l where the ratio falls through 0.5, interpolated linearly in
// (ln l, ln ratio) between the two bracketing box sizes. Missing (std::nullopt) when the
// ratio is already below 0.5 at the smallest box or never falls below it: the crossing is then
// outside the measured range and is not extrapolated.
#include <optional>
#include <vector>

#include "gel/analysis/density_field.hpp"
#include "gel/configuration.hpp"

namespace gel::analysis {

struct FluctuationOptions {
  double l_min = 1.0;         // [a]
  double l_max = 0;           // [a]; 0 = half the smaller side of the region
  double factor = 1.189207115002721;  // 2^(1/4)
};

struct DensityFluctuation {
  std::vector<double> l;       // box side [a] (geometric mean of the pixel box's sides)
  std::vector<double> ratio;   // Delta rho(l) / <rho>
  std::vector<int> boxes;      // boxes averaged
};

DensityFluctuation density_fluctuation(const DensityField& field, const FluctuationOptions& options = {});

inline constexpr double kXiLevel = 0.5;
std::optional<double> correlation_length(const DensityFluctuation& fluctuation, double level = kXiLevel);

// phi(y): area of the disks inside each of `slices` equal slices of the region (between the
// walls, or [0, L_y)), divided by L_x times the slice height. Exact disk-slab intersection
// areas, no pixels; periodic images in y are counted when the box is periodic in y.
inline constexpr int kDefaultProfileSlices = 20;  // MODEL.md: slices of L_y / 20
struct PackingProfile {
  std::vector<double> y;    // slice centres [a]
  std::vector<double> phi;
  double slice = 0;         // slice height [a]
};
PackingProfile packing_profile(const Configuration& config, int slices = kDefaultProfileSlices);

}  // namespace gel::analysis
