"""Compression curves as tables: the columns of the engine's curve.csv (core/src/curve_io.cpp,
curve_to_csv), names with their units, so that a DataFrame from geld and a curve.csv that
gelsim wrote read the same way."""
import numpy

from .v1 import service_pb2

# (column, numpy dtype, value of a gel.v1.CurveRow), in curve.csv's order. Keep in step with
# curve_to_csv: tests/service/test_python_package.sh compares these names with the header of
# the curve.csv that geld's engine writes.
_CURVE_CSV_COLUMNS = (
    ("k", numpy.int64, lambda r: r.k),
    ("phi [1]", numpy.float64, lambda r: r.phi),
    ("target_phi [1]", numpy.float64, lambda r: r.target_phi),
    ("P [F0/a^2]", numpy.float64, lambda r: r.p),
    ("P_top [F0/a^2]", numpy.float64, lambda r: r.p_top),
    ("P_bot [F0/a^2]", numpy.float64, lambda r: r.p_bot),
    ("contact_number [1]", numpy.float64, lambda r: r.contact_number),
    ("stored_energy [F0 a]", numpy.float64, lambda r: r.stored_energy),
    ("dissipated_energy [F0 a]", numpy.float64, lambda r: r.dissipated_energy),
    ("ruptures_normal [count]", numpy.int64, lambda r: r.ruptures.normal),
    ("ruptures_sliding [count]", numpy.int64, lambda r: r.ruptures.sliding),
    ("ruptures_rolling [count]", numpy.int64, lambda r: r.ruptures.rolling),
    ("bonds_created [count]", numpy.int64, lambda r: r.ruptures.created),
    ("equilibrated [0/1]", numpy.int64, lambda r: int(r.equilibrated)),
    ("steps [count]", numpy.int64, lambda r: r.steps),
    ("sim_time [t0]", numpy.float64, lambda r: r.sim_time),
    ("wall_seconds [s]", numpy.float64, lambda r: r.wall_seconds),
    ("drag_energy [F0 a]", numpy.float64, lambda r: r.drag_energy),
    ("wall_work [F0 a]", numpy.float64, lambda r: r.wall_work),
    ("kinetic_energy [F0 a]", numpy.float64, lambda r: r.kinetic_energy),
    ("bond_creation_energy [F0 a]", numpy.float64, lambda r: r.bond_creation_energy),
    ("absorbed_by_walls [F0 a]", numpy.float64, lambda r: r.absorbed_by_walls),
    ("snapshot", object, lambda r: r.snapshot),
    ("spans [0/1]", numpy.int64, lambda r: int(r.spans)),
    ("residual_force [F0]", numpy.float64, lambda r: r.residual_force),
    ("mean_bond_force [F0]", numpy.float64, lambda r: r.mean_bond_force),
    ("relax_iterations [count]", numpy.int64, lambda r: r.relax_iterations),
    # The virial stress, tension positive (sigma_yy = -P at force balance); NaN in rows recorded
    # before it was (they have no stress field), as curve.csv leaves those cells empty.
    ("sigma_xx [F0/a^2]", numpy.float64, lambda r: r.stress.xx if r.HasField("stress") else numpy.nan),
    ("sigma_yy [F0/a^2]", numpy.float64, lambda r: r.stress.yy if r.HasField("stress") else numpy.nan),
    ("sigma_xy [F0/a^2]", numpy.float64, lambda r: r.stress.xy if r.HasField("stress") else numpy.nan),
)

# An ensemble's members share one table; these say whose row it is.
MEMBER_COLUMNS = ("member", "seed")

CURVE_COLUMNS = MEMBER_COLUMNS + tuple(name for name, _, _ in _CURVE_CSV_COLUMNS)
"""Columns of Client.curve(): member (0-based index in the job's seeds), seed, then curve.csv's."""

PROFILE_COLUMN = "phi_profile [1]"

# The per-slice profiles of curve_arrays(): (name, values of a gel.v1.CurveRow), the slices of
# profiles.csv, bottom to top.
_PROFILES = (
    (PROFILE_COLUMN, lambda r: r.phi_profile),
    ("sigma_xx_profile [F0/a^2]", lambda r: r.stress.xx_profile),
    ("sigma_yy_profile [F0/a^2]", lambda r: r.stress.yy_profile),
    ("sigma_xy_profile [F0/a^2]", lambda r: r.stress.xy_profile),
)
PROFILE_COLUMNS = tuple(name for name, _ in _PROFILES)

