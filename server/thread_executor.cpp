// The "threads" executor: members run in geld's process, on the worker thread that took them,
// with gel::run_compression, or gel::resume_compression from the member's checkpoint.
#include <string>

#include "executor.hpp"
#include "gel/compression.hpp"
#include "gel/errors.hpp"

namespace geld {
namespace {

class ThreadExecutor final : public Executor {
 public:
  std::string name() const override { return "threads"; }

  RunResult run(const RunContext& ctx) override {
    gel::RunOptions options;
    options.out_dir = ctx.out_dir;
    options.on_progress = ctx.on_progress;
    options.on_row = ctx.on_row;
    options.stop = ctx.stop;
    gel::CompressionResult result;
    bool resumed = false;
    if (gel::has_checkpoint(ctx.out_dir)) {
      try {
        ctx.log_member("info", "resumes from its checkpoint");
        result = gel::resume_compression(options);
        resumed = true;
        if (result.resumed_from_previous_checkpoint)
          ctx.log_member("warn", "last checkpoint unusable (" + result.checkpoint_problem + "); went on from the one before it");
      } catch (const gel::StabilityError&) {
        throw;
      } catch (const std::exception& e) {
        // A checkpoint that cannot be read: the run is deterministic, so start it again.
        ctx.log_member("warn", std::string("checkpoint unusable (") + e.what() + "); starting again");
      }
    }
    if (!resumed) result = gel::run_compression(ctx.scene, options);
    RunResult out;
    out.finished = result.finished;
    out.stopped = result.stopped;
    out.curve = std::move(result.curve);
    return out;
  }
};

}  // namespace

std::unique_ptr<Executor> make_thread_executor() { return std::make_unique<ThreadExecutor>(); }

}  // namespace geld
