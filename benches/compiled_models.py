"""Models stated through the Python API against hand-written closed-form right-hand sides in Rust,
integrated by the same method, side by side in one run (issue 12, "Speed").

Scenes: the double pendulum, the forced two-mass system (seed eq. 41–44), the ball in a sphere
(eq. 49–53), the stiff spring pendulum (k = 1e6, radial damping ratio 10) and the N-pendulum for
N = 2, 4, 8, 16, 32 (energy route and particle route). The Rust side is ``benches/compiled.rs``,
run by this script as
``cargo bench -p lagrangian-benches --bench compiled --features jit -- --serve``; it also times
the same systems built in Rust from ``lagrangian::tape::Graph`` (the compiled route of a Rust user).

For each scene and target error (1e-6, 1e-9) every side gets the loosest tolerance of the ladder
1e-4, 10^-4.5, …, 1e-13 (rtol = atol) whose end state is within the target of a tight reference
(DOP853 at 1e-14 on the closed form); the error of an end state y is
maxᵢ |yᵢ − refᵢ| / max(1, |refᵢ|) over y = (q, q̇). Then it is timed there, best of R rounds,
the rounds alternating between the sides so that a change in load hits all of them. Per-RHS cost
is run time over the RHS evaluations the integrator reports (``sol.stats``), taken from the runs
at the tightest target both sides reached. Build is ``lg.Model(...)`` (derivation and compilation,
the expressions already written) against building the Graph model in Rust, best of R. A second
table gives one accelerations call at a state: the closed form and the Graph model in Rust, and
``model.accelerations`` from Python.

Run from the repository root after installing the Python module (``pip install .``, or
``maturin develop --release``):

    python3 benches/compiled_models.py [--rounds R] [--scenes a,b,...] [--json FILE]

Build both sides with the same release profile: ``pip install .`` and ``cargo bench`` both use
Cargo.toml's (fat LTO); to iterate faster set ``CARGO_PROFILE_RELEASE_LTO=false`` for both.
Not a test: timings depend on the machine and its load.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time
from typing import Any, Callable, Dict, List, Optional, Tuple

# numpy's BLAS threads spin while idle and would take a core from the runs being timed.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import lagrangian as lg  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TARGETS = (1e-6, 1e-9)
LADDER = [10.0 ** (-k / 2) for k in range(8, 27)]
# output_every: keep only the initial and the final state, as the Rust side does.
EVERY = 2**62
# Issue 12's targets.
RHS_TARGET = 1.5
TIME_TARGET = 1.5
CALL_TARGET = 1.5e-6
BUILD_TARGETS = {"double_pendulum": 10e-3, "n_pendulum_32": 200e-3}

Spec = Dict[str, Any]


# ---------------------------------------------------------------------------------------------
# The scenes as a Python user states them


def double_pendulum(p: Dict[str, float]) -> Dict[str, Spec]:
    th1, th2 = lg.coordinates("th1 th2")
    m1, m2, l1, l2, g = lg.parameters("m1 m2 l1 l2 g")
    T = (0.5 * (m1 + m2) * l1**2 * th1.d**2 + 0.5 * m2 * l2**2 * th2.d**2
         + m2 * l1 * l2 * th1.d * th2.d * lg.cos(th1 - th2))
    U = -g * ((m1 + m2) * l1 * lg.cos(th1) + m2 * l2 * lg.cos(th2))
    return {"energy": dict(coordinates=[th1, th2], kinetic=T, potential=U, parameters=p)}


def forced_two_mass(p: Dict[str, float]) -> Dict[str, Spec]:
    x1, x2 = lg.coordinates("x1 x2")
    m1, m2, k1, k2, f1, f2, omega = lg.parameters("m1 m2 k1 k2 f1 f2 omega")
    T = 0.5 * m1 * x1.d**2 + 0.5 * m2 * x2.d**2
    U = 0.5 * k1 * x1**2 + 0.5 * k2 * (x2 - x1) ** 2
    c = lg.cos(omega * lg.t)
    return {"energy": dict(coordinates=[x1, x2], kinetic=T, potential=U,
                           forces=[f1 * c, f2 * c], parameters=p)}


def ball_in_sphere(p: Dict[str, float]) -> Dict[str, Spec]:
    (th,) = lg.coordinates("theta")
    m, j, r1, r2, g = lg.parameters("m j r1 r2 g")
    T = 0.5 * (m + j / r2**2) * (r1 - r2) ** 2 * th.d**2
    U = -m * g * (r1 - r2) * lg.cos(th)
    return {"energy": dict(coordinates=[th], kinetic=T, potential=U, parameters=p)}


def stiff_spring(p: Dict[str, float]) -> Dict[str, Spec]:
    r, th = lg.coordinates("r theta")
    m, k, l0, g, c = lg.parameters("m k l0 g c")
    T = 0.5 * m * (r.d**2 + r**2 * th.d**2)
    U = 0.5 * k * (r - l0) ** 2 - m * g * r * lg.cos(th)
    return {"energy": dict(coordinates=[r, th], kinetic=T, potential=U,
                           dissipation=0.5 * c * r.d**2, parameters=p)}


def n_pendulum(n: int) -> Callable[[Dict[str, float]], Dict[str, Spec]]:
    """A chain of n equal links: the bobs at running sums of l (sin θⱼ, −cos θⱼ)."""

    def build(p: Dict[str, float]) -> Dict[str, Spec]:
        th = lg.coordinates(" ".join(f"th{i}" for i in range(n)))
        m, l, g = lg.parameters("m l g")
        x: Any = 0.0
        y: Any = 0.0
        vx: Any = 0.0
        vy: Any = 0.0
        T: Any = 0.0
        U: Any = 0.0
        positions = []
        for q in th:
            c, s = lg.cos(q), lg.sin(q)
            x, y = x + l * s, y - l * c
            vx, vy = vx + l * c * q.d, vy + l * s * q.d
            T = T + 0.5 * m * (vx**2 + vy**2)
            U = U + m * g * y
            positions.append((x, y))
        return {
            "energy": dict(coordinates=list(th), kinetic=T, potential=U, parameters=p),
            "particles": dict(coordinates=list(th), positions=positions, masses=[m] * n,
                              potential=U, parameters=p),
        }

    return build


BUILDERS: Dict[str, Callable[[Dict[str, float]], Dict[str, Spec]]] = {
    "double_pendulum": double_pendulum,
    "double_pendulum_gauss4": double_pendulum,
    "forced_two_mass": forced_two_mass,
    "ball_in_sphere": ball_in_sphere,
    "stiff_spring": stiff_spring,
    **{f"n_pendulum_{n}": n_pendulum(n) for n in (2, 4, 8, 16, 32)},
}


# ---------------------------------------------------------------------------------------------
# The Rust side


class Rust:
    """``benches/compiled.rs --serve``: one JSON line per request."""

    def __init__(self, scenes: Optional[str], t_scale: float) -> None:
        cmd = ["cargo", "bench", "-p", "lagrangian-benches", "--bench", "compiled",
               "--features", "jit", "--", "--serve", "--t-scale", repr(t_scale)]
        if scenes:
            cmd += ["--scenes", scenes]
        print("$ " + " ".join(cmd), file=sys.stderr, flush=True)
        self.proc = subprocess.Popen(cmd, cwd=ROOT, stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, text=True, bufsize=1)

    def ask(self, request: str, fatal: bool = True) -> Dict[str, Any]:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(request + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise SystemExit(f"the Rust benchmark stopped (exit code {self.proc.wait()})")
        answer: Dict[str, Any] = json.loads(line)
        if answer.get("kind") == "error" and fatal:
            raise SystemExit(f"Rust benchmark: {answer['error']} (request {request!r})")
        return answer

    def close(self) -> None:
        if self.proc.poll() is None:
            assert self.proc.stdin is not None
            self.proc.stdin.write("quit\n")
            self.proc.stdin.close()
        self.proc.wait(timeout=60)


# ---------------------------------------------------------------------------------------------
# Measurements


def error(end: np.ndarray, reference: List[float]) -> float:
    ref = np.asarray(reference, dtype=float)
    return float(np.max(np.abs(end - ref) / np.maximum(1.0, np.abs(ref))))


class Side:
    """One way to integrate a scene: `run(tol, inner)` gives the best of `inner` runs."""

    def __init__(self, label: str, run: Callable[[float, int], Dict[str, Any]]) -> None:
        self.label = label
        self.run = run


def options(scene: Dict[str, Any], tol: float) -> Dict[str, float]:
    """The options a ladder tolerance τ stands for: rtol = atol = τ, or for a fixed-step method
    of order p the step τ^(1/p) (its error then scales like τ), shortened so that whole steps end
    at t_end — as `options` in benches/compiled.rs."""
    p = scene["fixed_order"]
    if p is None:
        return dict(rtol=tol, atol=tol)
    steps = math.ceil(scene["t_end"] / tol ** (1.0 / p))
    return dict(dt=scene["t_end"] / steps)


def python_side(label: str, model: Any, scene: Dict[str, Any]) -> Side:
    def run(tol: float, inner: int) -> Dict[str, Any]:
        best = math.inf
        for _ in range(max(1, inner)):
            start = time.perf_counter()
            try:
                sol = model.simulate(scene["q0"], scene["qd0"], scene["t_end"],
                                     method=scene["method"], output_every=EVERY,
                                     **options(scene, tol))
            except lg.LagrangianError as e:
                # A run that fails (too many steps at a tight tolerance, …) reaches no target.
                print(f"  {label} at tol {tol:g}: {e}", file=sys.stderr)
                return {"seconds": math.inf, "rhs": 0, "jacobians": 0, "steps": 0,
                        "error": None}
            best = min(best, time.perf_counter() - start)
        end = np.concatenate([sol.q[-1], sol.qd[-1]])
        s = sol.stats
        return {"seconds": best, "rhs": s["rhs_evaluations"],
                "jacobians": s["jacobian_evaluations"], "steps": s["accepted_steps"],
                "error": error(end, scene["reference"])}

    return Side(label, run)


def rust_side(rust: Rust, side: str, scene: Dict[str, Any]) -> Side:
    def run(tol: float, inner: int) -> Dict[str, Any]:
        request = f"run {scene['scene']} {side} {scene['method']} {tol!r} {max(1, inner)}"
        answer = rust.ask(request, fatal=False)
        if answer.get("kind") == "error":
            # A run that fails (too many steps at a tight tolerance, …) reaches no target.
            print(f"  {side} at tol {tol:g}: {answer['error']}", file=sys.stderr)
            return {"seconds": math.inf, "rhs": 0, "jacobians": 0, "steps": 0, "error": None}
        return answer

    return Side(side, run)


def loosest(side: Side) -> Tuple[Dict[float, Optional[float]], float]:
    """For each target the loosest tolerance of the ladder reaching it (None if none does), and
    the time of one run at the tightest tolerance tried."""
    found: Dict[float, Optional[float]] = {t: None for t in TARGETS}
    seconds = 0.0
    for tol in LADDER:
        r = side.run(tol, 1)
        seconds = r["seconds"]
        for target in TARGETS:
            if found[target] is None and r["error"] is not None and r["error"] <= target:
                found[target] = tol
        if all(v is not None for v in found.values()):
            break
    return found, seconds


def check_model(label: str, model: Any, scene: Dict[str, Any]) -> None:
    """The model stated here must give the closed form's accelerations (1e-12 relative)."""
    for c in scene["checks"]:
        want = np.asarray(c["accelerations"])
        got = np.asarray(model.accelerations(c["t"], c["q"], c["qd"]))
        scale = max(1e-300, float(np.max(np.abs(want))))
        if np.max(np.abs(got - want)) > 1e-12 * scale:
            raise SystemExit(f"{scene['scene']} ({label}): accelerations {got} at {c} differ from "
                             f"the closed form's {want}: the comparison would be meaningless")


