#!/usr/bin/python3
"""Convert a product gel (gel.v1 Configuration JSON from `gelsim generate --out gel.json`) into the
input of the paper authors' 2D compression code (github.com/ryseto/ColloidalGelRheology, a wall
version: commit 491cca3 of 25 Jan 2013, the paper's era, or ac47e98 of 22 Dec 2013, the last one
with walls; see docs/reference_code.md), plus its parameter and bond files.

Writes into OUT_DIR:
  D2W<lx>H<h>_s<seed>.dat  particle centres "x z cluster" (the reference code reads lx and the box
                           height from the D..W..H.._ pattern of this file name)
  p.txt                    run parameters (keys with a trailing colon, "!" ends the file)
  bond.txt                 bond constants (used for both the initial bonds and new bonds)
  meta.json                what the converter did: shift, phi_0, targets, chosen parameters

Only the standard library and numpy. Run with /usr/bin/python3.
"""
import argparse
import json
import math
import os

import numpy as np

# MODEL.md bond presets (a = F0 = m = 1).
BONDS = {
    1: dict(kn=20.0, ks=20.0, kb=20.0, fnc=1.0, fsc=1.0, mbc=1.0, kn3=8e4),
    2: dict(kn=100.0, ks=100.0, kb=20.0, fnc=5.0, fsc=5.0, mbc=1.0, kn3=8e4),
}
# MODEL.md protocol reference values per bond set.
WALL_SPEED_V0 = {1: 5e-4, 2: 1e-4}
B_TOL = {1: 1e-3, 2: 1e-4}


def product_dt(bond, dt_fraction=0.025, inertia=0.4):
    """The product's time step: dt_fraction x the shortest period of one free bond
    (core/src/sim_params.cpp shortest_period)."""
    b = BONDS[bond]
    translational = 2.0 * max(b["kn"], b["ks"])
    rotational = 2.0 * (b["ks"] + b["kb"]) / inertia
    return dt_fraction * 2.0 * math.pi / math.sqrt(max(translational, rotational))


