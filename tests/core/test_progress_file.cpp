// The progress file's two ends (gel/progress_file.hpp): what gelsim's writer puts in the file,
// geld's Slurm executor reads back the same, for every kind of line. They used to be written
// separately (gelsim's command and geld's executor) and could drift apart in silence.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "gel/errors.hpp"
#include "gel/progress_file.hpp"

namespace gel {
namespace {

std::vector<std::string> lines_of(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST(ProgressFile, WhatTheWriterWritesTheReaderReadsBack) {
  const auto dir = std::filesystem::temp_directory_path() / ("gel_progress_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const auto path = dir / "run" / "progress.jsonl";  // its folder does not exist yet
  v1::Progress progress;
  progress.set_phase("relaxing");
  progress.set_k(3);
  progress.set_k_total(17);
  progress.set_phi(0.1 + 0.2);  // not a short decimal: the digits must survive
  progress.set_target_phi(0.31);
  progress.set_p(1.0 / 3.0);
  progress.mutable_events()->set_normal(5);
  progress.mutable_events()->set_created(2);
  progress.set_steps(12345);
  progress.set_remaining_seconds(-1);
  progress.set_residual_force(1e-5);
  progress.set_residual_target(1e-6);
  progress.set_relax_iterations(40);
  v1::CurveRow row;
  row.set_k(4);
  row.set_phi(0.123456789012345678);
  row.set_p(2.0 / 3.0);
  row.set_p_top(0.25);
  row.set_contact_number(3.25);
  row.mutable_ruptures()->set_sliding(7);
  row.set_equilibrated(true);
  {
    ProgressFile file(path.string());
    ASSERT_TRUE(file.open());
    file.progress(progress);
    file.row(row, 42);  // an ensemble member's line names its seed
    file.failed(RunFailure::kInstability, "overlap 0.9 a at step 12");
    file.failed(RunFailure::kInvalidArgument, "bond.k_normal: must be positive", "bond.k_normal");
    file.stopped("runs/x", 4);
    file.done("runs/x", 4);
  }
  const std::vector<std::string> lines = lines_of(path);
  ASSERT_EQ(lines.size(), 6u);

  const ProgressLine p = parse_progress_line(lines[0]);
  ASSERT_EQ(p.kind, ProgressLine::Progress);
  EXPECT_EQ(p.progress.phase(), "relaxing");
  EXPECT_EQ(p.progress.k(), 3);
  EXPECT_EQ(p.progress.k_total(), 17);
  EXPECT_EQ(p.progress.phi(), progress.phi());  // bit for bit
  EXPECT_EQ(p.progress.p(), progress.p());      // written "P", read into p
  EXPECT_EQ(p.progress.events().normal(), 5);
  EXPECT_EQ(p.progress.events().created(), 2);
  EXPECT_EQ(p.progress.steps(), 12345);
  EXPECT_EQ(p.progress.remaining_seconds(), -1);
  EXPECT_EQ(p.progress.relax_iterations(), 40);
  EXPECT_EQ(p.progress.residual_force(), 1e-5);

  const ProgressLine r = parse_progress_line(lines[1]);
  ASSERT_EQ(r.kind, ProgressLine::Row);
  EXPECT_EQ(r.row.k(), 4);
  EXPECT_EQ(r.row.phi(), row.phi());
  EXPECT_EQ(r.row.p(), row.p());
  EXPECT_EQ(r.row.p_top(), 0.25);
  EXPECT_EQ(r.row.contact_number(), 3.25);
  EXPECT_EQ(r.row.ruptures().sliding(), 7);
  EXPECT_TRUE(r.row.equilibrated());
  EXPECT_NE(lines[1].find("\"seed\":42"), std::string::npos) << lines[1];

  const ProgressLine unstable = parse_progress_line(lines[2]);
  ASSERT_EQ(unstable.kind, ProgressLine::Failed);
  EXPECT_EQ(unstable.error, std::string(kInstabilityPrefix) + "overlap 0.9 a at step 12");
  const ProgressLine invalid = parse_progress_line(lines[3]);
  ASSERT_EQ(invalid.kind, ProgressLine::Failed);
  EXPECT_EQ(invalid.error, "bond.k_normal: must be positive");
  EXPECT_NE(lines[3].find("\"field\":\"bond.k_normal\""), std::string::npos) << lines[3];

  EXPECT_EQ(parse_progress_line(lines[4]).kind, ProgressLine::Other);  // stopped: the run is resumable
  EXPECT_EQ(parse_progress_line(lines[5]).kind, ProgressLine::Done);
  std::filesystem::remove_all(dir);
}

TEST(ProgressFile, NoPathWritesNothingAndAnUnopenableOneIsRefusedByItsFlag) {
  ProgressFile none("");
  EXPECT_FALSE(none.open());
  none.done("x", 1);  // nothing to write to, nothing thrown
  try {
    ProgressFile bad("/proc/version/progress.jsonl");
    FAIL() << "opened a file below /proc/version";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "--progress-file");
  }
}

}  // namespace
}  // namespace gel
