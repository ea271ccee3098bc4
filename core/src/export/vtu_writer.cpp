// VTK XML unstructured grids (ParaView, VisIt, python3-vtk9): one .vtu per frame, and for
// several frames a .pvd collection that lists them with their step as the time.
//
// A frame is one grid: a vertex cell per particle (glyph it with the point array "radius" to
// see disks) and a line cell per bond. A bond that crosses the periodic x boundary would draw
// across the whole box, so its line ends at an image of the far particle instead: an extra
// point with ghost = 1 that repeats the data of the particle it images ("particle" holds the
// index). The version string is an XML comment after the declaration. Point arrays: radius,
// theta, orientation (unit vector of the body x axis), wall (0 free, 1 bottom, 2 top), particle,
// ghost, velocity, angular_velocity and, with the bond law, force and torque (the contact
// loads). Cell arrays: bond (-1 for particle cells) and the bond state of gel/export.hpp (gap,
// contact_i, contact_j, sliding_displacement, bending_angle and, with the bond law,
// normal_force, sliding_force, rolling_moment), 0 on particle cells: VTK's ASCII reader stops
// at "nan".
#include <cmath>
#include <filesystem>
#include <fmt/format.h>

#include "file_output.hpp"
#include "gel/export.hpp"
#include "gel/units.hpp"
#include "gel_version.hpp"

namespace gel::exporting {
namespace {

constexpr int kVtkVertex = 1, kVtkLine = 3;

// The version string, as an XML comment after the declaration: readers skip it, and VTK's
// ASCII string arrays are awkward to read back. "--" may not appear in a comment.
std::string version_comment() {
  std::string version = "gelsim " + program_version();
  for (std::size_t at = version.find("--"); at != std::string::npos; at = version.find("--")) version.replace(at, 2, "- -");
  return "<!-- program=\"" + version + "\" -->\n";
}

std::string vtu_document(const Frame& frame) {
  const Configuration& c = frame.configuration;
  const std::size_t n = c.size();
  // Points: the particles, then one image per bond that wraps around x (or y without walls).
  std::vector<double> px(c.x), py(c.y);
  std::vector<std::int32_t> owner(n);
  for (std::size_t i = 0; i < n; ++i) owner[i] = static_cast<std::int32_t>(i);
  std::vector<std::int64_t> line_end(c.bonds.size());
  for (std::size_t b = 0; b < c.bonds.size(); ++b) {
    const auto& bond = c.bonds[b];
    double dx = 0, dy = 0;
    c.separation(bond.i, bond.j, dx, dy);
    const double image_x = c.x[bond.i] + dx, image_y = c.y[bond.i] + dy;
    if (image_x == c.x[bond.j] && image_y == c.y[bond.j]) {
      line_end[b] = bond.j;
      continue;
    }
    line_end[b] = static_cast<std::int64_t>(px.size());
    px.push_back(image_x);
    py.push_back(image_y);
    owner.push_back(bond.j);
  }
  const std::size_t points = px.size(), cells = n + c.bonds.size();

  std::string xml = "<?xml version=\"1.0\"?>\n" + version_comment() + "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n";
  xml += "<FieldData>\n";
  const auto field = [&](const char* name, const char* type, const std::string& value) {
    xml += fmt::format("<DataArray type=\"{}\" Name=\"{}\" NumberOfTuples=\"1\" format=\"ascii\">{}</DataArray>\n", type, name, value);
  };
  field("step", "Int64", std::to_string(frame.step));
  field("phi", "Float64", fmt::format("{:.17g}", frame_phi(frame)));
  field("k", "Int32", std::to_string(frame.k));
  // VTK's ASCII reader stops at "nan": what is unknown is left out.
  if (std::isfinite(frame.p)) field("P", "Float64", fmt::format("{:.17g}", frame.p));
  field("box_lx", "Float64", fmt::format("{:.17g}", c.lx));
  field("box_ly", "Float64", fmt::format("{:.17g}", c.ly));
  if (c.has_walls()) {
    field("wall_bottom", "Float64", fmt::format("{:.17g}", c.wall_bottom));
    field("wall_top", "Float64", fmt::format("{:.17g}", c.wall_top));
  }
  xml += "</FieldData>\n";
  xml += fmt::format("<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n<PointData Scalars=\"radius\">\n", points, cells);
  const auto point_array = [&](const char* name, const char* type, int components, auto&& value) {
    xml += fmt::format("<DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"ascii\">\n", type, name, components);
    for (std::size_t p = 0; p < points; ++p) {
      xml += value(static_cast<std::size_t>(owner[p]), p);
      xml += '\n';
    }
    xml += "</DataArray>\n";
  };
  point_array("radius", "Float64", 1, [&](std::size_t, std::size_t) { return fmt::format("{:.17g}", kRadius); });
  point_array("theta", "Float64", 1, [&](std::size_t i, std::size_t) { return fmt::format("{:.17g}", c.theta[i]); });
  point_array("orientation", "Float64", 3, [&](std::size_t i, std::size_t) {
    return fmt::format("{:.17g} {:.17g} 0", std::cos(c.theta[i]), std::sin(c.theta[i]));
  });
  point_array("wall", "Int32", 1, [&](std::size_t i, std::size_t) { return std::to_string(c.has_walls() ? int(c.wall[i]) : 0); });
  point_array("particle", "Int32", 1, [&](std::size_t i, std::size_t) { return std::to_string(i); });
  point_array("ghost", "UInt8", 1, [&](std::size_t, std::size_t p) { return std::string(p < n ? "0" : "1"); });
  const auto at = [](const std::vector<double>& column, std::size_t i) { return column.empty() ? 0.0 : column[i]; };
  point_array("velocity", "Float64", 3, [&](std::size_t i, std::size_t) {
    return fmt::format("{:.17g} {:.17g} 0", at(c.vx, i), at(c.vy, i));
  });
  point_array("angular_velocity", "Float64", 1, [&](std::size_t i, std::size_t) { return fmt::format("{:.17g}", at(c.omega, i)); });
  const BondState state = bond_state(c, frame.bond_law ? &*frame.bond_law : nullptr, frame.effects);
  if (state.with_forces) {
    const ParticleLoads loads = particle_loads(c, state);
    point_array("force", "Float64", 3, [&](std::size_t i, std::size_t) { return fmt::format("{:.17g} {:.17g} 0", loads.fx[i], loads.fy[i]); });
    point_array("torque", "Float64", 1, [&](std::size_t i, std::size_t) { return fmt::format("{:.17g}", loads.torque[i]); });
  }
  xml += "</PointData>\n<CellData Scalars=\"bond\">\n<DataArray type=\"Int32\" Name=\"bond\" format=\"ascii\">\n";
  for (std::size_t i = 0; i < n; ++i) xml += "-1\n";
  for (std::size_t b = 0; b < c.bonds.size(); ++b) xml += std::to_string(b) + "\n";
  xml += "</DataArray>\n";
  // One value (or 2D vector, written with z = 0) per bond line; particle cells hold 0.
  const auto bond_array = [&](const char* name, const std::vector<double>& first, const std::vector<double>* second) {
    xml += fmt::format("<DataArray type=\"Float64\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"ascii\">\n", name, second ? 3 : 1);
    for (std::size_t i = 0; i < n; ++i) xml += second ? "0 0 0\n" : "0\n";
    for (std::size_t b = 0; b < c.bonds.size(); ++b)
      xml += second ? fmt::format("{:.17g} {:.17g} 0\n", first[b], (*second)[b]) : fmt::format("{:.17g}\n", first[b]);
    xml += "</DataArray>\n";
  };
  bond_array("gap", state.gap, nullptr);
  bond_array("contact_i", state.contact_ix, &state.contact_iy);
  bond_array("contact_j", state.contact_jx, &state.contact_jy);
  bond_array("sliding_displacement", state.sliding_x, &state.sliding_y);
  bond_array("bending_angle", state.bending, nullptr);
  if (state.with_forces) {
    bond_array("normal_force", state.normal_force, nullptr);
    bond_array("sliding_force", state.sliding_force_x, &state.sliding_force_y);
    bond_array("rolling_moment", state.rolling_moment, nullptr);
  }
  xml += "</CellData>\n<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
  for (std::size_t p = 0; p < points; ++p) xml += fmt::format("{:.17g} {:.17g} 0\n", px[p], py[p]);
  xml += "</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  for (std::size_t i = 0; i < n; ++i) xml += std::to_string(i) + "\n";
  for (std::size_t b = 0; b < c.bonds.size(); ++b) xml += fmt::format("{} {}\n", c.bonds[b].i, line_end[b]);
  xml += "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
  for (std::size_t i = 1; i <= n; ++i) xml += std::to_string(i) + "\n";
  for (std::size_t b = 1; b <= c.bonds.size(); ++b) xml += std::to_string(n + 2 * b) + "\n";
  xml += "</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n";
  for (std::size_t i = 0; i < n; ++i) xml += fmt::format("{}\n", kVtkVertex);
  for (std::size_t b = 0; b < c.bonds.size(); ++b) xml += fmt::format("{}\n", kVtkLine);
  xml += "</DataArray>\n</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
  return xml;
}

class VtuWriter final : public FrameWriter {
 public:
  explicit VtuWriter(const std::string& path) : path_(path), collection_(path.ends_with(".pvd")) {}

