#!/usr/bin/env bash
# Data in and data out as a HOOMD-blue or LAMMPS user meets them (docs/gelsim.md "Data in", "Data out"):
# 1. files written by the real gsd.hoomd and ASE (Debian's python3-gsd and python3-ase) read by
#    gelsim with the values they hold, and what cannot be a flat gel refused naming why;
# 2. a run started from an exported GSD frame is the run started from the snapshot it came from,
#    bit for bit, and one started from a trajectory frame starts from that frame's state;
# 3. the velocities, contact forces and torques and the per-bond state of GSD and VTU, read by
#    gsd.hoomd and VTK, equal to each other exactly and to MODEL.md's bond law computed here.
set -euo pipefail
GELSIM="$1"
PYTHON=/usr/bin/python3
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
cd "$WORK"

# 1. Foreign files: a 2D frame from gsd.hoomd and an extended XYZ file from ASE.
"$PYTHON" - <<'PY' || fail "writing the foreign files"
import warnings
import numpy as np, gsd.hoomd
from ase import Atoms
warnings.simplefilter("ignore", FutureWarning)  # gsd 2.7 compares the type lists with numpy's ==
from ase.io import write

def frame(**change):
    f = gsd.hoomd.Snapshot()
    n = 3
    f.configuration.box = [30, 20, 0, 0, 0, 0]
    f.particles.N = n
    f.particles.types = ["A"]
    f.particles.position = np.array([[-5, -3, 0], [-3, -3, 0], [12.5, 7.25, 0]], dtype=np.float32)
    theta = np.array([0.3, -1.2, 2.9])
    f.particles.orientation = np.stack([np.cos(theta / 2), 0 * theta, 0 * theta, np.sin(theta / 2)], axis=1).astype(np.float32)
    f.particles.diameter = np.full(n, 2.0, dtype=np.float32)
    f.particles.velocity = np.array([[0.5, -0.25, 0], [0, 0, 0], [1e-3, 2e-3, 0]], dtype=np.float32)
    f.particles.moment_inertia = np.array([[0, 0, 0.4]] * n, dtype=np.float32)
    omega = np.array([0.75, 0.0, -2.0])
    lz = 0.4 * omega
    q = f.particles.orientation.astype(float)
    f.particles.angmom = np.stack([-2 * q[:, 3] * lz, 0 * lz, 0 * lz, 2 * q[:, 0] * lz], axis=1).astype(np.float32)
    f.bonds.N = 1
    f.bonds.types = ["b"]
    f.bonds.group = np.array([[0, 1]], dtype=np.uint32)
    for key, value in change.items():
        group, name = key.split("__")
        setattr(getattr(f, group), name, value)
    return f

with gsd.hoomd.open("foreign.gsd", "wb") as t:
    t.append(frame())
    moved = frame()
    moved.particles.position = moved.particles.position + np.array([0.5, 0.5, 0], dtype=np.float32)
    t.append(moved)
bad = {
    # HOOMD-blue 2 kept L_z = 1 in 2D: the dimensions say what the box is.
    "box3d": dict(configuration__box=[30, 20, 10, 0, 0, 0], configuration__dimensions=3),
    "sheared": dict(configuration__box=[30, 20, 0, 0.5, 0, 0]),
    "sigma1": dict(particles__diameter=np.ones(3, dtype=np.float32)),
    "tilted": dict(particles__orientation=np.array([[0.7071, 0.7071, 0, 0]] * 3, dtype=np.float32)),
    "bondrange": dict(bonds__group=np.array([[0, 7]], dtype=np.uint32)),
}
for name, change in bad.items():
    with gsd.hoomd.open(name + ".gsd", "wb") as t:
        t.append(frame(**change))

atoms = Atoms("X3", positions=[[1.25, 2.5, 0], [3.25, 2.5, 0], [17.0, 9.125, 0]], cell=[30, 20, 0], pbc=[True, True, False])
atoms.new_array("theta", np.array([0.1, 0.2, -0.3]))
write("ase.xyz", atoms, format="extxyz")
atoms.pbc = [True, True, True]
atoms.cell = [30, 20, 10]
write("ase3d.xyz", atoms, format="extxyz")
PY

