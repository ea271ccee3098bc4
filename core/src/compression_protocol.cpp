// Stepwise uniaxial compression (MODEL.md "Stepwise uniaxial compression"): the walls close
// symmetrically at v_wall each until phi reaches the next target phi_k, stop, and the
// equilibrium test runs every m_exam steps; at equilibrium (or when the wait limit is reached)
// a curve row is recorded and compression resumes.
//
// The protocol is a small state machine (CompressionState) advanced in chunks of steps. Every
// decision depends only on the engine state and the protocol state, never on the wall clock,
// so a checkpoint taken between two chunks and resumed continues bit for bit: progress
// reports, wall-clock checkpoints and stop requests only happen between chunks and do not
// touch the physics.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "compression_checkpoint.hpp"
#include "compression_internal.hpp"
#include "compression_observables.hpp"
#include "gel/compression.hpp"
#include "gel/curve_io.hpp"
#include "gel/errors.hpp"
#include "gel/fnv1a.hpp"
#include "gel/export.hpp"
#include "gel/generator.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"
#include "thermo_log.hpp"

namespace gel {
namespace {

using Clock = std::chrono::steady_clock;

// Steps between two looks at the stop flag, the clock and the phase logic. Small against any
// protocol time scale, large against the cost of a clock read.
constexpr std::int64_t kChunkSteps = 128;

// Quasi-static approach: at most this many contact-to-contact jumps per target before the walls
// move, and the overlap each jump ends with so that the touching pair bonds [a].
constexpr int kMaxShortcutJumps = 10000;
constexpr double kContactHair = 1e-9;

// FIRE iterations between two looks at the stop flag, the clock and progress.
constexpr std::int64_t kRelaxChunk = 512;

// Adaptive wall controller, applied once per moving chunk: speed up gently (about 2.6x per
// thousand steps) so a sudden load is met before the walls run far ahead, and halve at once
// when drag takes too much of the wall work.
constexpr double kAdaptiveSpeedUp = 1.1;
constexpr double kAdaptiveSlowDown = 0.5;

// The scene's own output requests (output.trajectory_every into DIR/trajectory.gsd,
// output.thermo_every into DIR/thermo.csv) where the caller's options leave them open: a job of
// geld asks for its trajectory and thermo log this way.
RunOptions with_scene_outputs(RunOptions options, const gel::v1::Scene& scene) {
  if (options.trajectory_every <= 0 && scene.output().trajectory_every() > 0 && !options.out_dir.empty()) {
    options.trajectory_every = scene.output().trajectory_every();
    if (options.trajectory_path.empty())
      options.trajectory_path = default_trajectory_path(options.out_dir);
  }
  if (options.thermo_every <= 0 && scene.output().thermo_every() > 0 && !options.out_dir.empty()) {
    options.thermo_every = scene.output().thermo_every();
    if (options.thermo_path.empty()) options.thermo_path = default_thermo_path(options.out_dir);
  }
  return options;
}

// --- The run -----------------------------------------------------------------------------------

class CompressionRun {
 public:
  CompressionRun(System system, gel::v1::Curve curve, CompressionState state, const RunOptions& options)
      : system_(std::move(system)),
        curve_(std::move(curve)),
        state_(state),
        settings_(compression_settings(curve_.scene().compression())),
        options_(with_scene_outputs(options, curve_.scene())),
        targets_(compression_targets(state.phi0, settings_.w0, settings_.phi_max, settings_.steps)),
        dt_(resolve_sim_params(curve_.scene()).dt),
        session_start_(Clock::now()),
        last_progress_(session_start_),
        last_checkpoint_(session_start_) {
    // Any number gives the same bits (System::set_threads), so the option may override the scene.
    const int scene_threads = curve_.scene().integration().threads();
    system_.set_threads(options.threads > 0 ? options.threads : scene_threads > 0 ? scene_threads : 1);
  }

