"""The cost of events (issue 14): the double pendulum with and without a non-terminal event,
through the public Python API, with SciPy's ``solve_ivp`` and the same event beside it.

The model is the double pendulum stated with ``lg.Model`` (unit masses and lengths, g = 9.81),
released from θ = (1.0, 0.5) at rest and integrated to t = 50 with DOP853 at rtol = atol = 1e-10.
The event is θ₁ = 0 in both directions, non-terminal. Rows:

- ``simulate``: no event, only the final state kept (``output_every``);
- ``simulate, event``: the same with ``events=[lg.Event(th1)]``;
- ``simulate, dense=True``: the continuous solution kept instead (every step's interpolant);
- ``solve_ivp``: SciPy's DOP853 on ``model.rhs`` (the same compiled accelerations), same
  tolerances, without and with the event function ``lambda t, y: y[0]``.

Each is the best of R rounds, the rounds alternating between the rows so that a change in load
hits all of them. The table gives the time per run, each row's ratio to ``simulate`` without
events, and how many crossings each side found and how far apart their times are.

    python3 benches/events.py [--rounds R]

Not a test: timings depend on the machine and its load.
"""

import argparse
import os
import time
from typing import Callable, Dict, List

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import lagrangian as lg  # noqa: E402

T_END = 50.0
TOL = 1e-10
Q0, QD0 = [1.0, 0.5], [0.0, 0.0]


def double_pendulum() -> "tuple[lg.Model, lg.Coordinate]":
    th1, th2 = lg.coordinates("th1 th2")
    g = 9.81
    x1, y1 = lg.sin(th1), -lg.cos(th1)
    x2, y2 = x1 + lg.sin(th2), y1 - lg.cos(th2)
    v1 = th1.d**2
    v2 = th1.d**2 + th2.d**2 + 2 * th1.d * th2.d * lg.cos(th1 - th2)
    model = lg.Model(coordinates=[th1, th2], kinetic=0.5 * v1 + 0.5 * v2, potential=g * (y1 + y2))
    return model, th1


def timed(f: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    model, th1 = double_pendulum()
    event = lg.Event(th1, name="th1 = 0")
    every = 2**62

    def ours() -> object:
        return model.simulate(Q0, QD0, T_END, method="dop853", rtol=TOL, atol=TOL,
                              output_every=every)

    def ours_event() -> object:
        return model.simulate(Q0, QD0, T_END, method="dop853", rtol=TOL, atol=TOL,
                              output_every=every, events=[event])

    def ours_dense() -> object:
        return model.simulate(Q0, QD0, T_END, method="dop853", rtol=TOL, atol=TOL,
                              output_every=every, dense=True)

    rows: Dict[str, Callable[[], object]] = {
        "simulate": ours,
        "simulate, event": ours_event,
        "simulate, dense=True": ours_dense,
    }
    try:
        from scipy.integrate import solve_ivp
    except ImportError:  # pragma: no cover - SciPy is a test dependency
        solve_ivp = None
    if solve_ivp is not None:
        y0 = np.array(Q0 + QD0)

        def crossing(t: float, y: np.ndarray) -> float:
            return float(y[0])

        def scipy_plain() -> object:
            return solve_ivp(model.rhs, (0.0, T_END), y0, method="DOP853", rtol=TOL, atol=TOL)

        def scipy_event() -> object:
            return solve_ivp(model.rhs, (0.0, T_END), y0, method="DOP853", rtol=TOL, atol=TOL,
                             events=[crossing])

        rows["solve_ivp (SciPy DOP853)"] = scipy_plain
        rows["solve_ivp, event"] = scipy_event
    times: Dict[str, List[float]] = {k: [] for k in rows}
    for _ in range(args.rounds):
        for name, f in rows.items():
            times[name].append(timed(f))
    base = min(times["simulate"])
    sol = ours_event()
    ours_t = sol.t_events[0]
    print(f"double pendulum, DOP853, rtol = atol = {TOL:g}, t_end = {T_END:g}, "
          f"best of {args.rounds}")
    print()
    print("| run | time | ÷ simulate | RHS evaluations | crossings |")
    print("|---|---|---|---|---|")
    stats = {
        "simulate": ours().stats["rhs_evaluations"],  # type: ignore[attr-defined]
        "simulate, event": sol.stats["rhs_evaluations"],
        "simulate, dense=True": ours_dense().stats["rhs_evaluations"],  # type: ignore[attr-defined]
    }
    found = {"simulate, event": str(len(ours_t))}
    if solve_ivp is not None:
        ref = scipy_event()
        stats["solve_ivp (SciPy DOP853)"] = scipy_plain().nfev  # type: ignore[attr-defined]
        stats["solve_ivp, event"] = ref.nfev  # type: ignore[attr-defined]
        found["solve_ivp, event"] = str(len(ref.t_events[0]))  # type: ignore[attr-defined]
    for name in rows:
        t = min(times[name])
        print(f"| {name} | {t * 1e3:.2f} ms | {t / base:.2f}× | {stats[name]} | "
              f"{found.get(name, '')} |")
    if solve_ivp is not None:
        theirs = ref.t_events[0]  # type: ignore[attr-defined]
        if len(theirs) == len(ours_t):
            print()
            print(f"largest difference of the crossing times: {np.max(np.abs(theirs - ours_t)):.1e}")


if __name__ == "__main__":
    main()
