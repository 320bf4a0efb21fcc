"""The standard report: work–precision on the report scenes, long-run energy, SciPy peers and the
stability matrix, written to a folder (Markdown, PNG, JSON).

``lagrangian report [--quick] [--out DIR]`` runs it; ``--quick`` finishes in under a minute on
two cores (fewer tolerances and steps, shorter long runs).
"""

from __future__ import annotations

import json
import math
import platform
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from . import _lagrangian
from ._cases import Scene, report_scenes
from ._measure import UNSUPPORTED, Reference, state_error, unsupported_reason
from ._model import Model
from ._scipy import IMPLICIT_METHODS, SCIPY_METHODS, run_scipy, scipy_available
from ._solution import Solution
from ._workprec import Row, WorkPrecision, work_precision

__all__ = ["Settings", "run_report", "equal_error_ratios", "long_run_energy"]

Progress = Callable[[str], None]


@dataclass(frozen=True)
class Settings:
    """How much the report runs."""

    tolerances: Tuple[float, ...]
    steps_per_scale: Tuple[float, ...]
    repeats: int
    long_steps: int
    short_steps: int
    peer_tolerances: Tuple[float, ...]
    peer_scenes: Optional[Tuple[str, ...]]

    @staticmethod
    def full() -> "Settings":
        """The full report: 10⁶-step energy runs, five tolerances, four steps, three repeats."""
        return Settings((1e-3, 1e-5, 1e-7, 1e-9, 1e-11), (25.0, 80.0, 250.0, 800.0), 3,
                        1_000_000, 1_000, (1e-3, 1e-5, 1e-7, 1e-9, 1e-11), None)

    @staticmethod
    def quick() -> "Settings":
        """Under a minute on two cores: three tolerances, two steps, 10⁴-step energy runs, SciPy
        on the two target scenes only."""
        return Settings((1e-4, 1e-7, 1e-10), (40.0, 400.0), 1, 10_000, 100, (1e-4, 1e-7, 1e-10),
                        ("double_pendulum", "forced_two_mass"))


def _fixed_step_methods() -> List[str]:
    return [m for m in _lagrangian.methods() if m != "auto" and _lagrangian.method_info(m)[1] is False]


# -- peers -----------------------------------------------------------------------------------


def peer_rows(model: Model, scene: Scene, reference: Reference,
              tolerances: Sequence[float]) -> WorkPrecision:
    """SciPy's ``solve_ivp`` (RK45, DOP853, Radau, LSODA) on the model's own right-hand side
    :meth:`Model.rhs` (and :meth:`Model.jacobian` for Radau and LSODA), measured against the same
    reference. Needs SciPy."""
    rows: List[Row] = []
    for method in SCIPY_METHODS:
        jac = model.jacobian if method in IMPLICIT_METHODS else None
        for tol in tolerances:
            run = run_scipy(model.rhs, scene.q0, scene.qd0, scene.t_end, method, tol, tol,
                            jac=jac)
            name = f"scipy {method}"
            if not run.success:
                rows.append(Row(name, tol, None, None, None, None, run.steps, run.nfev,
                                f"solve_ivp: {run.message}"))
                continue
            error = state_error(np.asarray(run.q), np.asarray(run.qd), reference.q, reference.qd)
            rows.append(Row(name, tol, None, error, None, run.seconds, run.steps, run.nfev))
    return WorkPrecision(rows, reference, f"{scene.title} — SciPy")


def _time_to_reach(rows: List[Row], level: float) -> Optional[float]:
    """The least wall time at which this method's runs reach ``error ≤ level``, interpolated
    log–log along its Pareto front; ``None`` when no run gets there."""
    done = sorted((r.seconds, r.error) for r in rows if r.error is not None and r.seconds)
    front: List[Tuple[float, float]] = []
    for seconds, error in done:
        if not front or error < front[-1][1]:
            front.append((seconds, max(error, 1e-300)))
    if not front or front[-1][1] > level:
        return None
    if front[0][1] <= level:
        return front[0][0]
    for (t0, e0), (t1, e1) in zip(front, front[1:]):
        if e1 <= level <= e0:
            w = (math.log(e0) - math.log(level)) / (math.log(e0) - math.log(e1))
            return math.exp(math.log(t0) + w * (math.log(t1) - math.log(t0)))
    return None


def _best(wp: WorkPrecision, level: float) -> Optional[Tuple[str, float]]:
    best: Optional[Tuple[str, float]] = None
    for method in wp.methods:
        t = _time_to_reach(wp.by_method(method), level)
        if t is not None and (best is None or t < best[1]):
            best = (method, t)
    return best


