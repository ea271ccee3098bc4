"""geld's messages as plain Python dicts whose numbers are numbers.

The keys follow the JSON the project already writes, so that one name means one thing
everywhere: jobs as `gelctl status --json` (times as Unix milliseconds instead of text), progress
and rows as gelsim's --progress-file lines and curve.json rows ("P", "P_top", "ruptures", ...).
"""
from google.protobuf import descriptor, json_format

from .v1 import service_pb2

_INT64_TYPES = {descriptor.FieldDescriptor.TYPE_INT64, descriptor.FieldDescriptor.TYPE_UINT64,
                descriptor.FieldDescriptor.TYPE_SINT64, descriptor.FieldDescriptor.TYPE_FIXED64,
                descriptor.FieldDescriptor.TYPE_SFIXED64}
_FLOAT_TYPES = {descriptor.FieldDescriptor.TYPE_DOUBLE, descriptor.FieldDescriptor.TYPE_FLOAT}


def state_name(state):
    """JobState value -> "queued", "running", "succeeded", "failed", "cancelled" (gelctl's words)."""
    return service_pb2.JobState.Name(state).removeprefix("JOB_STATE_").lower()


def _numbers_from_json_text(value, field):
    # Protocol Buffers' JSON mapping writes 64-bit integers as strings (JavaScript's doubles
    # cannot hold them) and NaN/Infinity as strings; Python can hold both as numbers.
    if field.type == descriptor.FieldDescriptor.TYPE_MESSAGE:
        if field.message_type.GetOptions().map_entry:
            value_field = field.message_type.fields_by_name["value"]
            return {key: _numbers_from_json_text(item, value_field) for key, item in value.items()}
        if isinstance(value, list):
            return [_plain_message_dict(item, field.message_type) for item in value]
        return _plain_message_dict(value, field.message_type)
    if isinstance(value, list):
        return [_numbers_from_json_text(item, field) for item in value]
    if field.type in _INT64_TYPES and isinstance(value, str):
        return int(value)
    if field.type in _FLOAT_TYPES and isinstance(value, str):
        return float(value)
    return value


def _plain_message_dict(json_dict, message_descriptor):
    return {key: _numbers_from_json_text(value, message_descriptor.fields_by_name[key])
            for key, value in json_dict.items()}


def message_to_dict(message):
    """Any message (a Scene, a Configuration's generator, ...) in Protocol Buffers' JSON mapping with
    the .proto field names, as the scene files gelsim reads, but with every number a number.
    Fields at their default value are left out, as in those files."""
    json_dict = json_format.MessageToDict(message, preserving_proto_field_name=True)
    return _plain_message_dict(json_dict, message.DESCRIPTOR)


def events_to_dict(events):
    """Cumulative event counts: bonds broken (normal), sliding and rolling resets, bonds created."""
    return {"normal": events.normal, "sliding": events.sliding, "rolling": events.rolling,
            "created": events.created}


def progress_to_dict(progress):
    """A running member's progress: target k of k_total, phi -> target_phi [1], P [F0/a^2], steps,
    elapsed and estimated remaining seconds (< 0: unknown), and for quasi-static runs the FIRE
    residual [F0] against its target."""
    plain = {"phase": progress.phase, "k": progress.k, "k_total": progress.k_total, "phi": progress.phi,
             "target_phi": progress.target_phi, "P": progress.p, "events": events_to_dict(progress.events),
             "steps": progress.steps, "elapsed_seconds": progress.elapsed_seconds,
             "remaining_seconds": progress.remaining_seconds}
    if progress.relax_iterations > 0:
        plain.update(residual_force=progress.residual_force, residual_target=progress.residual_target,
                     relax_iterations=progress.relax_iterations)
    return plain


def curve_row_to_dict(row):
    """One equilibrium row with curve.json's keys: phi [1], P, P_top, P_bot [F0/a^2], energies [F0 a]
    (cumulative), ruptures and bonds_created (cumulative counts), steps, sim_time [t0],
    wall_seconds [s], phi_profile (phi per slice, bottom to top), ..., and "stress" (the virial
    stress [F0/a^2], tension positive: xx, yy, xy and their *_profile per slice) where the row has it."""
    return {"k": row.k, "phi": row.phi, "target_phi": row.target_phi, "P": row.p, "P_top": row.p_top,
            "P_bot": row.p_bot, "contact_number": row.contact_number, "stored_energy": row.stored_energy,
            "dissipated_energy": row.dissipated_energy,
            "ruptures": {"normal": row.ruptures.normal, "sliding": row.ruptures.sliding,
                         "rolling": row.ruptures.rolling},
            "bonds_created": row.ruptures.created, "equilibrated": row.equilibrated, "steps": row.steps,
            "sim_time": row.sim_time, "wall_seconds": row.wall_seconds, "drag_energy": row.drag_energy,
            "wall_work": row.wall_work, "kinetic_energy": row.kinetic_energy,
            "bond_creation_energy": row.bond_creation_energy, "absorbed_by_walls": row.absorbed_by_walls,
            "phi_profile": list(row.phi_profile), "snapshot": row.snapshot, "spans": row.spans,
            "residual_force": row.residual_force, "mean_bond_force": row.mean_bond_force,
            "relax_iterations": row.relax_iterations,
            **({"stress": {"xx": row.stress.xx, "yy": row.stress.yy, "xy": row.stress.xy,
                           "xx_profile": list(row.stress.xx_profile), "yy_profile": list(row.stress.yy_profile),
                           "xy_profile": list(row.stress.xy_profile)}} if row.HasField("stress") else {})}


def job_to_dict(job):
    """A job as `gelctl status --json` shows it, with times as Unix milliseconds (0: not yet) and
    `progress` None unless geld has a progress report for it."""
    return {"id": job.id, "name": job.name, "state": state_name(job.state), "labels": dict(job.labels),
            "seeds": list(job.seeds), "particles": job.particles, "bond_preset": job.bond_preset,
            "created_unix_ms": job.created_unix_ms, "started_unix_ms": job.started_unix_ms,
            "finished_unix_ms": job.finished_unix_ms, "error": job.error, "member": job.member,
            "rows": job.rows, "out_dir": job.out_dir, "program_version": job.program_version,
            "progress": progress_to_dict(job.progress) if job.HasField("progress") else None,
            "scene": message_to_dict(job.scene)}


def update_to_dict(update):
    """One WatchJob update. Every dict has `type` and `sequence`; by type:
      "snapshot" (first) and "state": `state`, `error` and the whole `job`;
      "progress": member, seed and progress_to_dict's keys;
      "row": member, seed and curve_row_to_dict's keys;
      "log": `message`."""
    Kind = service_pb2.JobUpdate
    plain = {"type": Kind.Kind.Name(update.kind).lower(), "sequence": update.sequence}
    if update.kind in (Kind.SNAPSHOT, Kind.STATE):
        plain.update(state=state_name(update.job.state), error=update.job.error, job=job_to_dict(update.job))
    elif update.kind == Kind.PROGRESS:
        plain.update(member=update.member, seed=update.seed, **progress_to_dict(update.progress))
    elif update.kind == Kind.ROW:
        plain.update(member=update.member, seed=update.seed, **curve_row_to_dict(update.row))
    elif update.kind == Kind.LOG:
        plain["message"] = update.message
    return plain