  // Opens the trajectory and the thermo log: a fresh run starts each file, a resumed one keeps
  // their frames and lines up to the checkpoint's step and writes the next one where the
  // uninterrupted run would have.
  void open_outputs(bool resumed) {
    if (options_.thermo_every > 0 && !options_.thermo_path.empty())
      thermo_ = std::make_unique<ThermoLog>(options_.thermo_path, options_.thermo_every,
                                            resumed ? system_.step_count() : -1);
    if (options_.trajectory_every <= 0 || options_.trajectory_path.empty()) return;
    const std::int64_t step = system_.step_count();
    if (!resumed) {
      trajectory_ = exporting::open_writer(exporting::Format::kGsd, options_.trajectory_path);
      next_frame_step_ = 0;
      return;
    }
    std::int64_t last_frame_step = -1;
    trajectory_ = exporting::reopen_gsd_trajectory(options_.trajectory_path, step, &last_frame_step);
    next_frame_step_ = last_frame_step < 0 ? 0 : (last_frame_step / options_.trajectory_every + 1) * options_.trajectory_every;
  }

  // A fresh run: records row 0 and writes its outputs.
  void start() {
    state_.next_exam_step = 0;
    open_outputs(false);
    write_frame_if_due();
    write_thermo_if_due();
    store_row(measure_row(true, state_.phi0));
  }

  CompressionResult run() {
    CompressionResult result;
    while (state_.phase != kDone) {
      if (options_.stop && options_.stop->load(std::memory_order_relaxed)) {
        save_checkpoint();
        result.stopped = true;
        result.curve = curve_;
        return result;
      }
      if (settings_.quasistatic)
        advance_quasistatic();
      else if (state_.phase == kMoving)
        advance_moving();
      else
        advance_waiting();
      between_chunks();
    }
    if (thermo_) thermo_->write(system_, state_k(), "done");  // the final state, unless just written
    save_checkpoint();
    if (options_.on_progress) options_.on_progress(progress("done"));
    result.finished = true;
    result.curve = curve_;
    return result;
  }

 private:
  double height_at(double phi) const {
    return kPi * kRadius * kRadius * static_cast<double>(system_.size()) / (system_.lx() * phi);
  }
  double target_phi() const { return targets_[static_cast<std::size_t>(state_.k - 1)]; }

  void set_walls(double v_each) {
    if (system_.wall_velocity_bottom() != v_each || system_.wall_velocity_top() != -v_each)
      system_.set_wall_velocities(v_each, -v_each);
  }

  void advance_moving() {
    const double target_height = height_at(target_phi());
    double gap = system_.wall_top() - system_.wall_bottom() - target_height;
    if (settings_.approach_shortcut && !state_.spanned && system_.wall_velocity_top() == 0.0) {
      // At the start of a target's compression only (walls at rest).
      // The quasi-static method repeats the jump from contact to contact (each contact bonds
      // and the group grows) until the network spans: the v -> 0 limit of pushing clusters
      // through the liquid, where drag vanishes.
      const int jumps = settings_.quasistatic ? kMaxShortcutJumps : 1;
      for (int jump_count = 0; jump_count < jumps && gap > 0.0; ++jump_count) {
        const std::vector<char> group = top_wall_group(system_);
        if (group_touches_bottom_wall(system_, group)) {
          state_.spanned = true;
          break;
        }
        double jump = std::min(distance_to_first_contact(system_, group), std::max(gap, 0.0));
        // Into contact by a hair, so that the touching pair bonds (or the particle sticks).
        if (settings_.quasistatic) jump = std::min(jump + kContactHair, gap);
        if (jump > 0.0) system_.translate_wall_group(kTopWall, -jump);
        if (settings_.quasistatic) system_.update_contacts();
        gap -= jump;
      }
      if (gap <= 0.0) return begin_wait();
    }
    if (gap <= 0.0) return begin_wait();
    system_.set_time_step(walk_time_step());
    const double dt = system_.params().dt;
    const double v_wall = settings_.adaptive_wall_max_factor > 1.0
                              ? adapt_wall_speed()
                              : loaded_wall_speed(settings_, settings_.v_wall, system_.wall_stress().p);
    const double per_step = 2.0 * v_wall * dt;
    const double full_steps = std::floor(gap / per_step);
    if (full_steps >= 2.0) {
      set_walls(v_wall);
      system_.run(std::min<std::int64_t>(kChunkSteps, static_cast<std::int64_t>(full_steps) - 1));
      return;
    }
    // The last step closes exactly the remaining gap, so the walls stop at the target.
    set_walls(0.5 * gap / dt);
    system_.step();
    begin_wait();
  }