def best_of(rounds: int, f: Callable[[], Any]) -> float:
    best = math.inf
    for _ in range(rounds):
        start = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - start)
    return best


def per_call(f: Callable[[], Any], reps: int = 2000) -> float:
    """The best over five batches of `reps` calls, per call."""
    best = math.inf
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(reps):
            f()
        best = min(best, (time.perf_counter() - start) / reps)
    return best


def measure(rust: Rust, scene: Dict[str, Any], rounds: int, round_seconds: float
            ) -> List[Dict[str, Any]]:
    """Every Python route of the scene against the closed form (and the Rust Graph model)."""
    name = scene["scene"]
    specs = BUILDERS[name](scene["params"])
    models = {}
    builds = {}
    for route, spec in specs.items():
        builds[route] = best_of(rounds, lambda: lg.Model(**spec))
        models[route] = lg.Model(**spec)
        check_model(route, models[route], scene)
    rust_build = rust.ask(f"build {name} {rounds}")["seconds"]
    # One accelerations call at a check state, as a user makes it from Python.
    rust_call = {side: rust.ask(f"call {name} {side} 10000")["seconds"]
                 for side in ("closed", "graph")}
    c = scene["checks"][1]
    q, qd = np.asarray(c["q"], dtype=float), np.asarray(c["qd"], dtype=float)
    python_call = {route: per_call(lambda: m.accelerations(c["t"], q, qd))
                   for route, m in models.items()}
    sides = [rust_side(rust, "closed", scene), rust_side(rust, "graph", scene)]
    sides += [python_side(route, m, scene) for route, m in models.items()]
    found = {}
    inner = {}
    for side in sides:
        found[side.label], seconds = loosest(side)
        # Enough runs per round that one round takes about `round_seconds`.
        inner[side.label] = max(1, min(50, int(round_seconds / max(seconds, 1e-9))))
    timings: Dict[Tuple[str, float], Dict[str, Any]] = {}
    for target in TARGETS:
        for _ in range(rounds):
            for side in sides:
                tol = found[side.label][target]
                if tol is None:
                    continue
                r = side.run(tol, inner[side.label])
                key = (side.label, target)
                if key not in timings or r["seconds"] < timings[key]["seconds"]:
                    timings[key] = dict(r, tol=tol)
    choice = None
    if scene["method"] not in ("dop853", "gauss4"):
        sol = next(iter(models.values())).simulate(scene["q0"], scene["qd0"], scene["t_end"],
                                                   method="auto", rtol=1e-6, atol=1e-6,
                                                   output_every=EVERY)
        choice = sol.stats["method"]
    rows = []
    for route, model in models.items():
        # The fixed cost of a call: a run of one step.
        one_step = dict(dt=1e-9) if scene["fixed_order"] else {}
        call = best_of(5 * rounds, lambda: model.simulate(
            scene["q0"], scene["qd0"], 1e-9, method=scene["method"], output_every=EVERY,
            **one_step))
        rows.append({
            "python_call": call,
            "call_closed": rust_call["closed"], "call_graph": rust_call["graph"],
            "call_python": python_call[route],
            "scene": name, "route": route, "method": scene["method"], "auto": choice,
            "backend": models[route].structure.get("backend"),
            "build_python": builds[route], "build_rust_graph": rust_build,
            "runs": {f"{side}@{target:g}": r for (side, target), r in timings.items()
                     if side in ("closed", "graph", route)},
        })
    return rows


