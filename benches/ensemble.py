"""Ensembles: ``Model.simulate_many`` against a Python loop over ``simulate``, on 1 and 2
threads and on a Dask LocalCluster (two worker processes, one thread each), for

- 10⁴ double-pendulum runs (the model stated in Python, compiled), t_end = 10, DOP853,
  rtol = atol = 1e-8, initial angles uniform in (−2, 2), at rest; final states only;
- the same with an event (θ₂ falling through zero, every occurrence recorded);
- 10³ runs of a resonance sweep of a forced, damped oscillator m ẍ + c ẋ + k x = F cos ωt,
  ω over (0.5, 4), t_end = 100, DOP853, rtol = 1e-8, atol = 1e-10, 201 output times over
  (80, 100).

Prints a Markdown table: time per run of each, the speedup of 2 threads over 1, and the fixed
cost per run of the ensemble machinery (thread pool task, setup of the run, copying its result
to NumPy, the ``Ensemble``) as a share of the time per run. That fixed cost is measured as the
time per run of the same ensemble over a span of one step, so it is an upper bound (it includes
that step).

Run after ``pip install '.[dask]'``:

    python3 benches/ensemble.py [repeats]

Not a test: timings depend on the machine and its load (printed). Each entry is the best of
``repeats`` rounds (default 3), the rounds alternating between the variants; the Python loop
runs a tenth of the runs, as its time per run does not depend on their number. The Dask column
is measured with the cluster warm; the first call (which also compiles the model on each
worker) is in brackets.
"""

import math
import os
import sys
import time

# numpy's BLAS threads spin while idle and would take a core from the runs being timed.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import lagrangian as lg  # noqa: E402


def double_pendulum():
    th1, th2 = lg.coordinates("th1 th2")
    m, l, g = lg.parameters("m l g")
    T = 0.5 * m * l**2 * (2 * th1.d**2 + th2.d**2 + 2 * th1.d * th2.d * lg.cos(th1 - th2))
    U = -m * g * l * (2 * lg.cos(th1) + lg.cos(th2))
    return lg.Model(coordinates=[th1, th2], kinetic=T, potential=U,
                    parameters={"m": 1.0, "l": 1.0, "g": 9.81})


def forced_oscillator():
    x, = lg.coordinates("x")
    m, k, c, f, w = lg.parameters("m k c F w")
    return lg.Model(coordinates=[x], kinetic=0.5 * m * x.d**2, potential=0.5 * k * x**2,
                    dissipation=0.5 * c * x.d**2, forces=[f * lg.cos(w * lg.t)],
                    parameters={"m": 1.0, "k": 4.0, "c": 0.4, "F": 1.0, "w": 1.0})


def cases():
    """(name, model, q0, qd0, t_end, ensemble kwargs, loop kwargs, one-step t_end) per case."""
    rng = np.random.default_rng(15)
    k = 10_000
    q0 = rng.uniform(-2.0, 2.0, (k, 2))
    dp = dict(method="dop853", rtol=1e-8, atol=1e-8)
    model = double_pendulum()
    yield ("double pendulum, 10⁴ runs", model, q0, np.zeros((k, 2)), 10.0, {},
           dict(dp, final_only=True), dict(dp, output_every=10**9), 1e-6)
    th1, th2 = model.coordinates
    event = [lg.Event(th2, direction=-1, name="th2 falls through 0")]
    yield ("the same with an event", model, q0, np.zeros((k, 2)), 10.0, {},
           dict(dp, final_only=True, events=event), dict(dp, output_every=10**9, events=event),
           1e-6)
    w = np.linspace(0.5, 4.0, 1000)
    t = np.linspace(80.0, 100.0, 201)
    fo = dict(method="dop853", rtol=1e-8, atol=1e-10)
    yield ("forced oscillator sweep, 10³ runs", forced_oscillator(), np.zeros((1000, 1)),
           np.zeros((1000, 1)), 100.0, {"w": w}, dict(fo, t_eval=t), dict(fo, t_eval=t), None)


def best(repeats, f):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    import distributed

    print(f"load average before: {os.getloadavg()[0]:.2f} (cores: {os.cpu_count()})\n")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=None, timeout=120)
    client = distributed.Client(cluster, timeout=120)
    rows = []
    try:
        for name, model, q0, qd0, t_end, sweep, many, loop, one_step in cases():
            k = len(q0)

            def ensemble(workers, span=t_end, **extra):
                kw = dict(many)
                if span != t_end and "t_eval" in kw:
                    kw["t_eval"] = np.linspace(0.0, span, len(kw["t_eval"]))
                return model.simulate_many(q0, qd0, span, parameters=sweep or None,
                                           workers=workers, **kw, **extra)

            def python_loop():
                for i in range(0, k, 10):
                    m = model.with_parameters(**{p: v[i] for p, v in sweep.items()})
                    m.simulate(q0[i], qd0[i], t_end, **loop)

            ens = ensemble(1)
            assert ens.ok.all()
            steps = float(np.mean(ens.stats["accepted_steps"]))
            start = time.perf_counter()
            ensemble(None, executor=client, timeout=600)
            cold = (time.perf_counter() - start) / k
            # Rounds alternate between the variants, so that a change in load hits all of them.
            timed = {
                "loop": (python_loop, k // 10),
                "1": (lambda: ensemble(1), k),
                "2": (lambda: ensemble(2), k),
                "fixed": (lambda: ensemble(1, span=one_step or 1e-6), k),
                "dask": (lambda: ensemble(None, executor=client, timeout=600), k),
            }
            per_run = {key: math.inf for key in timed}
            for _ in range(repeats):
                for key, (f, runs) in timed.items():
                    per_run[key] = min(per_run[key], best(1, f) / runs)
            rows.append((name, steps, per_run["loop"], per_run["1"], per_run["2"],
                         per_run["fixed"], per_run["dask"], cold))
    finally:
        client.close(timeout=60)
        cluster.close(timeout=60)
    print("| ensemble | steps per run | Python loop over `simulate` | `simulate_many`, 1 thread "
          "| 2 threads (speedup) | fixed cost per run | Dask LocalCluster, 2 processes "
          "(first call) |")
    print("|---|---|---|---|---|---|---|")
    for name, steps, t_loop, t1, t2, fixed, t_dask, cold in rows:
        us = lambda s: f"{s * 1e6:.0f} µs"  # noqa: E731
        print(f"| {name} | {steps:.0f} | {us(t_loop)} | {us(t1)} ({t_loop / t1:.2f}× the loop) "
              f"| {us(t2)} ({t1 / t2:.2f}×) | {us(fixed)} ({100 * fixed / t1:.1f} %) "
              f"| {us(t_dask)} ({us(cold)}) |")
    print(f"\nload average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
