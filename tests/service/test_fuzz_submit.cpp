// A bounded randomized test (a fuzz run of fixed length, so CI runs it under the sanitizers every
// time) of SubmitJob's validation as geld runs it: JobManager::submit on a real SQLite store,
// without the network (the gRPC service only forwards the request and maps ApiError to a
// status). Valid requests are mutated three ways: the scene JSON text (tests/common's mutator),
// the serialised request's bytes (what a hostile client can send; those that still parse are
// submitted), and single fields set to awkward values (seed lists, names, labels, scene and
// scene_json together, both empty). Every mutant must either be accepted, and then be stored
// once and readable, or be refused with INVALID_ARGUMENT or RESOURCE_EXHAUSTED naming a field
// ("field: why"). Any other exception, a crash or a sanitizer report is a bug.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <random>
#include <set>
#include <string>

#include "executor.hpp"
#include "gel/compression.hpp"
#include "gel/v1/service.pb.h"
#include "job_manager.hpp"
#include "scene_mutator.hpp"

namespace {

namespace fs = std::filesystem;

constexpr int kMutants = 3000;

// Members end at once (as if stopped): the test is about what submit() accepts and stores.
class StopAtOnce final : public geld::Executor {
 public:
  std::string name() const override { return "fuzz"; }
  geld::RunResult run(const geld::RunContext&) override {
    geld::RunResult result;
    result.stopped = true;
    return result;
  }
};

std::vector<gel::v1::SubmitJobRequest> seed_requests() {
  std::vector<gel::v1::SubmitJobRequest> requests;
  gel::v1::SubmitJobRequest json;
  json.set_scene_json(R"({"preset": "quick", "generator": {"n_floc": 8, "n_clusters": 8, "lx": 30, "ly": 50},
                          "compression": {"fidelity": "fast", "steps": 3}})");
  json.set_name("fuzz");
  (*json.mutable_labels())["suite"] = "fuzz";
  requests.push_back(json);
  gel::v1::SubmitJobRequest ensemble = json;
  for (std::uint64_t seed : {1u, 2u, 3u}) ensemble.add_seeds(seed);
  requests.push_back(ensemble);
  // The message form, fully resolved: every field present, so byte mutations reach each one.
  gel::v1::SubmitJobRequest message;
  gel::v1::Scene quick;
  quick.set_preset("quick");
  quick.mutable_compression()->set_fidelity("quasistatic");
  *message.mutable_scene() = gel::resolve_compression_scene(quick);
  message.add_seeds(7);
  requests.push_back(message);
  return requests;
}

std::string random_text(std::mt19937_64& random, std::size_t max_size) {
  static const std::string alphabet = "ab=_-. \x01\xff\xc3\xa9/";
  std::string text(random() % (max_size + 1), ' ');
  for (char& c : text) c = alphabet[random() % alphabet.size()];
  return text;
}

gel::v1::SubmitJobRequest mutate(const gel::v1::SubmitJobRequest& seed, std::mt19937_64& random, bool* parsed) {
  *parsed = true;
  gel::v1::SubmitJobRequest request = seed;
  switch (random() % 3) {
    case 0:  // the scene JSON text
      if (request.scene_json().empty()) request.set_scene_json(gel::scene_to_json(request.scene()));
      request.clear_scene();
      request.set_scene_json(gel::test::mutate_json(request.scene_json(), random));
      break;
    case 1: {  // the request's bytes
      std::string bytes = request.SerializeAsString();
      const int edits = 1 + static_cast<int>(random() % 4);
      for (int edit = 0; edit < edits && !bytes.empty(); ++edit) {
        const std::size_t at = random() % bytes.size();
        switch (random() % 3) {
          case 0: bytes[at] = static_cast<char>(random() % 256); break;
          case 1: bytes.erase(at, 1 + random() % 8); break;
          default: bytes.insert(at, bytes.substr(at, 1 + random() % 16));
        }
      }
      request.Clear();
      *parsed = request.ParseFromString(bytes);
      break;
    }
    default:  // one field set to an awkward value
      switch (random() % 7) {
        case 0: {
          const int count = static_cast<int>(random() % 1100);
          request.clear_seeds();
          for (int i = 0; i < count; ++i) request.add_seeds(random() % 2 ? random() : static_cast<std::uint64_t>(i));
          break;
        }
        case 1: request.set_name(random_text(random, 300)); break;
        case 2: {
          const int count = static_cast<int>(random() % 70);
          for (int i = 0; i < count; ++i) (*request.mutable_labels())[random_text(random, 270)] = random_text(random, 270);
          break;
        }
        case 3:  // both forms of the scene
          request.set_scene_json(R"({"preset": "quick"})");
          *request.mutable_scene() = gel::resolve_compression_scene(gel::scene_from_json(R"({"preset": "quick"})"));
          break;
        case 4:  // neither
          request.clear_scene();
          request.clear_scene_json();
          break;
        case 5: request.set_rerun(!request.rerun()); break;
        default: request.add_seeds(std::numeric_limits<std::uint64_t>::max());
      }
  }
  return request;
}

