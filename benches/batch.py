"""Ensemble throughput per core: our Taylor runs in SIMD lanes against one run per task, our
DOP853, and heyoka.py's scalar, batch (SIMD) and threaded ensemble modes (issue 43).

The ensemble
    2000 double pendulums (unit masses and lengths, g = 9.81; the model stated in Python, T and
    U as in ``benches/ensemble.py``), initial angles uniform in (−2, 2) from
    ``np.random.default_rng(15)``, at rest, to t = 10, rtol = atol = τ (heyoka's tol = τ) for
    each τ of ``--tol``; final states only.

Variants
    ours, taylor lanes        ``model.simulate_many(q0, qd0, 10, method="taylor", rtol=τ,
                              atol=τ, final_only=True, workers=1)``: final-only Taylor runs go
                              through SIMD lanes (16 runs at once per thread).
    ours, taylor per task     the same keeping every step instead of ``final_only`` (the lanes
                              take final states and states at times only): one run per task, no
                              lanes; each run's last row read (keeping the ≈ 340 rows of a run
                              is part of its time).
    ours, dop853              ``method="dop853"``, final_only, workers=1.
    ours, taylor lanes, 2 w.  the lanes with ``workers=2``: 2 cores.
    heyoka scalar             one ``taylor_adaptive``, a Python loop over the runs setting
                              ``ta.time = 0`` and ``ta.state`` then ``ta.propagate_until(10)``.
    heyoka batch              ``taylor_adaptive_batch`` of batch size
                              ``hy.recommended_simd_size()``, a Python loop over chunks of runs.
    heyoka ensemble           ``hy.ensemble_propagate_until_batch`` on that batch integrator
                              (a thread pool with its default size; it copies the integrator
                              for each chunk, and that copy is in the time).

Printed: a Markdown table per τ with the wall time per run, the core-seconds per 1000 runs (wall
time × cores used: 2 for ``workers=2``, the cores of the machine for heyoka's thread pool) and
heyoka batch's core-seconds over the variant's (> 1: the variant does more runs per core than
heyoka's batch mode); the speedup of 2 workers over 1; heyoka's build times (LLVM compile of
``taylor_adaptive`` and ``taylor_adaptive_batch``, with heyoka's in-memory and on-disk caches of
compiled code switched off so that every build is a real one; not in the timings) and the time
of one copy of the batch integrator (the ensemble makes one per chunk); the agreement of end
states with heyoka scalar's (max and median over the runs of max |difference|: the double
pendulum is chaotic from these angles, so a few runs differ by far more than the tolerance),
and whether our lanes give the same end states bit for bit as our runs one per task and as
``workers=2`` (they should).

Run from the repository root after installing the Python module, in an environment with
heyoka.py:

    python3 benches/batch.py [--rounds R] [--tol 1e-9,1e-12]

Not a test: timings depend on the machine and its load (printed). Each entry is the best of R
rounds (default 5), the rounds alternating between the variants so that a change of load hits
all of them; every variant runs once before the rounds (warm-up).
"""

import argparse
import copy
import os
import time
from typing import Callable, Dict, Tuple

# numpy's BLAS threads spin while idle and would take a core from the runs being timed.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import lagrangian as lg  # noqa: E402

RUNS = 2000
T_END = 10.0


def double_pendulum() -> lg.Model:
    th1, th2 = lg.coordinates("th1 th2")
    m, l, g = lg.parameters("m l g")
    T = 0.5 * m * l**2 * (2 * th1.d**2 + th2.d**2 + 2 * th1.d * th2.d * lg.cos(th1 - th2))
    U = -m * g * l * (2 * lg.cos(th1) + lg.cos(th2))
    return lg.Model(coordinates=[th1, th2], kinetic=T, potential=U,
                    parameters={"m": 1.0, "l": 1.0, "g": 9.81})


def heyoka_system(hy):
    q = list(hy.make_vars("th1", "th2"))
    v = list(hy.make_vars("w1", "w2"))
    T = 0.5 * (2 * v[0] ** 2 + v[1] ** 2 + 2 * v[0] * v[1] * hy.cos(q[0] - q[1]))
    U = -9.81 * (2 * hy.cos(q[0]) + hy.cos(q[1]))
    return hy.lagrangian(T - U, q, v)


def timed(f: Callable[[], object]) -> Tuple[float, object]:
    start = time.perf_counter()
    out = f()
    return time.perf_counter() - start, out


