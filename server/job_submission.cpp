// JobManager's submissions: the checks on a request, the resource budgets, memory admission,
// the run cache and the job's first store.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <limits>

#include <spdlog/spdlog.h>

#include "gel/fnv1a.hpp"
#include "gel/resources.hpp"
#include "gel/seed.hpp"
#include "job_manager.hpp"
#include "job_parameters.hpp"

namespace geld {

namespace {

void to_message(const gel::ResourceEstimate& e, int members, gel::v1::ResourceEstimate& out) {
  out.set_particles(e.particles);
  out.set_bonds(e.bonds);
  out.set_neighbour_pairs(e.neighbour_pairs);
  out.set_memory_bytes(e.memory_bytes);
  out.set_disk_bytes(e.disk_bytes);
  out.set_steps(e.steps);
  out.set_particle_steps(e.particle_steps);
  out.set_members(members);
}

std::string describe(const gel::ResourceEstimate& e) {
  return std::to_string(e.particles) + " particles, up to " + std::to_string(e.bonds) + " bonds and " +
         std::to_string(e.neighbour_pairs) + " neighbour pairs";
}

// The per-job budgets of Limits, from one member's estimate: each refusal names the field that
// drives the estimate, the estimate and the limit with the option that sets it.
void check_job_budgets(const gel::ResourceEstimate& e, int members, const Limits& limits) {
  const auto refuse = [](const std::string& field, const std::string& text) {
    throw ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED, field + ": " + text);
  };
  if (e.memory_bytes > limits.max_member_memory)
    refuse("scene." + e.memory_driver, "one member would hold about " + gel::format_bytes(static_cast<double>(e.memory_bytes)) +
                                           " (" + describe(e) + "), the limit is " +
                                           gel::format_bytes(static_cast<double>(limits.max_member_memory)) + " (--max-member-memory)");
  const double disk = static_cast<double>(e.disk_bytes) * members;
  if (disk > static_cast<double>(limits.max_job_disk))
    refuse(members > 1 && e.disk_bytes <= limits.max_job_disk ? "seeds" : "scene." + e.disk_driver,
           "the job's files would take about " + gel::format_bytes(disk) + " (" + std::to_string(members) + " member(s) of " +
               gel::format_bytes(static_cast<double>(e.disk_bytes)) + "), the limit is " +
               gel::format_bytes(static_cast<double>(limits.max_job_disk)) + " (--max-job-disk)");
  const double cost = e.particle_steps * members;
  if (cost > limits.max_job_particle_steps) {
    char text[200];
    std::snprintf(text, sizeof text, "the job would take at least %.3g particle-steps (%d member(s) of %lld particles x %.3g steps), "
                  "the limit is %.3g (--max-job-particle-steps)", cost, members, static_cast<long long>(e.particles),
                  static_cast<double>(e.steps), limits.max_job_particle_steps);
    refuse(members > 1 && e.particle_steps <= limits.max_job_particle_steps ? "seeds" : "scene.generator", text);
  }
}

// What geld itself holds besides its members (measured idle: about 20 MB).
constexpr std::int64_t kDaemonBytes = 64ll << 20;

// Protocol Buffers strings must be UTF-8: a job whose name or label is not would be stored, and
// then every client that lists it would fail to parse the answer. (gRPC's own parser refuses
// such requests; this guards the callers that build requests in C++.)
bool valid_utf8(std::string_view text) {
  std::size_t i = 0;
  while (i < text.size()) {
    const auto lead = static_cast<unsigned char>(text[i]);
    const std::size_t length = lead < 0x80 ? 1 : (lead >> 5) == 0x6 ? 2 : (lead >> 4) == 0xe ? 3 : (lead >> 3) == 0x1e ? 4 : 0;
    if (length == 0 || i + length > text.size()) return false;
    std::uint32_t code = length == 1 ? lead : lead & (0x7f >> length);
    for (std::size_t k = 1; k < length; ++k) {
      const auto next = static_cast<unsigned char>(text[i + k]);
      if ((next >> 6) != 0x2) return false;
      code = (code << 6) | (next & 0x3f);
    }
    // Overlong forms, UTF-16 surrogates and code points past U+10FFFF are not UTF-8.
    static constexpr std::uint32_t kSmallest[5] = {0, 0, 0x80, 0x800, 0x10000};
    if (code < kSmallest[length] || (code >= 0xd800 && code <= 0xdfff) || code > 0x10ffff) return false;
    i += length;
  }
  return true;
}

// Labels are listed with every job: 20 000 of them made ListJobs answers too large to read.
constexpr int kMaxLabels = 64;

}  // namespace

