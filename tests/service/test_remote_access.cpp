// Access: remote mode's token, the health service, and raw requests that are not valid messages.
#include <chrono>
#include <memory>
#include <stdexcept>
#include <string>

#include <grpcpp/generic/generic_stub.h>

#include "service_fixture.hpp"

namespace geld_test {
namespace {

// One unary call of `method` with the request's raw bytes, through a generic stub.
grpc::Status raw_unary_call(const std::shared_ptr<grpc::Channel>& channel, const std::string& token, const std::string& method,
                            const std::string& request_bytes, std::string* response_bytes) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
  context.set_deadline(std::chrono::system_clock::now() + 30s);
  grpc::CompletionQueue cq;
  grpc::Slice slice(request_bytes);
  grpc::ByteBuffer request(&slice, 1), response;
  auto call = stub.PrepareUnaryCall(&context, method, request, &cq);
  call->StartCall();
  grpc::Status status;
  call->Finish(&response, &status, reinterpret_cast<void*>(1));
  void* tag = nullptr;
  bool ok = false;
  cq.Next(&tag, &ok);
  std::vector<grpc::Slice> slices;
  response_bytes->clear();
  if (status.ok() && response.Dump(&slices).ok()) {
    for (const auto& s : slices) response_bytes->append(reinterpret_cast<const char*>(s.begin()), s.size());
  }
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }
  return status;
}

// One server-streaming call of `method` with the request's raw bytes: the first message's bytes
// (if one came) and the final status. When the first message equals `cancel_after`, the test
// cancels the stream itself.
grpc::Status raw_stream_call(const std::shared_ptr<grpc::Channel>& channel, const std::string& token, const std::string& method,
                             const std::string& request_bytes, std::string* first, const std::string& cancel_after = "") {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
  context.set_deadline(std::chrono::system_clock::now() + 10s);
  grpc::CompletionQueue cq;
  void* tag = nullptr;
  bool ok = false;
  auto call = stub.PrepareCall(&context, method, &cq);
  call->StartCall(reinterpret_cast<void*>(1));
  cq.Next(&tag, &ok);
  grpc::Slice slice(request_bytes);
  grpc::ByteBuffer request(&slice, 1), response;
  call->WriteLast(request, grpc::WriteOptions(), reinterpret_cast<void*>(2));
  cq.Next(&tag, &ok);
  call->Read(&response, reinterpret_cast<void*>(3));
  cq.Next(&tag, &ok);
  first->clear();
  std::vector<grpc::Slice> slices;
  if (ok && response.Dump(&slices).ok())
    for (const auto& s : slices) first->append(reinterpret_cast<const char*>(s.begin()), s.size());
  if (ok && !cancel_after.empty() && *first == cancel_after) context.TryCancel();
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(4));
  cq.Next(&tag, &ok);
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }
  return status;
}

// grpc.health.v1.Health through the generic stub (Debian ships no health client stubs): an
// empty request asks for the server's overall status; SERVING encodes as 08 01.
const std::string kServing("\x08\x01", 2);

grpc::Status health_check(const std::shared_ptr<grpc::Channel>& channel, const std::string& token, bool* serving) {
  std::string bytes;
  const grpc::Status status = raw_unary_call(channel, token, "/grpc.health.v1.Health/Check", "", &bytes);
  *serving = bytes == kServing;
  return status;
}

// Health Watch: with a valid token the first message says SERVING and the test then cancels.
grpc::Status health_watch(const std::shared_ptr<grpc::Channel>& channel, const std::string& token, std::string* first) {
  return raw_stream_call(channel, token, "/grpc.health.v1.Health/Watch", "", first, kServing);
}

