#!/usr/bin/python3
"""Convert the output of the paper authors' compression code (ColloidalGelRheology, wall versions
491cca3 or ac47e98) in RUN_DIR into a curve.json shaped like the product's (`gelsim compress` rows).

Reads RUN_DIR/meta.json (from gel_to_reference.py), data_*.dat (one row per accepted
equilibrium), log_*.dat (one row per m_exam interval) and stderr.txt (the code's progress lines
"<interval> <phi>: <target>" and "Equilibrium!", which tie each data row to its log row and
tell whether the wait cap, not the test, ended the wait).

491cca3 writes a data row for the start (k = 0) and no P_top/P_bot columns (P_top and P_bot are
null there; P is the code's 0.5 |P_top - P_bot-sensor| and the log's relative imbalance is kept as
P_imbalance_rel); ac47e98 writes no start row and adds P_top/P_bot.

Row fields: k, target_phi, phi, P, P_top, P_bot, contact_number, equilibrated, ruptures
{normal, sliding, rolling} (the code's own cumulative counters, see the caveat below),
ruptures_processed {normal, reset} (events actually applied), sim_time, intervals_waited.

Caveat (docs/reference_code.md): the code increments rup_* for every bond found over a threshold
at a check, but applies only the most stressed bond of each kind per check, so a bond over
threshold for several checks is counted several times. ruptures_processed is what was applied.
"""
import argparse
import glob
import gzip
import json
import math
import os
import re
import sys

PROGRESS = re.compile(r"^(\d+) (\S+): (\S+)$")


def read_table(path):
    rows = []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            rows.append([float(v) for v in line.split()])
    return rows


def header_value(path, key):
    with open(path) as f:
        for line in f:
            if line.startswith("# " + key + " "):
                return float(line.split()[2])
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run_dir")
    ap.add_argument("--out", help="curve.json path (default RUN_DIR/curve.json)")
    ap.add_argument("--wall-seconds", type=float)
    ap.add_argument("--cpu-seconds", type=float)
    args = ap.parse_args()
    d = args.run_dir
    meta = json.load(open(os.path.join(d, "meta.json")))
    data_path = glob.glob(os.path.join(d, "data_*.dat"))
    log_path = glob.glob(os.path.join(d, "log_*.dat"))
    if len(data_path) != 1 or len(log_path) != 1:
        sys.exit(f"{d}: expected one data_*.dat and one log_*.dat")
    data = read_table(data_path[0])
    log = read_table(log_path[0])
    # Progress: index of each interval's log row, targets, and which rows were accepted.
    intervals = []      # (phi, target) per log row
    accepted = []       # log row index of each equilibrium
    at_target = 0
    waited = []
    stderr_path = os.path.join(d, "stderr.txt")
    if not os.path.exists(stderr_path) and os.path.exists(stderr_path + ".gz"):
        stderr_path += ".gz"
    if os.path.exists(stderr_path):
        opener = gzip.open if stderr_path.endswith(".gz") else open
        with opener(stderr_path, "rt", errors="replace") as f:
            for line in f:
                line = line.strip()
                m = PROGRESS.match(line)
                if m:
                    phi, target = float(m.group(2)), float(m.group(3))
                    intervals.append((phi, target))
                    if phi >= target:
                        at_target += 1
                elif line == "Equilibrium!":
                    accepted.append(len(intervals) - 1)
                    waited.append(at_target)
                    at_target = 0
    max_wait = meta.get("max_wait", 0)
    n = meta["particles"]
    new_format = len(data[0]) >= 17 if data else True     # ac47e98: 17 columns, no k = 0 row
    rows = []
    if new_format:
        rows.append({
            "k": 0, "target_phi": meta["phi0"],
            "phi": header_value(data_path[0], "volume_fraction"),
            "P": 0.0, "P_top": 0.0, "P_bot": 0.0,
            "contact_number": 2.0 * meta.get("bonds_in_gel", 0) / n,
            "equilibrated": True,
            "ruptures": {"normal": 0, "sliding": 0, "rolling": 0},
            "ruptures_processed": {"normal": 0, "reset": 0},
            "sim_time": 0.0,
            "note": "k = 0: ac47e98 writes no row for the start; phi is after its percolation shift, "
                    "P is not measured (set 0), contact number is the product gel's 2 bonds / N",
        })
        eq_rows = data
    else:
        r = data[0]
        rows.append({"k": 0, "target_phi": meta["phi0"], "phi": r[0], "P": r[1], "P_top": None, "P_bot": None,
                     "contact_number": r[13], "equilibrated": True,
                     "ruptures": {"normal": int(r[5]), "sliding": int(r[6]), "rolling": int(r[7])},
                     "ruptures_processed": {"normal": 0, "reset": 0}, "sim_time": 0.0,
                     "note": "k = 0: the code's start row, after its percolation shift"})
        eq_rows = data[1:]
    for k, r in enumerate(eq_rows, start=1):
        row = {
            "k": k,
            "target_phi": meta["targets"][k - 1] if k - 1 < len(meta["targets"]) else None,
            "phi": r[0],
            "contact_number": r[13],
            "ruptures": {"normal": int(r[5]), "sliding": int(r[6]), "rolling": int(r[7])},
        }
        if new_format:
            p_top, p_bot = r[15], -r[16]
            row.update({"P": 0.5 * (p_top + p_bot), "P_code": r[1], "P_top": p_top, "P_bot": p_bot})
        else:
            row.update({"P": r[1], "P_top": None, "P_bot": None})
        if k - 1 < len(accepted) and 0 <= accepted[k - 1] < len(log):
            lr = log[accepted[k - 1]]
            row["sim_time"] = lr[0]
            row["ruptures_processed"] = {"normal": int(lr[17]), "reset": int(lr[16])}
            row["bonds"] = int(lr[18])
            if not new_format:
                row["P_imbalance_rel"] = lr[22]
            row["intervals_waited"] = waited[k - 1]
            # The code takes the row without a test once cnt_relaxation_loop > max_relaxation_loop,
            # i.e. at the (max_wait + 2)-th interval at the target. The progress lines print phi and
            # the target to 6 digits, so the first interval at the target may be miscounted by one:
            # a row that waited more than max_wait intervals is taken as capped.
            row["equilibrated"] = waited[k - 1] <= max_wait
        rows.append(row)
    curve = {
        "name": f"reference-code-{meta.get('code_version', 'ac47e98')}/{'small' if n < 3000 else 'paper'}-bond{meta['bond']}/seed_{meta['seed']}",
        "source": f"ryseto/ColloidalGelRheology {meta.get('code_version', 'ac47e98')} (wall version), via tools/reference_code",
        "particles": n,
        "parameters": {"bond": meta["bond"], "reference_code": meta["params"], "w": meta["w"],
                       "w0": meta["w0"], "dt": meta["dt"], "m_exam": meta["m_exam"]},
        "complete": len(eq_rows) >= len(meta["targets"]),
        "wall_seconds": args.wall_seconds, "cpu_seconds": args.cpu_seconds,
        "rows": rows,
    }
    out = args.out or os.path.join(d, "curve.json")
    with open(out, "w") as f:
        json.dump(curve, f, indent=1)
    print(f"{out}: {len(rows)} rows")


if __name__ == "__main__":
    main()