  void append(const Frame& frame) override {
    if (!collection_) {
      if (!written_.empty())
        throw InvalidArgument("path", "'" + path_ + "' holds one frame: name the output .pvd to write several");
      write_file_atomically(path_, vtu_document(frame));
      written_.push_back(path_);
      return;
    }
    // Frames beside the collection: run.pvd lists run_00000.vtu, run_00001.vtu, ...
    const std::filesystem::path pvd(path_);
    const std::string name = fmt::format("{}_{:05d}.vtu", pvd.stem().string(), frames_.size());
    write_file_atomically((pvd.parent_path() / name).string(), vtu_document(frame));
    frames_.push_back({frame.step, name});
    written_.push_back((pvd.parent_path() / name).string());
    std::string xml = "<?xml version=\"1.0\"?>\n" + version_comment() + "<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n";
    for (const auto& [step, file] : frames_) xml += fmt::format("<DataSet timestep=\"{}\" part=\"0\" file=\"{}\"/>\n", step, file);
    xml += "</Collection>\n</VTKFile>\n";
    write_file_atomically(path_, xml);
  }

  std::vector<std::string> files() const override {
    std::vector<std::string> all = written_;
    if (collection_ && !frames_.empty()) all.push_back(path_);
    return all;
  }

 private:
  std::string path_;
  bool collection_;
  std::vector<std::pair<std::int64_t, std::string>> frames_;
  std::vector<std::string> written_;
};

}  // namespace

std::unique_ptr<FrameWriter> make_vtu_writer(const std::string& path) { return std::make_unique<VtuWriter>(path); }

}  // namespace gel::exporting
