#!/usr/bin/env bash
# The Python package `gel` (client/python/gel) against a real geld on loopback, with Debian's
# /usr/bin/python3 (python3-grpcio, python3-protobuf, python3-numpy, python3-pandas):
#   connect with the token read as gelctl reads it; a wrong token is UNAUTHENTICATED; an address
#     without a port is a ValueError, and UNAVAILABLE says where it looked and how to choose geld
#   submit a small 2-seed ensemble, watch it from queued to succeeded (snapshot, progress and
#     rows as plain dicts with numbers as numbers), cancel a running job
#   curve() as a DataFrame: rows, dtypes, the engine's curve.csv header and values, and the
#     same numbers as `gelctl curve --json`; curve_arrays(), ensemble_curve(), jobs(), logs()
#   query_curves() and query_curves_frame() (QueryCurves) over two more jobs with other labels and
#     seeds: by label, by parameter filters in gelctl's --where syntax and as tuples, by bond preset,
#     state and limit; the same job ids as `gelctl query --json`; each job's rows with its job_id and
#     seed and curve()'s numbers; an empty or misspelt field is InvalidRequestError (INVALID_ARGUMENT)
#     from geld naming it, a malformed filter a ValueError before anything is sent
#   read_configuration() of `gelsim generate` output (.json and .pb) and of a job's snapshot
#   an unknown job id raises JobNotFoundError naming it; a misspelt override InvalidRequestError
#     naming the field, a NaN override ValueError
#
#   test_python_package.sh BUILD_DIR      (exit 77: skipped, no stubs or no Debian Python modules)
set -euo pipefail
build=$(cd "$1" && pwd)
source_dir=$(cd "$(dirname "$0")/../.." && pwd)
geld=$build/server/geld
gelctl=$build/client/gelctl
gelsim=$build/core/gelsim
py=/usr/bin/python3
stubs=$build/client/python
fail() { echo "FAIL: $*" >&2; exit 1; }

[ -f "$stubs/gel/v1/service_pb2_grpc.py" ] || { echo "skipped: no Python stubs in $stubs (grpc_python_plugin missing?)"; exit 77; }
$py -c 'import grpc, google.protobuf, numpy, pandas' 2>/dev/null \
  || { echo "skipped: $py lacks python3-grpcio, python3-protobuf, python3-numpy or python3-pandas"; exit 77; }

work=$(mktemp -d /tmp/gel-python.XXXXXX)
geld_pid=
stop_geld() {
  [ -n "$geld_pid" ] || return 0
  kill -TERM "$geld_pid" 2>/dev/null || true
  for _ in $(seq 1 100); do kill -0 "$geld_pid" 2>/dev/null || break; sleep 0.05; done
  kill -KILL "$geld_pid" 2>/dev/null || true
  wait "$geld_pid" 2>/dev/null || true
  geld_pid=
}
cleanup() {
  stop_geld
  rm -rf "$work"
}
trap cleanup EXIT