# ---------------------------------------------------------------------------------------------
# The table


def ms(seconds: Optional[float]) -> str:
    if seconds is None:
        return "—"
    if seconds < 1e-3:
        return f"{seconds * 1e3:.3f} ms"
    return f"{seconds * 1e3:.2f} ms" if seconds < 0.1 else f"{seconds * 1e3:.0f} ms"


def per_rhs(r: Optional[Dict[str, Any]]) -> Optional[float]:
    return None if r is None or not r["rhs"] else r["seconds"] / r["rhs"]


def ratio(a: Optional[float], b: Optional[float]) -> Optional[float]:
    return None if a is None or b is None or b == 0 else a / b


def fmt_ratio(x: Optional[float]) -> str:
    return "—" if x is None else f"{x:.2f}×"


def ns(seconds: Optional[float]) -> str:
    if seconds is None:
        return "—"
    return f"{seconds * 1e9:.0f} ns" if seconds < 1e-6 else f"{seconds * 1e6:.2f} µs"


def summarize(row: Dict[str, Any]) -> Dict[str, Any]:
    """Ratios of one row: the Python route and the Rust Graph model against the closed form."""
    runs = row["runs"]
    out: Dict[str, Any] = {}
    for side in (row["route"], "graph"):
        key = "python" if side == row["route"] else "graph"
        for target in TARGETS:
            out[f"{key}_time_{target:g}"] = ratio(
                runs.get(f"{side}@{target:g}", {}).get("seconds"),
                runs.get(f"closed@{target:g}", {}).get("seconds"))
        # Per RHS at the tightest target both reached.
        out[f"{key}_rhs"] = None
        for target in reversed(TARGETS):
            a, b = runs.get(f"{side}@{target:g}"), runs.get(f"closed@{target:g}")
            if a and b:
                out[f"{key}_rhs"] = ratio(per_rhs(a), per_rhs(b))
                break
    closed = [runs.get(f"closed@{t:g}") for t in TARGETS]
    out["closed_times"] = [None if r is None else r["seconds"] for r in closed]
    out["closed_rhs"] = next((per_rhs(r) for r in reversed(closed) if r), None)
    return out


