"""Pinocchio's C++ work in ``aba`` against lagrangian's compiled equations of motion, both without
the Python call around them (the issue's "from Rust against Pinocchio's C++ figure").

Pinocchio has no batch call from Python, so its C++ time is estimated as ``pin.aba``'s time on
the robot less its time on a one-joint arm (the call, argument checks and conversions, and a
one-joint recursion). lagrangian's is the per-state cost of one ``accelerations`` call on 1000
states (the compiled program run 1000 times in Rust, one Python call). Both in one run, in
alternating rounds, medians:

    python benches/robots_cpp_estimate.py      # with ``pip install pin example-robot-data``

Not a test: timings depend on the machine and its load.
"""

import statistics
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

import lagrangian as lg

sys.path.insert(0, str(Path(__file__).parent))
import robots  # noqa: E402


def per_call(f, reps: int) -> float:
    """Microseconds per call of ``f`` over ``reps`` calls."""
    start = time.perf_counter()
    for _ in range(reps):
        f()
    return (time.perf_counter() - start) / reps * 1e6


def main() -> None:
    one = pin.buildModelFromXML(robots.chain_urdf(1))
    one_data = one.createData()
    q1, v1, tau1 = np.zeros(one.nq), np.zeros(one.nv), np.zeros(one.nv)
    print("| robot | pin.aba (μs/call) | one-joint aba call (μs) | ≈ C++ work (μs) "
          "| lagrangian per state, batch of 1000 (μs) | ratio |")
    print("|---|---|---|---|---|---|")
    for name, rel in robots.ROBOTS.items():
        path = str(robots.robots_dir() / rel)
        model = pin.buildModelFromUrdf(path)
        data = model.createData()
        ours = lg.Model.from_urdf(path)
        rng = np.random.default_rng(0)
        q, v = pin.randomConfiguration(model), rng.normal(size=model.nv)
        tau = -np.array(model.damping) * v
        qs, vs = np.tile(q, (1000, 1)), np.tile(v, (1000, 1))
        times: dict = {"aba": [], "call": [], "ours": []}
        for _ in range(7):
            times["aba"].append(per_call(lambda: pin.aba(model, data, q, v, tau), 5000))
            times["call"].append(per_call(lambda: pin.aba(one, one_data, q1, v1, tau1), 5000))
            times["ours"].append(per_call(lambda: ours.accelerations(0.0, qs, vs), 20) / 1000)
        aba, call, mine = (statistics.median(times[k]) for k in ("aba", "call", "ours"))
        work = aba - call
        print(f"| {name} | {aba:.2f} | {call:.2f} | {work:.2f} | {mine:.2f} | {mine / work:.2f} |")


if __name__ == "__main__":
    main()
