#pragma once
// What geld asks the engine library (gelcore) about a job, besides running it (that is an
// Executor's work): checking and resolving a submitted scene, the JSON of scenes and curves,
// the program version, and the analysis of finished curves. The one implementation
// (make_gelcore_adapter, server/gelcore_adapter.cpp) calls gelcore; tests may inject their own.
#include <cstdint>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "gel/resources.hpp"
#include "gel/v1/service.pb.h"
#include "limits.hpp"

namespace geld {

class GelcoreAdapter {
 public:
  virtual ~GelcoreAdapter() = default;
  struct Prepared {
    gel::v1::Scene scene;  // resolved
    std::int64_t particles = 0;
    std::string bond_preset;
    // The resolved scene flattened: (dotted name, text value, numeric value or NaN).
    std::vector<std::tuple<std::string, std::string, double>> parameters;
    std::string scene_json;
    gel::ResourceEstimate estimate;  // one member's
  };
  // Validates and resolves a submission; throws ApiError (INVALID_ARGUMENT naming the field,
  // RESOURCE_EXHAUSTED over the limits).
  virtual Prepared prepare(const gel::v1::SubmitJobRequest& request, const Limits& limits) = 0;
  // The scene with another seed, as JSON (for executors that hand it to a process).
  virtual std::string scene_json(const gel::v1::Scene& scene) = 0;
  // The curve as one JSON object with a "rows" list.
  virtual std::string curve_json(const gel::v1::Curve& curve) = 0;
  virtual std::string program_version() = 0;
  // The curve analysis of one run or an ensemble (gelsim analyze-run's, as JSON text); throws
  // gel::InvalidArgument when the curves cannot be analysed.
  virtual std::string analysis_json(const std::vector<gel::v1::Curve>& curves, bool include_unequilibrated) = 0;
};

std::shared_ptr<GelcoreAdapter> make_gelcore_adapter();

}  // namespace geld