def table(rows: List[Dict[str, Any]]) -> str:
    lines = [
        "| scene | method | closed form: per RHS / to 1e-6 / to 1e-9 | Python model ÷ closed: "
        "per RHS / to 1e-6 / to 1e-9 | Rust Graph model ÷ closed: per RHS / to 1e-6 / to 1e-9 | "
        "build: Python `lg.Model` / Rust Graph |",
        "|---|---|---|---|---|---|",
    ]
    for row in rows:
        s = summarize(row)
        name = row["scene"].replace("n_pendulum_", "N-pendulum N = ").replace("_", " ")
        if row["route"] == "particles":
            name += " (particles)"
        t6, t9 = s["closed_times"]
        method = row["method"] + (f" (auto: {row['auto']})" if row["auto"] else "")
        graph = ("—" if row["route"] == "particles" else
                 f"{fmt_ratio(s['graph_rhs'])} / {fmt_ratio(s['graph_time_1e-06'])} / "
                 f"{fmt_ratio(s['graph_time_1e-09'])}")
        lines.append(
            f"| {name} | {method} | {ns(s['closed_rhs'])} / {ms(t6)} / {ms(t9)} | "
            f"{fmt_ratio(s['python_rhs'])} / {fmt_ratio(s['python_time_1e-06'])} / "
            f"{fmt_ratio(s['python_time_1e-09'])} | {graph} | "
            f"{ms(row['build_python'])} / "
            f"{'—' if row['route'] == 'particles' else ms(row['build_rust_graph'])} |")
    return "\n".join(lines)


