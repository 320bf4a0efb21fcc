#!/usr/bin/env python3
"""The stepping loops against their limits (issue 43): the table of docs/site/integrators.rst.

    python3 benches/loops.py            # runs `cargo bench -p lagrangian-benches --bench loops`
    python3 benches/loops.py --read     # only reads the last run's estimates

Each row is one pair from the same bench run: the limit (ode_solvers' DOP853 or DOPRI5, or RK4
written out by hand) and this crate's loop on the same hand-written right-hand side. "ratio" is
time over the limit's time; "per evaluation" divides each side's time by its own evaluation
count (the two step-size controls take nearly, not exactly, the same steps). Times are the
fastest of 1 500 runs of each side, in blocks of 25 taking turns (the bench's `paired`), which
the other load of a shared machine moves least; criterion's medians follow in a second table. All are read from
$CARGO_TARGET_DIR/criterion (default target/criterion): loops_meta.json and the estimates.
"""
import json
import os
import subprocess
import sys
from pathlib import Path

root = Path(os.environ.get("CARGO_TARGET_DIR", "target")) / "criterion"

if "--read" not in sys.argv:
    bench = subprocess.run(
        ["cargo", "bench", "-p", "lagrangian-benches", "--bench", "loops"],
        capture_output=True,
        text=True,
    )
    if bench.returncode != 0:
        sys.exit(bench.stderr)


def median_ns(group, name):
    path = root / group / name / "new" / "estimates.json"
    return json.loads(path.read_text())["median"]["point_estimate"]


meta = json.loads((root / "loops_meta.json").read_text())
rows = [
    ("DOP853, 1e-6", "loops_dop853_1e-6", "ode_solvers"),
    ("DOP853, 1e-9", "loops_dop853_1e-9", "ode_solvers"),
    ("DOPRI5, 1e-6", "loops_dopri5_1e-6", "ode_solvers"),
    ("DOPRI5, 1e-9", "loops_dopri5_1e-9", "ode_solvers"),
    ("RK4, 1 000 steps", "loops_rk4", "hand"),
    ("Störmer–Verlet, Kepler, 1 000 steps", "loops_stormer_verlet", "hand"),
    ("Yoshida 4, Kepler, 1 000 steps", "loops_yoshida4", "hand"),
]
print("| to t = 10 (double pendulum unless named) | limit | this crate | ratio | per evaluation |")
print("|---|---|---|---|---|")
for label, group, limit in rows:
    t_lim, t_ours = meta[group]["best_ns"][limit], meta[group]["best_ns"]["ours"]
    n_lim, n_ours = meta[group]["rhs"][limit], meta[group]["rhs"]["ours"]
    per = (t_ours / n_ours) / (t_lim / n_lim)
    print(
        f"| {label} | {t_lim / 1e3:.1f} µs, {n_lim} RHS | {t_ours / 1e3:.1f} µs, {n_ours} RHS "
        f"| {t_ours / t_lim:.2f}× | {per:.2f}× |"
    )
print()
print("| criterion's medians | limit | this crate | ratio |")
print("|---|---|---|---|")
for label, group, limit in rows:
    t_lim, t_ours = median_ns(group, limit), median_ns(group, "ours")
    print(f"| {label} | {t_lim / 1e3:.1f} µs | {t_ours / 1e3:.1f} µs | {t_ours / t_lim:.2f}× |")
