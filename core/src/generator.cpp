// The gel generator: parameters, the network stage (placement and random walks of the flocs
// in the periodic box), bonding and the summary. The floc stage is in generator_floc.cpp.
#include "gel/generator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "gel/errors.hpp"
#include "gel/seed.hpp"
#include "gel/units.hpp"
#include "generator_internal.hpp"

namespace gel {
namespace {

constexpr double kContact = kDiameter;  // 2a

std::string str(double value) {
  std::ostringstream out;
  out.precision(6);
  out << value;
  return out.str();
}

bool is_power_of_two(std::int64_t n) { return n >= 1 && (n & (n - 1)) == 0; }

// Puts v into [0, L]; L itself can come out of rounding (v slightly below 0) and stands for 0.
double wrap(double v, double length) {
  if (v >= length) v -= length * std::floor(v / length);
  else if (v < 0) v -= length * std::floor(v / length);
  return std::clamp(v, 0.0, length);
}

// Cell list of the periodic box with explicit images: a query walks the 3 x 3 cells around a
// point and reports, for each particle found, the shift that makes (x_q + sx, y_q + sy) the
// image next to the point. With at least 3 cells per direction the 9 cells are distinct, so
// every image within one cell width is reported once and no minimum-image assumption is
// needed (clusters may span the box). Particles can be moved one at a time.
//
// Each cell also knows its owner: the one cluster all its particles belong to, kEmpty or
// kMixed. A moving cluster then skips, without looking at any particle, the cells that hold
// only its own particles, which is most of them for a large cluster.
class PeriodicGrid {
 public:
  static constexpr std::int32_t kEmpty = -1;
  static constexpr std::int32_t kMixed = -2;

  PeriodicGrid(double lx, double ly, double min_cell, const std::vector<std::int32_t>& cluster_of)
      : lx_(lx), ly_(ly), cluster_of_(cluster_of) {
    nx_ = static_cast<int>(std::floor(lx / min_cell));
    ny_ = static_cast<int>(std::floor(ly / min_cell));
    if (nx_ < 3 || ny_ < 3) throw std::logic_error("periodic grid needs 3 cells per direction");
    wx_ = lx / nx_;
    wy_ = ly / ny_;
    cells_.resize(static_cast<std::size_t>(nx_) * ny_);
    owner_.assign(cells_.size(), kEmpty);
  }

  // Adds particle p (its cluster already set in cluster_of).
  void insert(std::int32_t p, double px, double py) {
    if (static_cast<std::size_t>(p) >= cell_.size()) {
      cell_.resize(p + 1, -1);
      slot_.resize(p + 1, -1);
    }
    add(p, index(cx(px), cy(py)));
  }

  // After particle p moved to (px, py).
  void update(std::int32_t p, double px, double py) {
    const int c = index(cx(px), cy(py));
    if (c == cell_[p]) return;
    const int old = cell_[p];
    std::vector<std::int32_t>& members = cells_[old];
    const std::int32_t last = members.back();
    members[slot_[p]] = last;
    slot_[last] = slot_[p];
    members.pop_back();
    refresh(old);
    add(p, c);
  }

  // After the cluster of particle p changed.
  void refresh_owner(std::int32_t p) { refresh(cell_[p]); }

  // f(q, sx, sy) for every particle in the 3 x 3 cells around (px, py), except in cells that
  // hold only particles of cluster `self` (pass kMixed to see all); stops when f returns true
  // and then returns true.
  template <class F>
  bool any_near(double px, double py, std::int32_t self, F&& f) const {
    const int x0 = cx(px), y0 = cy(py);
    for (int dy = -1; dy <= 1; ++dy) {
      int gy = y0 + dy;
      double sy = 0;
      if (gy < 0) gy += ny_, sy = -ly_;
      else if (gy >= ny_) gy -= ny_, sy = ly_;
      for (int dx = -1; dx <= 1; ++dx) {
        int gx = x0 + dx;
        double sx = 0;
        if (gx < 0) gx += nx_, sx = -lx_;
        else if (gx >= nx_) gx -= nx_, sx = lx_;
        const int c = index(gx, gy);
        if (owner_[c] == kEmpty || owner_[c] == self) continue;
        for (const std::int32_t q : cells_[c])
          if (f(q, sx, sy)) return true;
      }
    }
    return false;
  }

 private:
  int cx(double px) const { return std::clamp(static_cast<int>(px / wx_), 0, nx_ - 1); }
  int cy(double py) const { return std::clamp(static_cast<int>(py / wy_), 0, ny_ - 1); }
  int index(int gx, int gy) const { return gy * nx_ + gx; }