std::int64_t JobManager::memory_budget() const {
  if (options_.limits.max_memory > 0) return options_.limits.max_memory;
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? static_cast<std::int64_t>(pages) * page / 2 : 4ll << 30;
}

void JobManager::admit_memory(std::int64_t member_memory, int members) const {
  // Members of a Slurm executor run on the cluster's nodes, not in geld.
  if (!executor_->runs_in_process()) return;
  // Any `workers` members of the admitted jobs may run at once: the largest of them must fit.
  std::vector<std::pair<std::int64_t, int>> admitted;  // (one member's memory, members)
  for (const auto& [id, live] : live_) admitted.emplace_back(live->member_memory, live->members);
  admitted.emplace_back(member_memory, members);
  std::sort(admitted.begin(), admitted.end(), std::greater<>());
  std::int64_t peak = kDaemonBytes + gel::kProgramBytes;
  int slots = options_.workers;
  for (const auto& [memory, count] : admitted) {
    const int running = std::min(slots, std::max(count, 1));
    peak += memory * running;
    slots -= running;
    if (slots <= 0) break;
  }
  const std::int64_t budget = memory_budget();
  if (peak > budget)
    throw ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED,
                   "memory: with this job the " + std::to_string(options_.workers) + " largest members of the " +
                       std::to_string(live_.size() + 1) + " admitted jobs could hold " +
                       gel::format_bytes(static_cast<double>(peak)) + " together (this job's members " +
                       gel::format_bytes(static_cast<double>(member_memory)) + " each), over the daemon's budget of " +
                       gel::format_bytes(static_cast<double>(budget)) + " (--max-memory); wait for jobs to end or raise it");
}

GelcoreAdapter::Prepared JobManager::validated(const gel::v1::SubmitJobRequest& request) {
  // gelsim's rule (gel/seed.hpp): 0 would run as seed 1 while being recorded as 0.
  for (int i = 0; i < request.seeds_size(); ++i)
    if (const std::string problem = gel::seed_problem(request.seeds(i)); !problem.empty())
      throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "seeds[" + std::to_string(i) + "]: " + problem);
  if (request.seeds_size() > options_.limits.max_seeds) {
    throw ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED,
                   "seeds: " + std::to_string(request.seeds_size()) + " ensemble members, the limit is " +
                       std::to_string(options_.limits.max_seeds));
  }
  constexpr std::size_t kMaxLabelSize = 256;
  if (request.labels_size() > kMaxLabels) {
    throw ApiError(grpc::StatusCode::INVALID_ARGUMENT,
                   "labels: " + std::to_string(request.labels_size()) + " labels, the limit is " + std::to_string(kMaxLabels));
  }
  for (const auto& [key, value] : request.labels()) {
    if (key.empty() || key.find('=') != std::string::npos) {
      throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "labels: key '" + key.substr(0, 64) + "' must be non-empty without '='");
    }
    if (key.size() > kMaxLabelSize || value.size() > kMaxLabelSize) {
      throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "labels: key '" + key.substr(0, 64) + "': key and value are limited to " +
                                                             std::to_string(kMaxLabelSize) + " characters each");
    }
  }
  if (request.name().size() > 256) {
    throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "name: longer than 256 characters");
  }
  if (!valid_utf8(request.name())) throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "name: not valid UTF-8");
  for (const auto& [key, value] : request.labels())
    if (!valid_utf8(key) || !valid_utf8(value)) throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "labels: not valid UTF-8");
  if (!valid_utf8(request.scene_json())) throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "scene_json: not valid UTF-8");
  GelcoreAdapter::Prepared prepared = adapter_->prepare(request, options_.limits);
  check_job_budgets(prepared.estimate, std::max(1, request.seeds_size()), options_.limits);
  if (request.seeds_size() > 0) {
    // The members' seeds are what ran: each is queryable as generator.seed, the scene's is not.
    std::erase_if(prepared.parameters, [](const auto& parameter) { return std::get<0>(parameter) == "generator.seed"; });
    for (const std::uint64_t seed : request.seeds())
      prepared.parameters.emplace_back("generator.seed", std::to_string(seed), static_cast<double>(seed));
  }
  return prepared;
}

void JobManager::validate(const gel::v1::SubmitJobRequest& request) { validated(request); }

std::string JobManager::program_version() { return adapter_->program_version(); }