TEST_F(Service, AMalformedRequestIsInvalidArgumentNotInternal) {
  // A length-delimited field 1 that claims 2^31 bytes: no protobuf parser accepts it. gRPC's own
  // answer to such a request was INTERNAL with no message, as if geld had failed.
  start({.workers = 2});
  const std::string garbage("\x0a\xff\xff\xff\xff\x07", 6);
  for (const char* method : {"SubmitJob", "GetJob", "CancelJob", "ListJobs", "GetCurve", "QueryCurves", "GetLogs", "GetAnalysis"}) {
    std::string response;
    const grpc::Status status = raw_unary_call(channel_, "", std::string("/gel.v1.GelService/") + method, garbage, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << method << ": " << status.error_message();
    EXPECT_EQ(status.error_message(), std::string("request: not a valid gel.v1.") + method + "Request message");
  }
  std::string first;
  const grpc::Status watch = raw_stream_call(channel_, "", "/gel.v1.GelService/WatchJob", garbage, &first);
  EXPECT_EQ(watch.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << watch.error_message();
  EXPECT_TRUE(first.empty());
  // Nothing was stored, and well-formed calls go on being served; an empty message is a valid
  // (all-default) request and still gets the handler's own answer.
  EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
  std::string response;
  EXPECT_EQ(raw_unary_call(channel_, "", "/gel.v1.GelService/GetJob", "", &response).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(raw_unary_call(channel_, "", "/gel.v1.GelService/ListJobs", "", &response).ok());
  std::string id;
  ASSERT_TRUE(submit(tiny_scene_json(), {.rerun = true}, &id).ok());
}

TEST_F(Service, HealthServiceAnswers) {
  start({.workers = 2});
  bool serving = false;
  auto status = health_check(channel_, "", &serving);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_TRUE(serving);
}

TEST_F(Service, RemoteModeRequiresTheToken) {
  // A non-loopback address without a token is refused at start.
  {
    geld::DaemonOptions options;
    options.listen = "0.0.0.0:0";
    options.manager.data_dir = dir_.path();
    geld::Daemon refused(options, geld::make_gelcore_adapter(), geld::make_thread_executor());
    EXPECT_THROW(refused.start(), std::invalid_argument);
  }
  const std::string token = "s3cret-token";
  start({.workers = 1, .listen = "0.0.0.0:0", .token = token});
  gel::v1::ListJobsRequest request;
  gel::v1::ListJobsResponse response;
  auto status = stub_->ListJobs(ctx().get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  status = stub_->ListJobs(ctx("wrong").get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  std::string id;
  {
    gel::v1::SubmitJobRequest submit_request;
    submit_request.set_scene_json(tiny_scene_json());
    gel::v1::SubmitJobResponse submit_response;
    EXPECT_EQ(stub_->SubmitJob(ctx().get(), submit_request, &submit_response).error_code(),
              grpc::StatusCode::UNAUTHENTICATED);
    EXPECT_EQ(sqlite_count("SELECT count(*) FROM jobs"), 0);
    ASSERT_TRUE(stub_->SubmitJob(ctx(token).get(), submit_request, &submit_response).ok());
    id = submit_response.job_id();
  }
  status = stub_->ListJobs(ctx(token).get(), request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.jobs_size(), 1);
  bool serving = false;
  EXPECT_EQ(health_check(channel_, "", &serving).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_TRUE(health_check(channel_, token, &serving).ok());
  EXPECT_TRUE(serving);
  // The health Watch stream answered SERVING before its status could refuse it: now it ends at
  // once, without the status, and only with the token does it report SERVING.
  std::string first;
  const auto watch_start = std::chrono::steady_clock::now();
  const grpc::Status refused = health_watch(channel_, "", &first);
  EXPECT_FALSE(refused.ok());
  EXPECT_NE(first, std::string("\x08\x01", 2)) << "the serving status leaked without the token";
  EXPECT_LT(std::chrono::steady_clock::now() - watch_start, 5s) << "the refused stream stayed open";
  health_watch(channel_, token, &first);
  EXPECT_EQ(first, std::string("\x08\x01", 2));
  // Watch too.
  gel::v1::WatchJobRequest watch_request;
  watch_request.set_job_id(id);
  grpc::ClientContext context;
  auto reader = stub_->WatchJob(&context, watch_request);
  JobUpdate update;
  EXPECT_FALSE(reader->Read(&update));
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::UNAUTHENTICATED);
}

TEST(Address, LoopbackDetection) {
  EXPECT_TRUE(geld::is_loopback_address("127.0.0.1:50051"));
  EXPECT_TRUE(geld::is_loopback_address("127.1.2.3:1"));
  EXPECT_TRUE(geld::is_loopback_address("localhost:50051"));
  EXPECT_TRUE(geld::is_loopback_address("[::1]:50051"));
  EXPECT_FALSE(geld::is_loopback_address("0.0.0.0:50051"));
  EXPECT_FALSE(geld::is_loopback_address("[::]:50051"));
  EXPECT_FALSE(geld::is_loopback_address("192.168.1.2:50051"));
  EXPECT_FALSE(geld::is_loopback_address("example.org:50051"));
}

}  // namespace
}  // namespace geld_test
