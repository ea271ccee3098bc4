#!/usr/bin/env bash
# gelsim export and the run trajectory, read back by the programs users open them with: ASE
# (extended XYZ), gsd.hoomd (GSD) and VTK (VTU), all from Debian's archive. Every number read
# back is compared with the configuration it came from: positions exactly where the format
# keeps doubles (XYZ, VTU, GSD's log/particles/theta) and to float rounding where it keeps
# floats (GSD positions and quaternions).
set -euo pipefail
GELSIM="$1"
PYTHON=/usr/bin/python3  # Debian's interpreter: the readers are its packages
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

# 1. One generated gel (JSON, so the test reads the source numbers directly) in every format.
"$GELSIM" generate --preset quick --seed 5 --out "$WORK/gel.json" > /dev/null
"$GELSIM" export "$WORK/gel.json" --out "$WORK/gel.xyz" > /dev/null 2>&1 || fail "export to xyz"
"$GELSIM" export "$WORK/gel.json" --out "$WORK/gel.gsd" > /dev/null 2>&1 || fail "export to gsd"
"$GELSIM" export "$WORK/gel.json" --out "$WORK/gel.vtu" > /dev/null 2>&1 || fail "export to vtu"

# 2. A short compression with snapshots and a trajectory; its rows exported as GSD, XYZ and a
#    ParaView collection of VTU frames.
"$GELSIM" compress --preset quick --seed 3 --steps 2 --fidelity fast --out "$WORK/run" --trajectory-every 5000 \
  > /dev/null 2> "$WORK/run.log" || fail "compression: $(tail -3 "$WORK/run.log")"
for out in run.gsd run.xyz frames/run.pvd; do
  "$GELSIM" export "$WORK/run" --out "$WORK/$out" > /dev/null 2>&1 || fail "export of the run to $out"
done

# 3. Refusals: several frames into one .vtu, an unknown format, a missing input.
if "$GELSIM" export "$WORK/run" --out "$WORK/many.vtu" > /dev/null 2> "$WORK/err"; then fail "several frames went into one .vtu"; fi
grep -q "pvd" "$WORK/err" || fail "the .vtu refusal does not point at .pvd: $(cat "$WORK/err")"
if "$GELSIM" export "$WORK/gel.json" --out "$WORK/gel.pdb" > /dev/null 2> "$WORK/err"; then fail "an unknown ending was accepted"; fi
if "$GELSIM" export "$WORK/nothing.json" --out "$WORK/x.xyz" > /dev/null 2> "$WORK/err"; then fail "a missing input was accepted"; fi

GEL_VERSION_STRING="$("$GELSIM" --version)" "$PYTHON" - "$WORK" <<'PY' || fail "the readers disagree with the source"
import json, math, os, sys
import numpy as np
import gsd.hoomd
from ase.io import read
import vtk
from vtk.util.numpy_support import vtk_to_numpy

work = sys.argv[1]
gel = json.load(open(os.path.join(work, "gel.json")))
x, y, theta = (np.array(gel[key], dtype=float) for key in ("x", "y", "theta"))
n = len(x)
bonds = np.stack([np.array(gel["bond_i"]), np.array(gel["bond_j"])], axis=1)
lx, ly = float(gel["lx"]), float(gel["ly"])

# ASE, extended XYZ: positions and theta exactly, the cell and the periodicity.
atoms = read(os.path.join(work, "gel.xyz"))
assert len(atoms) == n, len(atoms)
assert np.array_equal(atoms.positions[:, 0], x) and np.array_equal(atoms.positions[:, 1], y), "xyz positions"
assert np.array_equal(atoms.arrays["theta"], theta), "xyz theta"
assert np.allclose(atoms.cell.lengths()[:2], [lx, ly]), atoms.cell
assert atoms.info["bonds"] == len(bonds), atoms.info
# The version string, as in every exported file (README): XYZ in the comment line, VTU and
# the PVD collection in an XML comment, GSD in its header.
version = os.environ["GEL_VERSION_STRING"]
assert atoms.info["program"] == "gelsim " + version, atoms.info
for name in ("gel.vtu", os.path.join("frames", "run.pvd"), os.path.join("frames", "run_00000.vtu")):
    assert '<!-- program="gelsim %s" -->' % version in open(os.path.join(work, name)).read(), name

