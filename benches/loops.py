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


def python_integrator_rows() -> None:
    """The same double pendulum stated in Python (``lg.Model``, eq. 55 derived and compiled),
    run through ``Model.integrator(...).propagate_until(10)`` as issue 43's first target
    measures it, against the limit of the bench run above (ode_solvers' DOP853 on the
    hand-written right-hand side): the fastest of 1 500 calls, a fresh integrator each."""
    import time

    import lagrangian as lg

    th1, th2 = lg.coordinates("th1 th2")
    m1, m2, l1, l2, g = lg.parameters("m1 m2 l1 l2 g")
    y1 = -l1 * lg.cos(th1)
    y2 = y1 - l2 * lg.cos(th2)
    v1 = (l1 * th1.d) ** 2
    v2 = v1 + (l2 * th2.d) ** 2 + 2 * l1 * l2 * th1.d * th2.d * lg.cos(th1 - th2)
    model = lg.Model([th1, th2], kinetic=0.5 * m1 * v1 + 0.5 * m2 * v2,
                     potential=m1 * g * y1 + m2 * g * y2,
                     parameters=dict(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81))
    print()
    print("| Python `Model.integrator`, dop853, to t = 10 | limit (above) | this crate | ratio |")
    print("|---|---|---|---|")
    for tol in (1e-6, 1e-9):
        best = float("inf")
        for _ in range(1500):
            ig = model.integrator([0.7, -0.4], [0.3, 1.2], method="dop853", rtol=tol, atol=tol)
            start = time.perf_counter_ns()
            ig.propagate_until(10.0)
            best = min(best, time.perf_counter_ns() - start)
        t_lim = meta[f"loops_dop853_{tol:.0e}".replace("e-0", "e-")]["best_ns"]["ode_solvers"]
        print(f"| {tol:g} | {t_lim / 1e3:.1f} µs | {best / 1e3:.1f} µs | {best / t_lim:.2f}× |")


python_integrator_rows()
