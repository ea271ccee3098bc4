#include "job_updates.hpp"

#include <utility>

namespace geld::job_update {
namespace {

gel::v1::JobUpdate of_kind(gel::v1::JobUpdate::Kind kind, int member) {
  gel::v1::JobUpdate update;
  update.set_kind(kind);
  update.set_member(member);
  return update;
}

}  // namespace

gel::v1::JobUpdate state(const gel::v1::Job& job) {
  gel::v1::JobUpdate update = of_kind(gel::v1::JobUpdate::STATE, job.member());
  *update.mutable_job() = job;
  return update;
}

gel::v1::JobUpdate snapshot(gel::v1::Job job, std::int64_t sequence) {
  gel::v1::JobUpdate update = of_kind(gel::v1::JobUpdate::SNAPSHOT, job.member());
  update.set_sequence(sequence);
  *update.mutable_job() = std::move(job);
  return update;
}

gel::v1::JobUpdate log(const std::string& message, int member) {
  gel::v1::JobUpdate update = of_kind(gel::v1::JobUpdate::LOG, member);
  update.set_message(message);
  return update;
}

gel::v1::JobUpdate progress(const gel::v1::Progress& progress, int member, std::uint64_t seed) {
  gel::v1::JobUpdate update = of_kind(gel::v1::JobUpdate::PROGRESS, member);
  update.set_seed(seed);
  *update.mutable_progress() = progress;
  return update;
}

gel::v1::JobUpdate row(gel::v1::CurveRow row, int member, std::uint64_t seed, std::int64_t sequence) {
  gel::v1::JobUpdate update = of_kind(gel::v1::JobUpdate::ROW, member);
  update.set_seed(seed);
  update.set_sequence(sequence);
  *update.mutable_row() = std::move(row);
  return update;
}

}  // namespace geld::job_update
