#pragma once
// The progress file (`gelsim compress --progress-file FILE`): one JSON object a line, appended
// and flushed as it happens, so that a follower (geld's Slurm executor) reads whole lines while
// the run goes on. Its writer and its reader are both here, so the two ends speak one dialect
// (docs/compression.md "Progress"):
//   {"type":"progress", "phase", "k", "k_total", "phi", "target_phi", "P",
//    "events": {"normal", "sliding", "rolling", "created"}, "steps", "elapsed_seconds",
//    "remaining_seconds" [, "residual_force", "residual_target", "relax_iterations"]}
//   {"type":"row", <one curve.json row: "k", "phi", "P", "P_top", ...>}
//   and at the end one of
//   {"type":"done", "out", "rows"}
//   {"type":"stopped", "out" [, "rows"]}
//   {"type":"failed", "kind": "invalid_argument" | "instability" | "error", "error" [, "field"]}
// An ensemble's lines also carry the member's "seed".
#include <cstdint>
#include <fstream>
#include <mutex>
#include <optional>
#include <string>

#include "gel/v1/scene.pb.h"

namespace gel {

enum class RunFailure { kInvalidArgument, kInstability, kError };

// The writer. Every call writes one whole line and flushes it; members of an ensemble write
// from their own threads.
class ProgressFile {
 public:
  // "": a file that writes nothing. Creates the file's folder (usually the run's own --out,
  // which does not exist yet); throws InvalidArgument("--progress-file") when it cannot open it.
  explicit ProgressFile(const std::string& path);
  bool open() const { return out_.is_open(); }

  void progress(const v1::Progress& progress, std::optional<std::uint64_t> seed = std::nullopt);
  void row(const v1::CurveRow& row, std::optional<std::uint64_t> seed = std::nullopt);
  void done(const std::string& out_dir, int rows, std::optional<std::uint64_t> seed = std::nullopt);
  void stopped(const std::string& out_dir, std::optional<int> rows = std::nullopt);
  // field: the InvalidArgument's field (written for kInvalidArgument only).
  void failed(RunFailure kind, const std::string& error, const std::string& field = "",
              std::optional<std::uint64_t> seed = std::nullopt);

 private:
  void write(const std::string& line);
  std::ofstream out_;
  std::mutex mutex_;
};

// The reader: one line parsed.
struct ProgressLine {
  enum Kind { Progress, Row, Done, Failed, Other } kind = Other;  // Other: "stopped" and unknown types
  v1::Progress progress;
  v1::CurveRow row;
  std::string error;  // Failed: the run's error; an instability says so (kInstabilityPrefix)
};
// Takes what ProgressFile writes, and also a payload nested under its type's key
// ({"type":"row","row":{...}}) and Protocol Buffers' JSON names ("p", "kTotal"); unknown fields
// are ignored. Throws std::runtime_error on a line that is not a JSON object or whose payload
// does not parse.
ProgressLine parse_progress_line(const std::string& line);

}  // namespace gel
