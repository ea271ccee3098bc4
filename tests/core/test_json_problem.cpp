// What a user writes as JSON (a --scene file, gelctl --set, a Python override, a --gel .json
// configuration) is refused in the product's words, naming the field and what it takes.
// Protobuf's parser said "invalid value \"nan\" for type TYPE_DOUBLE", "(compression) stepz:
// Cannot find field." or "Unexpected token" instead.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "gel/configuration.hpp"
#include "gel/errors.hpp"
#include "gel/v1/scene.pb.h"
#include "proto_json.hpp"

namespace gel {
namespace {

JsonProblem scene_problem(const std::string& json) { return json_problem(json, *gel::v1::Scene::descriptor()); }

TEST(JsonProblem, NamesTheFieldAndWhatItTakes) {
  struct Case {
    std::string json, field, message;
  };
  const Case cases[] = {
      {R"({"compression": {"stepz": 4}})", "compression.stepz", "no such field; did you mean 'steps'?"},
      {R"({"generator": {"nosuch": 1}})", "generator.nosuch",
       "no such field (generator has preset, lx, ly, n_floc, n_clusters, seed, walk_step, contact_tolerance, max_attempts)"},
      {R"({"compression": {"v_wall": "nan"}})", "compression.v_wall", "must be a finite number, got \"nan\""},
      {R"({"compression": {"v_wall": "NaN"}})", "compression.v_wall", "must be a finite number, got \"NaN\""},
      {R"({"compression": {"v_wall": "-Infinity"}})", "compression.v_wall", "must be a finite number, got \"-Infinity\""},
      {R"({"compression": {"v_wall": true}})", "compression.v_wall", "must be a finite number, got true"},
      {R"({"compression": {"steps": 4.5}})", "compression.steps", "must be a whole number from -2147483648 to 2147483647, got 4.5"},
      {R"({"compression": {"steps": 3000000000}})", "compression.steps",
       "must be a whole number from -2147483648 to 2147483647, got 3000000000"},
      {R"({"generator": {"seed": -1}})", "generator.seed", "must be a whole number from 0 to 2^64-1, got -1"},
      {R"({"generator": {"seed": "x"}})", "generator.seed", "must be a whole number from 0 to 2^64-1, got \"x\""},
      {R"({"compression": {"m_exam": 1e30}})", "compression.m_exam", "must be a whole number from -2^63 to 2^63-1, got 1e+30"},
      {R"({"compression": {"approach_shortcut": "yes"}})", "compression.approach_shortcut", "must be true or false, got \"yes\""},
      {R"({"preset": 1})", "preset", "must be a string (in quotes), got 1"},
      {R"({"effects": "normal"})", "effects", "must be a list [...], got \"normal\""},
      {R"({"effects": ["normal", null]})", "effects[1]", "must be a string (in quotes), got null"},
      {R"({"generator": [1]})", "generator", "must be a JSON object of generator fields ({\"name\": value, ...}), got a list [1]"},
      {R"({"bending": {}, "compression": {}})", "compression", "cannot be set together with bending (one of them, not both)"},
      {R"([])", "", "must be a JSON object of the Scene fields ({\"name\": value, ...}), got a list []"},
      // Found by FuzzScene: what protobuf refuses in its own words although the JSON is fine.
      {R"({"compression": {"m_exam": "x", "m_exam": 10}})", "compression.m_exam", "given twice: give each field once"},
      {R"({"generator": {"seed": "-0"}})", "generator.seed", "must be a whole number from 0 to 2^64-1, got \"-0\""},
      {R"({"generator": {"seed": -0}})", "generator.seed", "must be a whole number from 0 to 2^64-1, got -0"},
      {R"({"generator": {"seed": "1e9"}})", "generator.seed", "must be a whole number from 0 to 2^64-1, got \"1e9\""},
      // A name that cannot be part of a dotted field name is quoted; the field is its object.
      {R"({"compression": {"st eps": 1}})", "compression", "no such field \"st eps\"; did you mean 'steps'?"},
  };
  for (const Case& c : cases) {
    const JsonProblem problem = scene_problem(c.json);
    EXPECT_TRUE(problem) << c.json;
    EXPECT_EQ(problem.field, c.field) << c.json;
    EXPECT_EQ(problem.message, c.message) << c.json;
  }
}

TEST(JsonProblem, TextThatIsNotJsonSaysWhere) {
  const JsonProblem problem = scene_problem("{\"preset\": \"quick\",\n \"compression\": {\"steps\": 3,}}");
  EXPECT_EQ(problem.field, "");
  EXPECT_EQ(problem.message.rfind("not JSON: parse error at line 2, column ", 0), 0u) << problem.message;
  EXPECT_EQ(problem.message.find("json.exception"), std::string::npos) << problem.message;
  // Python's json.dumps writes NaN bare; protobuf's parser read unquoted keys, which JSON has not.
  EXPECT_EQ(scene_problem(R"({"compression": {"v_wall": NaN}})").message.rfind("not JSON: ", 0), 0u);
  EXPECT_EQ(scene_problem(R"({compression: {}})").message.rfind("not JSON: ", 0), 0u);
  EXPECT_EQ(scene_problem("").message.rfind("not JSON: ", 0), 0u);
}

TEST(JsonProblem, WhatProtobufsMappingAllowsGoesThrough) {
  for (const char* json : {R"({})", R"({"preset": "quick", "compression": {"steps": 3, "phi_max": 0.5}})",
                           R"({"generator": {"nFloc": 8, "n_clusters": "8", "seed": "18446744073709551615", "lx": "30.5"}})",
                           R"({"generator": {"walk_step": null}, "compression": {"steps": 4.0, "m_exam": -9223372036854775808}})",
                           R"({"effects": ["normal", "walls"], "integration": {"eta_factor": 0}})"}) {
    const JsonProblem problem = scene_problem(json);
    EXPECT_FALSE(problem) << json << ": " << problem.field << ": " << problem.message;
  }
}

TEST(JsonProblem, RequireJsonMessageThrowsInvalidArgumentNamingTheField) {
  try {
    require_json_message("scene", R"({"compression": {"stepz": 4}})", *gel::v1::Scene::descriptor());
    FAIL() << "accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "scene.compression.stepz");
    EXPECT_STREQ(e.what(), "scene.compression.stepz: no such field; did you mean 'steps'?");
  }
  try {
    require_json_message("scene", "{", *gel::v1::Scene::descriptor());
    FAIL() << "accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "scene");
  }
  EXPECT_NO_THROW(require_json_message("scene", R"({"preset": "quick"})", *gel::v1::Scene::descriptor()));
}

TEST(JsonProblem, FieldPathsOfQueries) {
  const auto& scene = *gel::v1::Scene::descriptor();
  EXPECT_EQ(field_path_problem(scene, "generator.lx"), "");
  EXPECT_EQ(field_path_problem(scene, "effects"), "");
  EXPECT_EQ(field_path_problem(scene, "preset"), "");
  EXPECT_EQ(field_path_problem(scene, "generator.lz"), "'generator.lz': no such field; did you mean 'lx'?");
  EXPECT_EQ(field_path_problem(scene, "generator.nosuch").rfind("'generator.nosuch': no such field (generator has preset, ", 0), 0u);
  EXPECT_EQ(field_path_problem(scene, "compression"),
            "'compression' is a group of fields, not a value: name one of them, e.g. compression.fidelity");
  EXPECT_EQ(field_path_problem(scene, "generator.lx.a"), "'generator.lx.a': generator.lx is a value and has no fields");
  EXPECT_EQ(field_path_problem(scene, "generator.").rfind("'generator.': no such field", 0), 0u);
}

TEST(ReadConfiguration, SaysWhichFormatsItReads) {
  const auto dir = std::filesystem::temp_directory_path() / ("gel_json_problem_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  auto refusal = [](const std::string& path) {
    try {
      read_configuration(path);
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  // A GSD file was read as a damaged protobuf message: "not a binary configuration". Now each
  // ending goes to its reader (test_import.cpp), which says what is wrong in its format's words.
  std::ofstream((dir / "frame.gsd").string()) << "GSD\x65\x65";
  EXPECT_NE(refusal((dir / "frame.gsd").string()).find("not a GSD file (no GSD header)"), std::string::npos);
  std::ofstream((dir / "frame.xyz").string()) << "GSD\x65\x65";
  EXPECT_NE(refusal((dir / "frame.xyz").string()).find("is not extended XYZ: frame 0 starts with"), std::string::npos);
  std::ofstream((dir / "frame.vtu").string()) << "GSD\x65\x65";
  const std::string vtu = refusal((dir / "frame.vtu").string());
  EXPECT_NE(vtu.find("VTK files are written for viewing and not read back"), std::string::npos) << vtu;
  EXPECT_NE(vtu.find("a GSD file (.gsd) or an extended XYZ file (.xyz, .extxyz)"), std::string::npos) << vtu;
  std::ofstream((dir / "bad.json").string()) << R"({"format_version": 1, "lx": "wide"})";
  EXPECT_EQ(refusal((dir / "bad.json").string()),
            "path: '" + (dir / "bad.json").string() + "' is not a configuration: lx: must be a finite number, got \"wide\"");
  std::ofstream((dir / "noise.pb").string()) << std::string("\xff\xff\xff\xff\xff", 5);
  EXPECT_NE(refusal((dir / "noise.pb").string()).find("is not a binary gel.v1 configuration: a gel is read from"), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace gel