port=$($py -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()')
server=127.0.0.1:$port
echo "python-test-token-$$" >"$work/token"
chmod 600 "$work/token"
data=$work/data
# One worker: the job queued behind a running one cannot start before the watch has begun.
"$geld" --listen "$server" --data-dir "$data" --token-file "$work/token" --workers 1 --log-level info \
  >"$work/geld.log" 2>&1 &
geld_pid=$!
for _ in $(seq 1 300); do
  "$gelctl" --server "$server" --token-file "$work/token" list >/dev/null 2>&1 && break
  kill -0 "$geld_pid" 2>/dev/null || { cat "$work/geld.log" >&2; fail "geld did not start"; }
  sleep 0.05
done

"$gelsim" generate --preset quick --seed 2 --out "$work/gel.json" >/dev/null || fail "gelsim generate (json)"
"$gelsim" generate --preset quick --seed 2 --out "$work/gel.pb" >/dev/null || fail "gelsim generate (pb)"

# A port where no geld listens, for the UNAVAILABLE message.
dead_port=$($py -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()')

# The source package and the build tree's stubs, as a researcher uses them from a checkout.
PYTHONPATH=$source_dir/client/python GEL_PYTHON_STUBS=$stubs GELD_SERVER=$server GELD_TOKEN_FILE=$work/token \
  GELD_VERSION="$("$geld" --version)" $py - "$gelctl" "$data" "$work" "$dead_port" <<'PY' || fail "python package checks"
import json
import math
import os
import re
import subprocess
import sys

import numpy
import pandas

import gel

gelctl, data_dir, work, dead_port = sys.argv[1:5]
client = gel.connect()  # address and token from GELD_SERVER and GELD_TOKEN_FILE, as gelctl

try:
    gel.connect(token="not-the-token").jobs()
    raise AssertionError("a wrong token was accepted")
except gel.GelError as error:
    assert error.code == "UNAUTHENTICATED", error
# Where geld is: an address without a port is refused, and no geld there says where it looked.
for address in ("127.0.0.1", "localhost:", "[::1]:70000"):
    try:
        gel.connect(address)
        raise AssertionError(f"connect({address!r}) was accepted")
    except ValueError as error:
        assert f"connect: address {address!r} is not HOST:PORT" in str(error), error
dead = gel.connect(f"127.0.0.1:{dead_port}", timeout=10)
try:
    dead.jobs()
    raise AssertionError("a call to a port where no geld listens succeeded")
except gel.GelError as error:
    assert error.code == "UNAVAILABLE" and error.details.startswith(f"no geld answers at 127.0.0.1:{dead_port} ("), error
    assert error.details.endswith("start geld there, or give its HOST:PORT to gel.connect() or in $GELD_SERVER"), error
print("ok: connect: a wrong token UNAUTHENTICATED, an address without a port ValueError, UNAVAILABLE says where it looked")

# A long job holds the only worker, so the small job waits queued until it is cancelled.
blocker = client.submit("quick", seeds=[7], name="blocker")
small = client.submit("quick", seeds=[1, 2], name="python", labels={"suite": "python"}, fidelity="fast",
                      overrides={"generator.n_floc": 8, "generator.n_clusters": 8, "generator.lx": 30,
                                 "generator.ly": 50, "compression.steps": 3})
updates = client.watch(small)
first = next(updates)
assert first["type"] == "snapshot" and first["state"] == "queued", first
cancelled = client.cancel(blocker)
assert cancelled["state"] == "cancelled" and cancelled["id"] == blocker, cancelled
try:
    client.cancel(blocker)
    raise AssertionError("cancelling an ended job succeeded")
except gel.GelError as error:
    assert error.code == "FAILED_PRECONDITION", error
updates = [first] + list(updates)

def assert_numbers(update, keys):
    for key in keys:
        assert isinstance(update[key], (int, float)) and not isinstance(update[key], bool), (key, update)

sequences = [u["sequence"] for u in updates]
assert sequences == sorted(sequences) and len(set(sequences)) == len(sequences), sequences
progress = [u for u in updates if u["type"] == "progress"]
rows = [u for u in updates if u["type"] == "row"]
assert {u["member"] for u in progress} == {0, 1}, progress
assert any(u["phase"] == "done" for u in progress), [u["phase"] for u in progress]
for u in progress:
    assert_numbers(u, ("member", "seed", "k", "k_total", "phi", "target_phi", "P", "steps", "elapsed_seconds",
                       "remaining_seconds"))
    assert_numbers(u["events"], ("normal", "sliding", "rolling", "created"))
assert len(rows) == 8, len(rows)
for u in rows:
    assert_numbers(u, ("member", "seed", "k", "phi", "P", "P_top", "P_bot", "contact_number", "steps", "sim_time",
                       "bonds_created"))
assert updates[-1]["type"] == "state" and updates[-1]["state"] == "succeeded", updates[-1]
assert updates[-1]["job"]["rows"] == 8 and updates[-1]["job"]["seeds"] == [1, 2], updates[-1]["job"]
print(f"ok: watch {small}: {len(updates)} updates, {len(progress)} progress, {len(rows)} rows, succeeded")

curve = client.curve(small)
assert isinstance(curve, pandas.DataFrame)
assert len(curve) == 8, len(curve)
assert list(curve.columns) == list(gel.CURVE_COLUMNS), list(curve.columns)
for column in curve.columns:
    if column != "snapshot":
        assert pandas.api.types.is_numeric_dtype(curve[column]), (column, curve[column].dtype)
assert pandas.api.types.is_integer_dtype(curve["k"]) and pandas.api.types.is_integer_dtype(curve["steps [count]"])
assert list(curve["member"]) == [0] * 4 + [1] * 4 and list(curve["seed"]) == [1] * 4 + [2] * 4
assert list(curve["k"]) == [0, 1, 2, 3] * 2

# One vocabulary: the engine's own curve.csv of member 0, same header and the same numbers.
job = client.job(small)
assert job["program_version"] == os.environ["GELD_VERSION"], (job.get("program_version"), os.environ["GELD_VERSION"])
engine_csv = pandas.read_csv(os.path.join(data_dir, job["out_dir"], "m0-seed1", "curve.csv"),
                             float_precision="round_trip")
assert list(engine_csv.columns) == list(gel.CURVE_COLUMNS[2:]), list(engine_csv.columns)
member0 = curve[curve["member"] == 0].reset_index(drop=True)
for column in engine_csv.columns:
    if column != "snapshot":
        assert (engine_csv[column].to_numpy() == member0[column].to_numpy()).all(), column

# The same numbers as gelctl prints for the job.
gelctl_json = json.loads(subprocess.run([gelctl, "--server", client.address, "--token-file",
                                         os.environ["GELD_TOKEN_FILE"], "curve", small, "--json"],
                                        check=True, capture_output=True, text=True).stdout)
compared = {"phi": "phi [1]", "P": "P [F0/a^2]", "P_top": "P_top [F0/a^2]", "contact_number": "contact_number [1]",
            "stored_energy": "stored_energy [F0 a]", "steps": "steps [count]", "k": "k"}
for member, member_json in enumerate(gelctl_json["members"]):
    table = curve[curve["member"] == member].reset_index(drop=True)
    assert member_json["seed"] == table["seed"][0] and len(member_json["rows"]) == len(table)
    for index, row_json in enumerate(member_json["rows"]):
        for json_key, column in compared.items():
            assert row_json[json_key] == table[column][index], (member, index, json_key, row_json[json_key],
                                                                 table[column][index])
        assert row_json["ruptures"]["normal"] == table["ruptures_normal [count]"][index]
ensemble = client.ensemble_curve(small)
assert list(ensemble["k"]) == [0, 1, 2, 3] and list(ensemble["n"]) == [2] * 4, ensemble
for index, row_json in enumerate(gelctl_json["rows"]):
    assert row_json["P"] == ensemble["P [F0/a^2]"][index] and row_json["P_std"] == ensemble["P_std [F0/a^2]"][index]
assert math.isclose(ensemble["P [F0/a^2]"][3], curve[curve["k"] == 3]["P [F0/a^2]"].mean(), rel_tol=1e-12)

arrays = client.curve_arrays(small)
assert set(arrays) == set(gel.CURVE_COLUMNS) | set(gel.PROFILE_COLUMNS), set(arrays)
assert "sigma_yy_profile [F0/a^2]" in gel.PROFILE_COLUMNS, gel.PROFILE_COLUMNS
assert all(isinstance(a, numpy.ndarray) and len(a) == 8 for a in arrays.values())
for name in gel.PROFILE_COLUMNS:
    assert arrays[name].shape == (8, 20), (name, arrays[name].shape)
# The virial stress beside P: tension positive, so sigma_yy = -P at force balance. These "fast"
# rows are at rest within the equilibrium test's A = 1e-2 (|P_top - P_bot| < A P; measured:
# |sigma_yy + P| <= 2e-3 P with gelsim on quick, seed 1).
loaded = (numpy.abs(arrays["P [F0/a^2]"]) > 1e-4) & (arrays["equilibrated [0/1]"] == 1)
assert loaded.any(), arrays["P [F0/a^2]"]
sigma_yy, pressure = arrays["sigma_yy [F0/a^2]"][loaded], arrays["P [F0/a^2]"][loaded]
assert (numpy.abs(sigma_yy + pressure) <= 1e-2 * pressure).all(), (sigma_yy, pressure)
assert (numpy.abs(arrays["sigma_yy_profile [F0/a^2]"][loaded].mean(axis=1) - sigma_yy) <= 1e-9 * pressure).all()
assert (arrays["P [F0/a^2]"] == curve["P [F0/a^2]"].to_numpy()).all()
print(f"ok: curve {small}: 8 rows, numeric dtypes, curve.csv's header and values, gelctl's numbers")

listed = client.jobs()
assert [j["id"] for j in listed] == [small, blocker], [j["id"] for j in listed]
assert [j["id"] for j in client.jobs(label="suite=python")] == [small]
assert [j["id"] for j in client.jobs(state="cancelled")] == [blocker]
assert isinstance(listed[0]["created_unix_ms"], int) and listed[0]["particles"] == 64, listed[0]
assert isinstance(listed[0]["scene"]["generator"]["seed"], int), listed[0]["scene"]["generator"]
assert any(line["message"] == "member 1 finished with 4 rows" for line in client.logs(small))
print("ok: jobs, logs, cancel")

# GetAnalysis: geld's analysis of the finished 2-seed ensemble; its row means are the means of the
# members' rows from curve(), and a cancelled job has none.
analysis = client.analysis(small)
assert analysis["members"] == 2, analysis["members"]
assert abs(analysis["E0"] - 0.025) < 1e-15, analysis["E0"]
means = client.analysis_rows(small)
members = curve.groupby("member")["P [F0/a^2]"].apply(list)
expected = [(a + b) / 2 for a, b in zip(members[0], members[1])]
assert len(means) == len(expected) == 4, (len(means), expected)
assert all(abs(m - e) <= 1e-12 * max(1.0, abs(e)) for m, e in zip(means["P"], expected)), (list(means["P"]), expected)
assert "P_std" in means.columns and (means["P_std"] >= 0).all()
try:
    client.analysis(blocker)
    raise SystemExit("FAIL: an analysis of a cancelled job")
except gel.GelError as error:
    assert error.code == "FAILED_PRECONDITION", error
print(f"ok: analysis {small}: 2 members, row means equal to the members' mean")

# QueryCurves: two more jobs, other labels and seeds (queued behind each other on the one worker).
small_overrides = {"generator.n_floc": 8, "generator.n_clusters": 8, "generator.lx": 30, "generator.ly": 50,
                   "compression.steps": 3}
query_a = client.submit("quick", seeds=[3], name="query-a", labels={"suite": "query", "which": "a"}, fidelity="fast",
                        overrides=small_overrides)
query_b = client.submit("quick", seeds=[4], name="query-b", labels={"suite": "query", "which": "b"}, fidelity="fast",
                        overrides=small_overrides)
assert len({small, query_a, query_b}) == 3, (small, query_a, query_b)  # not the run cache's answer
for job_id in (query_a, query_b):
    last = list(client.watch(job_id))[-1]
    assert last["type"] == "state" and last["state"] == "succeeded", last

def query_ids(**criteria):
    found = client.query_curves(**criteria)
    for job, table in found:
        assert isinstance(job, dict) and isinstance(table, pandas.DataFrame), (type(job), type(table))
        assert list(table.columns) == list(gel.CURVE_COLUMNS), list(table.columns)
        # A member has rows in the table once it has recorded one: a job cancelled before its
        # first row (the blocker, when the cancel wins the race with row 0) has none.
        assert len(table) == job["rows"] and set(table["seed"]) <= set(job["seeds"]), (job, table[["member", "seed"]])
        assert job["state"] == "cancelled" or set(table["seed"]) == set(job["seeds"]), (job, table[["member", "seed"]])
    return [job["id"] for job, _ in found]

assert query_ids(labels={"suite": "query"}) == [query_b, query_a], query_ids(labels={"suite": "query"})
assert query_ids(labels={"suite": "query", "which": "a"}) == [query_a]
assert query_ids(labels=["suite=query", "which=b"]) == [query_b]
assert query_ids(labels="suite=python") == [small]
assert query_ids(labels={"suite": "none"}) == []
assert query_ids(where=["generator.seed=3"]) == [query_a]
assert query_ids(where="generator.seed=4") == [query_b]
assert query_ids(where=["generator.seed=1"]) == [small]  # any member's seed of the ensemble
assert query_ids(where=["generator.seed>=3"]) == [query_b, query_a]
assert query_ids(where=[("generator.seed", "<=", 3)]) == [query_a, small]
assert query_ids(where=["generator.seed>=2", ("generator.seed", "<=", 3)]) == [query_a, small]
assert query_ids(where=[("generator.lx", "=", 30)]) == [query_b, query_a, small]
assert query_ids(where=["generator.lx>=30.5"]) == []
assert query_ids(where=[("compression.fidelity", "==", "fast")], labels={"which": "b"}) == [query_b]
assert query_ids(bond_preset="bond1", labels={"suite": "query"}) == [query_b, query_a]
assert query_ids(bond_preset="bond2") == []
assert query_ids(limit=2) == [query_b, query_a] and query_ids(limit=1, where=["generator.seed<=3"]) == [query_a]
assert query_ids(state="cancelled") == [blocker]
# gelctl query with the same filters chooses the same jobs.
for gelctl_options, criteria, expected in (
        (["--label", "suite=query", "--where", "generator.seed>=3"],
         {"labels": {"suite": "query"}, "where": ["generator.seed>=3"]}, [query_b, query_a]),
        (["--where", "generator.seed<=3"], {"where": ["generator.seed<=3"]}, [query_a, small])):
    lines = subprocess.run([gelctl, "--server", client.address, "--token-file", os.environ["GELD_TOKEN_FILE"],
                            "query", "--json", *gelctl_options], check=True, capture_output=True, text=True).stdout
    gelctl_ids = [json.loads(line)["job_id"] for line in lines.splitlines() if line.strip()]
    assert gelctl_ids == query_ids(**criteria) == expected, (gelctl_options, gelctl_ids, expected)

frame = client.query_curves_frame(labels={"suite": "query"})
assert list(frame.columns) == ["job_id"] + list(gel.CURVE_COLUMNS), list(frame.columns)
assert len(frame) == 8 and list(frame["job_id"]) == [query_b] * 4 + [query_a] * 4, list(frame["job_id"])
assert list(frame["seed"]) == [4] * 4 + [3] * 4 and list(frame["k"]) == [0, 1, 2, 3] * 2, list(frame["seed"])
assert pandas.api.types.is_integer_dtype(frame["seed"]) and pandas.api.types.is_float_dtype(frame["P [F0/a^2]"])
for job_id in (query_a, query_b):
    own = frame[frame["job_id"] == job_id].drop(columns="job_id").reset_index(drop=True)
    pandas.testing.assert_frame_equal(own, client.curve(job_id))
both = client.query_curves_frame(where=["generator.seed<=3"])
assert list(both["job_id"]) == [query_a] * 4 + [small] * 8 and list(both["seed"]) == [3] * 4 + [1] * 4 + [2] * 4
assert list(both["member"]) == [0] * 8 + [1] * 4, list(both["member"])
none = client.query_curves_frame(bond_preset="bond2")
assert len(none) == 0 and list(none.columns) == list(gel.JOB_CURVE_COLUMNS), none
assert none["seed"].dtype == frame["seed"].dtype and none["P [F0/a^2]"].dtype == frame["P [F0/a^2]"].dtype

# A misspelt field is refused naming it: it used to match no job, an empty table like an answer.
for refused, criteria in ((r"parameters\[0\]\.field", {"where": ["=1"]}),
                          (r"parameters\[1\]\.field", {"where": ["generator.seed=1", ("", "<=", 2)]}),
                          (r"parameters\[0\]\.field: 'generator\.nosuch': no such field \(generator has preset, lx, ",
                           {"where": ["generator.nosuch=1"]}),
                          (r"parameters\[0\]\.field: 'no\.such\.field': no such field", {"where": [("no.such.field", "=", 1)]}),
                          (r"limit", {"limit": -1})):
    for call in (client.query_curves, client.query_curves_frame):
        try:
            call(**criteria)
            raise AssertionError(f"{call.__name__}({criteria}) was accepted")
        except gel.InvalidRequestError as error:
            assert error.code == "INVALID_ARGUMENT" and isinstance(error, ValueError), error
            assert re.match(refused, error.details), error.details
for malformed in ("generator.seed", "generator.lx>=thirty", "generator.lx<=inf", ("generator.lx", ">", 1),
                  ("generator.lx", ">=", "x")):
    try:
        client.query_curves(where=[malformed])
        raise AssertionError(f"where={malformed!r} was accepted")
    except ValueError as error:
        assert not isinstance(error, gel.GelError) and "query_curves: where" in str(error), error
print(f"ok: query_curves {query_a} {query_b}: labels, --where filters, bond preset, state, limit, gelctl's ids, "
      "one DataFrame with job_id; INVALID_ARGUMENT from geld, ValueError for a malformed filter")

# A run-cache hit says so (`cached`) and puts its labels on the job it answers with.
again = client.submit("quick", seeds=[3], name="query-a-again", labels={"asked": "again"}, fidelity="fast",
                      overrides=small_overrides)
assert [job["id"] for job in client.jobs(label="asked=again")] == [query_a], client.jobs(label="asked=again")
assert again == query_a and again.cached is True, (again, getattr(again, "cached", None))
assert query_a.cached is False and query_a == str(query_a), (query_a, query_a.cached)
assert client.job(query_a)["name"] == "query-a", client.job(query_a)  # it had a name: kept
try:
    client.submit("quick", seeds=[3], labels={"which": "b"}, fidelity="fast", overrides=small_overrides)
    raise AssertionError("a cache hit changed the value of a label the job has")
except gel.InvalidRequestError as error:
    assert error.code == "INVALID_ARGUMENT" and "key 'which' is 'a' on " + query_a in error.details, error.details
print(f"ok: a cache hit of {query_a}: cached, its labels added, a conflicting value refused")

configuration = gel.read_configuration(os.path.join(work, "gel.json"))
with open(os.path.join(work, "gel.json"), encoding="utf-8") as config_json:
    as_written = json.load(config_json)
for key in ("x", "y", "theta"):
    assert configuration[key].dtype == numpy.float64 and len(configuration[key]) == 256, key
for key in ("bond_i", "bond_j", "bond_bix", "bond_biy", "bond_bjx", "bond_bjy"):
    assert len(configuration[key]) == 255, (key, len(configuration[key]))
assert configuration["x"][0] == as_written["x"][0] and configuration["bond_j"][-1] == as_written["bond_j"][-1]
assert configuration["lx"] == 60 and configuration["ly"] == 110 and configuration["periodic_y"] is True
assert configuration["seed"] == 2 and configuration["generator"]["seed"] == 2  # int64: a string in the JSON file
assert len(configuration["wall"]) == 0
binary = gel.read_configuration(os.path.join(work, "gel.pb"))
for key, value in configuration.items():
    assert (numpy.array_equal(value, binary[key]) if isinstance(value, numpy.ndarray) else value == binary[key]), key
snapshot = gel.read_configuration(os.path.join(data_dir, job["out_dir"], "m0-seed1", member0["snapshot"][3]))
assert len(snapshot["x"]) == 64 and len(snapshot["wall"]) == 64 and not snapshot["periodic_y"]
assert set(numpy.unique(snapshot["wall"])) <= {0, 1, 2} and snapshot["wall_top"] > snapshot["wall_bottom"]
# A generated gel is at rest (no velocities); a snapshot holds the engine's, one per particle.
assert len(configuration["vx"]) == 0 and len(snapshot["vx"]) == 64 and len(snapshot["omega"]) == 64
print("ok: read_configuration (.json, .pb, a job's snapshot)")

# A job's trajectory: the scene asks for a frame every 20000 steps; gsd.hoomd (Debian's
# python3-gsd) reads the member's DIR/trajectory.gsd, frames in step order, every particle.
try:
    import gsd.hoomd
except ImportError:
    gsd = None
if gsd is not None:
    traced = client.submit("quick", seeds=[9], fidelity="fast", overrides={"output.trajectory_every": 20000,
                                                                           "compression.steps": 2})
    for _ in client.watch(traced):
        pass
    job = client.job(traced)
    assert job["state"] == "succeeded", job
    with gsd.hoomd.open(os.path.join(data_dir, job["out_dir"], "m0-seed9", "trajectory.gsd"), "rb") as trajectory:
        steps = [frame.configuration.step for frame in trajectory]
        assert len(steps) >= 3 and steps == sorted(steps) and steps[0] == 0, steps
        # A frame at the first chunk boundary at or after each multiple of 20000 steps.
        periods = [step // 20000 for step in steps]
        assert periods == sorted(set(periods)), steps
        assert trajectory[0].particles.N == job["particles"], (trajectory[0].particles.N, job["particles"])
    try:
        client.submit("quick", overrides={"output.trajectory_every": 10})
        raise AssertionError("a frame every 10 steps was accepted")
    except gel.InvalidRequestError as error:
        assert "output.trajectory_every" in str(error), error
    print(f"ok: trajectory of {traced}: {len(steps)} frames, read by gsd.hoomd")

for call in (client.curve, client.job, client.cancel, lambda job_id: list(client.watch(job_id))):
    try:
        call("job-999999")
        raise AssertionError(f"{call} of an unknown job succeeded")
    except gel.JobNotFoundError as error:
        assert isinstance(error, LookupError) and error.job_id == "job-999999", error
        assert str(error) == "NOT_FOUND: job job-999999 not found", str(error)
try:
    client.submit("no-such-preset")
    raise AssertionError("an unknown preset was accepted")
except gel.InvalidRequestError as error:
    assert "scene.preset" in str(error), error
# Overrides geld cannot take are said naming the field, not in protobuf's words: a NaN (which
# json.dumps writes as a bare NaN, not JSON) before anything is sent, a misspelt name by geld.
for overrides, refusal in (({"compression.v_wall": float("nan")}, "submit: scene.compression.v_wall: must be a finite number, got nan"),
                           ({"compression.phi_max": numpy.float64("inf")}, "submit: scene.compression.phi_max: must be a finite number"),
                           ({"effects": [1.0, float("-inf")]}, "submit: scene.effects[1]: must be a finite number")):
    try:
        client.submit("quick", overrides=overrides)
        raise AssertionError(f"{overrides} was accepted")
    except ValueError as error:
        assert not isinstance(error, gel.GelError) and str(error).startswith(refusal), error
try:
    client.submit("quick", overrides={"compression.stepz": 4})
    raise AssertionError("compression.stepz was accepted")
except gel.InvalidRequestError as error:
    assert error.details == "scene.compression.stepz: no such field; did you mean 'steps'?", error.details
print("ok: an unknown job id raises JobNotFoundError naming it; a bad preset, a misspelt override InvalidRequestError; "
      "NaN overrides ValueError")

# Studies: two tiny ensembles as one unit, followed to the end, and their analysis with intervals.
tiny = {"preset": "quick", "generator": {"n_floc": 8, "n_clusters": 8, "lx": 30, "ly": 50},
        "compression": {"fidelity": "fast", "steps": 3}}
study_id = client.submit_study(ensembles={"bond1": tiny, "bond2": dict(tiny, bond={"preset": "bond2"})}, seeds=3,
                               name="python-study", rerun=True)
assert study_id.startswith("study-"), study_id
seen = [update for update in client.watch_study(study_id)]
assert "study" in seen[0] and seen[-1]["study"]["state"] == "succeeded", (seen[0], seen[-1])
assert {u["ensemble"] for u in seen if "update" in u and u["update"]["type"] == "row"} == {"bond1", "bond2"}
study = client.study(study_id)
assert study["state"] == "succeeded" and [job["ensemble"] for job in study["jobs"]] == ["bond1", "bond2"], study
assert study_id in [s["id"] for s in client.studies()]
result = client.study_analysis(study_id, bootstrap_samples=100)
assert result["format"] == "gel.study-analysis.v1", result.get("format")
for ensemble in result["ensembles"]:
    assert ensemble["members"] == 3 and ensemble["rows"][-1]["P"]["n"] == 3, ensemble["rows"][-1]
try:
    client.cancel_study(study_id)
    raise SystemExit("FAIL: cancelling a study that has ended")
except gel.GelError as error:
    assert error.code == "FAILED_PRECONDITION", error
print(f"ok: study {study_id}: 2 ensembles x 3 seeds, watched to the end, analysed with intervals")
PY

kill -TERM "$geld_pid"
status=0
wait "$geld_pid" || status=$?
geld_pid=
[ "$status" -eq 0 ] || fail "geld exited $status on SIGTERM"
echo "ok: the Python package against geld on $server"