# GetCurve's per-phi_k statistics over an ensemble's members: (name, unit, EnsembleRow field).
_ENSEMBLE_STATISTICS = (
    ("phi", "1", "phi"), ("P", "F0/a^2", "p"), ("P_top", "F0/a^2", "p_top"), ("P_bot", "F0/a^2", "p_bot"),
    ("contact_number", "1", "contact_number"), ("stored_energy", "F0 a", "stored_energy"),
    ("dissipated_energy", "F0 a", "dissipated_energy"),
)


def curve_arrays(curve_response):
    """GetCurveResponse -> {column: numpy array}, one element per row of every member in member
    order; CURVE_COLUMNS plus PROFILE_COLUMNS, (rows, slices) arrays of phi and of the stress
    components per slice along y, bottom to top (NaN where a row has fewer slices)."""
    member_rows = [(member.member, member.seed, row)
                   for member in curve_response.members for row in member.curve.rows]
    arrays = {
        "member": numpy.array([member for member, _, _ in member_rows], dtype=numpy.int64),
        "seed": numpy.array([seed for _, seed, _ in member_rows], dtype=numpy.uint64),
    }
    for name, dtype, value_of in _CURVE_CSV_COLUMNS:
        arrays[name] = numpy.array([value_of(row) for _, _, row in member_rows], dtype=dtype)
    for name, values_of in _PROFILES:
        slices = max((len(values_of(row)) for _, _, row in member_rows), default=0)
        profiles = numpy.full((len(member_rows), slices), numpy.nan)
        for index, (_, _, row) in enumerate(member_rows):
            values = values_of(row)
            profiles[index, :len(values)] = values
        arrays[name] = profiles
    return arrays


def curve_frame(curve_response):
    """GetCurveResponse -> pandas.DataFrame with CURVE_COLUMNS, one row per curve row."""
    import pandas  # only here: importing pandas costs a second that the rest of the package does not need

    arrays = curve_arrays(curve_response)
    for name in PROFILE_COLUMNS:
        del arrays[name]
    return pandas.DataFrame(arrays, columns=list(CURVE_COLUMNS))


def ensemble_frame(curve_response):
    """GetCurveResponse -> pandas.DataFrame of the ensemble statistics per phi_k: k, n (members that
    reached phi_k), then for each quantity its mean and sample standard deviation, e.g.
    "P [F0/a^2]" and "P_std [F0/a^2]". Empty for a single-seed job."""
    import pandas

    columns = {"k": numpy.array([row.k for row in curve_response.ensemble], dtype=numpy.int64),
               "n": numpy.array([row.n for row in curve_response.ensemble], dtype=numpy.int64)}
    for name, unit, field in _ENSEMBLE_STATISTICS:
        statistics = [getattr(row, field) for row in curve_response.ensemble]
        columns[f"{name} [{unit}]"] = numpy.array([s.mean for s in statistics], dtype=numpy.float64)
        columns[f"{name}_std [{unit}]"] = numpy.array([s.std for s in statistics], dtype=numpy.float64)
    return pandas.DataFrame(columns)


JOB_CURVE_COLUMNS = ("job_id",) + CURVE_COLUMNS
"""Columns of Client.query_curves_frame(): job_id (whose curve the row is), then CURVE_COLUMNS."""


def jobs_curve_frame(job_curves):
    """[(job id, GetCurveResponse), ...] -> one pandas.DataFrame with JOB_CURVE_COLUMNS: curve_frame()
    of each job, one after the other in the given order, each row with its job's id."""
    import pandas

    per_job = [(job_id, curve_arrays(curve_response)) for job_id, curve_response in job_curves]
    if not per_job:
        # No job: an empty table with the columns and dtypes that a non-empty one has.
        per_job = [("", curve_arrays(service_pb2.GetCurveResponse()))]
    columns = {"job_id": numpy.array([job_id for job_id, arrays in per_job for _ in range(len(arrays["k"]))],
                                     dtype=object)}
    for name in CURVE_COLUMNS:
        columns[name] = numpy.concatenate([arrays[name] for _, arrays in per_job])
    return pandas.DataFrame(columns, columns=list(JOB_CURVE_COLUMNS))
