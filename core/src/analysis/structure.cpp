#include "gel/analysis/structure.hpp"

#include <chrono>

#include "gel/errors.hpp"

namespace gel::analysis {

StructureAnalysis analyse_structure(const Configuration& config, const StructureOptions& options) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  StructureAnalysis a;
  a.phi = config.packing_fraction();
  a.particles = static_cast<int>(config.size());
  a.bonds = static_cast<int>(config.bonds.size());
  a.mean_contact_number = config.mean_contact_number();
  a.pixel = options.pixel;
  const DensityField field = pixelise(config, options.pixel);
  a.correlation = density_correlation(field, options.correlation);
  a.correlation_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  a.df_profile = fractal_dimension_profile(a.correlation.r, a.correlation.c, options.df_half_window);
  try {
    a.df_fit = fit_fractal_dimension(a.correlation.r, a.correlation.c, options.fit_rmin, options.fit_rmax);
  } catch (const InvalidArgument& error) {
    a.df_fit_error = error.what();
  }
  a.fluctuation = density_fluctuation(field, options.fluctuation);
  a.xi_05 = correlation_length(a.fluctuation);
  a.profile = packing_profile(config, options.profile_slices);
  a.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return a;
}

nlohmann::json to_json(const StructureAnalysis& a, const StructureOptions& options) {
  nlohmann::json j;
  j["phi"] = a.phi;
  j["particles"] = a.particles;
  j["bonds"] = a.bonds;
  j["mean_contact_number"] = a.mean_contact_number;
  j["pixel"] = a.pixel;
  j["correlation"] = {{"r", a.correlation.r}, {"C", a.correlation.c}, {"mean_density", a.correlation.mean_density}};
  j["fractal_dimension_profile"] = {{"r", a.df_profile.r}, {"D_f", a.df_profile.df}, {"half_window", options.df_half_window}};
  if (a.df_fit) {
    j["fractal_dimension_fit"] = {{"D_f", a.df_fit->df}, {"stderr", a.df_fit->stderr_}, {"rmin", a.df_fit->rmin},
                                  {"rmax", a.df_fit->rmax}, {"points", a.df_fit->points}};
  } else {
    j["fractal_dimension_fit"] = nullptr;
    j["fractal_dimension_fit_error"] = a.df_fit_error;
  }
  j["density_fluctuation"] = {{"l", a.fluctuation.l}, {"ratio", a.fluctuation.ratio}, {"boxes", a.fluctuation.boxes}};
  j["xi_05"] = a.xi_05 ? nlohmann::json(*a.xi_05) : nlohmann::json(nullptr);
  j["profile"] = {{"y", a.profile.y}, {"phi", a.profile.phi}, {"slice", a.profile.slice}};
  j["seconds"] = a.seconds;
  j["correlation_seconds"] = a.correlation_seconds;
  return j;
}

}  // namespace gel::analysis