gel::v1::SubmitJobResponse JobManager::submit(const gel::v1::SubmitJobRequest& request, bool adopt_metadata) {
  if (shutting_down_) throw shutting_down_error();
  GelcoreAdapter::Prepared prepared = validated(request);
  // Run cache: the same resolved scene, seeds and program give the same bits (the engine is
  // deterministic), so an identical submission gets the job that already has them.
  // The key leaves out what does not change a bit of the result: the engine threads (runs are
  // bit-identical for any number) and the scene's own seed when a seed list replaces it; a run
  // without a list is the list of its scene's seed.
  const std::string version = adapter_->program_version();
  gel::v1::Scene keyed = prepared.scene;
  keyed.mutable_integration()->clear_threads();
  std::string seeds_text;
  if (request.seeds_size() == 0) seeds_text = std::to_string(keyed.generator().seed()) + ",";
  for (const std::uint64_t seed : request.seeds()) seeds_text += std::to_string(seed) + ",";
  keyed.mutable_generator()->clear_seed();
  const std::string cache_key = gel::fnv1a_hex(adapter_->scene_json(keyed) + "|" + seeds_text + "|" + version);
  const double no_number = std::numeric_limits<double>::quiet_NaN();
  prepared.parameters.emplace_back(kCacheKeyParameter, cache_key, no_number);
  if (!request.rerun()) {
    if (const auto earlier = store_->find_job_by_parameter(kCacheKeyParameter, cache_key, gel::v1::JOB_STATE_SUCCEEDED)) {
      // Labels and name are metadata: the job takes them, so `list --label` finds it for this
      // submitter too; its first submitter still lists it by theirs, so a changed value is refused.
      if (adopt_metadata) {
        const Store::MetadataMerge merge = store_->merge_labels_and_name(*earlier, request.labels(), request.name(), kMaxLabels);
        if (!merge.conflicts.empty())
          throw ApiError(grpc::StatusCode::INVALID_ARGUMENT,
                         "labels: key '" + merge.conflicts.front().first + "' is '" + merge.conflicts.front().second + "' on " +
                             *earlier + ", the job that already has these results (run cache); give another key, or rerun");
        if (!merge.written)
          throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "labels: " + *earlier + " (run cache) would have " +
                                                                 std::to_string(merge.labels) + " labels, the limit is " +
                                                                 std::to_string(kMaxLabels));
      }
      gel::v1::SubmitJobResponse response;
      response.set_job_id(*earlier);
      *response.mutable_job() = get(*earlier);
      response.set_cached(true);
      spdlog::info("job {}: returned from the run cache (same scene, seeds and program)", *earlier);
      return response;
    }
  }

  gel::v1::Job job;
  job.set_name(request.name());
  *job.mutable_labels() = request.labels();
  *job.mutable_scene() = prepared.scene;
  if (request.seeds_size() > 0) {
    *job.mutable_seeds() = request.seeds();
  } else {
    job.add_seeds(prepared.scene.generator().seed());
  }
  job.set_particles(prepared.particles);
  job.set_bond_preset(prepared.bond_preset);
  job.set_created_unix_ms(now_ms());
  job.set_program_version(version);

  {
    std::lock_guard lock(mutex_);
    if (shutting_down_) throw shutting_down_error();
    if (queue_.size() + reserved_ >= options_.limits.max_queue) {
      throw ApiError(grpc::StatusCode::RESOURCE_EXHAUSTED,
                     "queue full: " + std::to_string(queue_.size()) + " jobs queued, the limit is " +
                         std::to_string(options_.limits.max_queue));
    }
    admit_memory(prepared.estimate.memory_bytes, job.seeds_size());
    ++reserved_;
  }
  // Committed before the reply: an acknowledged job is never lost.
  try {
    store_->insert_job(job, prepared.scene_json, prepared.parameters);
  } catch (...) {
    std::lock_guard lock(mutex_);
    --reserved_;
    throw;
  }
  {
    std::lock_guard lock(mutex_);
    --reserved_;
    auto live = std::make_shared<Live>();
    live->job = job;
    live->member_memory = prepared.estimate.memory_bytes;
    live->members = job.seeds_size();
    live_[job.id()] = live;
    queue_.push_back(job.id());
  }
  queue_changed_.notify_one();
  spdlog::info("job {}: queued ({} particles, {} seed(s), name '{}')", job.id(), job.particles(), job.seeds_size(),
               job.name());
  gel::v1::SubmitJobResponse response;
  response.set_job_id(job.id());
  to_message(prepared.estimate, job.seeds_size(), *response.mutable_estimate());
  *response.mutable_job() = std::move(job);
  return response;
}

}  // namespace geld
