// A frame of an extended XYZ file (the dialect of ASE and OVITO, and gelsim export's) as a
// configuration. The comment line gives the cell (Lattice), the column layout (Properties)
// and the periodicity (pbc, ASE's default T T T); gelsim's own files add the columns theta
// and wall and the wall positions wall_bottom/wall_top. Numbers are read as written, so a file
// of gelsim export comes back bit for bit. XYZ holds no bonds: a file that says it had some
// (gelsim's bonds=K) is refused rather than read as a gel that falls apart.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "gel/errors.hpp"
#include "gel/import.hpp"
#include "gel/units.hpp"

namespace gel::importing {
namespace {

// The comment line's key=value pairs; a value may be quoted ("...") or braced ({...}); a key
// without a value is a flag ("T").
std::map<std::string, std::string> comment_pairs(const std::string& line) {
  std::map<std::string, std::string> pairs;
  std::size_t at = 0;
  const auto skip_space = [&] {
    while (at < line.size() && std::isspace(static_cast<unsigned char>(line[at]))) ++at;
  };
  while (true) {
    skip_space();
    if (at >= line.size()) break;
    std::string key;
    while (at < line.size() && line[at] != '=' && !std::isspace(static_cast<unsigned char>(line[at]))) key += line[at++];
    skip_space();
    std::string value = "T";
    if (at < line.size() && line[at] == '=') {
      ++at;
      skip_space();
      value.clear();
      if (at < line.size() && (line[at] == '"' || line[at] == '{')) {
        const char close = line[at] == '"' ? '"' : '}';
        for (++at; at < line.size() && line[at] != close; ++at) {
          if (line[at] == '\\' && at + 1 < line.size()) ++at;
          value += line[at];
        }
        ++at;
      } else {
        while (at < line.size() && !std::isspace(static_cast<unsigned char>(line[at]))) value += line[at++];
      }
    }
    std::string lower;
    for (char ch : key) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    pairs[lower] = value;
  }
  return pairs;
}

std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> out;
  for (std::string word; in >> word;) out.push_back(word);
  return out;
}

bool is_true(const std::string& flag) { return flag == "T" || flag == "True" || flag == "true" || flag == "1"; }

struct Column {
  std::string name;
  char type;
  int width;
  int first;  // index of its first word on a particle line
};

}  // namespace