  void add(std::int32_t p, int c) {
    cell_[p] = c;
    slot_[p] = static_cast<std::int32_t>(cells_[c].size());
    cells_[c].push_back(p);
    const std::int32_t cluster = cluster_of_[p];
    if (owner_[c] == kEmpty) owner_[c] = cluster;
    else if (owner_[c] != cluster) owner_[c] = kMixed;
  }

  void refresh(int c) {
    std::int32_t owner = kEmpty;
    for (const std::int32_t q : cells_[c]) {
      if (owner == kEmpty) owner = cluster_of_[q];
      else if (owner != cluster_of_[q]) {
        owner = kMixed;
        break;
      }
    }
    owner_[c] = owner;
  }

  double lx_, ly_, wx_ = 1, wy_ = 1;
  int nx_ = 0, ny_ = 0;
  const std::vector<std::int32_t>& cluster_of_;
  std::vector<std::vector<std::int32_t>> cells_;
  std::vector<std::int32_t> owner_;  // per cell
  std::vector<int> cell_;
  std::vector<std::int32_t> slot_;
};

// Stage 2: flocs placed in the box, then random walks with coalescence.
class Network {
 public:
  explicit Network(const gel::v1::Generator& g)
      : lx_(g.lx()),
        ly_(g.ly()),
        step_(g.walk_step()),
        tolerance_(g.contact_tolerance()),
        max_attempts_(g.max_attempts()),
        n_clusters_(g.n_clusters()),
        grid_(g.lx(), g.ly(), kContact + g.walk_step() + 2.0 * g.contact_tolerance(), cluster_of_) {
    const std::size_t n = static_cast<std::size_t>(g.n_floc()) * g.n_clusters();
    x_.reserve(n);
    y_.reserve(n);
    c_.reserve(n);
    s_.reserve(n);
    cluster_of_.reserve(n);
  }

  // Rotates the floc at random and puts its centre of mass at a random point, until no
  // particle is within contact of an earlier one and the floc clears its own images.
  void place(const detail::Floc& floc, detail::Random& rng) {
    const std::size_t n = floc.x.size();
    std::vector<double> rx(n), ry(n);
    const double touch2 = (kContact + tolerance_) * (kContact + tolerance_);
    int too_wide = 0;  // attempts where the rotated floc did not fit the box at all
    for (int attempt = 0; attempt < max_attempts_; ++attempt) {
      double c, s;
      rng.direction(c, s);
      double min_x = 0, max_x = 0, min_y = 0, max_y = 0;
      for (std::size_t p = 0; p < n; ++p) {
        rx[p] = c * floc.x[p] - s * floc.y[p];
        ry[p] = s * floc.x[p] + c * floc.y[p];
        min_x = std::min(min_x, rx[p]);
        max_x = std::max(max_x, rx[p]);
        min_y = std::min(min_y, ry[p]);
        max_y = std::max(max_y, ry[p]);
      }
      const double centre_x = rng.uniform() * lx_;
      const double centre_y = rng.uniform() * ly_;
      // Bounding box + 2a + tolerance inside the box: no contact with its own periodic images.
      if (max_x - min_x + kContact + tolerance_ >= lx_ || max_y - min_y + kContact + tolerance_ >= ly_) {
        ++too_wide;
        continue;
      }
      bool clash = false;
      for (std::size_t p = 0; p < n && !clash; ++p) {
        const double px = wrap(centre_x + rx[p], lx_), py = wrap(centre_y + ry[p], ly_);
        clash = grid_.any_near(px, py, PeriodicGrid::kMixed, [&](std::int32_t q, double sx, double sy) {
          const double dx = x_[q] + sx - px, dy = y_[q] + sy - py;
          return dx * dx + dy * dy < touch2;
        });
      }
      if (clash) continue;
      const std::int32_t id = static_cast<std::int32_t>(members_.size());
      members_.emplace_back();
      active_position_.push_back(static_cast<std::int32_t>(active_.size()));
      active_.push_back(id);
      for (std::size_t p = 0; p < n; ++p) {
        const std::int32_t index = static_cast<std::int32_t>(x_.size());
        x_.push_back(wrap(centre_x + rx[p], lx_));
        y_.push_back(wrap(centre_y + ry[p], ly_));
        c_.push_back(c * floc.c[p] - s * floc.s[p]);
        s_.push_back(s * floc.c[p] + c * floc.s[p]);
        cluster_of_.push_back(id);
        members_[id].push_back(index);
        grid_.insert(index, x_[index], y_[index]);
      }
      return;
    }
    const std::string which = std::to_string(members_.size() + 1) + " of " + std::to_string(n_clusters_);
    if (too_wide == max_attempts_)
      throw InvalidArgument("generator.n_clusters",
                            "floc " + which + " (" + std::to_string(n) + " particles) does not fit into the " + str(lx_) +
                                " x " + str(ly_) + " box without touching its own periodic image in any of " +
                                std::to_string(max_attempts_) + " random orientations: use a larger box or smaller flocs");
    const double phi = kPi * static_cast<double>(n) * n_clusters_ / (lx_ * ly_);
    throw InvalidArgument("generator.n_clusters",
                          "could not place floc " + which + " without overlap in " + std::to_string(max_attempts_) +
                              " attempts (generator.max_attempts); phi = " + str(phi) +
                              " is too high for random placement of these flocs, or a floc does not fit the box: "
                              "use fewer clusters, a larger box or more attempts");
  }

