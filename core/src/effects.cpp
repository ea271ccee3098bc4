#include "gel/effects.hpp"

#include <array>
#include <utility>

#include "gel/errors.hpp"

namespace gel {
namespace {
constexpr std::array<std::pair<const char*, Effect>, 9> kEffectNames{{
    {"normal", kNormalSpring},
    {"overlap", kOverlapRepulsion},
    {"sliding", kSliding},
    {"rolling", kRolling},
    {"thresholds", kThresholds},
    {"creation", kBondCreation},
    {"drag", kDrag},
    {"walls", kWalls},
    {"periodic_x", kPeriodicX},
}};
}  // namespace

unsigned parse_effects(const std::vector<std::string>& names) {
  if (names.empty()) return kAllEffects;
  unsigned effects = 0;
  for (const std::string& name : names) {
    bool known = false;
    for (const auto& [effect_name, effect] : kEffectNames) {
      if (name == effect_name) {
        effects |= effect;
        known = true;
      }
    }
    if (!known) {
      std::string list;
      for (const auto& entry : kEffectNames) list += std::string(list.empty() ? "" : ", ") + entry.first;
      throw InvalidArgument("effects", "unknown effect " + quoted(name) + " (known: " + list + ")");
    }
  }
  return effects;
}

std::vector<std::string> effect_names(unsigned effects) {
  std::vector<std::string> names;
  for (const auto& [name, effect] : kEffectNames)
    if (effects & effect) names.emplace_back(name);
  return names;
}

}  // namespace gel
