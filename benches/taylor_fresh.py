"""Fresh Taylor runs as a user meets them, against heyoka.py, side by side in one run.

Issue 51's table: each scene at one tolerance, a new model per round (its build not timed),
then runs as a user makes them — a new ``model.integrator(q0, q̇0, method="taylor", rtol=τ,
atol=τ)`` and its ``propagate_until(t_end)`` with ``ig.q``, ``ig.qd`` read, and
``model.simulate(q0, q̇0, t_end, method="taylor", rtol=τ, atol=τ)`` (every step kept, the
default) — the first of each timed apart (it
compiles the recurrences) and the best of the next ``--calls`` (the model's first runs, before
it has expanded to the run's order often enough to compile the unrolled step on its own).
heyoka.py: ``taylor_adaptive`` (its build, caches of compiled code off, in the last column), ``propagate_until`` after resetting time and
state, best of 20 (its steady state). Printed: ms, medians over the rounds, steps and order of
each side, each side's error at t_end against a reference (ours at 1e-15), and heyoka ÷ ours.

    python3 benches/taylor_fresh.py [--rounds R] [--calls C] [--cases dp6,dp9,...]

Needs heyoka.py and the module installed. About a minute, most of it heyoka's builds (the 8-link
chain's is about 12 s a round). Not a test: timings depend on the machine and its load.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time
from types import SimpleNamespace
from typing import Any, Dict, List, Sequence, Tuple

sys.path.insert(0, os.path.dirname(__file__))
# NumPy's OpenBLAS threads spin after a call (the models' builds make some) and took a seventh of
# the 2-core machine from the runs that followed: one thread, for both sides alike.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import lagrangian as lg  # noqa: E402
import taylor as tb  # noqa: E402  (benches/taylor.py: the scenes and the systems)


def stiff_spring(q: Sequence[Any], v: Sequence[Any], p: Dict[str, Any], f: Any
                 ) -> Tuple[Any, Any]:
    """The stiff spring pendulum of benches/compiled_models.py (k = 1e6, c = 2e4)."""
    r, th = q
    vr, vth = v
    T = 0.5 * p["m"] * (vr**2 + r**2 * vth**2)
    U = 0.5 * p["k"] * (r - p["l0"]) ** 2 - p["m"] * p["g"] * r * f.cos(th)
    return T, U


STIFF = tb.Scene("stiff_spring", dict(m=1.0, k=1e6, l0=1.0, g=9.81, c=2e4),
                 [1.001, 0.5], [0.0, 0.0], 2.0, stiff_spring)
# Rayleigh's dissipation ½ c ṙ² (the radial dashpot).
DISSIPATION = {"stiff_spring": lambda v, p: 0.5 * p["c"] * v[0] ** 2}
SCENES = {**tb.SCENES, "stiff_spring": STIFF}

CASES = {
    "dp6": ("double_pendulum", 1e-6),
    "dp9": ("double_pendulum", 1e-9),
    "forced9": ("forced_two_mass", 1e-9),
    "ball9": ("ball_in_sphere", 1e-9),
    "stiff9": ("stiff_spring", 1e-9),
    "chain8": ("n_pendulum_8", 1e-9),
}


def our_model(s: tb.Scene) -> Any:
    qs = lg.coordinates(" ".join(f"q{i}" for i in range(s.dof)))
    names = list(s.params)
    p = dict(zip(names, lg.parameters(" ".join(names))))
    T, U = s.energy(qs, [q.d for q in qs], p, lg)
    extra: Dict[str, Any] = {}
    if s.forces is not None:
        extra["forces"] = s.forces(p, lg.t, lg)
    if s.name in DISSIPATION:
        extra["dissipation"] = DISSIPATION[s.name]([q.d for q in qs], p)
    return lg.Model(coordinates=list(qs), kinetic=T, potential=U, parameters=dict(s.params),
                    **extra)


def heyoka_system(s: tb.Scene) -> List[Tuple[Any, Any]]:
    import heyoka as hy

    if s.name not in DISSIPATION:
        return tb.heyoka_system(s)
    qs = [hy.make_vars(f"q{i}") for i in range(s.dof)]
    vs = [hy.make_vars(f"v{i}") for i in range(s.dof)]
    T, U = s.energy(qs, vs, s.params, SimpleNamespace(cos=hy.cos, sin=hy.sin))
    return list(hy.lagrangian(T - U, qs, vs, DISSIPATION[s.name](vs, s.params)))


def reference(s: tb.Scene) -> List[float]:
    ig = our_model(s).integrator(s.q0, s.qd0, method="taylor", rtol=1e-15, atol=1e-15)
    ig.propagate_until(s.t_end)
    return list(ig.q) + list(ig.qd)


def ours(s: tb.Scene, tol: float, calls: int) -> Dict[str, Any]:
    model = our_model(s)
    out: Dict[str, Any] = {}

    def integrator() -> Any:
        ig = model.integrator(s.q0, s.qd0, method="taylor", rtol=tol, atol=tol)
        ig.propagate_until(s.t_end)
        ig.q, ig.qd
        return ig

    def simulate() -> Any:
        sol = model.simulate(s.q0, s.qd0, s.t_end, method="taylor", rtol=tol, atol=tol)
        sol.q[-1], sol.qd[-1]
        return sol

    for name, call in (("ig", integrator), ("sim", simulate)):
        times = []
        for _ in range(calls + 1):
            start = time.perf_counter()
            res = call()
            times.append(time.perf_counter() - start)
        out[name + "_first"], out[name] = times[0], min(times[1:])
        if name == "ig":
            out["end"] = list(res.q) + list(res.qd)
            out["steps"] = int(res.stats["accepted_steps"])
            out["order"] = int(res.stats["rhs_evaluations"]) // max(1, out["steps"])
    return out


def heyoka(s: tb.Scene, tol: float) -> Dict[str, Any]:
    import heyoka as hy

    hy.llvm_state.set_memcache_limit(0)  # its build as a new process meets it
    hy.llvm_state.set_diskcache_enabled(False)
    start = time.perf_counter()
    ta = hy.taylor_adaptive(heyoka_system(s), s.x0, tol=tol)
    build = time.perf_counter() - start
    best = math.inf
    for _ in range(20):
        ta.time = 0.0
        ta.state[:] = s.x0
        start = time.perf_counter()
        res = ta.propagate_until(s.t_end)
        ta.state
        best = min(best, time.perf_counter() - start)
    # propagate_until gives (outcome, min h, max h, steps, ...).
    return {"build": build, "steady": best, "order": ta.order, "steps": int(res[3]),
            "end": list(ta.state)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--calls", type=int, default=5)
    ap.add_argument("--cases", default=",".join(CASES))
    args = ap.parse_args()
    ms = lambda x: f"{1e3 * x:7.3f}"  # noqa: E731
    print("ms, medians over rounds; hy = heyoka's steady propagate_until; err vs ours at 1e-15")
    print(f"{'case':8} {'hy':>7} {'ig':>7} {'sim':>7} {'ig 1st':>7} {'sim 1st':>7} | "
          f"{'hy/ig':>5} {'hy/sim':>6} | steps hy/ours, order hy/ours | err hy, ours | hy build")
    for name in args.cases.split(","):
        s, tol = SCENES[CASES[name][0]], CASES[name][1]
        ref = reference(s)
        rows_o, rows_h = [], []
        for _ in range(args.rounds):  # alternating, so that a change of load hits both
            rows_o.append(ours(s, tol, args.calls))
            rows_h.append(heyoka(s, tol))
        med = lambda rows, k: statistics.median(r[k] for r in rows)  # noqa: E731
        hy, ig, sim = med(rows_h, "steady"), med(rows_o, "ig"), med(rows_o, "sim")
        err = lambda end: float(np.max(np.abs(np.subtract(end, ref))  # noqa: E731
                                       / np.maximum(1.0, np.abs(ref))))
        o, h = rows_o[0], rows_h[0]
        print(f"{name:8} {ms(hy)} {ms(ig)} {ms(sim)} {ms(med(rows_o, 'ig_first'))} "
              f"{ms(med(rows_o, 'sim_first'))} | {hy / ig:5.2f} {hy / sim:6.2f} | "
              f"{h['steps']:5}/{o['steps']:<5} {h['order']:2}/{o['order']:<2} | "
              f"{err(h['end']):.1e}, {err(o['end']):.1e} | {med(rows_h, 'build'):.2f} s",
              flush=True)


if __name__ == "__main__":
    main()
