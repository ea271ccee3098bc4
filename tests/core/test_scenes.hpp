#pragma once
// Small scenes shared by the engine tests.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "gel/configuration.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"
#include "gel/v1/scene.pb.h"

namespace gel {

// A straight vertical chain of n bonded particles at x = 5, from y = 5 up, in an L_x wide box
// with room above it: install_walls() puts a wall at each end.
inline Configuration vertical_chain(int n, double lx) {
  Configuration config;
  config.lx = lx;
  config.ly = 2.0 * n + 10;
  for (int k = 0; k < n; ++k) config.add_particle(5, 5 + kDiameter * k);
  for (int k = 0; k + 1 < n; ++k) config.add_bond_at_contact(k, k + 1);
  return config;
}

// Two bonded particles along x in an open 40 x 40 box, the second moved by `gap` from contact.
inline Configuration pair_along_x(double gap) {
  Configuration config;
  config.lx = config.ly = 40;
  config.periodic_y = false;
  config.add_particle(10, 10);
  config.add_particle(10 + kDiameter, 10);
  config.add_bond_at_contact(0, 1);
  config.x[1] += gap;
  return config;
}

// Bond-1 parameters with the given effects and the default time-step rule.
inline SimParams bond1_params(unsigned effects) {
  SimParams params;
  params.bond = bond_preset("bond1");
  params.effects = effects;
  params.dt = params.dt_fraction * shortest_period(params.bond);
  return params;
}

// Two particles along x at distance 2a + gap, bonded at contact (contact points along n),
// turned by theta_i and theta_j.
inline Configuration bonded_pair(double gap, double theta_i = 0, double theta_j = 0) {
  Configuration config;
  config.lx = config.ly = 40;
  config.periodic_y = false;
  config.add_particle(10, 10, 0);
  config.add_particle(10 + kDiameter, 10, 0);
  config.add_bond_at_contact(0, 1);
  config.x[1] += gap;
  config.theta[0] = theta_i;
  config.theta[1] = theta_j;
  return config;
}

inline constexpr unsigned kSprings = kNormalSpring | kOverlapRepulsion | kSliding | kRolling;

// Surface gap of particles 0 and 1.
inline double pair_gap(const System& system) {
  const double dx = system.x()[1] - system.x()[0], dy = system.y()[1] - system.y()[0];
  return std::sqrt(dx * dx + dy * dy) - kDiameter;
}

// 96 particles (12 flocs of 8) in 24 x 48, bond 1, three targets up to phi = 0.5, at the given
// fidelity: a whole compression in well under a second, also under the sanitizers.
inline gel::v1::Scene tiny_compression_scene(const char* fidelity) {
  gel::v1::Scene scene;
  scene.mutable_bond()->set_preset("bond1");
  gel::v1::Generator* g = scene.mutable_generator();
  g->set_lx(24);
  g->set_ly(48);
  g->set_n_floc(8);
  g->set_n_clusters(12);
  g->set_seed(3);
  gel::v1::Compression* c = scene.mutable_compression();
  c->set_fidelity(fidelity);
  c->set_steps(3);
  c->set_phi_max(0.5);
  return scene;
}

// tiny_compression_scene at the fast fidelity, tested every 200 steps: the paper's waiting
// protocol in a fraction of a second.
inline gel::v1::Scene tiny_fast_scene() {
  gel::v1::Scene scene = tiny_compression_scene("fast");
  scene.mutable_compression()->set_m_exam(200);
  return scene;
}

// A path under the temporary folder that no earlier run left behind: gel_<name>_<pid>, removed
// if it exists (a test that wants the folder itself creates it, or lets the run do so).
inline std::string fresh_temp_path(const std::string& name) {
  const auto path = std::filesystem::temp_directory_path() / ("gel_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(path);
  return path.string();
}

}  // namespace gel