  // Random walks until one cluster remains; returns the number of moves.
  std::int64_t walk(detail::Random& rng, const std::atomic<bool>* stop) {
    std::int64_t moves = 0;
    std::vector<std::int32_t> touched;
    while (active_.size() > 1) {
      // An atomic load every 4096 moves costs nothing next to the moves themselves.
      if (stop && (moves & 4095) == 0 && stop->load(std::memory_order_relaxed)) throw GenerationStopped();
      if (++moves > kMaxWalkMoves)
        throw std::runtime_error("gel generator: " + std::to_string(active_.size()) + " clusters still apart after " +
                                 std::to_string(kMaxWalkMoves) + " random-walk moves; the box is too dilute");
      const std::int32_t id = active_[rng.below(active_.size())];
      double ux, uy;
      rng.direction(ux, uy);
      const double dx = step_ * ux, dy = step_ * uy;
      const double t = time_of_contact(id, dx, dy);
      if (t > 0) {
        for (const std::int32_t p : members_[id]) {
          x_[p] = wrap(x_[p] + t * dx, lx_);
          y_[p] = wrap(y_[p] + t * dy, ly_);
          grid_.update(p, x_[p], y_[p]);
        }
      }
      if (t < 1.0) {
        // Coalesce with every cluster the moved one now touches (the one it hit, and any other
        // within the tolerance).
        touched.clear();
        const double touch2 = (kContact + tolerance_) * (kContact + tolerance_);
        for (const std::int32_t p : members_[id])
          grid_.any_near(x_[p], y_[p], id, [&](std::int32_t q, double sx, double sy) {
            const std::int32_t other = cluster_of_[q];
            if (other != id) {
              const double ex = x_[q] + sx - x_[p], ey = y_[q] + sy - y_[p];
              if (ex * ex + ey * ey < touch2) touched.push_back(other);
            }
            return false;
          });
        touched.push_back(hit_cluster_);
        std::sort(touched.begin(), touched.end());
        touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
        std::int32_t merged = id;
        for (const std::int32_t other : touched) merged = merge(merged, other);
      }
    }
    return moves;
  }

  // Bonds every pair with gap below the tolerance; throws std::logic_error on an overlap
  // beyond it (which the algorithm excludes).
  Configuration configuration() const {
    Configuration config;
    config.lx = lx_;
    config.ly = ly_;
    config.periodic_y = true;
    for (std::size_t p = 0; p < x_.size(); ++p) config.add_particle(x_[p], y_[p], std::atan2(s_[p], c_[p]));
    const double touch2 = (kContact + tolerance_) * (kContact + tolerance_);
    const double overlap2 = (kContact - tolerance_) * (kContact - tolerance_);
    std::vector<std::pair<std::int32_t, std::int32_t>> pairs;
    for (std::int32_t p = 0; p < static_cast<std::int32_t>(x_.size()); ++p)
      grid_.any_near(x_[p], y_[p], PeriodicGrid::kMixed, [&](std::int32_t q, double sx, double sy) {
        if (q <= p) return false;
        const double ex = x_[q] + sx - x_[p], ey = y_[q] + sy - y_[p];
        const double d2 = ex * ex + ey * ey;
        if (d2 < overlap2)
          throw std::logic_error("gel generator: particles " + std::to_string(p) + " and " + std::to_string(q) +
                                 " overlap by " + str(kContact - std::sqrt(d2)));
        if (d2 < touch2) pairs.emplace_back(p, q);
        return false;
      });
    std::sort(pairs.begin(), pairs.end());
    for (const auto& [i, j] : pairs) config.add_bond_at_contact(i, j);
    return config;
  }

