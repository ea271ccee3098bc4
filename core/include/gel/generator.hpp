#pragma once
// The fractal gel generator (MODEL.md "Initial configuration: a fractal gel").
//
// Stage 1, flocs: reaction-limited hierarchical cluster-cluster aggregation, 2D, off-lattice.
// N_floc single particles are joined in pairs of equal size, level by level (1+1, 2+2, ...),
// up to N_floc (a power of two). In one join both clusters get a uniformly random orientation
// and the contact is drawn uniformly among all contact configurations of the two rigid
// clusters: a particle i of A, a particle j of B and an angle psi are drawn uniformly, B is
// translated so that j touches i along psi (|r_j - r_i| = 2a), and the draw is rejected if any
// other pair overlaps. Rejection sampling makes the accepted contact uniform (in arc length)
// over the boundary of the region of relative positions excluded by overlap, i.e. every
// touching configuration is equally likely, which is the reaction-limited limit (a
// diffusion-limited join would take the first contact along a random path instead). The
// boundary of pockets closed on every side is included; for two clusters of the same size
// such pockets big enough to hold the other cluster practically never occur.
//
// Stage 2, network: N_cl flocs (floc k made from its own seed, derived from the gel seed and
// k) are rotated at random and placed, centre of mass uniform in the L_x x L_y box (periodic
// in x and y), with no particle closer than contact to another one; a floc whose bounding box
// plus 2a does not fit into the box would touch its own periodic image and is re-rotated.
// Each floc gets at most `max_attempts` tries (default kDefaultMaxAttempts), then generation
// stops with InvalidArgument("generator.n_clusters"). Then random walks: at each move one
// cluster, chosen uniformly among the remaining ones, is translated by `walk_step` (default
// 1 a) in a uniformly random direction. A move that would bring two particles of different
// clusters closer than 2a is cut at the first contact and the two clusters (and any other
// cluster touching the moved one within the tolerance) coalesce and move on as one rigid
// cluster. The walk ends when one cluster remains (or after kMaxWalkMoves moves, an error).
// The step is half a particle diameter: small against the particle so that cluster paths are
// Brownian on the scale of the structure (a step of the order of the cluster size would make
// the aggregation ballistic), while the cost, which grows as 1/step^2, stays at well under a
// second for the paper-size gels. The collision search uses a cell list of cell width
// >= 2a + step with explicit periodic images, so clusters that span the box are handled; cost
// per move is proportional to the size of the moving cluster.
//
// Contacts: pairs with gap |r_j - r_i| - 2a below `contact_tolerance` (default 1e-9 a) are
// bonded at the end (contact points along the line of centres); no pair has a gap below
// -contact_tolerance (an overlap beyond rounding). Units: a = 1, contact distance 2.
//
// Reproducibility: every random number comes from std::mt19937_64 (its seeding is fixed by
// the C++ standard) through our own conversions to doubles, integers and directions (no
// std::*_distribution, no sin/cos in the positions), so a seed gives the same gel with any
// standard library on IEEE-754 hardware that does not fuse multiply-adds.
#include <atomic>
#include <cstdint>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "gel/configuration.hpp"
#include "gel/v1/scene.pb.h"

namespace gel {

inline constexpr double kDefaultWalkStep = 1.0;            // [a]
inline constexpr double kDefaultContactTolerance = 1e-9;   // [a]
inline constexpr int kDefaultMaxAttempts = 10000;          // placement attempts per floc
inline constexpr std::int64_t kMaxWalkMoves = 200000000;   // random-walk moves before giving up
// Densest packing of disks; a higher requested packing fraction is rejected at once.
inline constexpr double kMaxPackingFraction = 0.9068996821171089;  // pi / (2 sqrt 3)

// "paper-bond1" (300 x 500, 64 x 90 = 5760 particles), "paper-bond2" (200 x 500, 64 x 60 =
// 3840), "quick" (60 x 110, 16 x 16 = 256, phi ~ 0.12). Throws InvalidArgument
// ("generator.preset") for any other name.
gel::v1::Generator generator_preset(std::string_view name);

// Preset (if named) + explicit non-zero fields + defaults, validated: lx, ly > 0; n_floc a
// power of two >= 1; n_clusters >= 1; packing fraction below kMaxPackingFraction; walk_step
// in (0, 2]; contact_tolerance in (0, 1e-3]; max_attempts >= 1; a box of at least three
// cells of width 2 + walk_step each way. The seed is kept as given. Throws InvalidArgument
// naming the field.
gel::v1::Generator resolve_generator(const gel::v1::Generator& g);

struct GeneratorSummary {
  int particles = 0;
  double phi = 0;
  int bonds = 0;
  double mean_contact_number = 0;
  // Fit of the level means of Rg over all flocs, sizes >= min(8, max(2, n_floc / 4)).
  double floc_fractal_dimension = 0;         // NaN when the flocs have fewer than 2 fit levels
  double floc_fractal_dimension_stderr = 0;  // NaN when fewer than 3 fit levels
  double seconds = 0;                        // wall-clock time of generate_gel
  std::int64_t walk_moves = 0;               // random-walk moves of the network stage
};

// Thrown by generate_gel when its `stop` flag is set: a large box can take minutes to
// aggregate, and a cancelled or shut-down job must not wait for it.
class GenerationStopped : public std::runtime_error {
 public:
  GenerationStopped() : std::runtime_error("gel generation stopped on request") {}
};

// The whole gel: resolves `g` first (so presets and defaults apply), fills Configuration.seed
// and .generator (the resolved parameters). Positions lie in [0, L_x] x [0, L_y]. With `stop`,
// checked between flocs and every few thousand random-walk moves, throws GenerationStopped once
// it is set.
Configuration generate_gel(const gel::v1::Generator& g, GeneratorSummary* summary = nullptr,
                           const std::atomic<bool>* stop = nullptr);

// One floc of n particles (n a power of two), centre of mass at the origin, bonds between
// touching particles, in free space (lx = ly = 0: no periodic box). With size_rg, receives one
// (cluster size, mean radius of gyration of the clusters of that size) pair per hierarchy
// level from size 2 up to n; Rg is that of the particle centres. Throws InvalidArgument
// ("generator.n_floc").
Configuration generate_floc(int n_floc, std::uint64_t seed,
                            std::vector<std::pair<double, double>>* size_rg = nullptr);

struct FractalFit {
  double dimension = 0;       // least-squares slope of ln N against ln Rg
  double standard_error = 0;  // of the slope
  int points = 0;             // levels used
};
// Fits ln N = D ln Rg + c over the levels with N >= min_size. Fewer than 2 points give
// D = NaN, fewer than 3 a NaN standard error. The default skips sizes 2 and 4, whose shapes
// are set by one or three contacts (a pair always has Rg = a) and whose local slopes (about
// 1.1 and 1.36) are far from the asymptotic one; from size 8 on the local slope is within
// about 0.1 of its large-size value (about 1.53-1.55 for this algorithm).
FractalFit fit_fractal_dimension(const std::vector<std::pair<double, double>>& size_rg,
                                 double min_size = 8);

}  // namespace gel