# Read by gelsim, written back as its own GSD, whose exact chunks show what it read.
"$GELSIM" export foreign.gsd --out from_gsd.gsd > /dev/null 2> err || fail "foreign GSD: $(cat err)"
"$GELSIM" export foreign.gsd --frame 0 --out from_gsd0.gsd > /dev/null 2> err || fail "foreign GSD frame 0: $(cat err)"
"$GELSIM" export ase.xyz --out from_xyz.gsd > /dev/null 2> err || fail "ASE's XYZ: $(cat err)"
refused() {  # refused FILE TEXT [ARGS...]: gelsim export refuses FILE with a message holding TEXT
  local file="$1" text="$2"; shift 2
  if "$GELSIM" export "$file" "$@" --out "$WORK/never.gsd" > /dev/null 2> err; then fail "$file was accepted"; fi
  grep -qF -- "$text" err || fail "$file: '$text' not in: $(cat err)"
}
refused box3d.gsd "a 3D box (configuration/dimensions = 3, L_z = 10): gelsim simulates a 2D gel"
refused sheared.gsd "a sheared box (tilt factors xy = 0.5"
refused sigma1.gsd "particle 0 has diameter 1 (the hoomd default: no particles/diameter): gelsim's particles are disks of diameter 2"
refused tilted.gsd "particle 0's orientation"
refused bondrange.gsd "bond 0 joins particles 0 and 7 (there are 3)"
refused foreign.gsd "holds 2 frames (0 to 1, or -1 to -2 from the end): there is no frame 2" --frame 2
refused ase3d.xyz "a 3D box, periodic in z"
"$PYTHON" - <<'PY' || fail "gelsim read other values than gsd.hoomd and ASE wrote"
import numpy as np, gsd.hoomd
from ase.io import read
source = gsd.hoomd.open("foreign.gsd", "rb")
for name, index in (("from_gsd.gsd", 1), ("from_gsd0.gsd", 0)):
    src, got = source[index], gsd.hoomd.open(name, "rb")[0].log
    L = np.array([30.0, 20.0])
    pos = src.particles.position.astype(np.float64)[:, :2] + L / 2   # the centred box, shifted into [0, L)
    assert np.array_equal(got["gel/position"], pos), (got["gel/position"], pos)
    q = src.particles.orientation.astype(np.float64)
    assert np.allclose(got["particles/theta"], 2 * np.arctan2(q[:, 3], q[:, 0]), rtol=0, atol=1e-15)
    v = got["gel/velocity"]
    assert np.array_equal(v[:, :2], src.particles.velocity.astype(np.float64)[:, :2]), v
    a = src.particles.angmom.astype(np.float64)
    inertia = src.particles.moment_inertia.astype(np.float64)[:, 2]
    omega = 0.5 * ((q[:, 0] * a[:, 3] - q[:, 3] * a[:, 0]) / np.sqrt(q[:, 0] ** 2 + q[:, 3] ** 2)) / inertia
    assert np.allclose(v[:, 2], omega, rtol=1e-15, atol=0) and np.allclose(v[:, 2], [0.75, 0, -2], atol=1e-6), v[:, 2]
    assert np.array_equal(got["gel/box"], L) and got["gel/periodic_y"][0] == 1
    f = gsd.hoomd.open(name, "rb")[0]
    assert np.array_equal(f.bonds.group, [[0, 1]])
    # A foreign bond is bonded where the particles stand: contact points along the line of centres.
    assert np.allclose(got["bonds/sliding_displacement"], 0, atol=1e-15) and np.allclose(got["bonds/bending_angle"], 0, atol=1e-15)
ase = read("ase.xyz")
got = gsd.hoomd.open("from_xyz.gsd", "rb")[0].log
assert np.array_equal(got["gel/position"], ase.positions[:, :2]) and np.array_equal(got["particles/theta"], ase.arrays["theta"])
assert np.array_equal(got["gel/box"], [30, 20]) and got["gel/periodic_y"][0] == 1
print("ok: gsd.hoomd's and ASE's files read as written")
PY

# 2. A run; its rows exported as GSD; runs started from a snapshot and from its GSD frame agree
#    bit for bit; a run started from a trajectory frame starts from that frame.
"$GELSIM" compress --preset quick --seed 3 --steps 2 --fidelity fast --out run --trajectory-every 5000 > /dev/null 2> run.log ||
  fail "compression: $(tail -3 run.log)"
