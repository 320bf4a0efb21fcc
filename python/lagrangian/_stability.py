"""The stability matrix: every method on stiff and extreme cases, each run classified.

Each run ends in one of:

- ``solved``: the answer is within the case's tolerance of the reference (error and time shown);
- ``error``: a typed error (which one, and its message) — the method refused or gave up;
- ``chaotic``: the answer differs from the reference but so do the two reference runs from each
  other: past a few Lyapunov times no method can be checked, and the report says so;
- ``coarse``: a fixed-step run whose answer is off, where halving ``dt`` changes the answer by
  as much — the error is in plain sight of the usual check (a fixed-step method promises no
  accuracy, only order);
- ``WRONG``: a normal return whose answer is off without any sign of it: an adaptive method
  outside its tolerance, or a fixed-step answer that halving ``dt`` does not change. The matrix
  prints it in capitals; the goal is that it never happens.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from . import _lagrangian, scenes
from ._cases import kepler_exact, kepler_periapsis, oscillator_exact
from ._model import Model
from ._measure import (
    FINAL_ONLY,
    UNSUPPORTED,
    Reference,
    computed_reference,
    state_error,
    unsupported_reason,
)

__all__ = ["Case", "Outcome", "StabilityMatrix", "check_methods", "stability_cases", "run_stability"]

Progress = Callable[[str], None]
Exact = Callable[[float], Tuple[Any, Any]]


@dataclass(frozen=True)
class Case:
    """One stiff or extreme case.

    The adaptive methods run at rtol = atol = ``rtol``, the fixed-step ones at ``dt``. ``accept``
    is the largest relative error counted as solved; with ``measure="energy"`` the error is the
    relative energy change |E_end − E0| / |E0| instead of the state error (for long runs, where
    the phase error of every method grows without bound but the orbit must be kept).
    ``unscale`` maps a final state back to the unscaled system (extreme-scale cases), so a
    scaled system is checked against the unscaled answer.
    """

    key: str
    title: str
    make: Callable[[], Model]
    q0: Tuple[float, ...]
    qd0: Tuple[float, ...]
    t_end: float
    dt: float
    rtol: float = 1e-8
    accept: float = 1e-4
    exact: Optional[Exact] = None
    measure: str = "state"
    unscale: Optional[Callable[[np.ndarray, np.ndarray], Tuple[np.ndarray, np.ndarray]]] = None
    base: Optional[Tuple[Callable[[], Model], Tuple[float, ...], Tuple[float, ...], float]] = None
    notes: str = ""
    max_steps: int = 20_000_000
    chaotic: bool = False


@dataclass(frozen=True)
class Outcome:
    """One method on one case."""

    case: str
    method: str
    status: str
    error: Optional[float] = None
    seconds: Optional[float] = None
    steps: int = 0
    detail: str = ""

    def cell(self) -> str:
        """The Markdown table cell."""
        if self.status == "solved":
            return f"✓ {self.error:.0e} · {_seconds(self.seconds)}"
        if self.status == "error":
            return self.detail.split(":", 1)[0]
        if self.status == "n/a":
            return "n/a"
        if self.status == "chaotic":
            return f"chaotic {self.error:.0e}"
        if self.status == "coarse":
            return f"coarse {self.error:.0e}"
        return f"**WRONG {self.error:.0e}**"


def _seconds(s: Optional[float]) -> str:
    if s is None:
        return ""
    return f"{s:.2g} s" if s >= 1 else f"{s * 1e3:.2g} ms"


@dataclass
class StabilityMatrix:
    """The outcomes of :func:`run_stability`, one per case and method."""

    cases: List[Case]
    methods: List[str]
    outcomes: List[Outcome]
    references: Dict[str, str] = field(default_factory=dict)

    def outcome(self, case: str, method: str) -> Outcome:
        """The outcome of ``method`` on ``case``."""
        for o in self.outcomes:
            if o.case == case and o.method == method:
                return o
        raise KeyError((case, method))

    def wrong(self) -> List[Outcome]:
        """The runs that returned a wrong answer."""
        return [o for o in self.outcomes if o.status == "WRONG"]

    def table(self) -> str:
        """Markdown: one row per case, one column per method; then the notes per case."""
        head = "| case | " + " | ".join(f"`{m}`" for m in self.methods) + " |"
        lines = [head, "|---|" + "---|" * len(self.methods)]
        for case in self.cases:
            cells = [self.outcome(case.key, m).cell() for m in self.methods]
            lines.append(f"| {case.title} | " + " | ".join(cells) + " |")
        lines += ["", "✓ error · time: solved within the case's tolerance; a name: the typed "
                  "error the method returned; n/a: the method does not apply (its reason is "
                  "listed under the case: explicit splittings need a separable system, some "
                  "methods cannot keep a constrained run on its constraints); coarse: a fixed-step answer outside the "
                  "tolerance that halving dt visibly changes (the step is too coarse, and the "
                  "usual check shows it); chaotic: beyond the predictability horizon — the error "
                  "is what the Lyapunov exponent amplifies the tolerance to, or the two "
                  "reference runs disagree; **WRONG**: an answer outside the tolerance with no "
                  "sign of it.", ""]
        wrong = self.wrong()
        lines.append(f"Wrong answers: {len(wrong)}." if wrong else "Wrong answers: none.")
        lines.append("")
        for case in self.cases:
            ref = self.references.get(case.key, "")
            lines.append(f"- **{case.title}**: t_end = {case.t_end:.4g}, dt = {case.dt:.3g}, "
                         f"rtol = atol = {case.rtol:.0e}, tolerance {case.accept:.0e} "
                         f"({'relative energy change' if case.measure == 'energy' else 'relative state error'}); "
                         f"reference: {ref}. {case.notes}" + self._not_applicable(case.key))
        return "\n".join(lines)

    def _not_applicable(self, case: str) -> str:
        """The methods that do not apply to ``case``, grouped by the reason each gives."""
        why: Dict[str, List[str]] = {}
        for o in self.outcomes:
            if o.case == case and o.status == "n/a":
                reason = unsupported_reason(o.detail) or o.detail
                why.setdefault(reason, []).append(o.method)
        return "".join(f" Not applicable ({reason}): {', '.join(methods)}."
                       for reason, methods in why.items())

    def to_dict(self) -> Dict[str, Any]:
        """Plain data (JSON-ready)."""
        return {
            "methods": self.methods,
            "cases": [{"key": c.key, "title": c.title, "t_end": c.t_end, "dt": c.dt,
                       "rtol": c.rtol, "accept": c.accept, "measure": c.measure,
                       "reference": self.references.get(c.key), "notes": c.notes}
                      for c in self.cases],
            "outcomes": [o.__dict__ for o in self.outcomes],
        }


# -- the cases --------------------------------------------------------------------------------


def _elastic(k: float, c: float) -> Callable[[], Model]:
    return lambda: scenes.elastic_pendulum(m=1.0, k=k, l0=1.0, g=9.81, c=c)


def _double(m1: float, m2: float, l: float) -> Callable[[], Model]:
    return lambda: scenes.double_pendulum(m1=m1, m2=m2, l1=l, l2=l, g=9.81)


def _unscale_length(length: float) -> Callable[[np.ndarray, np.ndarray], Tuple[np.ndarray, np.ndarray]]:
    # Lengths scaled by L stretch time by √L: θ(t) = θ₁(t/√L), θ̇ = θ̇₁(t/√L)/√L.
    root = math.sqrt(length)
    return lambda q, qd: (q, qd * root)


def stability_cases(quick: bool = False) -> List[Case]:
    """The cases of the matrix; ``quick`` shortens the long run and the stiff spans."""
    cases: List[Case] = []

    def span(k: float) -> float:
        # The stiff references (DOP853 at 1e-13 follows every radial oscillation) dominate the
        # cost; --quick shortens them.
        return (0.1 if k > 1e6 else 0.5) if quick else 2.0

    for k in (1e3, 1e6, 1e9):
        r0 = 1.0 + 9.81 / k
        cases.append(Case(
            f"spring_k{k:.0e}", f"elastic pendulum k = {k:.0e}", _elastic(k, 0.0),
            (r0, 0.3), (0.0, 0.0), span(k), 1e-3,
            notes=f"radial ω = {math.sqrt(k):.3g} rad/s against a swing period of ~2 s."))
    for k in (1e3, 1e6, 1e9):
        c = 20.0 * math.sqrt(k)
        r0 = 1.0 + 9.81 / k
        cases.append(Case(
            f"damped_k{k:.0e}", f"elastic pendulum k = {k:.0e}, damping ζ = 10", _elastic(k, c),
            (r0 + 0.01, 0.3), (0.0, 0.0), span(k), 1e-3,
            notes=f"radial dashpot c = {c:.3g}: relaxation modes at −{c:.3g} and "
                  f"−{k / c:.3g} per second next to the swing."))
    cases.append(Case(
        "separatrix", "pendulum θ0 = π − 1e-8", lambda: scenes.simple_pendulum(m=1.0, l=1.0, g=9.81),
        (math.pi - 1e-8,), (0.0,), 8.0, 1e-3, rtol=1e-10, accept=1e-3,
        notes="it leaves the top after ~6 s; errors grow like e^{ωt} until then."))
    periods = 1_000 if quick else 1_000_000
    cases.append(Case(
        "long_run", f"oscillator, {periods:.0e} periods", lambda: scenes.damped_oscillator(1.0, 1.0, 0.0),
        (1.0,), (0.0,), 2 * math.pi * periods, 2 * math.pi / 32, rtol=1e-10, accept=1e-2,
        measure="energy", exact=oscillator_exact(1.0, 1.0, 0.0, 1.0, 0.0), max_steps=40 * periods,
        notes="checked on the energy: the phase error of every method grows with time, the "
              "orbit must be kept (32 steps per period for the fixed-step methods)."))
    base = (_double(1.0, 1.0, 1.0), (1.0, 0.5), (0.0, 0.0), 5.0)
    for m, l in ((1e-9, 1.0), (1e9, 1.0), (1.0, 1e-6), (1.0, 1e6), (1e9, 1e-6), (1e-9, 1e6)):
        root = math.sqrt(l)
        cases.append(Case(
            f"scale_m{m:.0e}_l{l:.0e}", f"double pendulum m = {m:.0e}, l = {l:.0e}",
            _double(m, m, l), (1.0, 0.5), (0.0, 0.0), 5.0 * root, 1e-3 * root,
            unscale=_unscale_length(l), base=base,
            notes="checked against the unscaled pendulum: θ(t) = θ₁(t/√l), masses drop out."))
    cases.append(Case(
        "ball_tight", "ball in sphere, r1 − r2 = 1e-6 r1",
        lambda: scenes.ball_in_sphere(m=1.0, j=0.4 * (1 - 1e-6) ** 2, r1=1.0, r2=1.0 - 1e-6, g=9.81),
        (0.5,), (0.0,), 0.05, 1e-5,
        notes="M = (m + J/r2²)(r1 − r2)² ≈ 1.4e-12: nearly singular, and ω ≈ 2.6e3 rad/s."))
    cases.append(Case(
        "ball_singular", "ball in sphere, r2 = r1",
        lambda: scenes.ball_in_sphere(m=1.0, j=0.4, r1=1.0, r2=1.0, g=9.81),
        (0.5,), (0.0,), 1.0, 1e-3, notes="M = 0: every method must refuse."))
    cases.append(Case(
        "light_bob", "double pendulum m2/m1 = 1e-9", _double(1.0, 1e-9, 1.0),
        (1.0, 0.5), (0.0, 0.0), 5.0, 1e-3,
        notes="M has condition number ~1e9; the light bob is driven by the heavy one."))
    cases.append(Case(
        "constrained_pendulum", "Cartesian pendulum x² + y² = l², θ0 = 2.5 (constrained)",
        lambda: scenes.cartesian_pendulum(m=1.0, l=1.0, g=9.81),
        (math.sin(2.5), -math.cos(2.5)), (0.0, 0.0), 5.0, 1e-3,
        notes="a constrained model (issue 41): the Runge–Kutta methods and radau5 project each "
              "step back onto the rod, stormer_verlet, yoshida4/6/8 and midpoint step by "
              "RATTLE and the constrained midpoint; the others refuse it (n/a, each with its reason)."))
    kq0, kqd0 = kepler_periapsis(1.0, 1.0, 0.99)
    kepler_steps = 50_000 if quick else 200_000
    cases.append(Case(
        "kepler_e099", "Kepler e = 0.99", lambda: scenes.kepler(m=1.0, mu=1.0), kq0, kqd0,
        2 * math.pi, 2 * math.pi / kepler_steps, rtol=1e-10, accept=1e-3,
        exact=kepler_exact(1.0, 1.0, 0.99),
        notes=f"periapsis r = 0.01 with speed 14: a fixed step must resolve it ({kepler_steps:.0e} "
              "steps per orbit)."))
    cases.append(Case(
        "chaotic", "chaotic double pendulum θ = (2.0, 2.5)", _double(1.0, 1.0, 1.0),
        (2.0, 2.5), (0.0, 0.0), 10.0, 1e-3, chaotic=True,
        notes="errors grow like e^{t/τ} with the Lyapunov time τ (estimated below); past a few τ "
              "the reference runs disagree and the answer is chaotic, not wrong."))
    return cases


# -- running ----------------------------------------------------------------------------------


def _reference(case: Case) -> Tuple[Optional[Reference], str]:
    """The reference for a case and its description (None when no reference can be had)."""
    if case.exact is not None:
        q, qd = case.exact(case.t_end)
        ref = Reference(np.asarray(q, dtype=float), np.asarray(qd, dtype=float), "exact",
                        "exact solution")
        return ref, "exact solution"
    make, q0, qd0, t_end = case.base if case.base is not None else (
        case.make, case.q0, case.qd0, case.t_end)
    try:
        ref = computed_reference(make(), np.asarray(q0, dtype=float), np.asarray(qd0, dtype=float),
                                  0.0, t_end, 20_000_000)
    except (_lagrangian.LagrangianError, ValueError) as e:
        return None, f"none ({type(e).__name__})"
    how = ref.description
    if case.base is not None:
        how = "the unscaled system: " + how
    if ref.agreement is not None:
        how += f"; the two agree to {ref.agreement:.1e}"
    return ref, how


def _lyapunov_time(case: Case) -> Optional[float]:
    """τ = 1/λ from the divergence of two runs started 1e-9 apart (DOP853 at 1e-13)."""
    model = case.make()
    times = np.linspace(0.0, case.t_end, 200)[1:]
    try:
        a = model.simulate(case.q0, case.qd0, case.t_end, method="dop853", rtol=1e-13,
                           atol=1e-13, t_eval=times)
        shifted = np.array(case.q0) + 1e-9
        b = model.simulate(shifted, case.qd0, case.t_end, method="dop853", rtol=1e-13,
                           atol=1e-13, t_eval=times)
    except (_lagrangian.LagrangianError, ValueError):
        return None
    sep = np.hypot(np.linalg.norm(a.q - b.q, axis=1), np.linalg.norm(a.qd - b.qd, axis=1))
    grow = (sep > 1e-8) & (sep < 1e-2)
    if grow.sum() < 5:
        return None
    slope = np.polyfit(times[grow], np.log(sep[grow]), 1)[0]
    return 1.0 / slope if slope > 0 else None


def _energy_change(model: Model, q0: Sequence[float], qd0: Sequence[float], q: np.ndarray,
                   qd: np.ndarray) -> float:
    e0 = float(model.energy(0.0, q0, qd0))
    return abs(float(model.energy(0.0, q, qd)) - e0) / abs(e0)


def _measure(case: Case, model: Model, q: np.ndarray, qd: np.ndarray,
             reference: Optional[Reference], method: str) -> Optional[float]:
    """The case's error of a final state (None without a reference)."""
    if case.measure == "energy":
        return _energy_change(model, case.q0, case.qd0, q, qd)
    if reference is None:
        return None
    if case.unscale is not None:
        q, qd = case.unscale(q, qd)
    q_ref, qd_ref = reference.against(method)
    return state_error(q, qd, q_ref, qd_ref)


