#include "service.hpp"

#include <arpa/inet.h>

#include <chrono>
#include <filesystem>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/support/server_interceptor.h>
#include <spdlog/spdlog.h>

#include "gel/errors.hpp"
#include "store.hpp"

namespace geld {

namespace {

bool constant_time_equal(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

grpc::Status check_metadata(const std::multimap<grpc::string_ref, grpc::string_ref>& metadata,
                            const std::string& token) {
  auto it = metadata.find("authorization");
  if (it == metadata.end()) {
    return {grpc::StatusCode::UNAUTHENTICATED, "authorization: missing; this geld requires 'Bearer <token>'"};
  }
  const std::string_view value(it->second.data(), it->second.size());
  constexpr std::string_view kBearer = "Bearer ";
  if (value.substr(0, kBearer.size()) != kBearer || !constant_time_equal(value.substr(kBearer.size()), token)) {
    return {grpc::StatusCode::UNAUTHENTICATED, "authorization: invalid bearer token"};
  }
  return grpc::Status::OK;
}

// Remote mode: every call (health and reflection included) without the token is refused.
// GelService's handlers check the token themselves before doing anything; this interceptor
// covers the services geld does not implement itself: a unary answer (health Check) has its
// status replaced by UNAUTHENTICATED, a stream (health Watch, reflection) is cancelled before
// its first message carries anything.
class TokenInterceptor final : public grpc::experimental::Interceptor {
 public:
  TokenInterceptor(std::shared_ptr<const std::string> token, grpc::experimental::ServerRpcInfo* info)
      : token_(std::move(token)), info_(info) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    using grpc::experimental::InterceptionHookPoints;
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_INITIAL_METADATA)) {
      if (auto* metadata = methods->GetRecvInitialMetadata()) status_ = check_metadata(*metadata, *token_);
    }
    // A streaming handler that does not check the token itself (health Watch, reflection) would
    // answer before its status could say UNAUTHENTICATED, and a Watch never ends on its own:
    // its message goes out empty and the call is cancelled at once.
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_MESSAGE) && !status_.ok() &&
        info_->type() != grpc::experimental::ServerRpcInfo::Type::UNARY) {
      if (auto* message = methods->GetSerializedSendMessage()) *message = grpc::ByteBuffer();
      if (!cancelled_) {
        cancelled_ = true;
        spdlog::warn("{}: {}; stream cancelled", info_->method(), status_.error_message());
        info_->server_context()->TryCancel();
      }
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS) && !status_.ok()) {
      methods->ModifySendStatus(status_);
    }
    methods->Proceed();
  }

 private:
  std::shared_ptr<const std::string> token_;
  grpc::experimental::ServerRpcInfo* info_;
  grpc::Status status_;
  bool cancelled_ = false;
};

class TokenInterceptorFactory final : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  explicit TokenInterceptorFactory(std::string token) : token_(std::make_shared<const std::string>(std::move(token))) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(grpc::experimental::ServerRpcInfo* info) override {
    return new TokenInterceptor(token_, info);
  }

 private:
  std::shared_ptr<const std::string> token_;
};

// gRPC answers a request that does not parse as its message with INTERNAL (and no message), as
// if geld itself had failed. The sync handler never runs then, so the status is corrected here:
// a GelService call whose request could not be deserialised (POST_RECV_MESSAGE without a
// message) and that ends in INTERNAL ends in INVALID_ARGUMENT, naming the method.
class MalformedRequestInterceptor final : public grpc::experimental::Interceptor {
 public:
  explicit MalformedRequestInterceptor(grpc::experimental::ServerRpcInfo* info) : info_(info) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    using grpc::experimental::InterceptionHookPoints;
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_MESSAGE) && methods->GetRecvMessage() == nullptr)
      malformed_ = true;
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS) && malformed_ &&
        methods->GetSendStatus().error_code() == grpc::StatusCode::INTERNAL) {
      const std::string method = info_->method();
      const std::string name = method.substr(method.rfind('/') + 1);
      spdlog::warn("{}: request is not a valid message", method);
      methods->ModifySendStatus(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                             "request: not a valid gel.v1." + name + "Request message"));
    }
    methods->Proceed();
  }

 private:
  grpc::experimental::ServerRpcInfo* info_;
  bool malformed_ = false;
};

class MalformedRequestInterceptorFactory final : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  grpc::experimental::Interceptor* CreateServerInterceptor(grpc::experimental::ServerRpcInfo* info) override {
    // Only geld's own service: a stream of the reflection service also ends without a message.
    if (std::string_view(info->method()).substr(0, kServicePrefix.size()) != kServicePrefix) return nullptr;
    return new MalformedRequestInterceptor(info);
  }

 private:
  static constexpr std::string_view kServicePrefix = "/gel.v1.GelService/";
};

}  // namespace

grpc::Status TokenCheck::check(const grpc::ServerContextBase& context) const {
  if (token_.empty()) return grpc::Status::OK;
  return check_metadata(context.client_metadata(), token_);
}