 private:
  // Fraction t in [0, 1] of the displacement (dx, dy) of cluster id before its first contact
  // with another cluster; 1 if none. Sets hit_cluster_ when t < 1.
  double time_of_contact(std::int32_t id, double dx, double dy) {
    const double d2 = dx * dx + dy * dy;
    const double contact2 = kContact * kContact;
    double t_min = 1.0;
    for (const std::int32_t p : members_[id]) {
      const double px = x_[p], py = y_[p];
      grid_.any_near(px, py, id, [&](std::int32_t q, double sx, double sy) {
        if (cluster_of_[q] == id) return false;
        const double rx = px - x_[q] - sx, ry = py - y_[q] - sy;
        const double b = rx * dx + ry * dy;
        if (b >= 0) return false;  // not approaching
        const double c = rx * rx + ry * ry - contact2;
        double t;
        if (c <= 0) {
          t = 0;  // touching (within rounding) and approaching
        } else {
          const double disc = b * b - d2 * c;
          if (disc <= 0) return false;  // passes by
          t = c / (-b + std::sqrt(disc));  // smaller root, without cancellation
        }
        if (t < t_min) {
          t_min = t;
          hit_cluster_ = cluster_of_[q];
        }
        return false;
      });
    }
    return t_min;
  }

  // Merges the smaller of clusters a and b into the larger; returns the survivor.
  std::int32_t merge(std::int32_t a, std::int32_t b) {
    if (a == b) return a;
    if (members_[a].size() < members_[b].size()) std::swap(a, b);
    for (const std::int32_t p : members_[b]) {
      cluster_of_[p] = a;
      members_[a].push_back(p);
    }
    for (const std::int32_t p : members_[b]) grid_.refresh_owner(p);
    members_[b].clear();
    members_[b].shrink_to_fit();
    const std::int32_t position = active_position_[b];
    const std::int32_t last = active_.back();
    active_[position] = last;
    active_position_[last] = position;
    active_.pop_back();
    active_position_[b] = -1;
    return a;
  }