"$GELSIM" export run --out run.gsd > /dev/null 2>&1 || fail "export of the run"
"$GELSIM" export run --out frames/run.pvd > /dev/null 2>&1 || fail "export of the run to VTU"
"$GELSIM" compress --gel run/snapshots/k_002.pb --steps 1 --json > from_pb.json 2> err || fail "from the snapshot: $(cat err)"
"$GELSIM" compress --gel run.gsd --gel-frame 2 --steps 1 --json > from_gsd.json 2> err || fail "from the GSD frame: $(cat err)"
"$GELSIM" compress --gel run/trajectory.gsd --steps 1 --out restart > /dev/null 2> err || fail "from the trajectory: $(cat err)"
"$GELSIM" export restart/snapshots/k_000.pb --out restart0.gsd > /dev/null 2>&1 || fail "export of the restart's row 0"
if "$GELSIM" compress --gel run.gsd --gel-frame 7 --steps 1 > /dev/null 2> err; then fail "a frame out of range was accepted"; fi
grep -qF "holds 3 frames (0 to 2, or -1 to -3 from the end): there is no frame 7" err || fail "frame refusal: $(cat err)"

"$PYTHON" - <<'PY' || fail "data out"
import json, numpy as np, gsd.hoomd, vtk
from vtk.util.numpy_support import vtk_to_numpy
# Runs from the snapshot and from its exported GSD frame: the same curve (the clock aside).
a, b = json.load(open("from_pb.json")), json.load(open("from_gsd.json"))
for ra, rb in zip(a["rows"], b["rows"]):
    ra.pop("wall_seconds"); rb.pop("wall_seconds")
assert a == b, "a run from a GSD frame differs from the run from its snapshot"
# A restart from the trajectory's last frame starts from it: its row 0 is that frame.
last = gsd.hoomd.open("run/trajectory.gsd", "rb")[-1]
row0 = gsd.hoomd.open("restart0.gsd", "rb")[0]
for key in ("gel/position", "gel/box", "gel/walls", "bonds/body_contact_i", "bonds/body_contact_j"):
    assert np.array_equal(last.log[key], row0.log[key]), key
assert np.array_equal(last.bonds.group, row0.bonds.group) and np.array_equal(last.particles.typeid, row0.particles.typeid)
# theta: the engine keeps (cos, sin), so theta -> (cos, sin) -> atan2 may move the last bit.
assert np.allclose(last.log["particles/theta"], row0.log["particles/theta"], rtol=0, atol=4e-15)
free = last.particles.typeid == 0
assert np.array_equal(last.log["gel/velocity"][free], row0.log["gel/velocity"][free]), "free particles' velocities"
assert np.abs(last.log["gel/velocity"][free]).max() > 0, "the trajectory frame is at rest: nothing was tested"

