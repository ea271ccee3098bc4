// What geld asks gelcore about a job besides running it (gelcore_adapter.hpp): submissions
// are validated and resolved, scenes and curves written as JSON, curves analysed.
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <nlohmann/json.hpp>

#include "gel/analysis/run_analysis.hpp"
#include "gel/compression.hpp"
#include "gel/configuration.hpp"
#include "gel/curve_io.hpp"
#include "gel/system.hpp"
#include "gel/errors.hpp"
#include "gel/generator.hpp"
#include "gel/resources.hpp"
#include "gelcore_adapter.hpp"
#include "requests.hpp"
#include "proto_json.hpp"

namespace geld {
namespace {

using google::protobuf::FieldDescriptor;

// The resolved scene flattened to (dotted name, text, number or NaN) for QueryCurves.
void flatten(const google::protobuf::Message& message, const std::string& prefix,
             std::vector<std::tuple<std::string, std::string, double>>& out) {
  const auto* reflection = message.GetReflection();
  // Every scalar field, at its default too: a resolved scene's false, 0 and "" are values that
  // ran (compression.quasistatic = false must match a fast run), though proto3 does not list
  // them as set. Unset sub-messages and empty lists stay out.
  const auto* descriptor = message.GetDescriptor();
  std::vector<const FieldDescriptor*> fields;
  for (int i = 0; i < descriptor->field_count(); ++i) {
    const FieldDescriptor* field = descriptor->field(i);
    if (field->is_repeated() ? reflection->FieldSize(message, field) > 0
                             : field->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE || reflection->HasField(message, field))
      fields.push_back(field);
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const auto* field : fields) {
    const std::string name = prefix + field->name();
    if (field->is_repeated()) {
      if (field->cpp_type() == FieldDescriptor::CPPTYPE_STRING) {
        std::string joined;
        for (int i = 0; i < reflection->FieldSize(message, field); ++i) {
          if (i) joined += ",";
          joined += reflection->GetRepeatedString(message, field, i);
        }
        out.emplace_back(name, joined, nan);
      }
      continue;
    }
    switch (field->cpp_type()) {
      case FieldDescriptor::CPPTYPE_MESSAGE:
        flatten(reflection->GetMessage(message, field), name + ".", out);
        break;
      case FieldDescriptor::CPPTYPE_STRING:
        out.emplace_back(name, reflection->GetString(message, field), nan);
        break;
      case FieldDescriptor::CPPTYPE_DOUBLE: {
        const double v = reflection->GetDouble(message, field);
        out.emplace_back(name, nlohmann::json(v).dump(), v);
        break;
      }
      case FieldDescriptor::CPPTYPE_FLOAT: {
        const double v = reflection->GetFloat(message, field);
        out.emplace_back(name, nlohmann::json(v).dump(), v);
        break;
      }
      case FieldDescriptor::CPPTYPE_INT32: {
        const auto v = reflection->GetInt32(message, field);
        out.emplace_back(name, std::to_string(v), static_cast<double>(v));
        break;
      }
      case FieldDescriptor::CPPTYPE_INT64: {
        const auto v = reflection->GetInt64(message, field);
        out.emplace_back(name, std::to_string(v), static_cast<double>(v));
        break;
      }
      case FieldDescriptor::CPPTYPE_UINT32: {
        const auto v = reflection->GetUInt32(message, field);
        out.emplace_back(name, std::to_string(v), static_cast<double>(v));
        break;
      }
      case FieldDescriptor::CPPTYPE_UINT64: {
        const auto v = reflection->GetUInt64(message, field);
        out.emplace_back(name, std::to_string(v), static_cast<double>(v));
        break;
      }
      case FieldDescriptor::CPPTYPE_BOOL: {
        const bool v = reflection->GetBool(message, field);
        out.emplace_back(name, v ? "true" : "false", v ? 1.0 : 0.0);
        break;
      }
      case FieldDescriptor::CPPTYPE_ENUM:
        out.emplace_back(name, reflection->GetEnum(message, field)->name(), nan);
        break;
    }
  }
}

ApiError invalid(const gel::InvalidArgument& e, const std::string& prefix) {
  return ApiError(grpc::StatusCode::INVALID_ARGUMENT, prefix + e.what());
}

ApiError too_large(std::int64_t particles, const Limits& limits) {
  return ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED,
                  "scene.generator: " + std::to_string(particles) + " particles per member, the limit is " +
                      std::to_string(limits.max_particles));
}

class Gelcore final : public GelcoreAdapter {
 public:
  Prepared prepare(const gel::v1::SubmitJobRequest& request, const Limits& limits) override {
    gel::v1::Scene scene;
    const bool has_message = request.has_scene();
    const bool has_json = !request.scene_json().empty();
    if (has_message && has_json) {
      throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "scene: give either scene or scene_json, not both");
    }
    if (!has_message && !has_json) {
      throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "scene: missing (set scene or scene_json)");
    }
    if (has_json) {
      // Said here rather than by protobuf's parser, whose words name no field.
      if (const gel::JsonProblem problem = gel::json_problem(request.scene_json(), *gel::v1::Scene::descriptor())) {
        throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, problem.field.empty() ? "scene_json: " + problem.message
                                                                                 : "scene." + problem.field + ": " + problem.message);
      }
      try {
        scene = gel::scene_from_json(request.scene_json());
      } catch (const gel::InvalidArgument& e) {
        throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "scene_json: " + std::string(e.what()));
      } catch (const std::exception& e) {
        throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "scene_json: " + std::string(e.what()));
      }
    } else {
      scene = request.scene();
    }
    // The daemon's default is written into the scene, so the stored job says how it ran.
    if (scene.integration().threads() == 0) scene.mutable_integration()->set_threads(limits.threads_per_member);
    if (scene.has_bending()) {
      throw ApiError(grpc::StatusCode::INVALID_ARGUMENT,
                     "scene.bending: only compression scenes run as jobs (set scene.compression or a preset)");
    }
    // A first look at the size before resolving: an absurd particle count is a resource
    // problem, whatever else is wrong with the scene.
    {
      std::int64_t n_floc = scene.generator().n_floc(), n_clusters = scene.generator().n_clusters();
      if (n_floc == 0 || n_clusters == 0) {
        try {
          std::string generator = scene.generator().preset();
          if (generator.empty() && !scene.preset().empty()) generator = gel::scene_preset(scene.preset()).generator().preset();
          if (!generator.empty()) {
            const auto preset = gel::generator_preset(generator);
            if (n_floc == 0) n_floc = preset.n_floc();
            if (n_clusters == 0) n_clusters = preset.n_clusters();
          }
        } catch (const std::exception&) {
          // An unknown preset: resolving names it below.
        }
      }
      if (n_floc > 0 && n_clusters > 0 && n_floc * n_clusters > limits.max_particles) {
        throw too_large(n_floc * n_clusters, limits);
      }
    }
    Prepared prepared;
    try {
      prepared.scene = gel::resolve_compression_scene(scene);
    } catch (const gel::InvalidArgument& e) {
      throw invalid(e, "scene.");
    }
    const auto& g = prepared.scene.generator();
    prepared.particles = static_cast<std::int64_t>(g.n_floc()) * static_cast<std::int64_t>(g.n_clusters());
    // A job always generates its gel: a scene without a generator would be accepted here and
    // fail only when a worker took it.
    if (prepared.particles <= 0) {
      throw ApiError(grpc::StatusCode::INVALID_ARGUMENT,
                     "scene.generator: no gel to generate (give scene.preset, generator.preset, or generator.n_floc and "
                     "generator.n_clusters)");
    }
    if (prepared.particles > limits.max_particles) throw too_large(prepared.particles, limits);
    // Valid values that cannot finish (v_wall = 1e-300, dt = 1e-300, m_exam = 9e18) would hold a
    // worker for ever: refused by the steps the walls need to close the box, 100x the largest preset.
    {
      constexpr double kMaxWallSteps = 1e10;
      constexpr std::int64_t kMaxExamSteps = 100'000'000;
      const auto& c = prepared.scene.compression();
      if (c.m_exam() > kMaxExamSteps) {
        throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "scene.compression.m_exam: " + std::to_string(c.m_exam()) +
                                                               " steps, the limit is " + std::to_string(kMaxExamSteps));
      }
      double dt = 0;
      try {
        dt = gel::resolve_sim_params(prepared.scene).dt;
      } catch (const gel::InvalidArgument& e) {
        throw invalid(e, "scene.");
      }
      const double wall_steps = g.ly() / (2.0 * c.v_wall() * dt);
      if (!(wall_steps <= kMaxWallSteps)) {
        char text[160];
        std::snprintf(text, sizeof text, "about %.3g steps to close the box (L_y / (2 v_wall dt)), the limit is %.0e",
                      wall_steps, kMaxWallSteps);
        // Blamed on whichever is further below its usual size (v_wall ~ 1e-3 a/t0, dt ~ 1e-2 t0).
        const bool wall_too_slow = c.v_wall() / 1e-3 < dt / 1e-2;
        throw ApiError(grpc::StatusCode::INVALID_ARGUMENT,
                       std::string(wall_too_slow ? "scene.compression.v_wall" : "scene.integration.dt") + ": " + text);
      }
    }
    prepared.estimate = gel::estimate_resources(prepared.scene);
    prepared.bond_preset = prepared.scene.bond().preset();
    flatten(prepared.scene, "", prepared.parameters);
    prepared.scene_json = gel::scene_to_json(prepared.scene);
    return prepared;
  }

  std::string scene_json(const gel::v1::Scene& scene) override { return gel::scene_to_json(scene); }
  std::string curve_json(const gel::v1::Curve& curve) override { return gel::curve_to_json(curve).dump(); }
  std::string program_version() override { return gel::program_version(); }
  std::string analysis_json(const std::vector<gel::v1::Curve>& curves, bool include_unequilibrated) override {
    gel::analysis::RunAnalysisOptions options;
    options.include_unequilibrated = include_unequilibrated;
    return gel::analysis::to_json(gel::analysis::analyse_curves(curves, options)).dump();
  }
};

}  // namespace

std::shared_ptr<GelcoreAdapter> make_gelcore_adapter() { return std::make_shared<Gelcore>(); }

}  // namespace geld