Configuration read_extended_xyz(const std::string& path, std::int64_t frame_choice) {
  std::ifstream in(path);
  if (!in) throw InvalidArgument("path", "cannot open '" + path + "'");
  // Where each frame starts, found by its particle count; then the frame asked for.
  std::vector<std::streampos> starts;
  std::string line;
  while (true) {
    const std::streampos start = in.tellg();
    if (!std::getline(in, line)) break;
    if (words(line).empty()) continue;  // blank lines between frames
    char* end = nullptr;
    const long long count = std::strtoll(line.c_str(), &end, 10);
    if (count <= 0 || !words(end).empty())
      throw InvalidArgument("path", fmt::format("'{}' is not extended XYZ: frame {} starts with '{}', not a particle count", path,
                                                starts.size(), line));
    starts.push_back(start);
    for (long long skip = 0; skip < count + 1; ++skip)
      if (!std::getline(in, line))
        throw InvalidArgument("path", fmt::format("'{}': frame {} is cut short ({} particles announced)", path, starts.size() - 1, count));
  }
  const std::uint64_t f = resolve_frame(path, frame_choice, starts.size());
  const auto refuse = [&](const std::string& why) { return InvalidArgument("path", fmt::format("'{}': frame {}: {}", path, f, why)); };
  in.clear();
  in.seekg(starts[f]);
  std::getline(in, line);
  const std::size_t n = static_cast<std::size_t>(std::strtoll(line.c_str(), nullptr, 10));
  std::getline(in, line);
  const auto info = comment_pairs(line);
  const auto value = [&](const char* key) -> const std::string* {
    const auto found = info.find(key);
    return found == info.end() ? nullptr : &found->second;
  };
  const auto number = [&](const std::string& text, const std::string& what) {
    char* end = nullptr;
    const double x = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || *end != '\0' || !std::isfinite(x)) throw refuse(fmt::format("{} is '{}', not a finite number", what, text));
    return x;
  };

  // The cell: a = (L_x, 0, 0), b = (0, L_y, 0); c only matters where z is periodic.
  const std::string* lattice = value("lattice");
  if (!lattice) throw refuse("no Lattice in the comment line: the box is unknown");
  const std::vector<std::string> cell_words = words(*lattice);
  if (cell_words.size() != 9) throw refuse("Lattice needs 9 numbers, got '" + *lattice + "'");
  std::vector<double> cell;
  for (const std::string& word : cell_words) cell.push_back(number(word, "a Lattice entry"));
  std::vector<bool> pbc = {true, true, true};  // ASE's rule when a Lattice is given
  if (const std::string* flags = value("pbc")) {
    const auto parts = words(*flags);
    if (parts.size() != 3) throw refuse("pbc needs 3 flags, got '" + *flags + "'");
    for (int d = 0; d < 3; ++d) pbc[d] = is_true(parts[d]);
  }
  if (cell[1] != 0 || cell[2] != 0 || cell[3] != 0 || cell[5] != 0)
    throw refuse("the cell is sheared or rotated (Lattice " + *lattice + "): gelsim's box is L_x along x and L_y along y");
  if (pbc[2] && (cell[6] != 0 || cell[7] != 0 || cell[8] != 0))
    throw refuse("a 3D box, periodic in z (pbc \"" + std::string(value("pbc") ? *value("pbc") : "T T T, ASE's default") +
                 "\"): gelsim simulates a 2D gel; write pbc=\"T T F\"");
  if (!pbc[0]) throw refuse("the box is not periodic in x (pbc): gelsim's always is");
  Configuration c;
  c.lx = cell[0];
  c.ly = cell[4];
  if (!(c.lx > 0) || !(c.ly > 0)) throw refuse(fmt::format("the cell is {} x {}: both sides must be positive", c.lx, c.ly));
  c.periodic_y = pbc[1];

  if (const std::string* bonds = value("bonds"); bonds && number(*bonds, "bonds") > 0)
    throw refuse(fmt::format("it records {} bonds, which extended XYZ does not hold: start from the GSD export (it holds them) "
                             "or the gel.v1 configuration",
                             *bonds));

  // Columns: name:type:width triplets; pos is required, species and the rest are skipped.
  const std::string properties = value("properties") ? *value("properties") : "species:S:1:pos:R:3";
  std::vector<Column> columns;
  {
    std::vector<std::string> parts;
    std::stringstream split(properties);
    for (std::string part; std::getline(split, part, ':');) parts.push_back(part);
    if (parts.size() % 3 != 0) throw refuse("Properties is not name:type:columns triplets: '" + properties + "'");
    int first = 0;
    for (std::size_t p = 0; p < parts.size(); p += 3) {
      const int width = std::atoi(parts[p + 2].c_str());
      if (width <= 0 || parts[p + 1].size() != 1) throw refuse("Properties is not name:type:columns triplets: '" + properties + "'");
      columns.push_back({parts[p], parts[p + 1][0], width, first});
      first += width;
    }
  }
  const auto column = [&](const char* name) -> const Column* {
    for (const Column& col : columns)
      if (col.name == name) return &col;
    return nullptr;
  };
  const Column* pos = column("pos");
  if (!pos || pos->type != 'R' || pos->width < 2 || pos->width > 3) throw refuse("no pos:R:3 column in Properties '" + properties + "'");
  const Column* radius = column("radius");
  const Column* theta = column("theta");
  const Column* wall = column("wall");
  const int width = columns.back().first + columns.back().width;

  bool walls = false;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::getline(in, line)) throw refuse("cut short");
    const auto w = words(line);
    if (static_cast<int>(w.size()) != width)
      throw refuse(fmt::format("particle {} has {} columns, Properties names {}", i, w.size(), width));
    const auto field = [&](const Column* col, int k, const char* what) { return number(w[col->first + k], fmt::format("particle {}'s {}", i, what)); };
    c.x.push_back(field(pos, 0, "x"));
    c.y.push_back(field(pos, 1, "y"));
    if (pos->width == 3 && field(pos, 2, "z") != 0) throw refuse(fmt::format("particle {} lies out of the plane (z = {})", i, w[pos->first + 2]));
    if (radius && std::abs(field(radius, 0, "radius") - kRadius) > 1e-6)
      throw refuse(fmt::format("particle {} has radius {}: gelsim's particles are disks of radius 1 (lengths in units of a)", i,
                               w[radius->first]));
    c.theta.push_back(theta ? field(theta, 0, "theta") : 0.0);
    const double side = wall ? field(wall, 0, "wall") : 0.0;
    if (side != 0 && side != 1 && side != 2) throw refuse(fmt::format("particle {} has wall {}: 0 free, 1 bottom, 2 top", i, w[wall->first]));
    c.wall.push_back(static_cast<std::int8_t>(side));
    walls = walls || side != 0;
  }
  // Walls stand where the comment line places them (gelsim writes both keys once they do).
  const std::string* bottom = value("wall_bottom");
  const std::string* top = value("wall_top");
  if (walls && (!bottom || !top)) throw refuse("particles on walls (column wall), but no wall positions (wall_bottom and wall_top)");
  if (bottom && top) {
    c.wall_bottom = number(*bottom, "wall_bottom");
    c.wall_top = number(*top, "wall_top");
  } else {
    c.wall.clear();
  }
  try {
    return from_proto(to_proto(c));
  } catch (const InvalidArgument& e) {
    throw refuse(e.what());
  }
}

}  // namespace gel::importing