def _halved_change(case: Case, model: Model, method: str, q: np.ndarray,
                   qd: np.ndarray) -> Optional[float]:
    """How much the answer changes when ``dt`` is halved (the check a fixed-step user makes),
    in the case's measure; ``None`` when the halved run fails."""
    try:
        sol = model.simulate(case.q0, case.qd0, case.t_end, method=method, dt=case.dt / 2,
                             max_steps=2 * case.max_steps, output_every=FINAL_ONLY)
    except (_lagrangian.LagrangianError, ValueError):
        return None
    q2, qd2 = np.asarray(sol.q[-1]), np.asarray(sol.qd[-1])
    if case.measure == "energy":
        return abs(_energy_change(model, case.q0, case.qd0, q, qd)
                   - _energy_change(model, case.q0, case.qd0, q2, qd2))
    return state_error(q, qd, q2, qd2)


def run_case(case: Case, methods: Sequence[str], reference: Optional[Reference],
             lyapunov_time: Optional[float] = None) -> List[Outcome]:
    """Every method on one case."""
    model = case.make()
    out = []
    for method in methods:
        adaptive = bool(_lagrangian.method_info(method)[1])
        kwargs: Dict[str, Any] = dict(method=method, max_steps=case.max_steps,
                                      output_every=FINAL_ONLY)
        if adaptive:
            kwargs.update(rtol=case.rtol, atol=case.rtol)
        else:
            kwargs["dt"] = case.dt
        start = time.perf_counter()
        try:
            sol = model.simulate(case.q0, case.qd0, case.t_end, **kwargs)
        except (_lagrangian.LagrangianError, ValueError) as e:
            if UNSUPPORTED in str(e):
                out.append(Outcome(case.key, method, "n/a", detail=f"{type(e).__name__}: {e}"))
            else:
                out.append(Outcome(case.key, method, "error", detail=f"{type(e).__name__}: {e}"))
            continue
        seconds = time.perf_counter() - start
        steps = int(sol.stats["accepted_steps"])
        q, qd = np.asarray(sol.q[-1]), np.asarray(sol.qd[-1])
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            out.append(Outcome(case.key, method, "WRONG", math.inf, seconds, steps,
                               "non-finite state returned"))
            continue
        error = _measure(case, model, q, qd, reference, method)
        if error is None:
            out.append(Outcome(case.key, method, "chaotic", math.nan, seconds, steps,
                               "no reference"))
            continue
        status, detail = "solved", ""
        if error > case.accept:
            status = "WRONG"
            if reference is not None and reference.agreement is not None and \
                    reference.agreement > case.accept / 10:
                status, detail = "chaotic", "the reference runs disagree as much"
            elif lyapunov_time is not None and adaptive and \
                    case.rtol * math.exp(case.t_end / lyapunov_time) > case.accept:
                status = "chaotic"
                detail = (f"rtol · e^(t/τ) = {case.rtol * math.exp(case.t_end / lyapunov_time):.1e}"
                          " exceeds the tolerance")
            elif not adaptive:
                change = _halved_change(case, model, method, q, qd)
                if change is None or change > case.accept / 10:
                    status = "coarse"
                    detail = ("halving dt fails" if change is None
                              else f"halving dt changes the answer by {change:.1e}")
        out.append(Outcome(case.key, method, status, error, seconds, steps, detail))
    return out