# Data out: the run's rows as gsd.hoomd reads them.
law = dict(k_N=20.0, k_S=20.0, k_R=20.0, C=8e4)   # bond 1, MODEL.md
traj = gsd.hoomd.open("run.gsd", "rb")
for index, f in enumerate(traj):
    log = f.log
    n, nb = f.particles.N, f.bonds.N
    v = log["gel/velocity"]
    assert f.particles.velocity.dtype == np.float32 and np.array_equal(f.particles.velocity[:, :2], v[:, :2].astype(np.float32))
    q = f.particles.orientation.astype(np.float64)
    lz = 0.5 * (q[:, 0] * f.particles.angmom[:, 3] - q[:, 3] * f.particles.angmom[:, 0])
    assert np.allclose(lz, 0.4 * v[:, 2], rtol=1e-6, atol=1e-9), "angmom"
    assert np.allclose(f.particles.moment_inertia, [0, 0, 0.4])
    # MODEL.md's bond law, computed here from the exact state.
    x, th = log["gel/position"], log["particles/theta"]
    i, j = f.bonds.group[:, 0], f.bonds.group[:, 1]
    L = log["gel/box"]
    d = x[j] - x[i]
    d[:, 0] -= L[0] * np.round(d[:, 0] / L[0])
    r = np.hypot(d[:, 0], d[:, 1]); nvec = d / r[:, None]; gap = r - 2
    rot = lambda t, b: np.stack([np.cos(t) * b[:, 0] - np.sin(t) * b[:, 1], np.sin(t) * b[:, 0] + np.cos(t) * b[:, 1]], axis=1)
    xi_i, xi_j = rot(th[i], log["bonds/body_contact_i"]), rot(th[j], log["bonds/body_contact_j"])
    u = xi_j - xi_i
    slide = u - (u * nvec).sum(1)[:, None] * nvec
    bend = -np.arcsin(xi_i[:, 0] * xi_j[:, 1] - xi_i[:, 1] * xi_j[:, 0])
    fn = law["k_N"] * gap + law["C"] * np.minimum(gap, 0) ** 3
    tol = dict(rtol=1e-9, atol=1e-12)
    assert np.allclose(log["bonds/gap"], gap, **tol) and np.allclose(log["bonds/contact_i"], xi_i, **tol)
    assert np.allclose(log["bonds/sliding_displacement"], slide, **tol) and np.allclose(log["bonds/bending_angle"], bend, **tol)
    assert np.allclose(log["bonds/normal_force"], fn, **tol), np.abs(log["bonds/normal_force"] - fn).max()
    assert np.allclose(log["bonds/sliding_force"], law["k_S"] * slide, **tol)
    assert np.allclose(log["bonds/rolling_moment"], law["k_R"] * bend, **tol)
    # Contact forces and torques: the bonds' loads; they cancel over the system.
    force = fn[:, None] * nvec + law["k_S"] * slide
    fx = np.zeros((n, 2)); np.add.at(fx, i, force); np.add.at(fx, j, -force)
    ts = nvec[:, 0] * law["k_S"] * slide[:, 1] - nvec[:, 1] * law["k_S"] * slide[:, 0]
    tq = np.zeros(n); np.add.at(tq, i, law["k_R"] * bend + ts); np.add.at(tq, j, -law["k_R"] * bend + ts)
    # Row 0 carries almost no load (forces ~1e-12 F0): the rounding of this recomputation (~1e-15 F0)
    # needs a floor of 1 F0 under the scale.
    scale = max(np.abs(fn).max(), 1.0)
    assert np.allclose(log["particles/forces"][:, :2], fx, rtol=0, atol=1e-9 * scale) and not log["particles/forces"][:, 2].any()
    assert np.allclose(log["particles/torques"][:, 2], tq, rtol=0, atol=1e-9 * scale)
    assert abs(log["particles/forces"][:, 1].sum()) < 1e-9 * scale * n
    # VTK reads the same numbers from the VTU frame: point data per particle, cell data per bond line.
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName("frames/run_%05d.vtu" % index)
    reader.Update()
    grid = reader.GetOutput()
    point = lambda name: vtk_to_numpy(grid.GetPointData().GetArray(name))[:n]
    cell = lambda name: vtk_to_numpy(grid.GetCellData().GetArray(name))[n:]
    assert np.array_equal(point("velocity")[:, :2], v[:, :2]) and np.array_equal(point("angular_velocity"), v[:, 2])
    assert np.array_equal(point("force"), log["particles/forces"]) and np.array_equal(point("torque"), log["particles/torques"][:, 2])
    for name in ("gap", "bending_angle", "normal_force", "rolling_moment"):
        assert np.array_equal(cell(name), log["bonds/" + name]), name
    for name in ("contact_i", "contact_j", "sliding_displacement", "sliding_force"):
        assert np.array_equal(cell(name)[:, :2], log["bonds/" + name]) and not cell(name)[:, 2].any(), name
    assert not vtk_to_numpy(grid.GetCellData().GetArray("normal_force"))[:n].any()
# A trajectory frame carries the run's forces too.
assert np.isfinite(last.log["particles/forces"]).all() and np.isfinite(last.log["bonds/normal_force"]).all()
print(f"ok: {len(traj)} rows; restart from a trajectory frame of {last.particles.N} particles")
PY
# A configuration file without --bond: the geometry of its bonds, forces NaN in GSD and left out of VTU.
"$GELSIM" generate --preset quick --seed 5 --out gel.json > /dev/null
"$GELSIM" export gel.json --out gel.gsd > /dev/null 2>&1 && "$GELSIM" export gel.json --out gel.vtu > /dev/null 2>&1 || fail "export of a gel"
"$PYTHON" - <<'PY' || fail "a gel without its law"
import numpy as np, gsd.hoomd, vtk
log = gsd.hoomd.open("gel.gsd", "rb")[0].log
assert np.isnan(log["bonds/normal_force"]).all() and np.isnan(log["particles/forces"]).all()
assert np.isfinite(log["bonds/bending_angle"]).all()
r = vtk.vtkXMLUnstructuredGridReader(); r.SetFileName("gel.vtu"); r.Update()
assert r.GetOutput().GetCellData().GetArray("normal_force") is None and r.GetOutput().GetCellData().GetArray("gap") is not None
PY
echo "import: gsd.hoomd's and ASE's files read; GSD frames restart runs; GSD and VTU hold the dynamics and the bond state"
