// The thermo log (core/src/thermo_log.hpp, docs/compression.md "Thermo log"): it never changes
// the run, its lines are where the documentation says and its last line is the final state;
// a resumed run drops what was written after its checkpoint and ends with an uninterrupted
// run's bytes. (The byte-identical resume of every protocol variant is in test_compression.cpp,
// expect_resume_bit_identical; pandas reads the file in tests/cli/test_thermo_log.sh.)
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <google/protobuf/util/message_differencer.h>

#include "curve_csv.hpp"
#include "gel/compression.hpp"
#include "gel/configuration.hpp"
#include "gel/errors.hpp"
#include "test_scenes.hpp"
#include "thermo_log.hpp"

namespace gel {
namespace {

std::string temp_dir(const std::string& name) { return fresh_temp_path("thermo_" + name); }

std::vector<std::vector<std::string>> read_lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> lines;
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream cells_in(line);
    for (std::string cell; std::getline(cells_in, cell, ',');) cells.push_back(cell);
    lines.push_back(cells);
  }
  return lines;
}

void expect_same_rows(const gel::v1::Curve& a, const gel::v1::Curve& b) {
  ASSERT_EQ(a.rows_size(), b.rows_size());
  for (int k = 0; k < a.rows_size(); ++k) {
    gel::v1::CurveRow x = a.rows(k), y = b.rows(k);
    x.clear_wall_seconds();
    y.clear_wall_seconds();
    EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(x, y)) << "row " << k;
  }
}

// With and without the log: the same rows and the same final configuration, bit for bit. The
// lines: the header, step 0, one at the first look at or after each multiple of N, and the final
// state last, with the same numbers as the last row.
void expect_log_changes_nothing(const gel::v1::Scene& scene, std::int64_t every) {
  const std::string plain = temp_dir("plain"), logged = temp_dir("logged");
  RunOptions options;
  options.out_dir = plain;
  const CompressionResult without = run_compression(scene, options);
  options.out_dir = logged;
  options.thermo_every = every;
  options.thermo_path = default_thermo_path(logged);
  const CompressionResult with = run_compression(scene, options);
  ASSERT_TRUE(without.finished && with.finished);
  expect_same_rows(without.curve, with.curve);
  const gel::v1::CurveRow& last = with.curve.rows(with.curve.rows_size() - 1);
  EXPECT_EQ(read_file(plain + "/" + last.snapshot()), read_file(logged + "/" + last.snapshot()));

  const auto lines = read_lines(options.thermo_path);
  ASSERT_GE(lines.size(), 5u);
  std::stringstream header(thermo_header());
  std::vector<std::string> names;
  for (std::string name; std::getline(header, name, ',');) names.push_back(name);
  EXPECT_EQ(lines[0], names);
  EXPECT_EQ(lines[1][0], "0");
  std::int64_t previous = -1;
  for (std::size_t l = 1; l < lines.size(); ++l) {
    ASSERT_EQ(lines[l].size(), names.size()) << "line " << l;
    const std::int64_t step = std::stoll(lines[l][0]);
    EXPECT_GT(step, previous) << "line " << l;
    // One line per multiple of N, written at the first chunk boundary after it (up to 512 FIRE
    // iterations of the quasi-static method later), the final line excepted.
    if (l + 1 < lines.size() && l > 1) {
      EXPECT_EQ(step / every, previous / every + 1) << "line " << l;
      EXPECT_LT(step % every, 512) << "line " << l;
    }
    previous = step;
  }
  const auto& final_line = lines.back();
  EXPECT_EQ(std::stoll(final_line[0]), last.steps());
  EXPECT_EQ(final_line[1], exact(last.sim_time()));
  EXPECT_EQ(final_line[2], std::to_string(last.k()));
  EXPECT_EQ(final_line[3], "done");
  EXPECT_EQ(final_line[4], exact(last.phi()));
  EXPECT_EQ(final_line[5], exact(last.p_top()));
  EXPECT_EQ(final_line[6], exact(last.p_bot()));
  EXPECT_EQ(final_line[7], exact(last.p()));
  EXPECT_EQ(final_line[8], exact(last.kinetic_energy()));
  EXPECT_EQ(final_line[9], exact(last.stored_energy()));
  EXPECT_EQ(final_line[10], std::to_string(last.ruptures().normal()));
  EXPECT_EQ(final_line[11], std::to_string(last.ruptures().sliding()));
  EXPECT_EQ(final_line[12], std::to_string(last.ruptures().rolling()));
  EXPECT_EQ(final_line[13], std::to_string(last.ruptures().created()));
  std::filesystem::remove_all(plain);
  std::filesystem::remove_all(logged);
}

