#pragma once
// One breadth-first search over the bonds, for the approach shortcut's wall group and the
// spanning test (compression_observables.cpp) and System::translate_wall_group.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "gel/system.hpp"

namespace gel {

// Marks every particle connected through bonds to a particle for which is_seed(i) holds, the
// seeds included, without going past a particle for which is_barrier(i) holds (it is neither
// marked nor crossed). The result is a set, so it does not depend on the order of the search.
template <class IsSeed, class IsBarrier>
std::vector<char> bonded_group(std::size_t n, const std::vector<Bond>& bonds, IsSeed&& is_seed, IsBarrier&& is_barrier) {
  std::vector<std::vector<std::int32_t>> adjacency(n);
  for (const Bond& bond : bonds) {
    adjacency[bond.i].push_back(bond.j);
    adjacency[bond.j].push_back(bond.i);
  }
  std::vector<char> in_group(n, 0);
  std::vector<std::int32_t> frontier;
  for (std::size_t i = 0; i < n; ++i)
    if (is_seed(i)) {
      in_group[i] = 1;
      frontier.push_back(static_cast<std::int32_t>(i));
    }
  while (!frontier.empty()) {
    const std::int32_t i = frontier.back();
    frontier.pop_back();
    for (const std::int32_t j : adjacency[i])
      if (!in_group[j] && !is_barrier(static_cast<std::size_t>(j))) {
        in_group[j] = 1;
        frontier.push_back(j);
      }
  }
  return in_group;
}

}  // namespace gel