namespace {
// A status's message travels in a header (grpc-message, percent-encoded: up to 3 bytes a byte)
// under the client's 8 KiB metadata limit; past it the client sees RESOURCE_EXHAUSTED instead of
// the error. Messages start with the field they are about, so cutting the end keeps it.
constexpr std::size_t kMaxStatusMessage = 1024;
grpc::Status status(grpc::StatusCode code, const std::string& message) {
  return {code, gel::truncated(message, kMaxStatusMessage)};
}
}  // namespace

template <class F>
grpc::Status GelServiceImpl::guarded(grpc::ServerContext* context, const char* method, F&& body) {
  if (auto status = auth_->check(*context); !status.ok()) {
    spdlog::warn("{} from {}: {}", method, context->peer(), status.error_message());
    return status;
  }
  try {
    body();
    return grpc::Status::OK;
  } catch (const ApiError& e) {
    spdlog::debug("{}: {} {}", method, static_cast<int>(e.code()), gel::truncated(e.what(), kMaxStatusMessage));
    return status(e.code(), e.what());
  } catch (const StoreError& e) {
    spdlog::error("{}: store: {}", method, e.what());
    return status(grpc::StatusCode::INTERNAL, std::string("store: ") + e.what());
  } catch (const std::exception& e) {
    spdlog::error("{}: {}", method, e.what());
    return status(grpc::StatusCode::INTERNAL, e.what());
  }
}

grpc::Status GelServiceImpl::SubmitJob(grpc::ServerContext* context, const gel::v1::SubmitJobRequest* request,
                                       gel::v1::SubmitJobResponse* response) {
  return guarded(context, "SubmitJob", [&] { *response = manager_.submit(*request); });
}

grpc::Status GelServiceImpl::WatchJob(grpc::ServerContext* context, const gel::v1::WatchJobRequest* request,
                                      grpc::ServerWriter<gel::v1::JobUpdate>* writer) {
  return guarded(context, "WatchJob", [&] {
    manager_.watch(
        request->job_id(), [&](const gel::v1::JobUpdate& update) { return writer->Write(update); },
        [&] { return context->IsCancelled(); });
  });
}

grpc::Status GelServiceImpl::CancelJob(grpc::ServerContext* context, const gel::v1::CancelJobRequest* request,
                                       gel::v1::Job* response) {
  return guarded(context, "CancelJob", [&] { *response = manager_.cancel(request->job_id()); });
}

grpc::Status GelServiceImpl::GetJob(grpc::ServerContext* context, const gel::v1::GetJobRequest* request,
                                    gel::v1::Job* response) {
  return guarded(context, "GetJob", [&] { *response = manager_.get(request->job_id()); });
}

grpc::Status GelServiceImpl::ListJobs(grpc::ServerContext* context, const gel::v1::ListJobsRequest* request,
                                      gel::v1::ListJobsResponse* response) {
  return guarded(context, "ListJobs", [&] { *response = manager_.list(*request); });
}

grpc::Status GelServiceImpl::GetCurve(grpc::ServerContext* context, const gel::v1::GetCurveRequest* request,
                                      gel::v1::GetCurveResponse* response) {
  return guarded(context, "GetCurve", [&] { *response = manager_.curve(request->job_id()); });
}

grpc::Status GelServiceImpl::QueryCurves(grpc::ServerContext* context, const gel::v1::QueryCurvesRequest* request,
                                         gel::v1::QueryCurvesResponse* response) {
  return guarded(context, "QueryCurves", [&] { *response = manager_.query(*request); });
}

grpc::Status GelServiceImpl::GetLogs(grpc::ServerContext* context, const gel::v1::GetLogsRequest* request,
                                     gel::v1::GetLogsResponse* response) {
  return guarded(context, "GetLogs", [&] { *response = manager_.logs(*request); });
}

grpc::Status GelServiceImpl::GetAnalysis(grpc::ServerContext* context, const gel::v1::GetAnalysisRequest* request,
                                         gel::v1::GetAnalysisResponse* response) {
  return guarded(context, "GetAnalysis", [&] { *response = manager_.analysis(*request); });
}

grpc::Status GelServiceImpl::SubmitStudy(grpc::ServerContext* context, const gel::v1::SubmitStudyRequest* request,
                                         gel::v1::SubmitStudyResponse* response) {
  return guarded(context, "SubmitStudy", [&] { *response = studies_.submit(*request); });
}

grpc::Status GelServiceImpl::GetStudy(grpc::ServerContext* context, const gel::v1::GetStudyRequest* request,
                                      gel::v1::Study* response) {
  return guarded(context, "GetStudy", [&] { *response = studies_.get(request->study_id()); });
}

grpc::Status GelServiceImpl::ListStudies(grpc::ServerContext* context, const gel::v1::ListStudiesRequest* request,
                                         gel::v1::ListStudiesResponse* response) {
  return guarded(context, "ListStudies", [&] { *response = studies_.list(*request); });
}

