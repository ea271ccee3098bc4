// gelsim compress --out over an earlier run wrote into it and left the old trajectory and the
// snapshots past the new last row beside the new curve. What an earlier run left is found by
// name, and --overwrite removes exactly that, only where gelsim wrote a run.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gel/errors.hpp"
#include "gel/run_directory.hpp"

namespace gel {
namespace {

namespace fs = std::filesystem;

class RunDirectory : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("gel_run_directory_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  void write(const fs::path& relative, const std::string& text) {
    fs::create_directories((dir_ / relative).parent_path());
    std::ofstream(dir_ / relative) << text;
  }
  std::vector<std::string> left() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
  std::string dir() const { return dir_.string(); }

 private:
  fs::path dir_;
};

TEST_F(RunDirectory, NothingThereOrNoDirectoryIsNoEarlierRun) {
  EXPECT_TRUE(earlier_run_outputs(dir()).empty());
  EXPECT_TRUE(earlier_run_outputs(dir() + "/missing").empty());
  EXPECT_TRUE(earlier_run_outputs("").empty());
  EXPECT_TRUE(clear_earlier_run(dir() + "/missing").empty());
  write("notes.txt", "mine");
  write("seed_1/notes.txt", "mine too");  // not a member: nothing of a run in it
  EXPECT_TRUE(earlier_run_outputs(dir()).empty());
  EXPECT_TRUE(clear_earlier_run(dir()).empty());
  EXPECT_EQ(left(), (std::vector<std::string>{"notes.txt", "seed_1"}));
}

TEST_F(RunDirectory, OverwriteRemovesTheEarlierRunAndNothingElse) {
  write("curve.json", R"({"program_version": "0.1.0", "particles": 4, "rows": []})");
  write("curve.csv", "k\n");
  write("profiles.csv", "k\n");
  write("checkpoint.bin", "GELCKPT5...");
  write("checkpoint.prev.bin.tmp", "GELCKPT5");
  write("trajectory.gsd", "GSD");
  write("snapshots/k_007.pb", "");
  write("plots/pressure.png", "");
  write("progress.jsonl", "{}\n");  // the user's --progress-file: not a run's own
  write("rows.gsd", "GSD");         // an export the user named
  const std::vector<std::string> outputs = {"checkpoint.bin", "checkpoint.prev.bin.tmp", "curve.csv",     "curve.json",
                                            "plots",          "profiles.csv",            "snapshots",     "trajectory.gsd"};
  EXPECT_EQ(earlier_run_outputs(dir()), outputs);
  EXPECT_EQ(clear_earlier_run(dir()), outputs);
  EXPECT_EQ(left(), (std::vector<std::string>{"progress.jsonl", "rows.gsd"}));
}

TEST_F(RunDirectory, AnEnsembleIsRecognisedByItsManifestAndMembers) {
  write("ensemble.json", R"({"seeds": [3, 4], "scene": {"preset": "quick"}})");
  write("seed_3/checkpoint.bin", "GELCKPT5");
  write("seed_4/curve.csv", "k\n");
  write("seed_x/curve.csv", "k\n");  // not a seed
  EXPECT_EQ(earlier_run_outputs(dir()), (std::vector<std::string>{"ensemble.json", "seed_3", "seed_4"}));
  clear_earlier_run(dir());
  EXPECT_EQ(left(), (std::vector<std::string>{"seed_x"}));
}

TEST_F(RunDirectory, AnEnsemblesMembersComeInTheManifestsOrderFinishedOnesApart) {
  EXPECT_TRUE(ensemble_members(dir()).finished.empty());  // nothing there
  write("ensemble.json", R"({"seeds": [10, 2, 7], "scene": {}})");
  write("seed_2/curve.json", "{}");
  write("seed_10/curve.json", "{}");
  write("seed_7/checkpoint.bin", "GELCKPT5");  // stopped or failed: no curve yet
  write("seed_x/curve.json", "{}");            // not a member
  const EnsembleMembers members = ensemble_members(dir());
  EXPECT_EQ(members.finished, (std::vector<std::string>{(fs::path(dir()) / "seed_10").string(), (fs::path(dir()) / "seed_2").string()}));
  EXPECT_EQ(members.unfinished, (std::vector<std::string>{(fs::path(dir()) / "seed_7").string()}));
  // Without a manifest (a study's ensemble, an archived copy): by seed, not by name.
  fs::remove(fs::path(dir()) / "ensemble.json");
  EXPECT_EQ(ensemble_members(dir()).finished.front(), (fs::path(dir()) / "seed_2").string());
  // A run's own folder is not an ensemble's, whatever else it holds.
  write("curve.json", "{}");
  EXPECT_TRUE(ensemble_members(dir()).finished.empty());
  EXPECT_TRUE(ensemble_members(dir()).unfinished.empty());
}

TEST_F(RunDirectory, AFolderThatOnlySharesNamesWithARunIsNeverEmptied) {
  write("snapshots/holiday.jpg", "");
  write("curve.json", R"({"x": [1, 2]})");   // a curve.json, but not gelsim's
  write("checkpoint.bin", "not a checkpoint");
  EXPECT_EQ(earlier_run_outputs(dir()), (std::vector<std::string>{"checkpoint.bin", "curve.json", "snapshots"}));
  try {
    clear_earlier_run(dir());
    FAIL() << "cleared";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "out_dir");
    EXPECT_NE(std::string(e.what()).find("holds checkpoint.bin, curve.json, snapshots but no checkpoint, curve.json or ensemble.json "
                                         "that gelsim wrote"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(left(), (std::vector<std::string>{"checkpoint.bin", "curve.json", "snapshots"}));
  EXPECT_TRUE(fs::exists(fs::path(dir()) / "snapshots" / "holiday.jpg"));
}

}  // namespace
}  // namespace gel