TEST(FuzzSubmit, MutatedRequestsAreStoredOnceOrRefusedNamingAField) {
  // Protocol Buffers logs every invalid UTF-8 string it meets; here those are expected.
  google::protobuf::SetLogHandler(nullptr);
  char pattern[] = "/tmp/geld-fuzz.XXXXXX";
  ASSERT_NE(mkdtemp(pattern), nullptr);
  const std::string dir = pattern;
  geld::ManagerOptions options;
  options.data_dir = dir;
  options.workers = 1;
  options.limits.max_queue = 100000;
  std::set<std::string> ids;
  int accepted = 0, refused = 0, unparsable = 0;
  {
    geld::JobManager manager(options, geld::make_gelcore_adapter(), std::make_shared<StopAtOnce>());
    manager.start();
    const auto seeds = seed_requests();
    std::mt19937_64 random(20261203);
    for (int n = 0; n < kMutants; ++n) {
      bool parsed = true;
      const gel::v1::SubmitJobRequest request = mutate(seeds[random() % seeds.size()], random, &parsed);
      if (!parsed) {
        ++unparsable;  // the gRPC layer answers these itself (INVALID_ARGUMENT, tested there)
        continue;
      }
      try {
        const gel::v1::SubmitJobResponse response = manager.submit(request);
        ASSERT_FALSE(response.job_id().empty());
        // A new job id each time, unless the run cache answered with an earlier job.
        ASSERT_TRUE(ids.insert(response.job_id()).second || response.cached()) << response.job_id();
        // Stored, and readable by any client: the job as ListJobs would send it parses back.
        const gel::v1::Job job = manager.get(response.job_id());
        ASSERT_EQ(job.id(), response.job_id());
        gel::v1::Job reparsed;
        ASSERT_TRUE(reparsed.ParseFromString(job.SerializeAsString())) << "a stored job no client can parse:\n" << request.DebugString();
        ++accepted;
      } catch (const geld::ApiError& e) {
        const std::string message = e.what();
        ASSERT_TRUE(e.code() == grpc::StatusCode::INVALID_ARGUMENT || e.code() == grpc::StatusCode::RESOURCE_EXHAUSTED)
            << "code " << e.code() << ": " << message << "\nfrom:\n" << request.DebugString();
        // "field: why", the field a dotted name.
        const std::size_t colon = message.find(": ");
        ASSERT_NE(colon, std::string::npos) << message;
        ASSERT_GT(colon, 0u) << message;
        for (const char c : message.substr(0, colon))
          ASSERT_TRUE(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '[' || c == ']')
              << "not a field name before the colon: " << message;
        ++refused;
      } catch (const std::exception& e) {
        FAIL() << "not an ApiError: " << e.what() << "\nfrom:\n" << request.DebugString();
      }
    }
    // Every accepted job is in the store exactly once.
    gel::v1::ListJobsRequest list;
    list.set_page_size(1000);
    std::set<std::string> listed;
    std::string token;
    do {
      list.set_page_token(token);
      const auto page = manager.list(list);
      for (const auto& job : page.jobs()) ASSERT_TRUE(listed.insert(job.id()).second) << "listed twice: " << job.id();
      token = page.next_page_token();
    } while (!token.empty());
    EXPECT_EQ(listed, ids);
    manager.shutdown();
  }
  // Each outcome must occur, or the mutations are not exercising the validation.
  EXPECT_GT(accepted, kMutants / 20);
  EXPECT_GT(refused, kMutants / 5);
  EXPECT_GT(unparsable, kMutants / 50);
  std::printf("%d mutants: %d accepted, %d refused, %d did not parse\n", kMutants, accepted, refused, unparsable);
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
