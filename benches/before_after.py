"""Before and after, side by side (issue 49: "no benchmark ratio worse than before"): the same
timing probes through the public Python API in two interpreters, each with its own build of
``lagrangian`` installed, in one run on one machine.

    python3 benches/before_after.py --before /work/venvs/before/bin/python \\
        --after /work/venvs/after/bin/python [--rounds 5] [--target 0.3] [--probes a,b,...] \\
        [--json FILE]

The two sides: each a release wheel (plain ``pip install .``, the profile the benchmarks
measure) in its own venv made with ``--system-site-packages``, e.g. for AFTER from its tree:
``CARGO_TARGET_DIR=/work/targets/after /work/venvs/after/bin/pip install .`` (a copy of
BEFORE's target directory as a warm start; the fat-LTO build takes 10–30 minutes on the shared
2-core machine). The workers import ``lagrangian`` with ``PYTHONPATH`` cleared and from ``/``,
so each side loads its venv's install; the first lines printed say from where.

How it measures
    Each round starts one worker process per interpreter (this file with ``--worker``); each
    builds every probe's model once and warms it up (the Taylor programs past the 10⁴
    expansions after which their expansion is compiled unrolled, ``UNROLL_AFTER`` in
    src/taylor/kernel.rs), so a round times steady-state work, not set-up (the ``build`` and
    ``taylor first`` probes time set-up on purpose, on a new model each call). Only one worker
    runs at a time: the other waits on its pipe. A probe's turn on one side is ``--reps``
    timings (best of) of ``n`` units of work each, ``n`` calibrated once on BEFORE so that a
    turn takes about ``--target`` CPU seconds, and the same on both sides. Within a round the
    probes alternate which side goes first (ABBA), so a change of load hits both; new workers
    each round, because a process carries a bias of its own through its life (where its code
    and data landed, the CPU it is kept on: one pair of long-lived workers of the same build
    once gave 1.21 on one probe with spreads of 1–4 %). The clock is the worker's CPU time
    (``time.process_time``): on the shared 2-core machine under load the wall time mostly
    measures the scheduler; the wall time's ratio is printed beside it. Printed per probe: the
    best per unit on each side over the rounds, after ÷ before (> 1: after is slower), each
    side's spread (median ÷ best − 1 over the rounds) and the accepted steps on each side (a
    ratio that moves with the steps is a change of numerics, not of speed).

Noise (the BEFORE build against itself, defaults, load average 6 on the 2 cores): every CPU
ratio within 0.96–1.07 (geometric mean 1.02); with ``--cpu 1`` 0.92–1.05 (0.99); the wall
ratios 0.69–1.61. Read a ratio above about 1.10 (flagged **) as a lead, and rerun it with
``--probes`` and more ``--rounds`` before believing it.

Probes (the double pendulum unless said; q0 = (1, 0.5), q̇0 = 0; rtol = atol where one number)
    build            ``lg.Model(...)`` of the double pendulum from its expressions (derivation and
                     compilation of the accelerations)
    accelerations    ``model.accelerations(t, q, q̇)``, one call
    jacobian         ``model.jacobian(t, y)``, one call (forward-mode AD of q̈)
    linearize        ``model.linearize(q, q̇)``, one call
    dop853           ``simulate`` DOP853 @ 1e-9 to t = 100
    taylor           a fresh ``model.integrator(..., method="taylor")`` @ 1e-9 and its
                     ``propagate_until(100)``
    taylor first     ``lg.Model(...)`` + its first Taylor ``simulate`` @ 1e-9 to t = 10 (derives
                     and compiles the Taylor recurrences: time to first result)
    gauss4           ``simulate`` Gauss–Legendre 4, dt = 1e-3 to t = 10 (implicit, (q, p) form)
    radau5 stiff     the stiff spring pendulum of benches/compiled_models.py (k = 1e6, radial
                     dashpot c = 2e4), ``simulate`` radau5 @ 1e-8 to t = 2
    scene dop853     ``lg.scenes.double_pendulum()`` (Rust energies), DOP853 @ 1e-9 to t = 100
    constrained xy   a pendulum in x, y with ``constraints=[x² + y² − l²]``, default tolerances,
                     to t = 100
    constrained ball ``lg.scenes.ball_in_sphere_constrained()`` (of ``lg.scenes.CONSTRAINED``),
                     default tolerances, to t = 100
    sens dop853      ``simulate(..., sensitivities=["g"])`` DOP853 @ 1e-9 to t = 10
    sens taylor      the same with Taylor
    many taylor      ``simulate_many`` of 256 runs (angles from ``default_rng(15)``) Taylor @ 1e-9
                     to t = 10, ``final_only=True``, ``workers=1`` (the SIMD lanes)
    events           DOP853 @ 1e-10 to t = 50 with the non-terminal event θ₁ = 0, final state
                     only (``output_every``)

The defaults (5 rounds × 3 timings, 0.3 CPU s a turn) cost 16 probes × 2 sides × 5 × 0.3 s
= 48 CPU seconds plus each worker's set-up (a few seconds): about 1.5 minutes of wall time on a
quiet machine, several times that under load (the wall time stretches, the CPU time does not).
Not a test: timings depend on the machine and its load; read the spreads before a ratio.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import statistics
import subprocess
import sys
import time
from typing import Any, Callable, Dict, List, Optional, Tuple

# numpy's BLAS threads spin while idle and would take a core from the runs being timed.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

Q0, QD0 = [1.0, 0.5], [0.0, 0.0]
EVERY = 2**62  # output_every: keep only the initial and the final state
UNROLL_AFTER = 10_000  # src/taylor/kernel.rs: expansions before the unrolled compile
ORDER = ["build", "accelerations", "jacobian", "linearize", "dop853", "taylor", "taylor first",
         "gauss4", "radau5 stiff", "scene dop853", "constrained xy", "constrained ball",
         "sens dop853", "sens taylor", "many taylor", "events"]


# ---------------------------------------------------------------------------------------------
# The worker: the probes, run in the interpreter under test.


def steps_of(x: Any) -> Optional[int]:
    stats = getattr(x, "stats", None)
    if isinstance(stats, dict) and "accepted_steps" in stats:
        return int(stats["accepted_steps"])
    return None


def probes() -> Dict[str, Callable[[], Optional[int]]]:
    """{name: one unit of work returning its accepted steps (or None)}: every model built."""
    import numpy as np

    import lagrangian as lg

    def double_pendulum() -> Any:
        th1, th2 = lg.coordinates("th1 th2")
        m, l, g = lg.parameters("m l g")
        T = 0.5 * m * l**2 * (2 * th1.d**2 + th2.d**2 + 2 * th1.d * th2.d * lg.cos(th1 - th2))
        U = -m * g * l * (2 * lg.cos(th1) + lg.cos(th2))
        return lg.Model(coordinates=[th1, th2], kinetic=T, potential=U,
                        parameters={"m": 1.0, "l": 1.0, "g": 9.81}), th1

    def stiff_spring() -> Any:
        r, th = lg.coordinates("r theta")
        m, k, l0, g, c = lg.parameters("m k l0 g c")
        T = 0.5 * m * (r.d**2 + r**2 * th.d**2)
        U = 0.5 * k * (r - l0) ** 2 - m * g * r * lg.cos(th)
        return lg.Model(coordinates=[r, th], kinetic=T, potential=U,
                        dissipation=0.5 * c * r.d**2,
                        parameters=dict(m=1.0, k=1e6, l0=1.0, g=9.81, c=2e4))

    def xy_pendulum() -> Any:
        x, y = lg.coordinates("x y")
        m, l, g = lg.parameters("m l g")
        return lg.Model(coordinates=[x, y], kinetic=0.5 * m * (x.d**2 + y.d**2),
                        potential=m * g * y, parameters={"m": 1.0, "l": 1.0, "g": 9.81},
                        constraints=[x**2 + y**2 - l**2])

    dp, th1 = double_pendulum()
    stiff = stiff_spring()
    scene = lg.scenes.double_pendulum(1.0, 1.0, 1.0, 1.0, 9.81)
    xy = xy_pendulum()
    ball = lg.scenes.ball_in_sphere_constrained()
    event = lg.Event(th1, name="th1 = 0")
    q, qd = np.array(Q0), np.array([0.3, -0.2])
    y = np.concatenate([q, qd])
    xy_q0, xy_qd0 = [math.sin(1.0), -math.cos(1.0)], [0.0, 0.0]
    # ball: (r1 − r2) θ₁ = r2 θ₂ with r1 = 1, r2 = 0.2.
    ball_q0, ball_qd0 = [1.0, 4.0], [0.0, 0.0]
    many_q0 = np.random.default_rng(15).uniform(-2.0, 2.0, (256, 2))
    many_qd0 = np.zeros_like(many_q0)

    def taylor_integrator() -> Optional[int]:
        ig = dp.integrator(Q0, QD0, method="taylor", rtol=1e-9, atol=1e-9)
        ig.propagate_until(100.0)
        ig.q
        return int(ig.stats["accepted_steps"])

    def taylor_first() -> Optional[int]:
        fresh, _ = double_pendulum()
        return steps_of(fresh.simulate(Q0, QD0, 10.0, method="taylor", output_every=EVERY,
                                       rtol=1e-9, atol=1e-9))

    def many() -> Optional[int]:
        e = dp.simulate_many(many_q0, many_qd0, 10.0, method="taylor", final_only=True,
                             workers=1, rtol=1e-9, atol=1e-9)
        assert bool(np.all(e.ok))
        return None

    def sens(method: str) -> Callable[[], Optional[int]]:
        def run() -> Optional[int]:
            sol = dp.simulate(Q0, QD0, 10.0, method=method, output_every=EVERY,
                              sensitivities=["g"], rtol=1e-9, atol=1e-9)
            sol.sensitivities["g"]
            return steps_of(sol)
        return run

    return {
        "build": lambda: (double_pendulum(), None)[1],
        "accelerations": lambda: (dp.accelerations(0.0, q, qd), None)[1],
        "jacobian": lambda: (dp.jacobian(0.0, y), None)[1],
        "linearize": lambda: (dp.linearize(q, qd), None)[1],
        "dop853": lambda: steps_of(dp.simulate(Q0, QD0, 100.0, method="dop853", rtol=1e-9,
                                               atol=1e-9)),
        "taylor": taylor_integrator,
        "taylor first": taylor_first,
        "gauss4": lambda: steps_of(dp.simulate(Q0, QD0, 10.0, method="gauss4", dt=1e-3)),
        "radau5 stiff": lambda: steps_of(stiff.simulate([1.1, 0.5], [0.0, 0.0], 2.0,
                                                        method="radau5", rtol=1e-8, atol=1e-8)),
        "scene dop853": lambda: steps_of(scene.simulate(Q0, QD0, 100.0, method="dop853",
                                                        rtol=1e-9, atol=1e-9)),
        "constrained xy": lambda: steps_of(xy.simulate(xy_q0, xy_qd0, 100.0)),
        "constrained ball": lambda: steps_of(ball.simulate(ball_q0, ball_qd0, 100.0)),
        "sens dop853": sens("dop853"),
        "sens taylor": sens("taylor"),
        "many taylor": many,
        "events": lambda: steps_of(dp.simulate(Q0, QD0, 50.0, method="dop853", events=[event],
                                               output_every=EVERY, rtol=1e-10, atol=1e-10)),
    }


def timed(f: Callable[[], Optional[int]], n: int) -> Tuple[float, float, Optional[int]]:
    """(CPU seconds of this process, wall seconds, steps of the last run) of n runs."""
    gc.collect()
    steps = None
    cpu, wall = time.process_time(), time.perf_counter()
    for _ in range(n):
        steps = f()
    return time.process_time() - cpu, time.perf_counter() - wall, steps


def warm(name: str, f: Callable[[], Optional[int]]) -> None:
    """One run; the Taylor probes until their programs have expanded past UNROLL_AFTER (each run
    at least a step per expansion; bounded)."""
    steps = f()
    if name == "many taylor":  # the lanes' programs: 256 runs expand far past it in one call
        f()
    if "taylor" in name and name != "taylor first" and steps:
        for _ in range(min(200, UNROLL_AFTER // steps + 2)):
            f()


def worker(cpu: Optional[int]) -> None:
    if cpu is not None:
        os.sched_setaffinity(0, {cpu})
    # The protocol on a private copy of stdout; anything the library prints goes to stderr.
    out = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    started = time.perf_counter()
    import lagrangian as lg

    table = probes()
    for name, f in table.items():
        warm(name, f)
    hello = dict(file=lg.__file__, prefix=sys.prefix, version=getattr(lg, "__version__", "?"),
                 setup=time.perf_counter() - started, probes=list(table))
    out.write(json.dumps(hello) + "\n")
    for line in sys.stdin:
        req = json.loads(line)
        if req["cmd"] == "quit":
            break
        f = table[req["probe"]]
        if req["cmd"] == "calibrate":
            n, seconds = 1, 0.0
            for _ in range(30):  # bounded: n grows at least 4× a pass
                seconds = timed(f, n)[0]
                if seconds >= req["target"] / 8:
                    break
                n *= 8 if seconds < req["target"] / 100 else 4
            seconds = min(seconds, timed(f, n)[0], timed(f, n)[0])  # a load spike's guard
            n = max(1, round(n * req["target"] / max(seconds, 1e-9)))
            out.write(json.dumps(dict(n=n)) + "\n")
        else:
            # The best of `reps` timings of n units: a load spike inside one does not count.
            runs = [timed(f, req["n"]) for _ in range(req["reps"])]
            out.write(json.dumps(dict(cpu=min(r[0] for r in runs), wall=min(r[1] for r in runs),
                                      steps=runs[-1][2])) + "\n")


# ---------------------------------------------------------------------------------------------
# The controller.


class Side:
    def __init__(self, label: str, python: str, cpu: Optional[int]) -> None:
        self.label = label
        env = dict(os.environ, PYTHONPATH="")  # the interpreter's own install, not a worktree's
        pin = [] if cpu is None else ["--cpu", str(cpu)]
        self.proc = subprocess.Popen([python, os.path.abspath(__file__), "--worker", *pin],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                     bufsize=1, env=env, cwd="/")
        self.hello = self.read()

    def read(self) -> Dict[str, Any]:
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        if not line:
            raise SystemExit(f"the {self.label} worker stopped (exit code {self.proc.wait()})")
        answer: Dict[str, Any] = json.loads(line)
        return answer

    def ask(self, **req: Any) -> Dict[str, Any]:
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps(req) + "\n")
        self.proc.stdin.flush()
        return self.read()

    def close(self) -> None:
        if self.proc.poll() is None:
            assert self.proc.stdin is not None
            self.proc.stdin.write(json.dumps(dict(cmd="quit")) + "\n")
            self.proc.stdin.close()
        self.proc.wait(timeout=60)


def unit(seconds: float) -> str:
    if seconds < 1e-3:
        return f"{seconds * 1e6:.2f} µs"
    if seconds < 1.0:
        return f"{seconds * 1e3:.3f} ms"
    return f"{seconds:.3f} s"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--before", help="the interpreter with the BEFORE build")
    ap.add_argument("--after", help="the interpreter with the AFTER build")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--target", type=float, default=0.3,
                    help="seconds per probe, side and round")
    ap.add_argument("--reps", type=int, default=3,
                    help="timings per probe, side and round (best of), target ÷ reps each")
    ap.add_argument("--probes", default=None,
                    help="comma-separated subset of: " + ", ".join(ORDER))
    ap.add_argument("--cpu", type=int, default=None,
                    help="pin both workers to this CPU (os.sched_setaffinity)")
    ap.add_argument("--json", default=None, help="also write the raw timings here")
    args = ap.parse_args()
    if args.worker:
        worker(args.cpu)
        return
    if not args.before or not args.after:
        ap.error("--before and --after are required")
    started = time.perf_counter()
    print(f"load average at start: {os.getloadavg()[0]:.2f} (cores: {os.cpu_count()})",
          flush=True)
    names = args.probes.split(",") if args.probes else ORDER
    clocks = ("cpu", "wall")
    times: Dict[str, Dict[str, Dict[str, List[float]]]] = {
        k: {c: {"before": [], "after": []} for c in clocks} for k in names}
    steps: Dict[str, Dict[str, Optional[int]]] = {k: {} for k in names}
    n: Dict[str, int] = {}
    hello: Dict[str, Dict[str, Any]] = {}
    for r in range(args.rounds):
        # New workers every round: a process's own bias (where its code and data landed, the
        # CPU the scheduler keeps it on) is drawn again, not carried through every round.
        sides = [Side(label, python, args.cpu)  # one at a time: set-ups do not overlap
                 for label, python in (("before", args.before), ("after", args.after))]
        if r == 0:
            for s in sides:
                hello[s.label] = s.hello
                print(f"{s.label}: {args.before if s.label == 'before' else args.after} → "
                      f"lagrangian {s.hello['version']} from {s.hello['file']} (set-up and "
                      f"warm-up {s.hello['setup']:.1f} s)", flush=True)
                if not str(s.hello["file"]).startswith(str(s.hello["prefix"])):
                    print(f"WARNING: the {s.label} side's lagrangian is not its venv's "
                          f"({s.hello['prefix']}): is the wheel installed there?")
            if sides[0].hello["file"] == sides[1].hello["file"]:
                print("note: both sides load the same lagrangian: a noise check, not a "
                      "comparison")
            for name in names:
                for s in sides:
                    if name not in s.hello["probes"]:
                        raise SystemExit(f"unknown probe {name!r} on the {s.label} side")
            n = {name: sides[0].ask(cmd="calibrate", probe=name,
                                    target=args.target / args.reps)["n"] for name in names}
            print(f"calibrated ({time.perf_counter() - started:.0f} s)", file=sys.stderr,
                  flush=True)
        for i, name in enumerate(names):
            order = sides if (r + i) % 2 == 0 else sides[::-1]
            for s in order:
                ans = s.ask(cmd="time", probe=name, n=n[name], reps=args.reps)
                for c in clocks:
                    times[name][c][s.label].append(ans[c] / n[name])
                steps[name][s.label] = ans["steps"]
        for s in sides:
            s.close()
        print(f"round {r + 1}/{args.rounds} done ({time.perf_counter() - started:.0f} s)",
              file=sys.stderr, flush=True)

    def spread(xs: List[float]) -> str:
        return f"{(statistics.median(xs) / min(xs) - 1) * 100:.0f} %"

    print(f"\nbest of {args.rounds} rounds (ABBA) × {args.reps} timings, per unit of work, in CPU "
          f"time of the worker process (wall time's ratio beside it); spread = median ÷ best − 1 "
          f"over the rounds; total {time.perf_counter() - started:.0f} s; load average at end "
          f"{os.getloadavg()[0]:.2f}\n")
    print("| probe | n | before | after | after ÷ before | wall: after ÷ before | spread b / a "
          "| steps b / a |")
    print("|---|---|---|---|---|---|---|---|")
    ratios = []
    for name in names:
        b, a = times[name]["cpu"]["before"], times[name]["cpu"]["after"]
        wb, wa = times[name]["wall"]["before"], times[name]["wall"]["after"]
        ratio = min(a) / min(b)
        ratios.append(ratio)
        sb, sa = steps[name].get("before"), steps[name].get("after")
        st = "—" if sb is None and sa is None else (f"{sb}" if sb == sa else f"**{sb} / {sa}**")
        flag = " **" if ratio > 1.10 else ""
        print(f"| {name} | {n[name]} | {unit(min(b))} | {unit(min(a))} | {ratio:.3f}{flag} | "
              f"{min(wa) / min(wb):.3f} | {spread(b)} / {spread(a)} | {st} |")
    geo = math.exp(sum(math.log(x) for x in ratios) / len(ratios))
    print(f"\ngeometric mean of after ÷ before (CPU): {geo:.3f}; range {min(ratios):.3f} – "
          f"{max(ratios):.3f} (** > 1.10)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dict(before=hello["before"], after=hello["after"], n=n, times=times,
                           steps=steps, rounds=args.rounds), f, indent=1)


if __name__ == "__main__":
    main()