def field(d, snake):
    """gel.v1 JSON may spell fields snake_case or lowerCamelCase."""
    if snake in d:
        return d[snake]
    parts = snake.split("_")
    camel = parts[0] + "".join(p.capitalize() for p in parts[1:])
    return d.get(camel, [])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("gel", help="gel.v1 configuration JSON")
    ap.add_argument("out_dir")
    ap.add_argument("--bond", type=int, choices=(1, 2), required=True)
    ap.add_argument("--seed", type=int, default=0, help="only used in the file name")
    ap.add_argument("--w0", type=float, default=4.0 / 3.0)
    ap.add_argument("--phi-max", type=float, default=0.74)
    ap.add_argument("--steps", type=int, default=17, help="k' (number of targets)")
    ap.add_argument("--wall-speed-v0", type=float, help="v_wall / v0 (default MODEL.md: 5e-4 bond 1, 1e-4 bond 2)")
    ap.add_argument("--dt", type=float, help="dt_max (default: the product's dt, 0.025 x shortest period)")
    ap.add_argument("--m-exam", type=int, default=10000, help="steps of dt_max between equilibrium tests")
    ap.add_argument("--b-tol", type=float, help="relative stress change between tests (default MODEL.md B)")
    ap.add_argument("--code-version", choices=("491cca3", "ac47e98"), default="491cca3",
                    help="491cca3: |P_top-P_bot|/P < A (relative, as published) OR max displacement over the "
                         "interval < eq_max_displacement; ac47e98: |P_top-P_bot| < A_abs (absolute) AND the "
                         "displacement test")
    ap.add_argument("--a-tol", type=float,
                    help="diff_stress_convergence (default: 1e-2 relative for 491cca3, 1e-5 absolute for ac47e98)")
    ap.add_argument("--eq-max-displacement", type=float,
                    help="default: 0 for 491cca3 (the displacement alternative never holds, leaving the "
                         "published A test), 1e9 for ac47e98 (disabled; its built-in '> 1' still applies)")
    ap.add_argument("--max-wait", type=int, default=100,
                    help="max_relaxation_loop: tests at a target before the row is taken anyway "
                         "(100 x m_exam = the product's 1e6-step max_wait_time)")
    ap.add_argument("--relax-for-restructuring", type=int, default=0,
                    help="steps after a rupture during which the walls stop and no thresholds are checked")
    ap.add_argument("--neighbor-interval", type=int, default=20)
    args = ap.parse_args()

    with open(args.gel) as f:
        gel = json.load(f)
    lx = float(gel["lx"])
    ly = float(gel["ly"])
    x = np.asarray(field(gel, "x"), dtype=float)
    y = np.asarray(field(gel, "y"), dtype=float)
    n = len(x)
    if n == 0 or len(y) != n:
        raise SystemExit(f"{args.gel}: no particles read")
    x = np.mod(x, lx)
    # Reference code: walls at z_min - 1 and z_max + 1 (System::setWall); its cell grid covers
    # [0, int(H/2.2)*2.2 + 2.2), so shift the gel to z_min = 1 (the bottom wall at 0).
    zmin, zmax = float(y.min()), float(y.max())
    z = y - zmin + 1.0
    gap = zmax - zmin + 2.0
    h_file = int(math.ceil(gap)) + 1           # integer, at most 3 characters (char[4] in importPositions)
    if h_file > 999 or lx > 999 or lx != int(lx):
        raise SystemExit("box too large or lx not an integer for the reference code's file-name parser")
    # Cluster index column (read and stored, unused by the compression): bonded components.
    bi = np.asarray(field(gel, "bond_i"), dtype=int)
    bj = np.asarray(field(gel, "bond_j"), dtype=int)
    parent = list(range(n))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for i, j in zip(bi, bj):
        ri, rj = find(int(i)), find(int(j))
        if ri != rj:
            parent[ri] = rj
    roots = {}
    cluster = [roots.setdefault(find(i), len(roots)) for i in range(n)]

    os.makedirs(args.out_dir, exist_ok=True)
    conf_name = f"D2W{int(lx)}H{h_file}_s{args.seed}.dat"
    with open(os.path.join(args.out_dir, conf_name), "w") as f:
        for i in range(n):
            f.write(f"{x[i]:.17g} {z[i]:.17g} {cluster[i]}\n")

    bond = BONDS[args.bond]
    with open(os.path.join(args.out_dir, "bond.txt"), "w") as f:
        f.write(f"# MODEL.md bond {args.bond}\n")
        for key in ("kn", "ks", "kb", "fnc", "fsc", "mbc", "kn3"):
            f.write(f"{key}: {bond[key]!r}\n")
        f.write("kt: 1.0\nmtc: 1.0\n!\n")   # torsion: 3D only, must be non-zero (prepareBond divides)

    phi_file = n * math.pi / (lx * h_file)      # the code's volume_fraction_init
    phi0 = n * math.pi / (lx * gap)             # phi at the walls' start (product convention)
    phi1 = args.w0 * phi0
    w = (args.phi_max / phi1) ** (1.0 / (args.steps - 1))
    targets = [phi1 * w ** k for k in range(args.steps)]
    initial_compaction = phi_file / phi1        # System::setFirstTarget: target = phi_init / initial_compaction
    v0 = math.sqrt(bond["kb"])                  # v0 = a sqrt(k_R / m)
    wall_v0 = args.wall_speed_v0 if args.wall_speed_v0 is not None else WALL_SPEED_V0[args.bond]
    dt = args.dt if args.dt is not None else product_dt(args.bond)
    b_tol = args.b_tol if args.b_tol is not None else B_TOL[args.bond]
    a_tol = args.a_tol if args.a_tol is not None else (1e-2 if args.code_version == "491cca3" else 1e-5)
    eq_disp = args.eq_max_displacement if args.eq_max_displacement is not None else \
        (0.0 if args.code_version == "491cca3" else 1e9)
    params = [
        ("bond0_file:", "bond.txt"),
        ("bond1_file:", "bond.txt"),
        ("initial_compaction:", repr(initial_compaction)),
        ("volumefraction_increment:", repr(w)),
        ("max_volume_fraction:", repr(args.phi_max * (1 - 1e-3))),
        ("step_strain_x:", "0.1"),
        ("max_strain_x:", "1"),
        ("wall_velocity:", repr(wall_v0 * v0)),
        ("dt_max:", repr(dt)),
        ("max_move_step:", "1e9"),            # keeps dt = dt_max (fixed step, as the product)
        ("eta_factor:", "0.1"),               # eta = 0.1 * 2 sqrt(k_R m), MODEL.md
        ("relax_for_restructuring:", str(args.relax_for_restructuring)),
        ("interval_convergence_check:", str(args.m_exam)),
        ("interval_makeNeighbor:", str(args.neighbor_interval)),
        ("max_velocity_convergence:", "1e9"),      # not a MODEL.md criterion: disabled
        ("max_ang_velocity_convergence:", "1e9"),  # not a MODEL.md criterion: disabled
        ("diff_stress_convergence:", repr(a_tol)),
        ("stress_change_convergence:", repr(b_tol)),
        ("stress_minimum:", "0"),
        ("min_relaxation_loop:", "0"),
        ("max_relaxation_loop:", str(args.max_wait)),
        ("eq_max_displacement:", repr(eq_disp)),
    ]
    with open(os.path.join(args.out_dir, "p.txt"), "w") as f:
        f.write(f"# written by tools/reference_code/gel_to_reference.py from {os.path.basename(args.gel)}\n")
        for k, v in params:
            f.write(f"{k} {v}\n")
        f.write("!\n")
    meta = {
        "gel": os.path.abspath(args.gel), "bond": args.bond, "seed": args.seed, "particles": n,
        "lx": lx, "ly": ly, "z_shift": 1.0 - zmin, "h_file": h_file, "wall_gap0": gap,
        "phi_file": phi_file, "phi0": phi0, "targets": targets, "w": w, "w0": args.w0,
        "bonds_in_gel": int(len(bi)), "conf": conf_name,
        "params": {k.rstrip(":"): v for k, v in params},
        "code_version": args.code_version, "max_wait": args.max_wait, "m_exam": args.m_exam, "dt": dt,
    }
    with open(os.path.join(args.out_dir, "meta.json"), "w") as f:
        json.dump(meta, f, indent=1)
    print(conf_name)


if __name__ == "__main__":
    main()
