// Format names and the writer factory of gel/export.hpp; the writers live one per file here.
#include <cmath>
#include <filesystem>

#include "gel/errors.hpp"
#include "gel/export.hpp"

namespace gel::exporting {

Format format_from_name(std::string_view name) {
  if (name == "xyz" || name == "extxyz") return Format::kExtendedXyz;
  if (name == "gsd") return Format::kGsd;
  if (name == "vtu" || name == "vtk") return Format::kVtu;
  throw InvalidArgument("format", "unknown export format '" + std::string(name) + "' (xyz, gsd or vtu)");
}

Format format_from_path(std::string_view path) {
  const auto ends_with = [&](std::string_view suffix) { return path.size() >= suffix.size() && path.substr(path.size() - suffix.size()) == suffix; };
  if (ends_with(".xyz") || ends_with(".extxyz")) return Format::kExtendedXyz;
  if (ends_with(".gsd")) return Format::kGsd;
  if (ends_with(".vtu") || ends_with(".pvd")) return Format::kVtu;
  throw InvalidArgument("format", "cannot tell the format from '" + std::string(path) +
                                      "': name it .xyz, .gsd, .vtu or .pvd, or give --format");
}

std::string_view format_name(Format format) {
  switch (format) {
    case Format::kExtendedXyz: return "xyz";
    case Format::kGsd: return "gsd";
    case Format::kVtu: return "vtu";
  }
  return "?";
}

std::unique_ptr<FrameWriter> open_writer(Format format, const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code error;
  if (!parent.empty()) std::filesystem::create_directories(parent, error);
  if (error) throw InvalidArgument("path", "cannot create the folder '" + parent.string() + "': " + error.message());
  switch (format) {
    case Format::kExtendedXyz: return make_xyz_writer(path);
    case Format::kGsd: return make_gsd_writer(path, false, 0, nullptr);
    case Format::kVtu: return make_vtu_writer(path);
  }
  throw InvalidArgument("format", "unknown export format");
}

std::unique_ptr<FrameWriter> reopen_gsd_trajectory(const std::string& path, std::int64_t last_step,
                                                   std::int64_t* last_kept_step) {
  return make_gsd_writer(path, true, last_step, last_kept_step);
}

double frame_phi(const Frame& frame) {
  return frame.phi >= 0 ? frame.phi : frame.configuration.packing_fraction();
}

}  // namespace gel::exporting