  // Beyond the published method (docs/accuracy.md): a quasi-static compression stores the
  // walls' work in the bonds; the share that Stokes drag takes instead measures how far the
  // network is from equilibrium (the drag stress against P). So run fast while the network is
  // unloaded or nearly all the work is stored, and slow down towards v_wall when drag takes
  // more than the target share (yielding, rearrangement). Decided from the engine state only,
  // so checkpoint and resume stay bit for bit.
  double adapt_wall_speed() {
    const EnergyLedger& ledger = system_.energy();
    const double work = ledger.wall_work - state_.wall_work_at_control;
    const double drag = ledger.drag - state_.drag_at_control;
    if (work == 0.0 && drag == 0.0) return settings_.v_wall * state_.wall_speed_factor;  // nothing moved yet
    state_.wall_work_at_control = ledger.wall_work;
    state_.drag_at_control = ledger.drag;
    const double target = settings_.adaptive_wall_drag_fraction;
    const bool unloaded = std::abs(system_.wall_stress().p) < settings_.stress_floor;
    double& factor = state_.wall_speed_factor;
    if (unloaded || (work > 0.0 && drag < 0.5 * target * work))
      factor = std::min(factor * kAdaptiveSpeedUp, settings_.adaptive_wall_max_factor);
    else if (work <= 0.0 || drag > target * work)
      factor = std::max(factor * kAdaptiveSlowDown, 1.0);
    return settings_.v_wall * factor;
  }

  // Quasi-static method: the walls reach each target either by the dynamics' wall motion
  // (default) or in affine strain steps of at most strain_step in ln(phi), each relaxed; at the
  // target FIRE relaxes the network at fixed walls, and the row is that relaxed state.
  void advance_quasistatic() {
    const bool affine = settings_.affine_steps || (settings_.affine_after_spanning && state_.spanned);
    if (state_.phase == kMoving && !affine) return advance_moving();  // ends in begin_wait()
    if (state_.phase == kMoving) {
      const double height = system_.wall_top() - system_.wall_bottom();
      const double target_height = height_at(target_phi());
      // A last step shorter than a tenth of a step joins the one before it.
      double next = height * std::exp(-settings_.strain_step);
      if (next < target_height * std::exp(0.1 * settings_.strain_step)) next = target_height;
      const double centre = 0.5 * (system_.wall_top() + system_.wall_bottom());
      system_.affine_move_walls(centre - 0.5 * next, centre + 0.5 * next);
      state_.relax = RelaxState{};
      state_.phase = kRelaxing;
      return;
    }
    const std::int64_t left = settings_.relax_max_iterations - state_.relax.iterations;
    system_.relax(state_.relax, settings_.relax, std::min(kRelaxChunk, std::max<std::int64_t>(left, 0)));
    const bool done = state_.relax.converged || state_.relax.stalled ||
                      state_.relax.iterations >= settings_.relax_max_iterations;
    if (!done) return;
    // The last step aimed at the target's height exactly; its wall positions round it.
    const double height = system_.wall_top() - system_.wall_bottom();
    if (height <= height_at(target_phi()) * (1 + 1e-12)) {
      finish_target(state_.relax.converged);
    } else {
      state_.phase = kMoving;
    }
  }

  std::int64_t counted_ruptures() const {
    return exam_ruptures(system_.events(), settings_.exam_all_ruptures);
  }

  // Decided from the state at each chunk, so a resumed run decides the same.
  double walk_time_step() const {
    return gel::walk_time_step(settings_, dt_, system_.wall_stress().p, [this] { return system_.fastest_contact_frequency(); });
  }

  void begin_wait() {
    set_walls(0.0);
    system_.set_time_step(dt_);  // every relaxation and wait at the scene's dt
    if (settings_.quasistatic) {
      // The walls are at the target: relax there instead of waiting.
      state_.relax = RelaxState{};
      state_.phase = kRelaxing;
      return;
    }
    state_.phase = kWaiting;
    state_.wait_start_time = system_.time();
    state_.previous_p = system_.wall_stress().p;
    state_.ruptures_at_previous = counted_ruptures();
    state_.next_exam_step = system_.step_count() + settings_.m_exam;
  }

  void advance_waiting() {
    const std::int64_t remaining = state_.next_exam_step - system_.step_count();
    if (remaining > 0) system_.run(std::min(kChunkSteps, remaining));
    if (system_.step_count() >= state_.next_exam_step) examine();
  }

