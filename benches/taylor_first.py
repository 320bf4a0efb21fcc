"""Time to first result of the Taylor method against heyoka.py, side by side in one run.

For each case (scene of ``benches/taylor.py``, tolerance) and each round, on a new model:

    model       ``lg.Model(...)`` (derivation, and the Cranelift compilation of the accelerations
                the other methods use)
    integrator  ``model.integrator(q0, q̇0, method="taylor", rtol=τ, atol=τ)``
    first run   the first ``ig.propagate_until(t_end)`` and the final state read: it lowers and
                compiles the Taylor recurrences (``SeriesKernel``) and runs
    next runs   runs 2 to 6 of the same integrator (reset to the initial state, not timed), best
                of them: the per-run cost before the unrolled expansion is compiled
    steady      after the model has expanded 10⁴ + 1 times to the run's order (the unrolled
                expansion compiled): best of 20 runs
    compile     the unrolled expansion's compile: the slowest of the runs up to it less the
                fastest; and the expansions that repay it, compile / ((next − steady) / steps)
                (`UNROLL_AFTER` = 10⁴ in src/taylor/kernel.rs is meant to be about this)

heyoka.py: ``taylor_adaptive(heyoka.lagrangian(...), tol=τ)`` built with its caches of compiled
code switched off (build), then ``propagate_until`` after resetting time and state (best of 20:
its steady state; compilation is excluded from it). Printed per case: the medians over the
rounds of each column, and the ratios of our first and next runs to heyoka's steady state.

Run from the repository root with the module installed and heyoka.py in the environment:

    python3 benches/taylor_first.py [--rounds R] [--cases dp12,dp9,forced9]

About a minute with the default 3 rounds. Not a test: timings depend on the machine and its load.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))

import taylor as tb  # noqa: E402  (benches/taylor.py: the scenes and the systems)

CASES = {
    "dp12": ("double_pendulum", 1e-12),
    "dp9": ("double_pendulum", 1e-9),
    "forced9": ("forced_two_mass", 1e-9),
    "forced12": ("forced_two_mass", 1e-12),
}


def ours(scene: tb.Scene, tol: float) -> dict:
    out = {}
    start = time.perf_counter()
    model = tb.our_model(scene)
    out["model"] = time.perf_counter() - start
    start = time.perf_counter()
    ig = model.integrator(scene.q0, scene.qd0, method="taylor", rtol=tol, atol=tol)
    out["integrator"] = time.perf_counter() - start
    start = time.perf_counter()
    ig.propagate_until(scene.t_end)
    ig.q, ig.qd
    out["first"] = time.perf_counter() - start
    steps = int(ig.stats["accepted_steps"])
    out["steps"] = steps
    best = math.inf
    for _ in range(5):
        ig.t, ig.q, ig.qd = 0.0, scene.q0, scene.qd0
        start = time.perf_counter()
        ig.propagate_until(scene.t_end)
        ig.q, ig.qd
        best = min(best, time.perf_counter() - start)
    out["next"] = best
    # Past the unrolled compile at this order (one expansion a step).
    runs = tb.UNROLL_AFTER // max(1, steps) + 2
    times = []
    for _ in range(runs):
        ig.t, ig.q, ig.qd = 0.0, scene.q0, scene.qd0
        start = time.perf_counter()
        ig.propagate_until(scene.t_end)
        times.append(time.perf_counter() - start)
    best = math.inf
    for _ in range(20):
        ig.t, ig.q, ig.qd = 0.0, scene.q0, scene.qd0
        start = time.perf_counter()
        ig.propagate_until(scene.t_end)
        ig.q, ig.qd
        best = min(best, time.perf_counter() - start)
    out["steady"] = best
    # The run that compiled the unrolled expansion, less a run without the compile.
    out["compile"] = max(times) - min(times)
    return out


def heyoka(scene: tb.Scene, tol: float) -> dict:
    import heyoka as hy

    hy.llvm_state.set_memcache_limit(0)
    hy.llvm_state.set_diskcache_enabled(False)
    start = time.perf_counter()
    ta = hy.taylor_adaptive(tb.heyoka_system(scene), scene.x0, tol=tol)
    build = time.perf_counter() - start
    best, first = math.inf, None
    for _ in range(21):
        ta.time = 0.0
        ta.state[:] = scene.x0
        start = time.perf_counter()
        ta.propagate_until(scene.t_end)
        ta.state
        t = time.perf_counter() - start
        first = t if first is None else first
        best = min(best, t)
    return {"build": build, "first": first, "steady": best, "order": ta.order}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--cases", default="dp12,dp9,forced9")
    args = ap.parse_args()
    ms = lambda x: f"{1e3 * x:8.3f}"  # noqa: E731
    print("ms, medians over rounds; ratios to heyoka's steady state")
    print(f"{'case':9} {'model':>8} {'1st run':>8} {'next':>8} {'steady':>8} | "
          f"{'hy build':>8} {'hy 1st':>8} {'hy stdy':>8} | {'1st/hy':>6} {'next/hy':>7} "
          f"{'stdy/hy':>7} steps {'compile':>8} {'repaid':>7}")
    for name in args.cases.split(","):
        scene, tol = tb.SCENES[CASES[name][0]], CASES[name][1]
        rows_o, rows_h = [], []
        for _ in range(args.rounds):  # alternating, so that a change of load hits both
            rows_o.append(ours(scene, tol))
            rows_h.append(heyoka(scene, tol))
        med = lambda rows, k: statistics.median(r[k] for r in rows)  # noqa: E731
        hs = med(rows_h, "steady")
        print(f"{name:9} {ms(med(rows_o, 'model'))} {ms(med(rows_o, 'first'))} "
              f"{ms(med(rows_o, 'next'))} {ms(med(rows_o, 'steady'))} | "
              f"{ms(med(rows_h, 'build'))} {ms(med(rows_h, 'first'))} {ms(hs)} | "
              f"{med(rows_o, 'first') / hs:6.2f} {med(rows_o, 'next') / hs:7.2f} "
              f"{med(rows_o, 'steady') / hs:7.2f} {rows_o[0]['steps']:5} "
              f"{ms(med(rows_o, 'compile'))} "
              f"{med(rows_o, 'compile') / ((med(rows_o, 'next') - med(rows_o, 'steady')) / rows_o[0]['steps']):7.0f}")


if __name__ == "__main__":
    main()
