// geld_bench: how many SubmitJob and GetJob calls per second a running geld answers with N
// concurrent clients (each its own channel, i.e. its own connection).
//
//   geld_bench --server 127.0.0.1:PORT [--clients 16] [--seconds 3]
//
// Submissions use a tiny valid scene; start geld with a large --max-queue and --workers 1 so
// they queue. Prints one line per phase: calls, calls/s, p50 and p99 latency.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "gel/v1/service.grpc.pb.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Result {
  std::vector<double> latencies_ms;
  long errors = 0;
};

template <class Call>
void phase(const char* name, const std::string& server, int clients, double seconds, Call call) {
  std::vector<Result> results(clients);
  std::vector<std::thread> threads;
  std::atomic<bool> go{false};
  const auto start = Clock::now();
  const auto until = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      grpc::ChannelArguments args;
      args.SetInt("grpc.use_local_subchannel_pool", 1);  // a connection of its own
      auto channel = grpc::CreateCustomChannel(server, grpc::InsecureChannelCredentials(), args);
      auto stub = gel::v1::GelService::NewStub(channel);
      while (!go) std::this_thread::yield();
      while (Clock::now() < until) {
        const auto t0 = Clock::now();
        const bool ok = call(*stub, c);
        results[c].latencies_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        if (!ok) ++results[c].errors;
      }
    });
  }
  go = true;
  for (auto& t : threads) t.join();
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  std::vector<double> all;
  long errors = 0;
  for (auto& r : results) {
    all.insert(all.end(), r.latencies_ms.begin(), r.latencies_ms.end());
    errors += r.errors;
  }
  std::sort(all.begin(), all.end());
  auto pct = [&](double p) { return all.empty() ? 0.0 : all[std::min(all.size() - 1, static_cast<size_t>(p * all.size()))]; };
  std::printf("%-8s %2d clients: %7zu calls in %.2f s = %8.0f calls/s, p50 %.2f ms, p99 %.2f ms, %ld errors\n", name,
              clients, all.size(), elapsed, all.size() / elapsed, pct(0.5), pct(0.99), errors);
}

}  // namespace

int main(int argc, char** argv) {
  std::string server = "127.0.0.1:50051";
  int clients = 16;
  double seconds = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--server") server = argv[i + 1];
    else if (flag == "--clients") clients = std::stoi(argv[i + 1]);
    else if (flag == "--seconds") seconds = std::stod(argv[i + 1]);
  }
  const std::string scene =
      R"({"preset": "quick", "generator": {"n_floc": 8, "n_clusters": 8, "lx": 30, "ly": 50},
          "compression": {"fidelity": "fast", "steps": 3}})";
  std::vector<std::string> ids(clients);
  phase("submit", server, clients, seconds, [&](gel::v1::GelService::Stub& stub, int c) {
    grpc::ClientContext context;
    gel::v1::SubmitJobRequest request;
    request.set_scene_json(scene);
    request.set_name("bench");
    gel::v1::SubmitJobResponse response;
    const bool ok = stub.SubmitJob(&context, request, &response).ok();
    if (ok) ids[c] = response.job_id();
    return ok;
  });
  phase("status", server, clients, seconds, [&](gel::v1::GelService::Stub& stub, int c) {
    grpc::ClientContext context;
    gel::v1::GetJobRequest request;
    request.set_job_id(ids[c].empty() ? "job-000001" : ids[c]);
    gel::v1::Job job;
    return stub.GetJob(&context, request, &job).ok();
  });
  return 0;
}