  void examine() {
    const WallStress stress = system_.wall_stress();
    require_finite_state("P_top", stress.p_top);
    require_finite_state("P_bot", stress.p_bottom);
    EquilibriumSample sample;
    sample.p_top = stress.p_top;
    sample.p_bot = stress.p_bottom;
    sample.previous_p = state_.previous_p;
    sample.bond_broke = counted_ruptures() != state_.ruptures_at_previous;
    sample.max_speed = system_.max_speed();
    sample.spans = network_spans(system_);
    if (equilibrium_reached(sample, settings_)) return finish_target(true);
    if (system_.time() - state_.wait_start_time >= settings_.max_wait_time) return finish_target(false);
    state_.previous_p = stress.p;
    state_.ruptures_at_previous = counted_ruptures();
    state_.next_exam_step += settings_.m_exam;
  }

  void finish_target(bool equilibrated) {
    const double target = target_phi();
    ++state_.k;
    state_.phase = state_.k > settings_.steps ? kDone : kMoving;
    // The adaptive wall judges the next compression by its own work and drag, not the wait's.
    state_.drag_at_control = system_.energy().drag;
    state_.wall_work_at_control = system_.energy().wall_work;
    gel::v1::CurveRow row = measure_row(equilibrated, target);
    // walls-then-affine: the walls walk through the liquid while they gather the network, and
    // once a relaxed network spans, affine strain steps take it on. Decided before the row is
    // stored, so that the checkpoint written with it holds the decision.
    if (settings_.affine_after_spanning && row.spans() && equilibrated) state_.spanned = true;
    store_row(std::move(row));
  }

  double wall_seconds() const {
    return state_.wall_seconds_before + std::chrono::duration<double>(Clock::now() - session_start_).count();
  }

  // The row of the state now: what it records, nothing decided.
  gel::v1::CurveRow measure_row(bool equilibrated, double target) const {
    gel::v1::CurveRow row;
    const WallStress stress = system_.wall_stress();
    const int index = curve_.rows_size();
    row.set_k(index);
    row.set_phi(system_.packing_fraction());
    row.set_target_phi(target);
    row.set_p(stress.p);
    row.set_p_top(stress.p_top);
    row.set_p_bot(stress.p_bottom);
    row.set_contact_number(system_.mean_contact_number());
    row.set_stored_energy(system_.stored_energy());
    row.set_dissipated_energy(system_.energy().dissipated);
    gel::v1::Events* events = row.mutable_ruptures();
    events->set_normal(system_.events().normal);
    events->set_sliding(system_.events().sliding);
    events->set_rolling(system_.events().rolling);
    events->set_created(system_.events().created);
    row.set_equilibrated(equilibrated);
    row.set_steps(system_.step_count());
    row.set_sim_time(system_.time());
    row.set_wall_seconds(wall_seconds());
    for (const double phi : phi_profile(system_, settings_.profile_slices)) row.add_phi_profile(phi);
    *row.mutable_stress() = stress_record(system_, settings_.profile_slices);
    row.set_drag_energy(system_.energy().drag);
    row.set_wall_work(system_.energy().wall_work);
    row.set_kinetic_energy(system_.kinetic_energy());
    row.set_bond_creation_energy(system_.energy().created);
    row.set_absorbed_by_walls(system_.energy().absorbed_by_walls);
    row.set_spans(network_spans(system_));
    if (settings_.quasistatic && index > 0) {
      row.set_residual_force(state_.relax.residual);
      row.set_mean_bond_force(state_.relax.force_scale);
      row.set_relax_iterations(state_.relax.iterations);
    }
    for (const double value : {row.p(), row.stored_energy(), row.dissipated_energy(), row.kinetic_energy(), row.phi(),
                               row.stress().xx(), row.stress().yy(), row.stress().xy()})
      require_finite_state("a recorded observable", value);
    return row;
  }

  // Appends the row to the curve, with its snapshot, and writes the curve and a checkpoint.
  void store_row(gel::v1::CurveRow row) {
    if (!options_.out_dir.empty() && options_.write_snapshots) {
      char name[32];
      std::snprintf(name, sizeof name, "snapshots/k_%03d.pb", row.k());
      std::filesystem::create_directories(std::filesystem::path(options_.out_dir) / "snapshots");
      write_configuration(system_.configuration(), (std::filesystem::path(options_.out_dir) / name).string());
      row.set_snapshot(name);
    }
    *curve_.add_rows() = row;
    if (!options_.out_dir.empty()) {
      write_curve(curve_, options_.out_dir);
      save_checkpoint();
    }
    if (options_.on_row) options_.on_row(row);
  }