def check_methods(methods: Sequence[str]) -> List[str]:
    """The canonical names of ``methods`` (aliases such as ``"verlet"`` resolved), or a
    ``ValueError`` naming the first unknown one (or ``"auto"``, which is no one method) and
    listing the known ones: checked before any run."""
    known = [m for m in _lagrangian.methods() if m != "auto"]
    if not methods:
        raise ValueError(f"no methods given; known: {', '.join(known)}")
    names = []
    for name in methods:
        if not isinstance(name, str):
            raise ValueError(f"method {name!r} is not a name; known: {', '.join(known)}")
        try:
            canonical = _lagrangian.method_info(name)[0]
        except ValueError:
            canonical = None
        if canonical is None:
            raise ValueError(f"unknown method {name!r}; known: {', '.join(known)}")
        if canonical == "auto":
            raise ValueError("'auto' picks a method per run; list the methods to compare: "
                             f"{', '.join(known)}")
        names.append(canonical)
    return names


def run_stability(quick: bool = False, methods: Optional[Sequence[str]] = None,
                  cases: Optional[Sequence[str]] = None,
                  progress: Progress = print) -> StabilityMatrix:
    """Run every method on every stability case (``lagrangian stability``). Unknown methods or
    cases are a ``ValueError`` before any run."""
    names = check_methods(methods) if methods is not None else [
        m for m in _lagrangian.methods() if m != "auto"]
    chosen = stability_cases(quick)
    if cases is not None:
        unknown = set(cases) - {c.key for c in chosen}
        if unknown:
            raise ValueError(f"unknown cases {sorted(unknown)}; known: {[c.key for c in chosen]}")
        chosen = [c for c in chosen if c.key in cases]
    outcomes: List[Outcome] = []
    references: Dict[str, str] = {}
    shared: Dict[int, Tuple[Optional[Reference], str]] = {}
    for case in chosen:
        progress(f"  {case.title}")
        if case.measure == "energy":
            ref, how = None, "energy function at the start"
        elif case.base is not None and id(case.base) in shared:
            # The scaled cases share one unscaled reference: compute it once.
            ref, how = shared[id(case.base)]
        else:
            ref, how = _reference(case)
            if case.base is not None:
                shared[id(case.base)] = (ref, how)
        tau = _lyapunov_time(case) if case.chaotic else None
        if tau is not None:
            how += f"; Lyapunov time τ ≈ {tau:.2g} s, so t_end ≈ {case.t_end / tau:.0f} τ"
        references[case.key] = how
        outcomes += run_case(case, names, ref, tau)
    return StabilityMatrix(chosen, names, outcomes, references)
