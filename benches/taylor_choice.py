"""When ``method="auto"`` picks ``taylor``: the measurements behind its cost model, and whether
its choice is the faster method, model by model and tolerance by tolerance.

For each model and rtol = atol = τ ∈ {1e-6, 1e-9, 1e-12, 1e-15}, through the public Python API
(``model.simulate(q0, qd0, t_end, method=..., rtol=τ, atol=τ, output_every=2**62)``):

- ``dop853``: best of at least 3 runs (more while under 0.3 s), its steps (accepted and
  rejected);
- ``taylor`` as ``auto`` weighs it: best of the runs before the model has expanded 10⁴ times to
  the order (before its expansion is compiled unrolled; ``auto`` never counts on code it has not
  compiled);
- ``taylor`` in its steady state: best of 3 runs once it is compiled unrolled (where the program
  is small enough to be);
- ``auto``'s choice and its estimate of Taylor's cost over DOP853's (from ``stats["choice"]``).

Printed: a Markdown table with the measured ratios taylor ÷ dop853 (before and after the unrolled
code), the estimate, the choice, and whether it was the faster one (before the unrolled code),
then the fit that ``src/integrators/auto.rs`` states: nanoseconds per step of each method
against the programs' sizes (least squares, relative), and DOP853's steps per Taylor step by
tolerance. The timings include the fixed cost of a ``simulate`` call (measured and subtracted
for the per-step fit).

Models: the scenes of ``benches/taylor.py`` (double pendulum, ball in a sphere, forced two-mass,
Kepler e = 0.6, N-pendulum N = 2, 4, 8, 16) and Hénon–Heiles, a charge in a magnetic field and a
harmonic trap (velocity-dependent L), a pendulum on a vertically driven pivot (time-dependent
L) and an elastic pendulum.

Run from the repository root after installing the Python module:

    python3 benches/taylor_choice.py [--models a,b,...] [--json FILE]

About 8 minutes on a 2-core machine. Not a test: timings depend on the machine and its load.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import time
from typing import Any, Callable, Dict, List, Sequence, Tuple

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import lagrangian as lg  # noqa: E402
from taylor import SCENES, Scene, n_pendulum, our_model  # noqa: E402

TOLERANCES = (1e-6, 1e-9, 1e-12, 1e-15)
EVERY = 2**62
UNROLL_AFTER = 10_000  # src/taylor/kernel.rs

Case = Tuple[Any, List[float], List[float], float]

def cases() -> Dict[str, Callable[[], Case]]:
    out: Dict[str, Callable[[], Case]] = {}
    for name, s in SCENES.items():
        out[name] = lambda s=s: (our_model(s), s.q0, s.qd0, s.t_end)
    chain2 = Scene("n_pendulum_2", dict(m=1.0, l=1.0, g=9.81), [1.0, 0.5], [0.0, 0.0], 10.0,
                   n_pendulum)
    out["n_pendulum_2"] = lambda: (our_model(chain2), chain2.q0, chain2.qd0, chain2.t_end)

    def henon_heiles() -> Case:
        x, y = lg.coordinates("x y")
        model = lg.Model(coordinates=[x, y], kinetic=0.5 * (x.d**2 + y.d**2),
                         potential=0.5 * (x**2 + y**2) + x**2 * y - y**3 / 3)
        return model, [0.0, 0.1], [0.49, 0.0], 100.0

    def charge() -> Case:
        x, y = lg.coordinates("x y")
        b, k = lg.parameters("B k")
        model = lg.Model(coordinates=[x, y],
                         kinetic=0.5 * (x.d**2 + y.d**2) + 0.5 * b * (x * y.d - y * x.d),
                         potential=0.5 * k * (x**2 + y**2), parameters={"B": 2.0, "k": 1.0})
        return model, [1.0, 0.0], [0.0, 0.5], 50.0

    def driven_pivot() -> Case:
        th, = lg.coordinates("th")
        a, w, g, l = lg.parameters("a w g l")
        pivot_speed = -a * w * lg.sin(w * lg.t)  # the pivot at height a cos ωt
        T = 0.5 * ((l * lg.cos(th) * th.d) ** 2 + (pivot_speed + l * lg.sin(th) * th.d) ** 2)
        U = g * (a * lg.cos(w * lg.t) - l * lg.cos(th))
        model = lg.Model(coordinates=[th], kinetic=T, potential=U,
                         parameters={"a": 0.1, "w": 5.0, "g": 9.81, "l": 1.0})
        return model, [0.5], [0.0], 20.0

    def elastic_pendulum() -> Case:
        r, ph = lg.coordinates("r ph")
        k, l0, g = lg.parameters("k l0 g")
        model = lg.Model(coordinates=[r, ph], kinetic=0.5 * (r.d**2 + r**2 * ph.d**2),
                         potential=0.5 * k * (r - l0) ** 2 - g * r * lg.cos(ph),
                         parameters={"k": 40.0, "l0": 1.0, "g": 9.81})
        return model, [1.1, 0.6], [0.0, 0.0], 10.0

    out.update(henon_heiles=henon_heiles, charge_in_field=charge, driven_pivot=driven_pivot,
               elastic_pendulum=elastic_pendulum)
    return out

def best(run: Callable[[], Any], at_least: int, seconds: float = 0.3) -> float:
    out, start, n = math.inf, time.perf_counter(), 0
    while n < at_least or (time.perf_counter() - start < seconds and n < 50):
        t0 = time.perf_counter()
        run()
        out = min(out, time.perf_counter() - t0)
        n += 1
    return out

def measure(name: str, case: Case) -> List[Dict[str, Any]]:
    model, q0, qd0, t_end = case
    rows = []
    for tol in TOLERANCES:
        def sim(method: str) -> Any:
            return model.simulate(q0, qd0, t_end, method=method, rtol=tol, atol=tol,
                                  output_every=EVERY)

        auto = sim("auto")
        text = auto.stats["choice"]
        found = re.search(r"estimated at ([0-9.]+) times", text)
        estimate = float(found.group(1)) if found else None
        found = re.search(r"a Taylor step ≈ ([0-9.]+) DOP853 steps' work", text)
        step_estimate = float(found.group(1)) if found else None
        dop = sim("dop853")
        dop_steps = dop.stats["accepted_steps"] + dop.stats["rejected_steps"]
        dop_time = best(lambda: sim("dop853"), 3)
        first = sim("taylor")
        steps = first.stats["accepted_steps"]
        # Before the unrolled code: stop well short of 10⁴ expansions to the order.
        done, cold = steps, math.inf
        while done + steps < 0.9 * UNROLL_AFTER and done < 20 * steps:
            t0 = time.perf_counter()
            sim("taylor")
            cold = min(cold, time.perf_counter() - t0)
            done += steps
        while done <= UNROLL_AFTER:
            sim("taylor")
            done += steps
        warm = best(lambda: sim("taylor"), 3)
        row = dict(model=name, tol=tol, choice=auto.stats["method"], estimate=estimate,
                   step_estimate=step_estimate,
                   dop853_steps=dop_steps, taylor_steps=steps, dop853=dop_time, taylor_cold=cold,
                   taylor_warm=warm, choice_text=auto.stats["choice"])
        print(f"  {name} {tol:.0e}: dop853 {dop_time * 1e3:.3f} ms, taylor {cold * 1e3:.3f} / "
              f"{warm * 1e3:.3f} ms, auto {row['choice']}", file=sys.stderr, flush=True)
        rows.append(row)
    return rows

def fixed_cost() -> float:
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2)
    return best(lambda: model.simulate([1.0], [0.0], 1e-9, method="dop853", output_every=EVERY),
                20)

def table(rows: List[Dict[str, Any]]) -> str:
    lines = ["| model | tol | taylor ÷ dop853 (before / after unrolled) | auto's estimate | "
             "auto | faster? |", "|---|---|---|---|---|---|"]
    for r in rows:
        measured = r["taylor_cold"] / r["dop853"]
        right = (r["choice"] == "taylor") == (measured < 1)
        lines.append(
            f"| {r['model']} | {r['tol']:.0e} | {measured:.2f} / "
            f"{r['taylor_warm'] / r['dop853']:.2f} | "
            f"{'–' if r['estimate'] is None else format(r['estimate'], '.2f')} | {r['choice']} | "
            f"{'yes' if right else 'no'} |")
    return "\n".join(lines)

def fit(rows: List[Dict[str, Any]], fixed: float) -> str:
    """The two halves of auto's estimate against the measurements: DOP853's steps per Taylor
    step by tolerance, and the work of a Taylor step in DOP853 steps (per-step times with the
    fixed cost of a call taken off, Taylor before its unrolled code)."""
    out = ["DOP853 steps per Taylor step, by tolerance (min–max over the models):"]
    for tol in TOLERANCES:
        ratios = [r["dop853_steps"] / r["taylor_steps"] for r in rows if r["tol"] == tol]
        out.append(f"  {tol:.0e}: {min(ratios):.2f}–{max(ratios):.2f} "
                   f"(auto's model: {(1e-9 / tol) ** (1 / 9):.2f})")
    out.append("A Taylor step in DOP853 steps, measured (estimated); ns per step of dop853 / "
               "taylor before the unrolled code / after:")
    for r in rows:
        dop, cold, warm = ((r[k] - fixed) / r[s] * 1e9 for k, s in (
            ("dop853", "dop853_steps"), ("taylor_cold", "taylor_steps"),
            ("taylor_warm", "taylor_steps")))
        est = "–" if r["step_estimate"] is None else f"{r['step_estimate']:.1f}"
        out.append(f"  {r['model']:18s} {r['tol']:.0e}: {cold / dop:5.1f} ({est})   "
                   f"{dop:6.0f} / {cold:6.0f} / {warm:6.0f}")
    return "\n".join(out)

def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", help="comma-separated subset of the models")
    parser.add_argument("--json", help="write the rows to this file")
    args = parser.parse_args()
    chosen = cases()
    if args.models:
        wanted = args.models.split(",")
        unknown = [m for m in wanted if m not in chosen]
        if unknown:
            parser.error(f"unknown models {unknown}; known: {', '.join(chosen)}")
        chosen = {m: chosen[m] for m in wanted}
    fixed = fixed_cost()
    rows: List[Dict[str, Any]] = []
    for name, make in chosen.items():
        rows += measure(name, make())
    print(table(rows))
    print()
    print(f"fixed cost of a simulate call: {fixed * 1e6:.1f} µs")
    print(fit(rows, fixed))
    wrong = [r for r in rows if (r["choice"] == "taylor") != (r["taylor_cold"] < r["dop853"])]
    print(f"auto chose the slower method in {len(wrong)} of {len(rows)} cases" + (
        ": " + ", ".join(f"{r['model']} {r['tol']:.0e} (taylor ÷ dop853 "
                         f"{r['taylor_cold'] / r['dop853']:.2f})" for r in wrong)
        if wrong else ""))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dict(fixed=fixed, rows=rows), f, indent=1)

if __name__ == "__main__":
    main()