  double lx_, ly_, step_, tolerance_;
  int max_attempts_, n_clusters_;
  std::vector<std::int32_t> cluster_of_;  // declared before grid_, which keeps a reference
  PeriodicGrid grid_;
  std::vector<double> x_, y_, c_, s_;  // positions in the box, orientations as unit vectors
  std::vector<std::vector<std::int32_t>> members_;
  std::vector<std::int32_t> active_, active_position_;
  std::int32_t hit_cluster_ = -1;
};

void require_given_positive(const std::string& field, double value) {
  if (value == 0) throw InvalidArgument(field, "must be given (no preset sets it)");
  require_positive(field, value);
}

}  // namespace

gel::v1::Generator generator_preset(std::string_view name) {
  // "paper-bond1-4x", "paper-bond2-16x": the paper's box scaled by 2 (4) in each direction at the
  // same phi_0 and floc size, i.e. 4x (16x) the clusters and particles, for users who trade
  // seeds for size (bigger gels self-average).
  for (const auto& [suffix, scale] : {std::pair<std::string_view, int>{"-4x", 2}, {"-16x", 4}}) {
    if (name.size() > suffix.size() && name.substr(name.size() - suffix.size()) == suffix) {
      const std::string_view base = name.substr(0, name.size() - suffix.size());
      if (base != "paper-bond1" && base != "paper-bond2") break;
      gel::v1::Generator g = generator_preset(base);
      g.set_preset(std::string(name));
      g.set_lx(g.lx() * scale);
      g.set_ly(g.ly() * scale);
      g.set_n_clusters(g.n_clusters() * scale * scale);
      return g;
    }
  }
  gel::v1::Generator g;
  g.set_preset(std::string(name));
  if (name == "paper-bond1") {
    g.set_lx(300);
    g.set_ly(500);
    g.set_n_floc(64);
    g.set_n_clusters(90);
  } else if (name == "paper-bond2") {
    g.set_lx(200);
    g.set_ly(500);
    g.set_n_floc(64);
    g.set_n_clusters(60);
  } else if (name == "quick") {
    g.set_lx(60);
    g.set_ly(110);
    g.set_n_floc(16);
    g.set_n_clusters(16);
  } else {
    throw InvalidArgument("generator.preset", "unknown preset " + quoted(std::string(name)) +
                                                  " (known: paper-bond1, paper-bond2, quick; paper-bond1-4x, -16x and the same for bond 2)");
  }
  return g;
}

gel::v1::Generator resolve_generator(const gel::v1::Generator& g) {
  gel::v1::Generator r;
  if (!g.preset().empty()) r = generator_preset(g.preset());
  if (g.lx() != 0) r.set_lx(g.lx());
  if (g.ly() != 0) r.set_ly(g.ly());
  if (g.n_floc() != 0) r.set_n_floc(g.n_floc());
  if (g.n_clusters() != 0) r.set_n_clusters(g.n_clusters());
  r.set_seed(g.seed());
  r.set_walk_step(g.walk_step() != 0 ? g.walk_step() : kDefaultWalkStep);
  r.set_contact_tolerance(g.contact_tolerance() != 0 ? g.contact_tolerance() : kDefaultContactTolerance);
  r.set_max_attempts(g.max_attempts() != 0 ? g.max_attempts() : kDefaultMaxAttempts);

  if (r.seed() != 0) require_seed("generator.seed", r.seed());  // 0: the scene's default
  require_given_positive("generator.lx", r.lx());
  require_given_positive("generator.ly", r.ly());
  if (r.n_floc() == 0) throw InvalidArgument("generator.n_floc", "must be given (no preset sets it)");
  if (!is_power_of_two(r.n_floc()))
    throw InvalidArgument("generator.n_floc", "must be a power of two >= 1 (hierarchical aggregation), got " +
                                                  std::to_string(r.n_floc()));
  if (r.n_clusters() == 0) throw InvalidArgument("generator.n_clusters", "must be given (no preset sets it)");
  if (r.n_clusters() < 0)
    throw InvalidArgument("generator.n_clusters", "must be positive, got " + std::to_string(r.n_clusters()));
  // The clusters' random walk is diffusive: the steps to bring them together grow as
  // 1/walk_step^2, so 0.1 a costs 100x the default 1 a (walk_step = 1e-300 held a worker for
  // minutes); above one diameter a step would jump over a particle.
  require_positive("generator.walk_step", r.walk_step());
  require_within("generator.walk_step", r.walk_step(), 0.1, kContact, "in a: 0.1 a to one particle diameter");
  require_positive("generator.contact_tolerance", r.contact_tolerance());
  if (r.contact_tolerance() > 1e-3)
    throw InvalidArgument("generator.contact_tolerance", "must be at most 1e-3 a, got " + str(r.contact_tolerance()));
  if (r.max_attempts() < 0 || r.max_attempts() > 10'000'000)
    throw InvalidArgument("generator.max_attempts", "must be 1 to 10000000 placement attempts per floc, got " +
                                                        std::to_string(r.max_attempts()));

  const std::int64_t n = static_cast<std::int64_t>(r.n_floc()) * r.n_clusters();
  if (n > std::numeric_limits<std::int32_t>::max())
    throw InvalidArgument("generator.n_clusters", "n_floc * n_clusters = " + std::to_string(n) + " particles is too many");
  const double min_box = 3.0 * (kContact + r.walk_step() + 2.0 * r.contact_tolerance());
  if (r.lx() < min_box) throw InvalidArgument("generator.lx", "box too small: needs at least " + str(min_box) + " a");
  if (r.ly() < min_box) throw InvalidArgument("generator.ly", "box too small: needs at least " + str(min_box) + " a");
  // The generator's cell grid and its random walk grow with the box area (a 15000 a square took
  // 690 MB before it placed a particle): 2.5e7 a^2 is ten times the 16x paper box.
  constexpr double kMaxBoxArea = 2.5e7;
  if (!(r.lx() * r.ly() <= kMaxBoxArea))
    throw InvalidArgument(r.lx() >= r.ly() ? "generator.lx" : "generator.ly",
                          "box of " + str(r.lx()) + " a x " + str(r.ly()) + " a exceeds the limit of " + str(kMaxBoxArea) +
                              " a^2 on lx * ly (ten times the paper-bond1-16x box)");
  const double phi = kPi * kRadius * kRadius * static_cast<double>(n) / (r.lx() * r.ly());
  if (!(phi < kMaxPackingFraction))
    throw InvalidArgument("generator.n_clusters", "packing fraction " + str(phi) +
                                                      " is impossible (densest disk packing is 0.9069)");
  return r;
}

FractalFit fit_fractal_dimension(const std::vector<std::pair<double, double>>& size_rg, double min_size) {
  std::vector<double> xs, ys;
  for (const auto& [size, rg] : size_rg)
    if (size >= min_size && rg > 0) {
      xs.push_back(std::log(rg));
      ys.push_back(std::log(size));
    }
  FractalFit fit;
  fit.points = static_cast<int>(xs.size());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (fit.points < 2) {
    fit.dimension = fit.standard_error = nan;
    return fit;
  }
  const double n = fit.points;
  double mx = 0, my = 0;
  for (int k = 0; k < fit.points; ++k) {
    mx += xs[k];
    my += ys[k];
  }
  mx /= n;
  my /= n;
  double sxx = 0, sxy = 0;
  for (int k = 0; k < fit.points; ++k) {
    sxx += (xs[k] - mx) * (xs[k] - mx);
    sxy += (xs[k] - mx) * (ys[k] - my);
  }
  fit.dimension = sxy / sxx;
  if (fit.points < 3) {
    fit.standard_error = nan;
    return fit;
  }
  double ssr = 0;
  for (int k = 0; k < fit.points; ++k) {
    const double residual = ys[k] - my - fit.dimension * (xs[k] - mx);
    ssr += residual * residual;
  }
  fit.standard_error = std::sqrt(ssr / (n - 2) / sxx);
  return fit;
}

Configuration generate_floc(int n_floc, std::uint64_t seed, std::vector<std::pair<double, double>>* size_rg) {
  if (!is_power_of_two(n_floc))
    throw InvalidArgument("generator.n_floc", "must be a power of two >= 1, got " + std::to_string(n_floc));
  const detail::Floc floc = detail::aggregate_floc(n_floc, seed, kDefaultContactTolerance);
  Configuration config;
  for (std::size_t p = 0; p < floc.x.size(); ++p) config.add_particle(floc.x[p], floc.y[p], std::atan2(floc.s[p], floc.c[p]));
  for (const auto& [i, j] : detail::touching_pairs_free(floc.x, floc.y, kDefaultContactTolerance))
    config.add_bond_at_contact(i, j);
  config.seed = seed;
  config.generator.set_n_floc(n_floc);
  config.generator.set_n_clusters(1);
  config.generator.set_seed(seed);
  config.generator.set_contact_tolerance(kDefaultContactTolerance);
  if (size_rg) *size_rg = floc.size_rg;
  return config;
}

Configuration generate_gel(const gel::v1::Generator& request, GeneratorSummary* summary, const std::atomic<bool>* stop) {
  const auto start = std::chrono::steady_clock::now();
  const gel::v1::Generator g = resolve_generator(request);
  Network network(g);
  detail::Random network_rng(detail::derive_seed(g.seed(), detail::kNetworkStream));
  std::vector<std::pair<double, double>> pooled;  // per level: (size, sum of floc means)
  for (int k = 0; k < g.n_clusters(); ++k) {
    if (stop && stop->load(std::memory_order_relaxed)) throw GenerationStopped();
    const detail::Floc floc =
        detail::aggregate_floc(g.n_floc(), detail::derive_seed(g.seed(), static_cast<std::uint64_t>(k)), g.contact_tolerance());
    if (pooled.empty()) pooled.assign(floc.size_rg.size(), {0.0, 0.0});
    for (std::size_t level = 0; level < floc.size_rg.size(); ++level) {
      pooled[level].first = floc.size_rg[level].first;
      pooled[level].second += floc.size_rg[level].second;
    }
    network.place(floc, network_rng);
  }
  const std::int64_t moves = network.walk(network_rng, stop);
  Configuration config = network.configuration();
  config.seed = g.seed();
  config.generator = g;
  if (summary) {
    for (auto& level : pooled) level.second /= g.n_clusters();
    // Sizes from 8 up (see fit_fractal_dimension); small flocs keep three levels when they can.
    const FractalFit fit = fit_fractal_dimension(pooled, std::clamp(g.n_floc() / 4, 2, 8));
    summary->particles = static_cast<int>(config.size());
    summary->phi = config.packing_fraction();
    summary->bonds = static_cast<int>(config.bonds.size());
    summary->mean_contact_number = config.mean_contact_number();
    summary->floc_fractal_dimension = fit.dimension;
    summary->floc_fractal_dimension_stderr = fit.standard_error;
    summary->walk_moves = moves;
    summary->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return config;
}

}  // namespace gel
