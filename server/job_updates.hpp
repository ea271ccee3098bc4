#pragma once
// The one builder of the JobUpdate messages WatchJob streams (docs/api.md "Watching a job"):
// each kind with the fields it carries. The sequence is set by the job manager when it
// publishes an update, except for stored rows replayed to a new watcher.
#include <cstdint>
#include <string>

#include "gel/v1/service.pb.h"

namespace geld::job_update {

// The job's state changed: the whole job, for the member it names.
gel::v1::JobUpdate state(const gel::v1::Job& job);
// The first update a watcher gets: the job as it is now, as of `sequence`.
gel::v1::JobUpdate snapshot(gel::v1::Job job, std::int64_t sequence = 0);
gel::v1::JobUpdate log(const std::string& message, int member);
gel::v1::JobUpdate progress(const gel::v1::Progress& progress, int member, std::uint64_t seed);
gel::v1::JobUpdate row(gel::v1::CurveRow row, int member, std::uint64_t seed, std::int64_t sequence = 0);

}  // namespace geld::job_update
