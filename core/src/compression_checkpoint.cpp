// The compression's checkpoint file: the magic, a gel.v1.Checkpoint message and its hash.
#include "compression_checkpoint.hpp"

#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "gel/compression.hpp"
#include "gel/curve_io.hpp"
#include "gel/errors.hpp"
#include "gel/fnv1a.hpp"

namespace gel {
namespace {

constexpr char kCheckpointFile[] = "checkpoint.bin";
constexpr char kPreviousCheckpointFile[] = "checkpoint.prev.bin";
// The file is the magic, a gel.v1.Checkpoint message (proto/gel/v1/checkpoint.proto) and the
// 64-bit FNV-1a hash of that message: a flipped bit in a stored double would otherwise parse
// fine and resume a corrupted run. Formats 1-4 were raw little-endian struct bytes; they are
// refused with their number, and the service then runs the member again from its seed.
constexpr char kCheckpointMagic[8] = {'G', 'E', 'L', 'C', 'K', 'P', 'T', '5'};
constexpr char kCheckpointMagicPrefix[7] = {'G', 'E', 'L', 'C', 'K', 'P', 'T'};
constexpr std::uint32_t kCheckpointFormat = 5;

void encode_state(const CompressionState& s, gel::v1::ProtocolState& m) {
  m.set_phi0(s.phi0);
  m.set_k(s.k);
  m.set_phase(s.phase);
  m.set_next_exam_step(s.next_exam_step);
  m.set_wait_start_time(s.wait_start_time);
  m.set_previous_p(s.previous_p);
  m.set_ruptures_at_previous(s.ruptures_at_previous);
  m.set_spanned(s.spanned);
  m.set_wall_seconds_before(s.wall_seconds_before);
  m.set_wall_speed_factor(s.wall_speed_factor);
  m.set_drag_at_control(s.drag_at_control);
  m.set_wall_work_at_control(s.wall_work_at_control);
  gel::v1::RelaxState& relax = *m.mutable_relax();
  relax.set_dt(s.relax.dt);
  relax.set_dt_max(s.relax.dt_max);
  relax.set_alpha(s.relax.alpha);
  relax.set_n_positive(s.relax.n_positive);
  relax.set_n_negative(s.relax.n_negative);
  relax.set_iterations(s.relax.iterations);
  relax.set_residual(s.relax.residual);
  relax.set_force_scale(s.relax.force_scale);
  relax.set_tolerance_factor(s.relax.tolerance_factor);
  relax.set_converged(s.relax.converged);
  relax.set_stalled(s.relax.stalled);
}

CompressionState decode_state(const gel::v1::ProtocolState& m) {
  if (m.phase() < kMoving || m.phase() > kRelaxing || m.k() < 1) throw std::runtime_error("its protocol state is invalid");
  CompressionState s;
  s.phi0 = m.phi0();
  s.k = m.k();
  s.phase = static_cast<Phase>(m.phase());
  s.next_exam_step = m.next_exam_step();
  s.wait_start_time = m.wait_start_time();
  s.previous_p = m.previous_p();
  s.ruptures_at_previous = m.ruptures_at_previous();
  s.spanned = m.spanned();
  s.wall_seconds_before = m.wall_seconds_before();
  s.wall_speed_factor = m.wall_speed_factor();
  s.drag_at_control = m.drag_at_control();
  s.wall_work_at_control = m.wall_work_at_control();
  const gel::v1::RelaxState& relax = m.relax();
  s.relax.dt = relax.dt();
  s.relax.dt_max = relax.dt_max();
  s.relax.alpha = relax.alpha();
  s.relax.n_positive = relax.n_positive();
  s.relax.n_negative = relax.n_negative();
  s.relax.iterations = relax.iterations();
  s.relax.residual = relax.residual();
  s.relax.force_scale = relax.force_scale();
  s.relax.tolerance_factor = relax.tolerance_factor();
  s.relax.converged = relax.converged();
  s.relax.stalled = relax.stalled();
  return s;
}

}  // namespace

std::string checkpoint_path(const std::string& out_dir) {
  return (std::filesystem::path(out_dir) / kCheckpointFile).string();
}

std::string previous_checkpoint_path(const std::string& out_dir) {
  return (std::filesystem::path(out_dir) / kPreviousCheckpointFile).string();
}

void write_checkpoint(const std::string& out_dir, const gel::v1::Curve& curve, const CompressionState& state,
                      const System& system) {
  gel::v1::Checkpoint checkpoint;
  checkpoint.set_format(kCheckpointFormat);
  checkpoint.set_program_version(program_version());
  *checkpoint.mutable_curve() = curve;
  encode_state(state, *checkpoint.mutable_protocol());
  system.save_state(*checkpoint.mutable_engine());
  std::string message;
  checkpoint.SerializeToString(&message);
  const std::uint64_t hash = fnv1a(message);
  std::string bytes(kCheckpointMagic, sizeof kCheckpointMagic);
  bytes += message;
  for (int byte = 0; byte < 8; ++byte) bytes.push_back(static_cast<char>((hash >> (8 * byte)) & 0xff));
  const std::string path = checkpoint_path(out_dir);
  if (std::filesystem::is_regular_file(path)) std::filesystem::rename(path, previous_checkpoint_path(out_dir));
  write_file_atomically(path, bytes);
}

LoadedCheckpoint load_checkpoint(const std::string& path) {
  const std::string bytes = read_file(path);
  if (bytes.size() < sizeof kCheckpointMagic + 8 ||
      std::memcmp(bytes.data(), kCheckpointMagicPrefix, sizeof kCheckpointMagicPrefix) != 0)
    throw InvalidArgument("out_dir", "'" + path + "' is not a compression checkpoint");
  if (bytes[sizeof kCheckpointMagicPrefix] != kCheckpointMagic[sizeof kCheckpointMagicPrefix])
    throw InvalidArgument("out_dir", "'" + path + "' is a checkpoint of format " + std::string(1, bytes[sizeof kCheckpointMagicPrefix]) +
                                         ", which this version (format " + std::to_string(kCheckpointFormat) + ") does not read");
  const std::string message = bytes.substr(sizeof kCheckpointMagic, bytes.size() - sizeof kCheckpointMagic - 8);
  std::uint64_t stored = 0;
  for (int byte = 7; byte >= 0; --byte)
    stored = (stored << 8) | static_cast<unsigned char>(bytes[bytes.size() - 8 + static_cast<std::size_t>(byte)]);
  if (fnv1a(message) != stored) throw InvalidArgument("out_dir", "'" + path + "' is corrupt (checksum mismatch)");
  LoadedCheckpoint loaded;
  try {
    gel::v1::Checkpoint checkpoint;
    if (!checkpoint.ParseFromString(message)) throw std::runtime_error("it does not parse");
    if (checkpoint.format() != kCheckpointFormat)
      throw std::runtime_error("its format is " + std::to_string(checkpoint.format()) + " (written by " +
                               checkpoint.program_version() + "), not " + std::to_string(kCheckpointFormat));
    loaded.curve = std::move(*checkpoint.mutable_curve());
    loaded.state = decode_state(checkpoint.protocol());
    loaded.system.emplace(System::load_state(checkpoint.engine()));
  } catch (const std::exception& e) {
    throw InvalidArgument("out_dir", "'" + path + "' cannot be read: " + e.what());
  }
  return loaded;
}

bool has_checkpoint(const std::string& out_dir) {
  return !out_dir.empty() && (std::filesystem::is_regular_file(checkpoint_path(out_dir)) ||
                              std::filesystem::is_regular_file(previous_checkpoint_path(out_dir)));
}

}  // namespace gel
