#include "gel/run_directory.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string_view>

#include <nlohmann/json.hpp>

#include "gel/errors.hpp"

namespace gel {
namespace {

namespace fs = std::filesystem;

// What a run writes into its directory (gel/compression.hpp, gel/curve_io.hpp), what gelsim
// plot adds to it by default, and an ensemble's manifest; each file also as the ".tmp" an
// interrupted atomic write leaves.
constexpr std::array<std::string_view, 8> kRunFiles = {"curve.json",          "curve.csv",      "profiles.csv",  "checkpoint.bin",
                                                       "checkpoint.prev.bin", "trajectory.gsd", "ensemble.json", "thermo.csv"};
constexpr std::array<std::string_view, 2> kRunFolders = {"snapshots", "plots"};

bool is_member_folder(const fs::directory_entry& entry) {
  const std::string name = entry.path().filename().string();
  return name.size() > 5 && name.rfind("seed_", 0) == 0 &&
         name.find_first_not_of("0123456789", 5) == std::string::npos && entry.is_directory() &&
         !earlier_run_outputs(entry.path().string()).empty();
}

bool is_run_output(const fs::directory_entry& entry) {
  const std::string name = entry.path().filename().string();
  for (const std::string_view file : kRunFiles)
    if (name == file || name == std::string(file) + ".tmp") return true;
  if (std::find(kRunFolders.begin(), kRunFolders.end(), name) != kRunFolders.end()) return true;
  return is_member_folder(entry);
}

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in, nullptr, false);
}

// A checkpoint, curve.json or ensemble.json that gelsim wrote: its magic, or its keys.
bool written_by_gelsim(const fs::path& dir) {
  for (const char* name : {"checkpoint.bin", "checkpoint.prev.bin"}) {
    std::ifstream in(dir / name, std::ios::binary);
    char magic[7] = {};
    if (in.read(magic, sizeof magic) && std::string_view(magic, sizeof magic) == "GELCKPT") return true;
  }
  const nlohmann::json curve = read_json(dir / "curve.json");
  if (curve.is_object() && curve.contains("program_version") && curve.contains("rows") && curve.at("rows").is_array())
    return true;
  const nlohmann::json ensemble = read_json(dir / "ensemble.json");
  return ensemble.is_object() && ensemble.contains("seeds") && ensemble.at("seeds").is_array() && ensemble.contains("scene");
}

}  // namespace

std::vector<std::string> earlier_run_outputs(const std::string& dir) {
  std::vector<std::string> found;
  std::error_code error;
  if (dir.empty() || !fs::is_directory(dir, error)) return found;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir, error))
    if (is_run_output(entry)) found.push_back(entry.path().filename().string());
  std::sort(found.begin(), found.end());
  return found;
}

std::vector<std::string> clear_earlier_run(const std::string& dir) {
  const std::vector<std::string> outputs = earlier_run_outputs(dir);
  if (outputs.empty()) return outputs;
  if (!written_by_gelsim(dir)) {
    std::string names;
    for (const std::string& name : outputs) names += (names.empty() ? "" : ", ") + name;
    throw InvalidArgument("out_dir", "'" + dir + "' holds " + names +
                                         " but no checkpoint, curve.json or ensemble.json that gelsim wrote, so it may not be a "
                                         "run's folder: nothing was removed; remove them yourself or write the run elsewhere");
  }
  for (const std::string& name : outputs) fs::remove_all(fs::path(dir) / name);
  return outputs;
}

EnsembleMembers ensemble_members(const std::string& dir) {
  EnsembleMembers members;
  std::error_code error;
  if (dir.empty() || !fs::is_directory(dir, error) || fs::exists(fs::path(dir) / "curve.json", error)) return members;
  std::vector<std::pair<std::uint64_t, fs::path>> found;  // (seed, folder)
  for (const fs::directory_entry& entry : fs::directory_iterator(dir, error)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_directory() || name.size() <= 5 || name.rfind("seed_", 0) != 0 ||
        name.find_first_not_of("0123456789", 5) != std::string::npos)
      continue;
    try {
      found.emplace_back(std::stoull(name.substr(5)), entry.path());
    } catch (const std::out_of_range&) {  // more digits than a seed has: not a member
    }
  }
  // The manifest's order is the order the ensemble was asked for (--seeds 3,1,2); without one
  // (a study's ensemble, an archived copy), by seed.
  std::vector<std::uint64_t> order;
  const nlohmann::json manifest = read_json(fs::path(dir) / "ensemble.json");
  if (manifest.is_object() && manifest.contains("seeds") && manifest.at("seeds").is_array())
    for (const nlohmann::json& seed : manifest.at("seeds"))
      if (seed.is_number_unsigned()) order.push_back(seed.get<std::uint64_t>());
  auto rank = [&](std::uint64_t seed) {
    const auto at = std::find(order.begin(), order.end(), seed);
    return std::pair<std::size_t, std::uint64_t>(static_cast<std::size_t>(at - order.begin()), seed);
  };
  std::sort(found.begin(), found.end(), [&](const auto& a, const auto& b) { return rank(a.first) < rank(b.first); });
  for (const auto& [seed, folder] : found)
    (fs::exists(folder / "curve.json", error) ? members.finished : members.unfinished).push_back(folder.string());
  return members;
}

}  // namespace gel