  void save_checkpoint() {
    if (options_.out_dir.empty()) return;
    CompressionState state = state_;
    state.wall_seconds_before = wall_seconds();
    write_checkpoint(options_.out_dir, curve_, state, system_);
    last_checkpoint_ = Clock::now();
  }

  // The target being worked towards (the last one once done).
  int state_k() const { return std::min(state_.k, settings_.steps); }

  gel::v1::Progress progress(const char* phase) const {
    gel::v1::Progress p;
    const int k = state_k();
    p.set_k(k);
    p.set_k_total(settings_.steps);
    p.set_phi(system_.packing_fraction());
    p.set_target_phi(targets_[static_cast<std::size_t>(k - 1)]);
    p.set_p(system_.wall_stress().p);
    gel::v1::Events* events = p.mutable_events();
    events->set_normal(system_.events().normal);
    events->set_sliding(system_.events().sliding);
    events->set_rolling(system_.events().rolling);
    events->set_created(system_.events().created);
    const double elapsed = wall_seconds();
    p.set_elapsed_seconds(elapsed);
    // Done fraction: finished targets plus the compression in ln(phi) towards the current one
    // (waits are counted as done with their target: a rough but monotonic estimate).
    double fraction = 1.0;
    if (state_.phase != kDone) {
      const double from = state_.k == 1 ? state_.phi0 : targets_[static_cast<std::size_t>(state_.k - 2)];
      const double within = std::clamp(std::log(p.phi() / from) / std::log(p.target_phi() / from), 0.0, 1.0);
      fraction = (state_.k - 1 + within) / settings_.steps;
    }
    p.set_remaining_seconds(fraction > 0.01 ? elapsed * (1.0 - fraction) / fraction : -1.0);
    p.set_steps(system_.step_count());
    p.set_phase(phase);
    if (settings_.quasistatic) {
      p.set_residual_force(state_.relax.residual);
      p.set_residual_target(std::max(settings_.relax.force_tolerance * state_.relax.tolerance_factor * state_.relax.force_scale,
                                     settings_.relax.force_floor));
      p.set_relax_iterations(state_.relax.iterations);
    }
    return p;
  }

  const char* phase_name() const {
    switch (state_.phase) {
      case kMoving: return "compressing";
      case kWaiting: return "waiting";
      case kRelaxing: return "relaxing";
      default: return "done";
    }
  }

  void write_frame_if_due() {
    if (!trajectory_ || system_.step_count() < next_frame_step_) return;
    exporting::Frame frame;
    frame.configuration = system_.configuration();
    frame.step = system_.step_count();
    frame.p = system_.wall_stress().p;
    frame.bond_law = system_.params().bond;
    frame.effects = system_.params().effects;
    trajectory_->append(frame);
    next_frame_step_ = (frame.step / options_.trajectory_every + 1) * options_.trajectory_every;
  }

  void write_thermo_if_due() {
    if (thermo_ && thermo_->due(system_.step_count())) thermo_->write(system_, state_k(), phase_name());
  }

  void between_chunks() {
    write_frame_if_due();
    write_thermo_if_due();
    const bool want_clock = static_cast<bool>(options_.on_progress) || !options_.out_dir.empty();
    if (!want_clock) return;
    const Clock::time_point now = Clock::now();
    if (options_.on_progress &&
        std::chrono::duration<double>(now - last_progress_).count() >= options_.progress_interval_seconds) {
      last_progress_ = now;
      options_.on_progress(progress(phase_name()));
    }
    if (!options_.out_dir.empty() &&
        std::chrono::duration<double>(now - last_checkpoint_).count() >= settings_.checkpoint_seconds)
      save_checkpoint();
  }