def variants(hy, model: lg.Model, q0: np.ndarray, tol: float
             ) -> Tuple[Dict[str, Tuple[Callable[[], np.ndarray], int]], Dict[str, float]]:
    """{name: (run returning the (RUNS, 4) end states, cores used)}, heyoka's build times."""
    qd0 = np.zeros_like(q0)
    builds = {}
    builds["build of taylor_adaptive"], ta = timed(
        lambda: hy.taylor_adaptive(heyoka_system(hy), [0.0] * 4, tol=tol))
    b = hy.recommended_simd_size()
    builds[f"build of taylor_adaptive_batch ({b} lanes)"], tb = timed(
        lambda: hy.taylor_adaptive_batch(heyoka_system(hy), np.zeros((4, b)), tol=tol))
    chunks = -(-RUNS // b)
    # Initial states of the chunks, (chunks, 4, b); the last chunk padded with its last run.
    padded = np.concatenate([q0, np.repeat(q0[-1:], chunks * b - RUNS, axis=0)])
    x0 = np.zeros((chunks, 4, b))
    x0[:, :2, :] = padded.reshape(chunks, b, 2).transpose(0, 2, 1)

    def ours(method: str, **kw) -> Callable[[], np.ndarray]:
        kw.setdefault("final_only", True)

        def run() -> np.ndarray:
            e = model.simulate_many(q0, qd0, T_END, method=method, rtol=tol, atol=tol, **kw)
            assert e.ok.all()
            if isinstance(e.q, list):  # every step kept: one array per run
                q, qd = np.array([q[-1] for q in e.q]), np.array([v[-1] for v in e.qd])
            else:
                q, qd = (e.q, e.qd) if e.q.ndim == 2 else (e.q[:, -1], e.qd[:, -1])
            return np.hstack([q, qd])
        return run

    def heyoka_scalar() -> np.ndarray:
        out = np.empty((RUNS, 4))
        for i in range(RUNS):
            ta.time = 0.0
            ta.state[:] = (q0[i, 0], q0[i, 1], 0.0, 0.0)
            ta.propagate_until(T_END)
            out[i] = ta.state
        return out

    def heyoka_batch() -> np.ndarray:
        out = np.empty((chunks * b, 4))
        for c in range(chunks):
            tb.set_time(0.0)
            tb.state[:] = x0[c]
            tb.propagate_until(T_END)
            out[c * b:(c + 1) * b] = tb.state.T
        return out[:RUNS]

    def gen(local, c):
        local.set_time(0.0)
        local.state[:] = x0[c]
        return local

    def heyoka_ensemble() -> np.ndarray:
        res = hy.ensemble_propagate_until_batch(tb, T_END, chunks, gen)
        return np.concatenate([r[0].state.T for r in res])[:RUNS]

    # ThreadPoolExecutor's default size, min(32, cores + 4): all the cores.
    cores = os.cpu_count() or 1
    builds["copy of the batch integrator (ensemble, per chunk; timed with it)"] = min(
        timed(lambda: copy.deepcopy(tb))[0] for _ in range(20))
    return {
        "ours, taylor lanes": (ours("taylor", workers=1), 1),
        "ours, taylor one run per task": (
            ours("taylor", workers=1, final_only=False), 1),
        "ours, dop853": (ours("dop853", workers=1), 1),
        "ours, taylor lanes, workers=2": (ours("taylor", workers=2), 2),
        "heyoka scalar loop": (heyoka_scalar, 1),
        f"heyoka batch loop ({b} lanes)": (heyoka_batch, 1),
        f"heyoka ensemble_propagate_until_batch ({cores} threads)": (heyoka_ensemble, cores),
    }, builds


def bench(hy, model: lg.Model, q0: np.ndarray, tol: float, rounds: int) -> None:
    runs, builds = variants(hy, model, q0, tol)
    finals = {name: f() for name, (f, _) in runs.items()}  # warm-up, and the end states
    best = {name: np.inf for name in runs}
    for _ in range(rounds):
        for name, (f, _) in runs.items():
            best[name] = min(best[name], timed(f)[0])

    ref = next(name for name in runs if name.startswith("heyoka batch"))
    ref_core = best[ref] * runs[ref][1]
    print(f"\n### tol = {tol:g} ({RUNS} runs to t = {T_END:g}, best of {rounds})\n")
    print("| variant | cores | time per run (µs) | core-seconds per 1000 runs "
          "| heyoka batch ÷ this, per core |")
    print("|---|---|---|---|---|")
    for name, (_, cores) in runs.items():
        core = best[name] * cores
        print(f"| {name} | {cores} | {best[name] / RUNS * 1e6:.1f} "
              f"| {core / RUNS * 1e3:.3f} | {ref_core / core:.2f} |")

    one, two = best["ours, taylor lanes"], best["ours, taylor lanes, workers=2"]
    print(f"\nspeedup of workers=2 over workers=1 (taylor lanes): {one / two:.2f}×")
    for name, seconds in builds.items():
        took = f"{seconds:.2f} s" if seconds >= 0.1 else f"{seconds * 1e3:.2f} ms"
        print(f"heyoka, {name}: {took}")
    lanes = finals["ours, taylor lanes"]
    heyoka = finals["heyoka scalar loop"]
    for name in ("ours, taylor lanes", "ours, dop853", ref):
        diff = np.abs(finals[name] - heyoka).max(axis=1)
        print(f"|end state − heyoka scalar's|, {name}: max {diff.max():.2e}, "
              f"median over the runs {np.median(diff):.2e}")
    print("ours, taylor lanes bit-identical to one run per task: "
          f"{np.array_equal(lanes, finals['ours, taylor one run per task'])}")
    print("ours, taylor lanes bit-identical with workers=2: "
          f"{np.array_equal(lanes, finals['ours, taylor lanes, workers=2'])}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--tol", default="1e-9,1e-12",
                        help="comma-separated tolerances (rtol = atol = tol)")
    args = parser.parse_args()
    import heyoka as hy

    # Every build a real one: no compiled code from heyoka's caches in memory or on disk.
    hy.llvm_state.set_memcache_limit(0)
    hy.llvm_state.set_diskcache_enabled(False)
    print(f"load average before: {os.getloadavg()[0]:.2f} (cores: {os.cpu_count()}), "
          f"heyoka.py {hy.__version__}")
    q0 = np.random.default_rng(15).uniform(-2.0, 2.0, (RUNS, 2))
    model = double_pendulum()
    for tol in (float(s) for s in args.tol.split(",")):
        bench(hy, model, q0, tol, args.rounds)
    print(f"\nload average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