grpc::Status GelServiceImpl::WatchStudy(grpc::ServerContext* context, const gel::v1::WatchStudyRequest* request,
                                        grpc::ServerWriter<gel::v1::StudyUpdate>* writer) {
  return guarded(context, "WatchStudy", [&] {
    studies_.watch(
        request->study_id(), [&](const gel::v1::StudyUpdate& update) { return writer->Write(update); },
        [&] { return context->IsCancelled(); });
  });
}

grpc::Status GelServiceImpl::CancelStudy(grpc::ServerContext* context, const gel::v1::CancelStudyRequest* request,
                                         gel::v1::Study* response) {
  return guarded(context, "CancelStudy", [&] { *response = studies_.cancel(request->study_id()); });
}

grpc::Status GelServiceImpl::GetStudyAnalysis(grpc::ServerContext* context,
                                              const gel::v1::GetStudyAnalysisRequest* request,
                                              gel::v1::GetStudyAnalysisResponse* response) {
  return guarded(context, "GetStudyAnalysis", [&] { *response = studies_.analysis(*request); });
}

bool is_loopback_address(const std::string& host_port) {
  std::string host = host_port;
  if (!host.empty() && host.front() == '[') {
    auto close = host.find(']');
    host = host.substr(1, close == std::string::npos ? std::string::npos : close - 1);
  } else if (auto colon = host.rfind(':'); colon != std::string::npos && host.find(':') == colon) {
    host = host.substr(0, colon);
  }
  if (host == "localhost" || host == "::1") return true;
  in_addr v4{};
  if (inet_pton(AF_INET, host.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  return false;
}

Daemon::Daemon(DaemonOptions options, std::shared_ptr<GelcoreAdapter> adapter, std::shared_ptr<Executor> executor)
    : options_(std::move(options)) {
  manager_ = std::make_unique<JobManager>(options_.manager, std::move(adapter), std::move(executor));
  studies_ = std::make_unique<StudyManager>(*manager_);
}

Daemon::~Daemon() { shutdown(); }

std::string Daemon::address() const {
  auto colon = options_.listen.rfind(':');
  return options_.listen.substr(0, colon) + ":" + std::to_string(port_);
}

namespace {
// Plain text unless a certificate is given; with a client CA, a client must present a
// certificate it signed (mutual TLS) before any call, the token check coming on top.
std::shared_ptr<grpc::ServerCredentials> server_credentials(const TlsOptions& tls) {
  if (!tls.enabled()) return grpc::InsecureServerCredentials();
  grpc::SslServerCredentialsOptions ssl(tls.client_ca.empty() ? GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE
                                                              : GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  ssl.pem_root_certs = tls.client_ca;
  ssl.pem_key_cert_pairs.push_back({tls.private_key, tls.certificate_chain});
  return grpc::SslServerCredentials(ssl);
}
}  // namespace

void Daemon::start() {
  if (!is_loopback_address(options_.listen) && options_.token.empty()) {
    throw std::invalid_argument("listen: " + options_.listen +
                                " is not a loopback address; give --token-file to open it to other machines");
  }
  manager_->start();
  auto auth = std::make_shared<const TokenCheck>(options_.token);
  service_ = std::make_unique<GelServiceImpl>(*manager_, *studies_, auth);
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  // gRPC sets SO_REUSEPORT by default, so a second geld on the same port would start silently
  // and take half of the connections; without it the second bind fails.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddListeningPort(options_.listen, server_credentials(options_.tls), &port_);
  builder.RegisterService(service_.get());
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(std::make_unique<MalformedRequestInterceptorFactory>());
  if (!options_.token.empty()) interceptors.push_back(std::make_unique<TokenInterceptorFactory>(options_.token));
  builder.experimental().SetInterceptorCreators(std::move(interceptors));
  server_ = builder.BuildAndStart();
  if (!server_ || port_ == 0) {
    manager_->shutdown();
    throw std::runtime_error("listen: cannot listen on " + options_.listen);
  }
  if (auto* health = server_->GetHealthCheckService()) {
    health->SetServingStatus(true);
    health->SetServingStatus("gel.v1.GelService", true);
  }
  spdlog::info("geld listening on {}{}{}", address(), options_.tls.enabled() ? (options_.tls.client_ca.empty() ? " (TLS)" : " (mutual TLS)") : "",
               options_.token.empty() ? "" : " (bearer token required)");
}

void Daemon::shutdown() {
  if (stopped_) return;
  stopped_ = true;
  if (server_) {
    if (auto* health = server_->GetHealthCheckService()) health->SetServingStatus(false);
  }
  // Stop taking work and checkpoint the running jobs; the server keeps answering reads (and
  // UNAVAILABLE for submissions and watches) meanwhile.
  manager_->shutdown();
  if (server_) {
    server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(5));
    server_->Wait();
  }
  spdlog::info("geld stopped");
}

}  // namespace geld