def calls_table(rows: List[Dict[str, Any]]) -> str:
    lines = ["| scene | closed form | Rust Graph model | Python `model.accelerations` |",
             "|---|---|---|---|"]
    for row in rows:
        name = row["scene"].replace("n_pendulum_", "N-pendulum N = ").replace("_", " ")
        if row["route"] == "particles":
            name += " (particles)"
        graph = "—" if row["route"] == "particles" else ns(row["call_graph"])
        lines.append(f"| {name} | {ns(row['call_closed'])} | {graph} | "
                     f"{ns(row['call_python'])} |")
    return "\n".join(lines)


def targets(rows: List[Dict[str, Any]]) -> str:
    """Issue 12's targets for the Python models, one line per row: met or missed."""
    out = []
    for row in rows:
        s = summarize(row)
        label = row["scene"] + ("" if row["route"] == "energy" else f" ({row['route']})")
        checks = []

        def check(what: str, x: Optional[float], limit: float, text: str) -> None:
            ok = x is not None and x <= limit
            checks.append(f"{what} {text} (≤ {limit:g}×: {'met' if ok else 'MISSED'})")

        if row["scene"] in ("double_pendulum", "forced_two_mass"):
            check("per RHS", s["python_rhs"], RHS_TARGET, fmt_ratio(s["python_rhs"]))
        # Every scene: the same method within 1.5× of the hand-written limit; the chain through
        # the particle route also against the looser 2× for N = 16, 32.
        limit = TIME_TARGET
        for target in TARGETS:
            x = s[f"python_time_{target:g}"]
            check(f"to {target:g}", x, limit, fmt_ratio(x))
        if row["route"] == "particles" and row["scene"] in ("n_pendulum_16", "n_pendulum_32"):
            x = s["python_time_1e-06"]
            check("particle route to 1e-06", x, 2.0, fmt_ratio(x))
        call = row["call_python"]
        if row["scene"] == "double_pendulum":
            checks.append(f"`model.accelerations` {ns(call)} (≤ {ns(CALL_TARGET)}: "
                          f"{'met' if call <= CALL_TARGET else 'MISSED'})")
        build = BUILD_TARGETS.get(row["scene"])
        if build is not None and row["route"] == "energy":
            checks.append(f"build {ms(row['build_python'])} (≤ {ms(build)}: "
                          f"{'met' if row['build_python'] <= build else 'MISSED'})")
        out.append(f"- {label}: " + "; ".join(checks))
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=7, help="timing rounds per side (best of)")
    ap.add_argument("--round-seconds", type=float, default=0.05,
                    help="repeat short runs within a round to about this long")
    ap.add_argument("--scenes", default=None, help="comma-separated subset of " + ", ".join(BUILDERS))
    ap.add_argument("--t-scale", type=float, default=1.0,
                    help="multiply every scene's span (longer runs amortize a call's fixed cost)")
    ap.add_argument("--json", default=None, help="also write the raw measurements here")
    args = ap.parse_args()
    if args.scenes:
        unknown = set(args.scenes.split(",")) - set(BUILDERS)
        if unknown:
            ap.error(f"unknown scenes {sorted(unknown)}; known: {', '.join(BUILDERS)}")
    started = time.perf_counter()
    rust = Rust(args.scenes, args.t_scale)
    try:
        scenes = rust.ask("scenes")["scenes"]
        rows = []
        for scene in scenes:
            print(f"{scene['scene']} (reference spread {scene['reference_spread']:.1e}, "
                  f"Rust Graph backend {scene['backend']}) …", file=sys.stderr, flush=True)
            rows += measure(rust, scene, args.rounds, args.round_seconds)
    finally:
        rust.close()
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"scenes": scenes, "rows": rows}, f, indent=1)
    print(f"\nBest of {args.rounds} rounds, alternating sides; total "
          f"{time.perf_counter() - started:.0f} s. Closed form: hand-written RHS in Rust "
          "(benches/closed_forms/); ratios are time ÷ closed form's time with the same method, "
          "each side at its own loosest tolerance reaching the error.\n")
    print(table(rows))
    calls = [r["python_call"] for r in rows]
    print(f"\nFixed cost of one Python `model.simulate` call, included in the Python times "
          f"(a one-step run of the cheapest scene): {min(calls) * 1e6:.1f} µs.")
    print("\nOne accelerations call at a state (best of five batches, per call):\n")
    print(calls_table(rows))
    print("\nIssue 12 targets (Python models):\n")
    print(targets(rows))


if __name__ == "__main__":
    main()