# gsd.hoomd: a box centred on the origin, float positions, quaternions about z, the bonds.
frame = gsd.hoomd.open(os.path.join(work, "gel.gsd"), "rb")[0]
assert frame.configuration.dimensions == 2
assert np.allclose(frame.configuration.box[:2], [lx, ly])
assert frame.particles.N == n and frame.bonds.N == len(bonds)
pos = frame.particles.position.astype(float)
assert np.allclose(pos[:, 0] + lx / 2, x, atol=1e-4) and np.allclose(pos[:, 1] + ly / 2, y, atol=1e-4), "gsd positions"
q = frame.particles.orientation.astype(float)
assert np.allclose(2 * np.arctan2(q[:, 3], q[:, 0]), np.angle(np.exp(1j * theta)), atol=1e-5) or \
       np.allclose(np.exp(2j * np.arctan2(q[:, 3], q[:, 0])), np.exp(1j * theta), atol=1e-5), "gsd orientation"
assert np.array_equal(frame.log["particles/theta"], theta), "gsd log theta"
assert np.array_equal(frame.bonds.group, bonds), "gsd bonds"
assert np.allclose(frame.particles.diameter, 2.0)

# VTK: a vertex per particle, a line per bond; lines join touching particles (|r| ~ 2a).
reader = vtk.vtkXMLUnstructuredGridReader()
reader.SetFileName(os.path.join(work, "gel.vtu"))
reader.Update()
grid = reader.GetOutput()
assert grid.GetNumberOfCells() == n + len(bonds), grid.GetNumberOfCells()
points = vtk_to_numpy(grid.GetPoints().GetData())
assert np.array_equal(points[:n, 0], x) and np.array_equal(points[:n, 1], y), "vtu positions"
owner = vtk_to_numpy(grid.GetPointData().GetArray("particle"))
ghost = vtk_to_numpy(grid.GetPointData().GetArray("ghost"))
assert np.array_equal(owner[:n], np.arange(n)) and not ghost[:n].any() and ghost[n:].all()
for b in range(len(bonds)):
    ids = grid.GetCell(n + b).GetPointIds()
    i, j = ids.GetId(0), ids.GetId(1)
    assert owner[i] == bonds[b, 0] and owner[j] == bonds[b, 1], (b, i, j)
    length = np.linalg.norm(points[j] - points[i])
    assert 1.8 < length < 2.2, f"bond {b} drawn {length} long"

# The run: one frame per curve row, with its k, phi and P; the trajectory is readable and
# starts at step 0, a frame per 5000 steps, ending at or before the last row's step.
rows = json.load(open(os.path.join(work, "run", "curve.json")))["rows"]
traj = gsd.hoomd.open(os.path.join(work, "run.gsd"), "rb")
assert len(traj) == len(rows), (len(traj), len(rows))
for row, f in zip(rows, traj):
    assert f.log["compression/k"][0] == row["k"] and f.configuration.step == row["steps"]
    assert f.log["compression/phi"][0] == row["phi"] and f.log["compression/P"][0] == row["P"]
    walls = np.bincount(f.particles.typeid, minlength=3)
    assert walls[1] > 0 and walls[2] > 0, walls  # walls stand from row 0 on
frames = read(os.path.join(work, "run.xyz"), index=":")
assert [a.info["k"] for a in frames] == [r["k"] for r in rows]
assert all(a.info["wall_bottom"] < a.info["wall_top"] for a in frames)
pvd = open(os.path.join(work, "frames", "run.pvd")).read()
assert pvd.count("<DataSet") == len(rows), pvd
last = vtk.vtkXMLUnstructuredGridReader()
last.SetFileName(os.path.join(work, "frames", "run_%05d.vtu" % (len(rows) - 1)))
last.Update()
assert last.GetOutput().GetFieldData().GetArray("phi").GetValue(0) == rows[-1]["phi"]
trajectory = gsd.hoomd.open(os.path.join(work, "run", "trajectory.gsd"), "rb")
steps = [int(f.configuration.step) for f in trajectory]
assert steps[0] == 0 and len(steps) >= 3, steps
# A frame at the first chunk boundary at or after every multiple of 5000 steps (chunks are
# shorter than that), so frame i lies in [5000 i, 5000 (i + 1)).
assert [s // 5000 for s in steps] == list(range(len(steps))), steps
assert steps[-1] <= rows[-1]["steps"]
particles = json.load(open(os.path.join(work, "run", "curve.json")))["particles"]
assert all(f.particles.N == particles for f in trajectory)
print(f"ok: {n} particles, {len(bonds)} bonds; run of {len(rows)} rows, trajectory of {len(steps)} frames")
PY
echo "export: ASE, gsd.hoomd and VTK read back every format"
