"""A ready-made scene against the same system stated by hand: the N-link pendulum of
``lg.scenes.n_pendulum`` and the chain written with ``lg.Model`` (T and U as expressions), DOP853
at rtol = atol = 1e-8, every object made fresh inside the timing (the stated model's build and the
scene's trace and compile included), to t = 1 and t = 10, for N = 8, 16, 32.

The scene runs twice: held on the Rust route (``LAGRANGIAN_SCENE_PATH=rust``: every release
before the fast path) and as it now chooses (the Rust route, then the traced program once the
run has spent what compiling costs; ``stats["scene_path"]`` says which). Prints a Markdown table
of the best wall times and the ratios to the stated model.

Run after ``pip install .``:

    python3 benches/scene_fast_path.py [rounds]

Not a test: timings depend on the machine and its load. Each round times the three in turn, so
that a change in load hits all of them.
"""

import os
import sys
import time
from typing import Any, Callable, Dict, List

# numpy's BLAS threads spin while idle and would take a core from the runs being timed.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import lagrangian as lg  # noqa: E402

G = 9.81
RUN = dict(method="dop853", rtol=1e-8, atol=1e-8)


def stated(n: int) -> lg.Model:
    """The chain of n unit links and masses by hand: bob j at Σ_{k≤j} (sin θ_k, −cos θ_k)."""
    th = lg.coordinates(" ".join(f"th{i}" for i in range(n)))
    vx: Any = 0.0
    vy: Any = 0.0
    y: Any = 0.0
    T: Any = 0.0
    U: Any = 0.0
    for q in th:
        vx, vy = vx + lg.cos(q) * q.d, vy + lg.sin(q) * q.d
        y = y - lg.cos(q)
        T = T + 0.5 * (vx**2 + vy**2)
        U = U + G * y
    return lg.Model(coordinates=list(th), kinetic=T, potential=U)


def scene(n: int) -> lg.Model:
    return lg.scenes.n_pendulum(masses=[1.0] * n, lengths=[1.0] * n, g=G)


def timed(make: Callable[[], lg.Model], n: int, t_end: float, path: str) -> Dict[str, Any]:
    """One fresh model built and run; the wall time and the scene's route."""
    os.environ["LAGRANGIAN_SCENE_PATH"] = path
    start = time.perf_counter()
    sol = make().simulate([0.5] * n, [0.0] * n, t_end, **RUN)
    wall = time.perf_counter() - start
    return {"wall": wall, "path": sol.stats.get("scene_path", ""), "q": sol.q[-1]}


def main() -> None:
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    for n in (8, 16, 32):
        a, b = scene(n), stated(n)
        q, qd = np.linspace(0.1, 0.6, n), np.linspace(-0.2, 0.3, n)
        gap = np.max(np.abs(a.accelerations(0.0, q, qd) - b.accelerations(0.0, q, qd)))
        assert gap < 1e-9, f"the stated chain is not the scene's: q̈ differ by {gap:.1e}"
    print(f"N-link pendulum, DOP853 at 1e-8, q0 = 0.5, q̇0 = 0, fresh objects, best of {rounds}\n")
    print("| N | t_end | scene, Rust route (before) | scene, as chosen (after) | stated `lg.Model` "
          "| before / stated | after / stated | after's route |")
    print("|---|---|---|---|---|---|---|---|")
    for n in (8, 16, 32):
        for t_end in (1.0, 10.0):
            runs: Dict[str, List[Dict[str, Any]]] = {"before": [], "after": [], "stated": []}
            for _ in range(rounds):
                runs["before"].append(timed(lambda: scene(n), n, t_end, "rust"))
                runs["after"].append(timed(lambda: scene(n), n, t_end, ""))
                runs["stated"].append(timed(lambda: stated(n), n, t_end, ""))
            best = {k: min(r["wall"] for r in v) for k, v in runs.items()}
            route = runs["after"][-1]["path"].split(":")[0]
            print(f"| {n} | {t_end:g} | {best['before'] * 1e3:.1f} ms | {best['after'] * 1e3:.1f} ms "
                  f"| {best['stated'] * 1e3:.1f} ms | {best['before'] / best['stated']:.2f} "
                  f"| {best['after'] / best['stated']:.2f} | {route} |", flush=True)
    os.environ.pop("LAGRANGIAN_SCENE_PATH")


if __name__ == "__main__":
    main()
