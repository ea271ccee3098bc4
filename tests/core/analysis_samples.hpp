#pragma once
// Samples shared by the analysis tests (test_correlation.cpp, test_fluctuation.cpp,
// test_curve_analysis.cpp, test_run_analysis.cpp, test_pictures.cpp).
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "gel/configuration.hpp"
#include "gel/generator.hpp"
#include "gel/v1/scene.pb.h"  // gel::v1::Curve

namespace gel::analysis {

inline Configuration periodic_box(double lx, double ly) {
  Configuration c;
  c.lx = lx;
  c.ly = ly;
  c.periodic_y = true;
  return c;
}

inline Configuration quick_gel(std::uint64_t seed) {
  gel::v1::Generator g;
  g.set_preset("quick");
  g.set_seed(seed);
  return generate_gel(g);
}

// A curve with planted regimes: intervals 0-4 store more than they dissipate, 5-9 dissipate by
// rolling only, 10-14 break and slide too; interval 7 carries a stray burst of sliding.
inline gel::v1::Curve planted_curve() {
  gel::v1::Curve curve;
  curve.set_particles(1000);
  double stored = 0, dissipated = 0;
  long normal = 0, sliding = 0, rolling = 0;
  for (int k = 0; k <= 15; ++k) {
    if (k > 0) {
      const int i = k - 1;
      if (i < 5) stored += 10, dissipated += 1, rolling += 2;
      else if (i < 10) stored += 1, dissipated += 10, rolling += 50, sliding += (i == 7 ? 10 : 0);
      else stored += 1, dissipated += 30, rolling += 50, sliding += 20, normal += 10;
    }
    auto* row = curve.add_rows();
    row->set_k(k);
    row->set_phi(0.12 * std::pow(1.1, k));
    row->set_target_phi(row->phi());
    row->set_p(std::pow(row->phi(), 3));
    row->set_equilibrated(true);
    row->set_spans(true);
    row->set_stored_energy(stored);
    row->set_dissipated_energy(dissipated);
    row->mutable_ruptures()->set_normal(normal);
    row->mutable_ruptures()->set_sliding(sliding);
    row->mutable_ruptures()->set_rolling(rolling);
  }
  return curve;
}

inline std::string temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("gel_analysis_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir.string();
}

inline std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace gel::analysis