  System system_;
  gel::v1::Curve curve_;
  CompressionState state_;
  CompressionSettings settings_;
  RunOptions options_;
  std::vector<double> targets_;
  double dt_;  // the scene's time step; the walk may take a multiple of it
  Clock::time_point session_start_, last_progress_, last_checkpoint_;
  std::unique_ptr<exporting::FrameWriter> trajectory_;
  std::int64_t next_frame_step_ = 0;
  std::unique_ptr<ThermoLog> thermo_;
};

}  // namespace

bool equilibrium_reached(const EquilibriumSample& sample, const CompressionSettings& settings) {
  if (sample.bond_broke) return false;
  // A network that does not reach both walls carries no load: P is drag on the wall clusters,
  // so only rest means equilibrium.
  if (!sample.spans) return sample.max_speed < settings.rest_speed;
  const double p = 0.5 * (sample.p_top + sample.p_bot);
  const double scale = std::abs(p);
  if (scale < settings.stress_floor && std::abs(sample.previous_p) < settings.stress_floor)
    return sample.max_speed < settings.rest_speed;
  return std::abs(sample.p_top - sample.p_bot) < settings.a_tolerance * scale &&
         std::abs(p - sample.previous_p) < settings.b_tolerance * scale;
}

bool equilibrium_reached(const EquilibriumSample& sample, const gel::v1::Compression& compression) {
  return equilibrium_reached(sample, compression_settings(compression));
}

std::int64_t exam_ruptures(const EventCounts& events, bool all_modes) {
  return all_modes ? events.normal + events.sliding + events.rolling : events.normal;
}

std::int64_t exam_ruptures(const EventCounts& events, const gel::v1::Compression& compression) {
  return exam_ruptures(events, compression_settings(compression).exam_all_ruptures);
}


CompressionResult run_compression(const gel::v1::Scene& scene, const RunOptions& options, const Configuration* initial) {
  const gel::v1::Scene resolved = resolve_compression_scene(scene);
  require_non_negative("progress_interval_seconds", options.progress_interval_seconds);
  const SimParams params = resolve_sim_params(resolved);
  if (!options.out_dir.empty()) std::filesystem::create_directories(options.out_dir);

  std::optional<Configuration> generated;
  if (!initial) {
    if (resolved.generator().n_floc() == 0)
      throw InvalidArgument("generator", "needs a generator preset or parameters, or an initial configuration");
    if (options.on_progress) {
      gel::v1::Progress p;
      p.set_phase("generating");
      p.set_k_total(resolved.compression().steps());
      p.set_remaining_seconds(-1);
      options.on_progress(p);
    }
    try {
      generated = generate_gel(resolved.generator(), nullptr, options.stop);
    } catch (const GenerationStopped&) {
      // Nothing to checkpoint yet: a resumed run generates the same gel again from its seed.
      CompressionResult stopped;
      *stopped.curve.mutable_scene() = resolved;
      stopped.stopped = true;
      return stopped;
    }
    initial = &*generated;
  }
  System system(*initial, params);
  if (!system.has_walls()) system.install_walls();
  system.compute_forces();

  gel::v1::Curve curve;
  *curve.mutable_scene() = resolved;
  curve.set_program_version(program_version());
  curve.set_particles(static_cast<int>(system.size()));
  CompressionState state;
  state.phi0 = system.packing_fraction();
  compression_targets(state.phi0, resolved.compression().w0(), resolved.compression().phi_max(),
                      resolved.compression().steps());  // validates phi_max against phi_1

  CompressionRun run(std::move(system), std::move(curve), state, options);
  run.start();
  return run.run();
}


CompressionResult resume_compression(const RunOptions& options) {
  if (!has_checkpoint(options.out_dir))
    throw InvalidArgument("out_dir", "no checkpoint in '" + options.out_dir + "'");
  std::string problems;
  for (const std::string& path : {checkpoint_path(options.out_dir), previous_checkpoint_path(options.out_dir)}) {
    if (!std::filesystem::is_regular_file(path)) continue;
    LoadedCheckpoint loaded;
    try {
      loaded = load_checkpoint(path);
    } catch (const InvalidArgument& e) {
      problems += (problems.empty() ? "" : "; ") + std::string(e.what());
      continue;
    }
    CompressionRun run(std::move(*loaded.system), std::move(loaded.curve), loaded.state, options);
    run.open_outputs(true);
    CompressionResult result = run.run();
    result.resumed_from_previous_checkpoint = path == previous_checkpoint_path(options.out_dir);
    result.checkpoint_problem = problems;
    return result;
  }
  throw InvalidArgument("out_dir", problems);
}

std::string default_trajectory_path(const std::string& out_dir) {
  return (std::filesystem::path(out_dir) / "trajectory.gsd").string();
}

std::string default_thermo_path(const std::string& out_dir) {
  return (std::filesystem::path(out_dir) / "thermo.csv").string();
}

}  // namespace gel
