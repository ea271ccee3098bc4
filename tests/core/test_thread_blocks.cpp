// On several threads the bond loop cuts the particles into blocks (bond_kernels.hpp): a bond
// with its ends in two blocks is computed by both owners, each adding it to its own end, and the
// breaks and resets found there are applied once, in bond order; contact detection looks for
// touching pairs in ranges of candidates. Here nearly every bond crosses blocks, and bonds
// break, reset and form while the run goes on, with T = 1, 2 and 3 and a change midway: the bits
// must not change.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

#include "engine/bond_kernels.hpp"
#include "gel/bench_network.hpp"
#include "gel/system.hpp"
#include "same_bits.hpp"
#include "test_scenes.hpp"

namespace gel {
namespace {

// The network with its particles numbered at random: its bonds join far-apart indices.
Configuration renumbered(const Configuration& config, std::uint64_t seed) {
  std::vector<std::int32_t> to(config.size());
  std::iota(to.begin(), to.end(), 0);
  std::shuffle(to.begin(), to.end(), std::mt19937_64(seed));
  Configuration out = config;
  for (std::size_t p = 0; p < config.size(); ++p) {
    const auto q = static_cast<std::size_t>(to[p]);
    out.x[q] = config.x[p];
    out.y[q] = config.y[p];
    out.theta[q] = config.theta[p];
    if (config.has_velocities()) {
      out.vx[q] = config.vx[p];
      out.vy[q] = config.vy[p];
      out.omega[q] = config.omega[p];
    }
  }
  for (BondRecord& bond : out.bonds) {
    bond.i = to[static_cast<std::size_t>(bond.i)];
    bond.j = to[static_cast<std::size_t>(bond.j)];
  }
  return out;
}

// Squeezed, then pulled apart: bonds reset and form, then break.
System deformed(const Configuration& config, const std::vector<int>& threads_per_segment) {
  System system(config, bond1_params(kAllEffects));
  system.install_walls();
  for (std::size_t k = 0; k < threads_per_segment.size(); ++k) {
    const double v = k == 0 ? 0.08 : -0.15;
    system.set_wall_velocities(v, -v);
    system.set_threads(threads_per_segment[k]);
    system.run(500);
  }
  return system;
}

TEST(ThreadBlocks, BondsAcrossBlocksGiveTheSameBitsOnAnyNumberOfThreads) {
  // Three blocks and a bit, numbered at random; about 1700 candidate pairs, two ranges of
  // contact detection.
  const Configuration config = renumbered(random_network(3 * static_cast<int>(detail::kParticleBlock) + 500, 5), 11);
  std::size_t across = 0;
  for (const BondRecord& bond : config.bonds)
    across += static_cast<std::size_t>(bond.i) / detail::kParticleBlock != static_cast<std::size_t>(bond.j) / detail::kParticleBlock;
  ASSERT_GT(across, config.bonds.size() / 2);

  const System serial = deformed(config, {1, 1, 1});
  // Every kind of event happened, so the exact path, its records and the rebuilt blocks ran.
  ASSERT_GT(serial.events().normal, 0);
  ASSERT_GT(serial.events().sliding + serial.events().rolling, 0);
  ASSERT_GT(serial.events().created, 0);
  for (const auto& segments : std::vector<std::vector<int>>{{2, 2, 2}, {3, 3, 3}, {3, 1, 2}}) {
    SCOPED_TRACE(::testing::PrintToString(segments));
    expect_same_bits(deformed(config, segments), serial);
  }
}

// Dimers numbered at random and flung apart: hundreds break in one step, in every block, and the
// energy they release is added to the ledger in bond order (the blocks' records merged) whatever
// the number of threads.
TEST(ThreadBlocks, BreaksInManyBlocksAreBookedInBondOrder) {
  Configuration config;
  const int pairs = 3 * static_cast<int>(detail::kParticleBlock) / 2 + 300, columns = 64;
  config.lx = 8.0 * columns;
  config.ly = 6.0 * (pairs / columns + 1);
  std::mt19937_64 random(3);
  std::uniform_real_distribution<double> speed(0.8, 1.0), angle(-3.0, 3.0);
  std::vector<double> vx;
  for (int p = 0; p < pairs; ++p) {
    const double x = 8.0 * (p % columns) + 1.0, y = 6.0 * (p / columns) + 1.0;
    const std::int32_t i = config.add_particle(x, y, angle(random)), j = config.add_particle(x + 2.0, y, angle(random));
    config.add_bond_at_contact(i, j);
    const double v = speed(random);
    vx.insert(vx.end(), {-v, v});
  }
  config.vx = vx;
  config.vy.assign(config.size(), 0.0);
  config.omega.assign(config.size(), 0.0);
  config = renumbered(config, 13);
  auto run = [&](int threads) {
    System system(config, bond1_params(kAllEffects));
    system.set_threads(threads);
    system.run(100);
    return system;
  };
  const System serial = run(1);
  ASSERT_EQ(serial.events().normal, pairs);
  for (const int threads : {2, 3}) {
    SCOPED_TRACE(threads);
    expect_same_bits(run(threads), serial);
  }
}

// The network in its own numbering (a walk: most bonds inside a block) gives the same bits too,
// and a state saved on three threads resumes on two as on one.
TEST(ThreadBlocks, SavedStateResumesWithAnotherNumberOfThreads) {
  const Configuration config = random_network(2 * static_cast<int>(detail::kParticleBlock) + 700, 6);
  System original = deformed(config, {3, 3});
  System on_one = System::load_state(original.save_state());
  System on_two = System::load_state(original.save_state());
  on_one.set_threads(1);
  on_two.set_threads(2);
  on_one.run(500);
  on_two.run(500);
  ASSERT_GT(on_one.events().normal + on_one.events().sliding + on_one.events().rolling, 0);
  expect_same_bits(on_two, on_one);
}


// A reset copies the new contact points into both blocks of a bond that crosses them. A copy
// left stale is not always caught by the exact path: here particle 0 spins, its bond to the
// particle in the next block (2048) resets, and the pair then rocks about the new contact points
// within the threshold, where the stale points would give a smaller, unflagged rolling moment.
TEST(ThreadBlocks, AResetReachesBothCopiesOfABondAcrossBlocks) {
  Configuration config;
  config.lx = config.ly = 200;
  config.periodic_y = false;
  config.add_particle(10, 5, 0);
  for (int p = 1; p < 2048; ++p) config.add_particle(4.0 * (p % 46) + 2, 4.0 * (p / 46) + 14, 0);  // apart
  config.add_particle(10 + kDiameter, 5, 0);
  config.add_bond_at_contact(0, 2048);
  config.vx.assign(config.size(), 0.0);
  config.vy.assign(config.size(), 0.0);
  config.omega.assign(config.size(), 0.0);
  config.omega[0] = 0.5;
  auto run = [&config](int threads) {
    System system(config, bond1_params(kSprings | kThresholds));
    system.set_threads(threads);
    system.run(20000);
    return system;
  };
  const System serial = run(1);
  ASSERT_EQ(serial.bonds().size(), 1u);
  ASSERT_GT(serial.events().rolling, 0);  // it reset
  expect_same_bits(run(2), serial);
}

}  // namespace
}  // namespace gel
