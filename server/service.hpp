#pragma once
// The gRPC face of geld: GelService (a thin layer over JobManager, like gRPC's route_guide),
// the standard health service, server reflection (grpc.reflection.v1alpha) and, in remote mode,
// a bearer token on every call. Daemon owns the server and the manager; geld's main() and the
// service tests both start it.
#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>

#include "executor.hpp"
#include "gel/v1/service.grpc.pb.h"
#include "job_manager.hpp"
#include "study_manager.hpp"

namespace geld {

// "authorization: Bearer <token>" on every call; an empty token accepts every call.
class TokenCheck {
 public:
  explicit TokenCheck(std::string token) : token_(std::move(token)) {}
  bool required() const { return !token_.empty(); }
  // OK, or UNAUTHENTICATED saying what is missing.
  grpc::Status check(const grpc::ServerContextBase& context) const;

 private:
  std::string token_;
};

class GelServiceImpl final : public gel::v1::GelService::Service {
 public:
  GelServiceImpl(JobManager& manager, StudyManager& studies, std::shared_ptr<const TokenCheck> auth)
      : manager_(manager), studies_(studies), auth_(std::move(auth)) {}

  grpc::Status SubmitJob(grpc::ServerContext* context, const gel::v1::SubmitJobRequest* request,
                         gel::v1::SubmitJobResponse* response) override;
  grpc::Status WatchJob(grpc::ServerContext* context, const gel::v1::WatchJobRequest* request,
                        grpc::ServerWriter<gel::v1::JobUpdate>* writer) override;
  grpc::Status CancelJob(grpc::ServerContext* context, const gel::v1::CancelJobRequest* request,
                         gel::v1::Job* response) override;
  grpc::Status GetJob(grpc::ServerContext* context, const gel::v1::GetJobRequest* request,
                      gel::v1::Job* response) override;
  grpc::Status ListJobs(grpc::ServerContext* context, const gel::v1::ListJobsRequest* request,
                        gel::v1::ListJobsResponse* response) override;
  grpc::Status GetCurve(grpc::ServerContext* context, const gel::v1::GetCurveRequest* request,
                        gel::v1::GetCurveResponse* response) override;
  grpc::Status QueryCurves(grpc::ServerContext* context, const gel::v1::QueryCurvesRequest* request,
                           gel::v1::QueryCurvesResponse* response) override;
  grpc::Status GetLogs(grpc::ServerContext* context, const gel::v1::GetLogsRequest* request,
                       gel::v1::GetLogsResponse* response) override;
  grpc::Status GetAnalysis(grpc::ServerContext* context, const gel::v1::GetAnalysisRequest* request,
                           gel::v1::GetAnalysisResponse* response) override;
  grpc::Status SubmitStudy(grpc::ServerContext* context, const gel::v1::SubmitStudyRequest* request,
                           gel::v1::SubmitStudyResponse* response) override;
  grpc::Status GetStudy(grpc::ServerContext* context, const gel::v1::GetStudyRequest* request,
                        gel::v1::Study* response) override;
  grpc::Status ListStudies(grpc::ServerContext* context, const gel::v1::ListStudiesRequest* request,
                           gel::v1::ListStudiesResponse* response) override;
  grpc::Status WatchStudy(grpc::ServerContext* context, const gel::v1::WatchStudyRequest* request,
                          grpc::ServerWriter<gel::v1::StudyUpdate>* writer) override;
  grpc::Status CancelStudy(grpc::ServerContext* context, const gel::v1::CancelStudyRequest* request,
                           gel::v1::Study* response) override;
  grpc::Status GetStudyAnalysis(grpc::ServerContext* context, const gel::v1::GetStudyAnalysisRequest* request,
                                gel::v1::GetStudyAnalysisResponse* response) override;

 private:
  template <class F>
  grpc::Status guarded(grpc::ServerContext* context, const char* method, F&& body);

  JobManager& manager_;
  StudyManager& studies_;
  std::shared_ptr<const TokenCheck> auth_;
};

// TLS for remote mode: PEM contents (not paths), read by main() from files.
struct TlsOptions {
  std::string certificate_chain;  // the server's certificate (and intermediates)
  std::string private_key;
  std::string client_ca;          // when set, clients must present a certificate signed by it
  bool enabled() const { return !certificate_chain.empty(); }
};

struct DaemonOptions {
  std::string listen = "127.0.0.1:0";  // host:port; port 0 picks a free one
  std::string token;                   // required on every call when not empty
  TlsOptions tls;                      // off: plain text (loopback, or behind a TLS proxy)
  ManagerOptions manager;
};

// True for 127.0.0.0/8, ::1 and localhost (with or without a port).
bool is_loopback_address(const std::string& host_port);

class Daemon {
 public:
  Daemon(DaemonOptions options, std::shared_ptr<GelcoreAdapter> adapter, std::shared_ptr<Executor> executor);
  ~Daemon();

  // Opens the store, recovers jobs, starts the workers and the server. Throws on failure
  // (e.g. the address cannot be bound).
  void start();
  int port() const { return port_; }
  std::string address() const;  // host:port actually bound
  // Stops taking work (UNAVAILABLE), checkpoints running jobs, stops the server. Idempotent.
  void shutdown();
  JobManager& manager() { return *manager_; }
  StudyManager& studies() { return *studies_; }

 private:
  DaemonOptions options_;
  std::unique_ptr<JobManager> manager_;
  std::unique_ptr<StudyManager> studies_;
  std::unique_ptr<GelServiceImpl> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  bool stopped_ = false;
};

}  // namespace geld