def equal_error_ratios(ours: WorkPrecision, theirs: WorkPrecision,
                       levels: Sequence[float] = (1e-3, 1e-5, 1e-7, 1e-9)) -> List[Dict[str, Any]]:
    """At each error level both sides reach: the fastest method of each (time interpolated along
    its work–precision front) and our time ÷ their time."""
    out = []
    for level in levels:
        a, b = _best(ours, level), _best(theirs, level)
        if a is None or b is None:
            continue
        out.append({"error": level, "ours": a[0], "our_seconds": a[1], "theirs": b[0],
                    "their_seconds": b[1], "ratio": a[1] / b[1]})
    return out


# -- long runs -------------------------------------------------------------------------------


def _relative_energy_error(model: Model, sol: Solution) -> float:
    """max |E − E0| relative to the size of the energy terms, max(|E|, |L|) over the run, so
    round-off in the large terms of an accelerating body is not read as drift."""
    drift = float(np.max(np.abs(sol.energy - sol.energy[0])))
    size = max(float(np.max(np.abs(sol.energy))), max(
        abs(model.lagrangian(t, q, qd)) for t, q, qd in zip(sol.t, sol.q, sol.qd)))
    return drift / size if size > 0 else drift


def long_run_energy(model: Model, q0: Sequence[float], qd0: Sequence[float], dt: float,
                    steps: int, short: int, methods: Sequence[str]) -> List[Dict[str, Any]]:
    """max |E − E0| over the first ``short`` steps and over all ``steps`` steps of size ``dt``,
    per method (adaptive methods at rtol = atol = 1e-10 over the same span), relative to the
    size of the energy terms max(|E|, |L|) in the same window."""
    out: List[Dict[str, Any]] = []
    span = steps * dt
    samples = 10_000
    for method in methods:
        adaptive = bool(_lagrangian.method_info(method)[1])
        kwargs: Dict[str, Any] = dict(method=method, max_steps=50 * steps)
        kwargs.update(dict(rtol=1e-10, atol=1e-10) if adaptive else dict(dt=dt))
        try:
            # Every step of the short window, then ~10⁴ samples of the whole run (the step count
            # of an adaptive run is estimated from the window).
            probe = model.simulate(q0, qd0, short * dt, **kwargs)
            every = max(1, int(probe.stats["accepted_steps"]) * (steps // short) // samples)
            start = time.perf_counter()
            sol = model.simulate(q0, qd0, span, output_every=every, **kwargs)
            seconds = time.perf_counter() - start
        except (_lagrangian.LagrangianError, ValueError) as e:
            if UNSUPPORTED in str(e):
                continue
            out.append({"method": method, "failure": f"{type(e).__name__}: {e}"})
            continue
        short_error = _relative_energy_error(model, probe)
        long_error = max(short_error, _relative_energy_error(model, sol))
        out.append({
            "method": method, "steps": int(sol.stats["accepted_steps"]), "seconds": seconds,
            "short": short_error, "long": long_error,
            "growth": long_error / max(short_error, 1e-300),
        })
    return out


# -- the report ------------------------------------------------------------------------------


def _fmt(x: Optional[float], spec: str = ".2e") -> str:
    return "—" if x is None else format(x, spec)


def run_report(out: Path, *, quick: bool = False, scenes: Optional[Sequence[str]] = None,
               peers: bool = True, stability: bool = True, progress: Progress = print) -> Dict[str, Any]:
    """Run the report and write ``out/README.md``, one ``out/<scene>.png`` per scene and
    ``out/report.json``. Returns the JSON data."""
    settings = Settings.quick() if quick else Settings.full()
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    chosen = report_scenes()
    if scenes is not None:
        unknown = set(scenes) - {s.key for s in chosen}
        if unknown:
            raise ValueError(f"unknown scenes {sorted(unknown)}; known: {[s.key for s in chosen]}")
        chosen = [s for s in chosen if s.key in scenes]
    have_scipy = peers and scipy_available()
    data: Dict[str, Any] = {
        "quick": quick, "settings": asdict(settings), "version": _lagrangian.__version__,
        "machine": f"{platform.machine()} {platform.system()}, Python {platform.python_version()}",
        "scenes": [],
    }
    md = [f"# lagrangian report{' (quick)' if quick else ''}", "",
          f"lagrangian {_lagrangian.__version__}; {data['machine']}. Errors are relative "
          "final-state errors ‖x − x_ref‖/‖x_ref‖ of x = (q, q̇); times are medians of "
          f"{settings.repeats} run(s) on this machine — compare ratios, not absolute times.", ""]
    if peers and not have_scipy:
        data["peers_note"] = "SciPy is not installed: the SciPy rows are skipped"
        md += [f"{data['peers_note']} (`pip install lagrangian[peers]` adds them).", ""]
        progress(data["peers_note"])
    for scene in chosen:
        progress(f"work–precision: {scene.title}")
        model = scene.model()
        dts = [scene.scale / k for k in settings.steps_per_scale]
        wp = work_precision(model, scene.q0, scene.qd0, scene.t_end, tolerances=settings.tolerances,
                            dts=dts, reference=scene.exact, repeats=settings.repeats,
                            title=scene.title)
        entry: Dict[str, Any] = {"key": scene.key, "work_precision": wp.to_dict()}
        theirs = None
        wanted = settings.peer_scenes is None or scene.key in settings.peer_scenes
        if have_scipy and scene.peers and wanted:
            progress(f"  SciPy peers: {scene.title}")
            theirs = peer_rows(model, scene, wp.reference, settings.peer_tolerances)
            entry["peers"] = theirs.to_dict()
            entry["equal_error"] = equal_error_ratios(wp, theirs)
        wp.plot(str(out / f"{scene.key}.png"), peers=theirs)
        md += [f"## {scene.title}", "", f"![work–precision]({scene.key}.png)", "",
               f"Reference: {wp.reference.kind} — {wp.reference.description}"
               + (f"; agreement of the two reference runs {wp.reference.agreement:.1e}"
                  if wp.reference.agreement is not None else ""), "",
               _table_without_unsupported(wp), ""]
        if theirs is not None:
            md += ["SciPy `solve_ivp` on the model's own right-hand side (`model.rhs`; "
                   "`model.jacobian` for Radau and LSODA), same reference:", "",
                   _table_without_unsupported(theirs), ""]
            ratios = entry["equal_error"]
            if ratios:
                md += ["At equal error (fastest method of each side, time interpolated along "
                       "its work–precision front):", "",
                       "| error | ours | SciPy | our time ÷ their time |", "|---|---|---|---|"]
                md += [f"| {r['error']:.0e} | {r['ours']} {r['our_seconds'] * 1e3:.3g} ms | "
                       f"{r['theirs']} {r['their_seconds'] * 1e3:.3g} ms | {r['ratio']:.2g} "
                       f"({1 / r['ratio']:.0f}× faster) |" for r in ratios]
                md.append("")
        structure = model.structure
        if structure["conservative"] and not structure["time_dependent"]:
            progress(f"  long-run energy ({settings.long_steps} steps): {scene.title}")
            dt = scene.scale / 100
            methods = [m for m in _lagrangian.methods() if m != "auto"]
            runs = long_run_energy(model, scene.q0, scene.qd0, dt, settings.long_steps,
                                   settings.short_steps, methods)
            entry["long_run"] = {"dt": dt, "steps": settings.long_steps,
                                 "short_steps": settings.short_steps, "runs": runs}
            md += [f"Energy over a long run: dt = {dt:.3g} for {settings.long_steps} steps "
                   f"(adaptive methods: rtol = atol = 1e-10 over the same span); max |E − E0| "
                   f"relative to the size of the energy terms, max(|E|, |L|), after "
                   f"{settings.short_steps} steps and at the end:", "",
                   "| method | after short | after all | growth | steps | time |",
                   "|---|---|---|---|---|---|"]
            for r in runs:
                if "failure" in r:
                    md.append(f"| {r['method']} | failed: {r['failure'][:120]} | | | | |")
                else:
                    md.append(f"| {r['method']} | {r['short']:.2e} | {r['long']:.2e} | "
                              f"{r['growth']:.3g}× | {r['steps']} | {r['seconds']:.2f} s |")
            md.append("")
        data["scenes"].append(entry)
    if stability:
        from ._stability import run_stability

        progress("stability matrix")
        matrix = run_stability(quick=quick, progress=progress)
        data["stability"] = matrix.to_dict()
        (out / "stability.md").write_text(matrix.table() + "\n")
        md += ["## Stability matrix", "", matrix.table(), ""]
    data["seconds"] = time.perf_counter() - started
    md.append(f"Report written in {data['seconds']:.1f} s.")
    (out / "README.md").write_text("\n".join(md) + "\n")
    (out / "report.json").write_text(json.dumps(data, indent=1, default=_json_default))
    return data


def _table_without_unsupported(wp: WorkPrecision) -> str:
    """The table without the rows of methods that cannot integrate the scene: after it, one line
    per reason (the method's own, from its fit check in Rust) naming those methods."""
    rows: List[Row] = []
    why: Dict[str, List[str]] = {}
    for r in wp.rows:
        reason = unsupported_reason(r.failure) if r.failure else None
        if reason is not None:
            if r.method not in why.setdefault(reason, []):
                why[reason].append(r.method)
            continue
        rows.append(r)
    table = WorkPrecision(rows, wp.reference, wp.title).table()
    for reason, methods in why.items():
        table += f"\n\nNot applicable ({reason}): {', '.join(sorted(methods))}."
    return table


def _json_default(x: Any) -> Any:
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")
