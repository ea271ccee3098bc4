// The progress file's writer and reader: see gel/progress_file.hpp for the lines.
#include "gel/progress_file.hpp"

#include <filesystem>
#include <stdexcept>
#include <system_error>

#include <google/protobuf/util/json_util.h>
#include <nlohmann/json.hpp>

#include "gel/curve_io.hpp"
#include "gel/errors.hpp"

namespace gel {
namespace {

// The line types, written and read here only.
constexpr char kProgress[] = "progress";
constexpr char kRow[] = "row";
constexpr char kDone[] = "done";
constexpr char kStopped[] = "stopped";
constexpr char kFailed[] = "failed";

const char* failure_name(RunFailure kind) {
  switch (kind) {
    case RunFailure::kInvalidArgument: return "invalid_argument";
    case RunFailure::kInstability: return "instability";
    case RunFailure::kError: break;
  }
  return "error";
}

nlohmann::json events_json(const v1::Events& e) {
  return {{"normal", e.normal()}, {"sliding", e.sliding()}, {"rolling", e.rolling()}, {"created", e.created()}};
}

void add_seed(nlohmann::json& line, std::optional<std::uint64_t> seed) {
  if (seed) line["seed"] = *seed;
}

}  // namespace

ProgressFile::ProgressFile(const std::string& path) {
  if (path.empty()) return;
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code error;
  if (!parent.empty()) std::filesystem::create_directories(parent, error);
  out_.open(path, std::ios::app);
  if (!out_) throw InvalidArgument("--progress-file", "cannot open '" + path + "' for appending");
}

void ProgressFile::write(const std::string& line) {
  if (!out_.is_open()) return;
  const std::string text = line + '\n';  // one write: a follower never sees half a line as whole
  std::lock_guard lock(mutex_);
  out_ << text;
  out_.flush();
}

void ProgressFile::progress(const v1::Progress& p, std::optional<std::uint64_t> seed) {
  if (!open()) return;
  nlohmann::json line = {{"type", kProgress},       {"phase", p.phase()},
                         {"k", p.k()},              {"k_total", p.k_total()},
                         {"phi", p.phi()},          {"target_phi", p.target_phi()},
                         {"P", p.p()},              {"events", events_json(p.events())},
                         {"steps", p.steps()},      {"elapsed_seconds", p.elapsed_seconds()},
                         {"remaining_seconds", p.remaining_seconds()}};
  if (p.relax_iterations() > 0 || p.residual_force() > 0) {
    line["residual_force"] = p.residual_force();
    line["residual_target"] = p.residual_target();
    line["relax_iterations"] = p.relax_iterations();
  }
  add_seed(line, seed);
  write(line.dump());
}

void ProgressFile::row(const v1::CurveRow& row, std::optional<std::uint64_t> seed) {
  if (!open()) return;
  nlohmann::json line = curve_row_to_json(row);
  line["type"] = kRow;
  add_seed(line, seed);
  write(line.dump());
}

void ProgressFile::done(const std::string& out_dir, int rows, std::optional<std::uint64_t> seed) {
  nlohmann::json line = {{"type", kDone}, {"out", out_dir}, {"rows", rows}};
  add_seed(line, seed);
  write(line.dump());
}

void ProgressFile::stopped(const std::string& out_dir, std::optional<int> rows) {
  nlohmann::json line = {{"type", kStopped}, {"out", out_dir}};
  if (rows) line["rows"] = *rows;
  write(line.dump());
}

void ProgressFile::failed(RunFailure kind, const std::string& error, const std::string& field,
                          std::optional<std::uint64_t> seed) {
  nlohmann::json line = {{"type", kFailed}, {"kind", failure_name(kind)}, {"error", error}};
  if (kind == RunFailure::kInvalidArgument) line["field"] = field;
  add_seed(line, seed);
  write(line.dump());
}

namespace {

template <class Message>
void proto_from_json(const nlohmann::json& object, Message& message, const char* what) {
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = true;
  const auto status = google::protobuf::util::JsonStringToMessage(object.dump(), &message, options);
  if (!status.ok()) throw std::runtime_error(std::string("bad ") + what + " line: " + status.ToString());
}

// The payload is either nested ({"type":"row","row":{...}}) or the line itself.
nlohmann::json payload(const nlohmann::json& line, const char* key) {
  if (line.contains(key) && line.at(key).is_object()) return line.at(key);
  nlohmann::json copy = line;
  copy.erase("type");
  return copy;
}

}  // namespace

ProgressLine parse_progress_line(const std::string& text) {
  nlohmann::json line;
  try {
    line = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(std::string("progress file: not JSON: ") + e.what());
  }
  if (!line.is_object()) throw std::runtime_error("progress file: a line is not a JSON object");
  ProgressLine parsed;
  const std::string type = line.value("type", "");
  if (type == kProgress) {
    parsed.kind = ProgressLine::Progress;
    nlohmann::json progress = payload(line, kProgress);
    // The writer spells the pressure "P" (curve.json's spelling); the proto field is "p".
    if (progress.contains("P") && !progress.contains("p")) {
      progress["p"] = progress["P"];
      progress.erase("P");
    }
    proto_from_json(progress, parsed.progress, kProgress);
  } else if (type == kRow) {
    parsed.kind = ProgressLine::Row;
    const nlohmann::json row = payload(line, kRow);
    // curve.json's spelling ("P", "P_top", ...) or the proto's JSON mapping.
    if (row.contains("P")) {
      try {
        parsed.row = curve_row_from_json(row);
      } catch (const std::exception& e) {
        throw std::runtime_error(std::string("bad row line: ") + e.what());
      }
    } else {
      proto_from_json(row, parsed.row, kRow);
    }
  } else if (type == kDone) {
    parsed.kind = ProgressLine::Done;
  } else if (type == kFailed) {
    parsed.kind = ProgressLine::Failed;
    const auto& error = line.contains("error") ? line.at("error") : line.value("message", nlohmann::json());
    parsed.error = error.is_string() ? error.get<std::string>() : error.dump();
    if (parsed.error.empty() || parsed.error == "null") parsed.error = "gelsim reported a failure";
    if (line.value("kind", "") == failure_name(RunFailure::kInstability)) parsed.error = kInstabilityPrefix + parsed.error;
  }
  return parsed;
}

}  // namespace gel