TEST(ThermoLog, ChangesNothingAndEndsWithTheFinalStateDynamics) { expect_log_changes_nothing(tiny_fast_scene(), 1000); }

TEST(ThermoLog, ChangesNothingAndEndsWithTheFinalStateQuasistatic) {
  expect_log_changes_nothing(tiny_compression_scene("quasistatic"), 5000);
}

// A run killed after its checkpoint left lines past it and a torn one: the resume drops them and
// the file ends as an uninterrupted run's, byte for byte.
TEST(ThermoLog, AResumeDropsWhatCameAfterTheCheckpoint) {
  const gel::v1::Scene scene = tiny_fast_scene();
  const std::string reference_dir = temp_dir("reference"), resumed_dir = temp_dir("resumed");
  RunOptions reference;
  reference.out_dir = reference_dir;
  reference.thermo_every = 700;
  reference.thermo_path = default_thermo_path(reference_dir);
  const CompressionResult whole = run_compression(scene, reference);
  ASSERT_TRUE(whole.finished);
  const std::int64_t total_steps = whole.curve.rows(whole.curve.rows_size() - 1).steps();

  std::atomic<bool> stop{false};
  RunOptions options = reference;
  options.out_dir = resumed_dir;
  options.thermo_path = default_thermo_path(resumed_dir);
  options.stop = &stop;
  options.progress_interval_seconds = 0;
  options.on_progress = [&](const gel::v1::Progress& p) {
    if (p.steps() >= total_steps / 2) stop = true;
  };
  ASSERT_TRUE(run_compression(scene, options).stopped);
  const std::string at_stop = read_file(options.thermo_path);
  // What an interrupted run may leave after its checkpoint: a line past it, then a torn one.
  std::ofstream(options.thermo_path, std::ios::app) << total_steps * 2 << ",1,1,waiting,0.3,0,0,0,0,0,0,0,0,0\n"
                                                    << total_steps * 3 << ",0.5,2,wai";
  stop = false;
  options.on_progress = nullptr;
  ASSERT_TRUE(resume_compression(options).finished);
  const std::string expected = read_file(reference.thermo_path);
  EXPECT_EQ(read_file(options.thermo_path), expected);
  EXPECT_EQ(expected.compare(0, at_stop.size(), at_stop), 0) << "the lines before the stop were not kept as they were";
  // Resuming the finished run adds nothing.
  ASSERT_TRUE(resume_compression(options).finished);
  EXPECT_EQ(read_file(options.thermo_path), expected);
  std::filesystem::remove_all(reference_dir);
  std::filesystem::remove_all(resumed_dir);
}

// A file in the log's place that is not a thermo log is refused on resume, and left as it was.
TEST(ThermoLog, AResumeRefusesAForeignFile) {
  const std::string dir = temp_dir("foreign");
  std::filesystem::create_directories(dir);
  const std::string path = default_thermo_path(dir);
  std::ofstream(path) << "time,energy\n1,2\n";
  try {
    ThermoLog log(path, 100, 5000);
    ADD_FAILURE() << "a foreign file was taken for a thermo log";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "thermo");
    EXPECT_NE(std::string(e.what()).find("move it away"), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_file(path), "time,energy\n1,2\n");
  std::filesystem::remove_all(dir);
}

// The scene's output.thermo_every (how a geld job asks for the log) writes DIR/thermo.csv; a
// negative one is refused naming the field.
TEST(ThermoLog, TheSceneFieldAsksForItAndIsChecked) {
  gel::v1::Scene scene = tiny_fast_scene();
  scene.mutable_compression()->set_steps(1);
  scene.mutable_output()->set_thermo_every(2000);
  const std::string dir = temp_dir("scene");
  RunOptions options;
  options.out_dir = dir;
  ASSERT_TRUE(run_compression(scene, options).finished);
  const auto lines = read_lines(default_thermo_path(dir));
  ASSERT_GE(lines.size(), 3u);
  EXPECT_EQ(lines[1][0], "0");
  scene.mutable_output()->set_thermo_every(-1);
  try {
    resolve_compression_scene(scene);
    ADD_FAILURE() << "a negative thermo_every was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "output.thermo_every");
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace gel
