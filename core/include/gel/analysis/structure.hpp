#pragma once
// Everything measured on one configuration (MODEL.md "Structure analysis"): C(r), D_f(r), the
// D_f fit, Delta rho(l)/<rho> and xi^(0.5), and phi(y). What `gelsim analyze CONFIG` prints.
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "gel/analysis/correlation.hpp"
#include "gel/analysis/density_field.hpp"
#include "gel/analysis/fluctuation.hpp"
#include "gel/configuration.hpp"

namespace gel::analysis {

struct StructureOptions {
  double pixel = kDefaultPixel;
  double fit_rmin = kDefaultFitRmin, fit_rmax = kDefaultFitRmax;
  double df_half_window = kDefaultDfHalfWindow;
  int profile_slices = kDefaultProfileSlices;
  CorrelationOptions correlation;
  FluctuationOptions fluctuation;
};

struct StructureAnalysis {
  double phi = 0;
  int particles = 0;
  int bonds = 0;
  double mean_contact_number = 0;
  double pixel = 0;
  Correlation correlation;
  DfProfile df_profile;
  std::optional<DfFit> df_fit;  // missing when the fit range holds fewer than 3 bins
  std::string df_fit_error;     // why it is missing
  DensityFluctuation fluctuation;
  std::optional<double> xi_05;
  PackingProfile profile;
  double seconds = 0;              // wall-clock time of the whole analysis
  double correlation_seconds = 0;  // pixelisation + FFT + radial average
};

StructureAnalysis analyse_structure(const Configuration& config, const StructureOptions& options = {});

// {"phi", "particles", "bonds", "mean_contact_number", "pixel",
//  "correlation": {"r", "C", "mean_density"}, "fractal_dimension_profile": {"r", "D_f", "half_window"},
//  "fractal_dimension_fit": {"D_f", "stderr", "rmin", "rmax", "points"} | null,
//  "density_fluctuation": {"l", "ratio", "boxes"}, "xi_05": number | null,
//  "profile": {"y", "phi", "slice"}, "seconds", "correlation_seconds"}
nlohmann::json to_json(const StructureAnalysis& analysis, const StructureOptions& options = {});

}  // namespace gel::analysis
