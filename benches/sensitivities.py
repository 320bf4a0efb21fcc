"""Forward sensitivities (``model.simulate(..., sensitivities=[...])``, issue 42 "Speed"): their
cost against the plain run, against central finite differences of the same accuracy and against
heyoka.py's variational equations, side by side in one run on one machine (ratios, not absolute
claims).

Scenes (the same energies, parameters, initial state and t_end on every side)
    double pendulum   T, U of benches/taylor.py with parameters m1 = m2 = l1 = l2 = 1,
                      g = 9.81; q0 = (1, 0.5), q̇0 = 0, t ∈ [0, 10] (chaotic: the
                      sensitivities grow to about 20). Sensitivities in p = 1 (l1), 2 (l1, g)
                      and 5 (m1, m2, l1, l2, g) parameters.
    forced two-mass   seed eq. 41–44: m = (1, 0.5), k = (10, 5), a force F cos Ωt on mass 1
                      (F = 1, Ω = 2), x0 = (0.1, −0.05), ẋ0 = (0, 0.3), t ∈ [0, 20];
                      sensitivities in p = 2 (k1, k2). heyoka.lagrangian takes L(q, q̇) only,
                      so on heyoka's side the force is added to the accelerations
                      (ẍ1 += F cos(Ω t) / m1, ``heyoka.time``).
    damped oscillator m ẍ + c ẋ + k x = 0 (T = ½ m ẋ², U = ½ k x², D = ½ c ẋ²), m = 1, k = 4,
                      c = 0.3, x0 = 1, ẋ0 = 0, 200 samples on [0, 10]: the fit-like workload.

Reference (the end state and its sensitivities at t_end): heyoka.py's ``var_ode_sys`` of the
same system (parameters as ``heyoka.par``) in extended precision (``np.longdouble``, 80-bit on
x86-64), compact mode, tol 1e-19; its spread against tol 1e-16 is printed, and so is our DOP853
at 1e-14 against it (independent derivations: heyoka differentiates its own equations of
motion). The error of a result is maxᵢ |yᵢ − refᵢ| / max(1, |refᵢ|) over the sensitivities'
entries (the state's entries too in the heyoka table).

Tables
    1. Cost of the sensitivities. Each scene and p, DOP853 at 1e-9 and Taylor at 1e-9 and 1e-12
       (rtol = atol): the time of ``simulate`` with the sensitivities over the time of the same
       call without them (same method, same tolerance), with both runs' steps. The target is
       ≤ 1 + p. Both also with ``sensitivity_error_control=False`` (the step controlled on
       (q, q̇) only). Taylor is timed in its steady state: each program is warmed up past the
       10⁴ expansions after which its expansion is compiled unrolled (src/taylor/kernel.rs,
       ``UNROLL_AFTER``); the ratio before that compile is printed too ("first runs": the best
       run among those before it, the first run excluded).
    2. Against central finite differences of the same accuracy. For each row of table 1 (error
       control on) our sensitivities have an error E against the reference. Central
       differences (x(p + h) − x(p − h)) / 2h take 2p + 1 plain runs (the nominal one gives
       x itself) by the same method; the ladder 10^-(k/2) of tolerances is walked from E
       tighter, and at each rung the steps h = |p|·10^-2 … 10^-7 are tried, each judged
       against the reference (an oracle's choice of h: generous to the differences). The first
       rung where some h reaches E is timed (the 2p + 1 runs, the models rebound with
       ``with_parameters`` beforehand, not timed). "not reached" when no rung down to 1e-15
       does: the best error E' then found is printed, and both sides are compared at E'
       instead (our loosest rung reaching E', the differences' first rung reaching it).
    3. Against heyoka.py, double pendulum, p = 2 and 5: ``heyoka.var_ode_sys(sys, [par...],
       order=1)`` integrated by ``heyoka.taylor_adaptive(var_sys, x0, tol=τ, pars=...,
       compact_mode=False)``. Equal accuracy: for each target error (of the end state and the
       sensitivities) every side runs at the loosest rung of the ladder meeting it. heyoka's
       order is fixed at its build, so each rung is a build: its search starts at our Taylor's
       rung (both choose order and step as Jorba & Zou) and moves a rung at a time. Timed per
       propagate, best of R (rounds alternating between the sides): heyoka's
       ``propagate_until(t_end)`` after resetting time and state (not timed) and reading the
       state; ours the whole ``simulate`` call with its sensitivities read (its fixed cost
       included), Taylor warmed up as in table 1; builds excluded on both sides. heyoka's
       caches of compiled code (memory and disk) are switched off, so every build is real.
       Each side's own price of the sensitivities is printed too: its time over the time of
       its plain system at the same tolerance (heyoka's plain system: the first 2n equations
       of its variational one, built at that tolerance).
       Time to first result: heyoka's ``lagrangian`` + ``var_ode_sys`` + ``taylor_adaptive``
       build + its first propagate, at its rung; ours ``lg.Model(...)`` + the first
       ``simulate`` with the sensitivities (which derives and compiles the variational system
       and the Taylor recurrences), best of R on new models.
    4. The fit-like workload: one ``simulate`` with t_eval = the 200 samples, without and with
       the sensitivities in k and c (DOP853 at 1e-9), and a whole fit of k and c to noisy
       synthetic samples by ``scipy.optimize.least_squares`` with our sensitivities as its
       Jacobian (one ``with_parameters`` + ``simulate`` per evaluation; wall time).

Run from the repository root, with the Python module and heyoka.py installed:

    python3 benches/sensitivities.py [--quick] [--rounds R] [--markdown FILE] [--json FILE]

About 1 minute on a 2-core machine (most of it heyoka's builds: 0.5–9 s each, more under
load); ``--quick`` (p = 1 and 2 on the double pendulum, no Taylor at 1e-12, the heyoka
comparison at 1e-9 and p = 2 only, 3 rounds) about 15 s. Not a test: timings depend on the
machine and its load.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import sys
import time
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

# numpy's BLAS threads spin while idle and would take a core from the runs being timed.
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import lagrangian as lg  # noqa: E402

LADDER: List[float] = [10.0 ** (-k / 2) for k in range(8, 31)]  # 1e-4 … 1e-15
EVERY = 2**62  # output_every: keep only the initial and the final state
UNROLL_AFTER = 10_000  # src/taylor/kernel.rs: expansions before the unrolled compile
MAX_INNER = 20
FD_STEPS = [10.0 ** -k for k in range(2, 8)]
REF_TOL, REF_SPREAD_TOL = 1e-19, 1e-16

Vector = List[float]


# ---------------------------------------------------------------------------------------------
# The scenes, stated once for both sides: `energy(q, v, p, f)` gives (T, U) from coordinates q,
# velocities v, parameters p (lg.parameters or heyoka.par) and functions f (cos).


@dataclass
class Scene:
    name: str
    params: Dict[str, float]
    q0: Vector
    qd0: Vector
    t_end: float
    energy: Callable[..., Tuple[Any, Any]]
    # Generalized forces Q(p, t, f) for ours, the accelerations M⁻¹Q they add for heyoka's.
    forces: Optional[Callable[..., List[Any]]] = None
    accelerations: Optional[Callable[..., List[Any]]] = None
    # The sensitivity sets of table 1.
    sets: List[List[str]] = field(default_factory=list)

    @property
    def dof(self) -> int:
        return len(self.q0)


def double_pendulum(q: Sequence[Any], v: Sequence[Any], p: Dict[str, Any], f: Any
                    ) -> Tuple[Any, Any]:
    th1, th2 = q
    w1, w2 = v
    m1, m2, l1, l2, g = (p[k] for k in ("m1", "m2", "l1", "l2", "g"))
    T = (0.5 * (m1 + m2) * l1**2 * w1**2 + 0.5 * m2 * l2**2 * w2**2
         + m2 * l1 * l2 * w1 * w2 * f.cos(th1 - th2))
    U = -g * ((m1 + m2) * l1 * f.cos(th1) + m2 * l2 * f.cos(th2))
    return T, U


def two_mass(q: Sequence[Any], v: Sequence[Any], p: Dict[str, Any], f: Any) -> Tuple[Any, Any]:
    x1, x2 = q
    v1, v2 = v
    T = 0.5 * p["m1"] * v1**2 + 0.5 * p["m2"] * v2**2
    U = 0.5 * p["k1"] * x1**2 + 0.5 * p["k2"] * (x2 - x1) ** 2
    return T, U


SCENES: Dict[str, Scene] = {
    "double_pendulum": Scene(
        "double_pendulum", dict(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81), [1.0, 0.5], [0.0, 0.0],
        10.0, double_pendulum,
        sets=[["l1"], ["l1", "g"], ["m1", "m2", "l1", "l2", "g"]]),
    "forced_two_mass": Scene(
        "forced_two_mass", dict(m1=1.0, m2=0.5, k1=10.0, k2=5.0, F=1.0, omega=2.0),
        [0.1, -0.05], [0.0, 0.3], 20.0, two_mass,
        forces=lambda p, t, f: [p["F"] * f.cos(p["omega"] * t), 0.0 * t],
        accelerations=lambda p, t, f: [p["F"] / p["m1"] * f.cos(p["omega"] * t), None],
        sets=[["k1", "k2"]]),
}


def our_model(s: Scene) -> Any:
    qs = lg.coordinates(" ".join(f"q{i}" for i in range(s.dof)))
    names = list(s.params)
    p = dict(zip(names, lg.parameters(" ".join(names))))
    T, U = s.energy(qs, [q.d for q in qs], p, lg)
    extra: Dict[str, Any] = {}
    if s.forces is not None:
        extra["forces"] = s.forces(p, lg.t, lg)
    return lg.Model(coordinates=list(qs), kinetic=T, potential=U, parameters=dict(s.params),
                    **extra)


def heyoka_variational(s: Scene, names: Sequence[str]) -> Any:
    """heyoka's equations of motion of `s` (every parameter a ``heyoka.par``, values in the
    order of ``s.params``) and their first-order variational system in `names`."""
    import heyoka as hy

    qs = [hy.make_vars(f"q{i}") for i in range(s.dof)]
    vs = [hy.make_vars(f"v{i}") for i in range(s.dof)]
    order = list(s.params)
    p = {k: hy.par[i] for i, k in enumerate(order)}
    T, U = s.energy(qs, vs, p, SimpleNamespace(cos=hy.cos))
    sys_ = list(hy.lagrangian(T - U, qs, vs))
    if s.accelerations is not None:
        for i, a in enumerate(s.accelerations(p, hy.time, SimpleNamespace(cos=hy.cos))):
            if a is not None:
                var, rhs = sys_[s.dof + i]
                sys_[s.dof + i] = (var, rhs + a)
    return hy.var_ode_sys(sys_, [hy.par[order.index(k)] for k in names], order=1)


def heyoka_plain(s: Scene) -> Any:
    """The variational system's first 2n equations: heyoka's plain system of `s`."""
    return heyoka_variational(s, list(s.params)[:1]).sys[: 2 * s.dof]


def heyoka_layout(ta: Any, n2: int, m: int) -> List[Tuple[int, int, int]]:
    """(state index, coordinate i of (q, q̇), direction j) of each first-order entry."""
    out = []
    for k in range(n2, len(ta.state)):
        idx = [int(x) for x in ta.get_mindex(k)]
        i, d = idx[0], idx[1:]
        assert sum(d) == 1 and len(d) == m, idx
        out.append((k, i, d.index(1)))
    return out


def heyoka_result(ta: Any, layout: List[Tuple[int, int, int]], n2: int, m: int
                  ) -> Tuple[np.ndarray, np.ndarray]:
    """The end state (2n) and the sensitivities (m × 2n) of a heyoka integrator."""
    st = np.asarray(ta.state, dtype=float)
    sens = np.zeros((m, n2))
    for k, i, j in layout:
        sens[j, i] = st[k]
    return st[:n2], sens


# ---------------------------------------------------------------------------------------------
# Measurements


def err(y: Any, ref: Any) -> float:
    y, r = np.asarray(y, dtype=float), np.asarray(ref, dtype=float)
    return float(np.max(np.abs(y - r) / np.maximum(1.0, np.abs(r))))


def best_of(sides: Dict[str, Callable[[], Any]], rounds: int, round_seconds: float
            ) -> Dict[str, float]:
    """The best time of each side, R rounds alternating between the sides (reversed every
    other round); a round repeats a side's short run up to about `round_seconds`."""
    best = {k: math.inf for k in sides}
    keys = list(sides)
    for r in range(rounds):
        for k in (keys if r % 2 == 0 else keys[::-1]):
            f, began, inner = sides[k], time.perf_counter(), 0
            while True:
                start = time.perf_counter()
                f()
                best[k] = min(best[k], time.perf_counter() - start)
                inner += 1
                if inner >= MAX_INNER or time.perf_counter() - began >= round_seconds:
                    break
    return best


class Runner:
    """Our `simulate` on one scene: plain or with sensitivities, final state only."""

    def __init__(self, s: Scene, model: Any) -> None:
        self.s, self.model = s, model
        self.warmed: Dict[Tuple[Any, ...], float] = {}
        self.compile: Dict[Tuple[Any, ...], float] = {}

    def run(self, method: str, tol: float, names: Optional[Sequence[str]] = None,
            control: bool = True, model: Any = None) -> Any:
        kw: Dict[str, Any] = {}
        if names is not None:
            kw = dict(sensitivities=list(names), sensitivity_error_control=control)
        s = self.s
        return (model or self.model).simulate(s.q0, s.qd0, s.t_end, method=method, rtol=tol,
                                              atol=tol, output_every=EVERY, **kw)

    def result(self, sol: Any, names: Sequence[str]) -> Tuple[np.ndarray, np.ndarray]:
        y = np.concatenate([sol.q[-1], sol.qd[-1]])
        return y, np.array([sol.sensitivities[k][-1] for k in names])

    def timed(self, method: str, tol: float, names: Optional[Sequence[str]] = None,
              control: bool = True) -> Callable[[], Any]:
        def go() -> Any:
            sol = self.run(method, tol, names, control)
            if names is None:
                return sol.q[-1], sol.qd[-1]
            return [sol.sensitivities[k][-1] for k in names]
        return go

    def warm(self, method: str, tol: float, names: Optional[Sequence[str]] = None,
             control: bool = True) -> float:
        """Taylor: run until this program has expanded past UNROLL_AFTER at this order; the
        best run before that (the first excluded: it compiles). Others: one run. Returns the
        pre-unroll time (nan for other methods)."""
        key = (method, tol, tuple(names or ()), control)
        if key in self.warmed:
            return self.warmed[key]
        if method != "taylor":
            self.run(method, tol, names, control)
            self.warmed[key] = math.nan
            return math.nan
        steps, first = 0, math.inf
        times: List[float] = []
        while steps <= UNROLL_AFTER + 1 and len(times) < 100_000:
            start = time.perf_counter()
            sol = self.run(method, tol, names, control)
            dt = time.perf_counter() - start
            n = int(sol.stats["accepted_steps"])
            if times and steps + n < UNROLL_AFTER:
                first = min(first, dt)
            times.append(dt)
            steps += n
        for _ in range(3):
            start = time.perf_counter()
            self.run(method, tol, names, control)
            times.append(time.perf_counter() - start)
        # The run that compiled the unrolled expansion, less the fastest (the first run, which
        # compiles the series kernel, excluded).
        self.compile[key] = max(times[1:]) - min(times[1:])
        self.warmed[key] = first
        return first


def steps_of(sol: Any) -> str:
    a, r = int(sol.stats["accepted_steps"]), int(sol.stats["rejected_steps"])
    return f"{a}" + (f" (+{r})" if r else "")


# ---------------------------------------------------------------------------------------------
# Reference: heyoka's variational equations in extended precision


def reference(s: Scene, names: Sequence[str]) -> Dict[str, Any]:
    import heyoka as hy

    L = np.longdouble
    out: Dict[str, Any] = {}
    n2, m = 2 * s.dof, len(names)
    for tol in (REF_TOL, REF_SPREAD_TOL):
        start = time.perf_counter()
        vsys = heyoka_variational(s, names)
        ta = hy.taylor_adaptive(vsys, [L(x) for x in s.q0 + s.qd0], tol=L(tol),
                                pars=[L(v) for v in s.params.values()], compact_mode=True,
                                fp_type=L)
        res = ta.propagate_until(L(s.t_end))
        if "time_limit" not in str(res[0]):
            raise RuntimeError(f"reference: propagate_until ended with {res[0]}")
        y, S = heyoka_result(ta, heyoka_layout(ta, n2, m), n2, m)
        if tol == REF_TOL:
            out.update(y=y, S=S, seconds=time.perf_counter() - start)
        else:
            out["spread"] = max(err(y, out["y"]), err(S, out["S"]))
    out["names"] = list(names)
    return out


def ref_columns(ref: Dict[str, Any], names: Sequence[str]) -> np.ndarray:
    return np.array([ref["S"][ref["names"].index(k)] for k in names])


# ---------------------------------------------------------------------------------------------
# Table 1 and 2: cost against the plain run, and against central differences


def fd_search(r: Runner, method: str, names: Sequence[str], target: float, ref_y: np.ndarray,
              ref_S: np.ndarray) -> Dict[str, Any]:
    """The loosest rung (from `target` tighter) at which central differences with some step h
    reach `target`; the models for each h, the best error seen."""
    s = r.s
    start = min(range(len(LADDER)), key=lambda i: abs(math.log(LADDER[i] / target)))
    best: Tuple[float, Optional[float], Optional[float]] = (math.inf, None, None)
    for i in range(start, len(LADDER)):
        tol = LADDER[i]
        for h_rel in FD_STEPS:
            cols = []
            for k in names:
                h = h_rel * max(abs(s.params[k]), 1e-300)
                up = r.run(method, tol, model=r.model.with_parameters(**{k: s.params[k] + h}))
                dn = r.run(method, tol, model=r.model.with_parameters(**{k: s.params[k] - h}))
                yu = np.concatenate([up.q[-1], up.qd[-1]])
                yd = np.concatenate([dn.q[-1], dn.qd[-1]])
                cols.append((yu - yd) / (2 * h))
            e = err(np.array(cols), ref_S)
            if e < best[0]:
                best = (e, tol, h_rel)
            if e <= target:
                return dict(tol=tol, h=h_rel, error=e, reached=True)
    return dict(tol=None, h=best[2], error=best[0], best_tol=best[1], reached=False)


def fd_timer(r: Runner, method: str, names: Sequence[str], tol: float, h_rel: float
             ) -> Callable[[], Any]:
    s = r.s
    models = [r.model]
    for k in names:
        h = h_rel * abs(s.params[k])
        models += [r.model.with_parameters(**{k: s.params[k] + h}),
                   r.model.with_parameters(**{k: s.params[k] - h})]

    def go() -> Any:
        out = []
        for mdl in models:
            sol = r.run(method, tol, model=mdl)
            out.append((sol.q[-1], sol.qd[-1]))
        return out
    go.models = models  # type: ignore[attr-defined]
    return go


def cost_rows(s: Scene, ref: Dict[str, Any], configs: Sequence[Tuple[str, float]],
              sets: Sequence[Sequence[str]], rounds: int, round_seconds: float
              ) -> List[Dict[str, Any]]:
    rows = []
    for method, tol in configs:
        # A new model per configuration: its Taylor programs have not expanded yet (the
        # differences' runs at other tolerances would have unrolled the plain one's orders).
        r = Runner(s, our_model(s))
        pre_plain = r.warm(method, tol)
        plain_sol = r.run(method, tol)
        for names in sets:
            ref_S = ref_columns(ref, names)
            row: Dict[str, Any] = dict(scene=s.name, method=method, tol=tol, names=list(names),
                                       p=len(names), plain_steps=steps_of(plain_sol))
            pre_sens = r.warm(method, tol, names)
            sides = {"plain": r.timed(method, tol), "sens": r.timed(method, tol, names)}
            sol = r.run(method, tol, names)
            row["sens_steps"] = steps_of(sol)
            row["error"] = err(r.result(sol, names)[1], ref_S)
            if method in ("dop853", "dopri5", "radau5", "taylor"):
                r.warm(method, tol, names, False)
                sides["sens_off"] = r.timed(method, tol, names, False)
                sol_off = r.run(method, tol, names, False)
                row["off_steps"] = steps_of(sol_off)
                row["off_error"] = err(r.result(sol_off, names)[1], ref_S)
            # Central differences reaching our error, by the same method.
            fd = fd_search(r, method, names, row["error"], ref["y"], ref_S)
            row["fd"] = fd
            if fd["reached"]:
                go = fd_timer(r, method, names, fd["tol"], fd["h"])
                if method == "taylor":
                    r.warm(method, fd["tol"])  # the models share the plain program
                go()
                sides["fd"] = go
            else:
                # At the differences' best accuracy instead: our loosest rung reaching it.
                best = fd["error"]

                def ours_err(i: int) -> float:
                    sol = r.run(method, LADDER[i], names)
                    return err(r.result(sol, names)[1], ref_S)
                io, _ = loosest(ours_err, nearest(best), best)
                again = fd_search(r, method, names, best * (1 + 1e-9), ref["y"], ref_S)
                if io is not None and again["reached"]:
                    go = fd_timer(r, method, names, again["tol"], again["h"])
                    if method == "taylor":
                        r.warm(method, again["tol"])
                    r.warm(method, LADDER[io], names)
                    go()
                    sides["fd"] = go
                    sides["sens_at_fd"] = r.timed(method, LADDER[io], names)
                    fd["at_best"] = dict(target=best, ours_tol=LADDER[io], fd_tol=again["tol"],
                                         h=again["h"])
            t = best_of(sides, rounds, round_seconds)
            row.update(plain=t["plain"], sens=t["sens"], ratio=t["sens"] / t["plain"])
            if "sens_off" in t:
                row.update(off=t["sens_off"], off_ratio=t["sens_off"] / t["plain"])
            if "fd" in t:
                fd["seconds"] = t["fd"]
                fd["ratio"] = t["fd"] / t.get("sens_at_fd", t["sens"])
                if "sens_at_fd" in t:
                    fd["at_best"]["ours_seconds"] = t["sens_at_fd"]
            if method == "taylor":
                row["pre_ratio"] = pre_sens / pre_plain
                row["pre_plain"], row["pre_sens"] = pre_plain, pre_sens
                row["unrolled_compile"] = r.compile[(method, tol, tuple(names), True)]
            rows.append(row)
            print(f"  {s.name} {method}@{tol:g} p={len(names)}: ratio {row['ratio']:.2f}",
                  file=sys.stderr, flush=True)
    return rows


# ---------------------------------------------------------------------------------------------
# Table 3: heyoka's var_ode_sys at equal accuracy


def nearest(target: float) -> int:
    return min(range(len(LADDER)), key=lambda i: abs(math.log(LADDER[i] / target)))


def loosest(error_at: Callable[[int], float], start: int, target: float, limit: int = 30
            ) -> Tuple[Optional[int], Dict[int, float]]:
    """The loosest rung meeting `target`, searched from `start`: looser while met, tighter
    until met (at most `limit` evaluations)."""
    seen: Dict[int, float] = {}

    def e(i: int) -> float:
        if i not in seen:
            seen[i] = error_at(i)
        return seen[i]

    i = start
    if e(i) <= target:
        while i > 0 and len(seen) < limit and e(i - 1) <= target:
            i -= 1
        return i, seen
    while i + 1 < len(LADDER) and len(seen) < limit:
        i += 1
        if e(i) <= target:
            return i, seen
    return None, seen


def heyoka_rows(s: Scene, ref: Dict[str, Any], sets: Sequence[Sequence[str]],
                targets: Sequence[float], rounds: int, round_seconds: float,
                budget: float) -> List[Dict[str, Any]]:
    import heyoka as hy

    n2 = 2 * s.dof
    rows = []
    r = Runner(s, our_model(s))
    for names in sets:
        m = len(names)
        ref_all = np.concatenate([ref["y"], ref_columns(ref, names).ravel()])
        builds: Dict[int, Dict[str, Any]] = {}
        spent = 0.0

        def hey(i: int) -> Dict[str, Any]:
            nonlocal spent
            if i not in builds:
                start = time.perf_counter()
                vsys = heyoka_variational(s, names)
                ta = hy.taylor_adaptive(vsys, s.q0 + s.qd0, tol=LADDER[i],
                                        pars=list(s.params.values()), compact_mode=False)
                build = time.perf_counter() - start
                x0 = np.array(ta.state)
                start = time.perf_counter()
                res = ta.propagate_until(s.t_end)
                np.array(ta.state)
                first = time.perf_counter() - start
                y, S = heyoka_result(ta, heyoka_layout(ta, n2, m), n2, m)
                spent += build
                builds[i] = dict(ta=ta, x0=x0, build=build, first=first, order=ta.order,
                                 steps=int(res[3]), error=err(np.concatenate([y, S.ravel()]),
                                                               ref_all))
            return builds[i]

        def ours_error(method: str) -> Callable[[int], float]:
            def f(i: int) -> float:
                y, S = r.result(r.run(method, LADDER[i], names), names)
                return err(np.concatenate([y, S.ravel()]), ref_all)
            return f

        for target in targets:
            row: Dict[str, Any] = dict(names=list(names), p=m, target=target)
            it, _ = loosest(ours_error("taylor"), nearest(target), target)
            idp, _ = loosest(ours_error("dop853"), nearest(target), target)
            ih: Optional[int] = None
            if it is not None and spent < budget:
                def herr(i: int) -> float:
                    if spent >= budget and i not in builds:
                        return math.inf
                    return float(hey(i)["error"])
                ih, _ = loosest(herr, it, target, limit=4)
            elif spent >= budget:
                row["heyoka_stopped"] = "build budget spent"
            sides: Dict[str, Callable[[], Any]] = {}
            if ih is not None:
                b = hey(ih)
                ta, x0 = b["ta"], b["x0"]

                def hgo(ta: Any = ta, x0: Any = x0) -> Any:
                    ta.time = 0.0
                    ta.state[:] = x0
                    ta.propagate_until(s.t_end)
                    return np.array(ta.state)
                hgo()
                sides["heyoka"] = hgo
                row["heyoka"] = dict(tol=LADDER[ih], order=b["order"], steps=b["steps"],
                                     error=b["error"], build=b["build"],
                                     first_result=b["build"] + b["first"])
                # heyoka's own overhead: its plain system at the same tolerance.
                start = time.perf_counter()
                plain = hy.taylor_adaptive(heyoka_plain(s), s.q0 + s.qd0, tol=LADDER[ih],
                                           pars=list(s.params.values()), compact_mode=False)
                spent += time.perf_counter() - start
                px0 = np.array(plain.state)

                def hplain(ta: Any = plain, x0: Any = px0) -> Any:
                    ta.time = 0.0
                    ta.state[:] = x0
                    ta.propagate_until(s.t_end)
                    return np.array(ta.state)
                hplain()
                sides["heyoka_plain"] = hplain
            for label, idx, method in (("taylor", it, "taylor"), ("dop853", idp, "dop853")):
                if idx is None:
                    continue
                r.warm(method, LADDER[idx], names)
                sides[label] = r.timed(method, LADDER[idx], names)
                r.warm(method, LADDER[idx])
                sides[label + "_plain"] = r.timed(method, LADDER[idx])
                sol = r.run(method, LADDER[idx], names)
                y, S = r.result(sol, names)
                row[label] = dict(tol=LADDER[idx], steps=steps_of(sol),
                                  error=err(np.concatenate([y, S.ravel()]), ref_all))
            t = best_of(sides, rounds, round_seconds)
            for label in ("heyoka", "taylor", "dop853"):
                if label in t:
                    row[label]["seconds"] = t[label]
                    row[label]["overhead"] = t[label] / t[label + "_plain"]
            # Ours, time to first result: a new model, its first call (which compiles).
            if it is not None:
                first = math.inf
                for _ in range(rounds):
                    start = time.perf_counter()
                    fresh = our_model(s)
                    sol = fresh.simulate(s.q0, s.qd0, s.t_end, method="taylor", rtol=LADDER[it],
                                         atol=LADDER[it], output_every=EVERY,
                                         sensitivities=list(names))
                    [sol.sensitivities[k][-1] for k in names]
                    first = min(first, time.perf_counter() - start)
                row["taylor"]["first_result"] = first
            rows.append(row)
            print(f"  heyoka p={m} target {target:g} done ({spent:.0f} s of builds)",
                  file=sys.stderr, flush=True)
    return rows


# ---------------------------------------------------------------------------------------------
# Table 4: the fit-like workload


def fit_workload(rounds: int, round_seconds: float) -> Dict[str, Any]:
    from scipy.optimize import least_squares

    (x,) = lg.coordinates("x")
    m, k, c = lg.parameters("m k c")
    true = dict(m=1.0, k=4.0, c=0.3)
    model = lg.Model(coordinates=[x], kinetic=0.5 * m * x.d**2, potential=0.5 * k * x**2,
                     dissipation=0.5 * c * x.d**2, parameters=true)
    t = np.linspace(0.0, 10.0, 200)
    tol = 1e-9

    def sim(mdl: Any, sens: bool) -> Any:
        kw = dict(sensitivities=["k", "c"]) if sens else {}
        return mdl.simulate([1.0], [0.0], 10.0, method="dop853", rtol=tol, atol=tol, t_eval=t,
                            **kw)

    sim(model, True)
    plain_sol, sens_sol = sim(model, False), sim(model, True)
    times = best_of({"plain": lambda: sim(model, False).q,
                     "sens": lambda: sim(model, True).sensitivities["k"]},
                    rounds, round_seconds)
    rng = np.random.default_rng(42)
    sigma = 0.01
    data = sim(model, False).q[:, 0] + sigma * rng.standard_normal(t.size)
    cache: Dict[Tuple[float, float], Any] = {}

    def solve(theta: np.ndarray) -> Any:
        key = (float(theta[0]), float(theta[1]))
        if key not in cache:
            cache.clear()
            cache[key] = sim(model.with_parameters(k=key[0], c=key[1]), True)
        return cache[key]

    def residual(theta: np.ndarray) -> np.ndarray:
        out: np.ndarray = solve(theta).q[:, 0] - data
        return out

    def jacobian(theta: np.ndarray) -> np.ndarray:
        sol = solve(theta)
        return np.stack([sol.sensitivities["k"][:, 0], sol.sensitivities["c"][:, 0]], axis=1)

    fits = []
    for _ in range(rounds):
        cache.clear()
        start = time.perf_counter()
        fit = least_squares(residual, [3.0, 0.5], jac=jacobian, bounds=([0, 0], [np.inf, np.inf]))
        fits.append((time.perf_counter() - start, fit))
    seconds, fit = min(fits, key=lambda f: f[0])
    return dict(plain=times["plain"], sens=times["sens"], ratio=times["sens"] / times["plain"],
                plain_steps=steps_of(plain_sol), sens_steps=steps_of(sens_sol), fit=seconds,
                nfev=int(fit.nfev), njev=int(fit.njev), k=float(fit.x[0]), c=float(fit.x[1]),
                success=bool(fit.success))


# ---------------------------------------------------------------------------------------------
# Output


def ms(seconds: Optional[float]) -> str:
    if seconds is None or not math.isfinite(seconds):
        return "—"
    if seconds < 1e-3:
        return f"{seconds * 1e3:.3f} ms"
    if seconds < 1.0:
        return f"{seconds * 1e3:.2f} ms" if seconds < 0.1 else f"{seconds * 1e3:.0f} ms"
    return f"{seconds:.1f} s"


def fmt_tol(tol: Optional[float]) -> str:
    if tol is None:
        return "—"
    k = -2.0 * math.log10(tol)
    return f"1e-{round(k / 2)}" if round(k) % 2 == 0 else f"{tol:.1e}"


def scene_name(name: str) -> str:
    return name.replace("_", " ")


def table_cost(rows: List[Dict[str, Any]]) -> str:
    lines = ["| scene | method @ tol | p | plain: time (steps) | with sensitivities: time (steps) "
             "| ratio | ≤ 1 + p? | errconS off: time (steps), ratio | error of ∂ (on / off) "
             "| Taylor first runs: ratio (plain, sensitivities; unrolled compile) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        off = (f"{ms(r['off'])} ({r['off_steps']}), {r['off_ratio']:.2f}×" if "off" in r
               else "—")
        errs = f"{r['error']:.1e}" + (f" / {r['off_error']:.1e}" if "off_error" in r else "")
        pre = (f"{r['pre_ratio']:.1f}× ({ms(r['pre_plain'])}, {ms(r['pre_sens'])}; "
               f"{ms(r['unrolled_compile'])})" if "pre_ratio" in r else "—")
        ok = "yes" if r["ratio"] <= 1 + r["p"] else "**no**"
        if "off_ratio" in r and r["ratio"] > 1 + r["p"] and r["off_ratio"] <= 1 + r["p"]:
            ok += " (errconS off: yes)"
        lines.append(
            f"| {scene_name(r['scene'])} | {r['method']} @ {fmt_tol(r['tol'])} | "
            f"{r['p']} ({', '.join(r['names'])}) | {ms(r['plain'])} ({r['plain_steps']}) | "
            f"{ms(r['sens'])} ({r['sens_steps']}) | {r['ratio']:.2f}× | {ok} | {off} | {errs} | "
            f"{pre} |")
    return "\n".join(lines)


def table_fd(rows: List[Dict[str, Any]]) -> str:
    lines = ["| scene | ours: method @ tol | p | error of our ∂ | ours: time | central "
             "differences reaching it: tol, h/|p|, error | FD: time (2p + 1 runs) | FD ÷ ours |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        fd = r["fd"]
        if fd["reached"]:
            how = f"{fmt_tol(fd['tol'])}, {fd['h']:.0e}, {fd['error']:.1e}"
            t, ratio = ms(fd.get("seconds")), (f"{fd['ratio']:.1f}×" if "ratio" in fd else "—")
        else:
            how = (f"not reached (best {fd['error']:.1e} at {fmt_tol(fd.get('best_tol'))}, "
                   f"h/|p| = {fd['h']:.0e})")
            t, ratio = "—", "—"
            b = fd.get("at_best")
            if b is not None and "ours_seconds" in b:
                how += (f"; at that error: FD @ {fmt_tol(b['fd_tol'])}, ours @ "
                        f"{fmt_tol(b['ours_tol'])} {ms(b['ours_seconds'])}")
                t, ratio = ms(fd.get("seconds")), f"{fd['ratio']:.1f}× (at FD's best)"
        lines.append(f"| {scene_name(r['scene'])} | {r['method']} @ {fmt_tol(r['tol'])} | "
                     f"{r['p']} | {r['error']:.1e} | {ms(r['sens'])} | {how} | {t} | {ratio} |")
    return "\n".join(lines)


def table_heyoka(rows: List[Dict[str, Any]]) -> str:
    lines = ["| p | target | heyoka `var_ode_sys`: time @ tol (order, steps; error) | ours "
             "taylor: time @ tol (steps; error) | heyoka ÷ ours taylor | ours dop853: time @ tol "
             "(steps; error) | heyoka ÷ ours dop853 | sensitivities ÷ plain at that tol: heyoka, "
             "ours taylor, ours dop853 | first result: heyoka (build) | first result: ours |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        h, t, d = r.get("heyoka"), r.get("taylor"), r.get("dop853")

        def cell(x: Optional[Dict[str, Any]], extra: str = "") -> str:
            if x is None:
                return "not reached"
            return (f"{ms(x.get('seconds'))} @ {fmt_tol(x['tol'])} ({extra}{x['steps']}; "
                    f"{x['error']:.0e})")

        def ratio(a: Optional[Dict[str, Any]], b: Optional[Dict[str, Any]]) -> str:
            if a is None or b is None:
                return "—"
            return f"{a['seconds'] / b['seconds']:.2f}×"

        hcell = (cell(h, f"{h['order']}, ") if h is not None
                 else r.get("heyoka_stopped", "not reached"))
        first_h = f"{ms(h['first_result'])} ({ms(h['build'])})" if h else "—"
        first_o = ms(t.get("first_result")) if t else "—"
        over = ", ".join(f"{x['overhead']:.2f}×" if x and "overhead" in x else "—"
                         for x in (h, t, d))
        lines.append(f"| {r['p']} ({', '.join(r['names'])}) | {r['target']:g} | {hcell} | "
                     f"{cell(t)} | {ratio(h, t)} | {cell(d)} | {ratio(h, d)} | {over} | "
                     f"{first_h} | {first_o} |")
    return "\n".join(lines)


def table_fit(f: Dict[str, Any]) -> str:
    return "\n".join([
        "| damped oscillator, 200 samples, dop853 @ 1e-9 | time | steps |",
        "|---|---|---|",
        f"| `simulate` | {ms(f['plain'])} | {f['plain_steps']} |",
        f"| `simulate(sensitivities=[\"k\", \"c\"])` | {ms(f['sens'])} ({f['ratio']:.2f}×) | "
        f"{f['sens_steps']} |",
        f"| `least_squares` fit of k, c from (3, 0.5), σ = 0.01 noise | {ms(f['fit'])} | "
        f"{f['nfev']} evaluations, {f['njev']} Jacobians → k = {f['k']:.4f}, c = {f['c']:.4f} "
        f"(true 4, 0.3) |",
    ])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="a subset, about 15 s")
    ap.add_argument("--rounds", type=int, default=None, help="timing rounds (best of); 5, "
                    "quick 3")
    ap.add_argument("--round-seconds", type=float, default=0.02,
                    help=f"repeat short runs within a round to about this long (≤ {MAX_INNER})")
    ap.add_argument("--heyoka-budget", type=float, default=90.0,
                    help="seconds of heyoka builds per sensitivity set of table 3")
    ap.add_argument("--markdown", default=None, help="also write the tables here")
    ap.add_argument("--json", default=None, help="also write the raw measurements here")
    args = ap.parse_args()
    rounds = args.rounds or (3 if args.quick else 5)
    import heyoka as hy

    # Every heyoka build a real one: no compiled code from its caches in memory or on disk.
    hy.llvm_state.set_memcache_limit(0)
    hy.llvm_state.set_diskcache_enabled(False)
    command = "python3 benches/sensitivities.py" + "".join(f" {a}" for a in sys.argv[1:])
    started = time.perf_counter()
    dp, fm = SCENES["double_pendulum"], SCENES["forced_two_mass"]
    configs: List[Tuple[str, float]] = [("dop853", 1e-9), ("taylor", 1e-9)]
    if not args.quick:
        configs.append(("taylor", 1e-12))
    dp_sets = dp.sets[:2] if args.quick else dp.sets

    print("references …", file=sys.stderr, flush=True)
    refs = {dp.name: reference(dp, dp.sets[-1]), fm.name: reference(fm, fm.sets[-1])}
    checks = []
    for s in (dp, fm):
        ref = refs[s.name]
        r = Runner(s, our_model(s))
        names = ref["names"]
        y, S = r.result(r.run("dop853", 1e-14, names), names)
        checks.append(f"- {scene_name(s.name)}: reference heyoka `var_ode_sys` longdouble tol "
                      f"{REF_TOL:g} ({ms(ref['seconds'])}), spread vs tol {REF_SPREAD_TOL:g} "
                      f"{ref['spread']:.1e}; our dop853 @ 1e-14 vs reference: state "
                      f"{err(y, ref['y']):.1e}, sensitivities {err(S, ref['S']):.1e}; largest "
                      f"|∂(q, q̇)/∂p| {np.max(np.abs(ref['S'])):.1f}")

    print("cost and finite differences …", file=sys.stderr, flush=True)
    cost = cost_rows(dp, refs[dp.name], configs, dp_sets, rounds, args.round_seconds)
    cost += cost_rows(fm, refs[fm.name], configs, fm.sets, rounds, args.round_seconds)

    print("heyoka …", file=sys.stderr, flush=True)
    h_sets = [["l1", "g"]] if args.quick else [["l1", "g"], dp.sets[-1]]
    targets = [1e-9] if args.quick else [1e-6, 1e-9, 1e-12]
    hey = heyoka_rows(dp, refs[dp.name], h_sets, targets, rounds, args.round_seconds,
                      args.heyoka_budget)

    print("fit …", file=sys.stderr, flush=True)
    fit = fit_workload(rounds, args.round_seconds)
    total = time.perf_counter() - started

    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    head = (f"`{command}` — {date}, lagrangian {getattr(lg, '__version__', '?')}, heyoka.py "
            f"{hy.__version__}, {platform.machine()} 2-core shared machine, best of {rounds} "
            f"rounds alternating sides; total {total:.0f} s.")
    parts = [
        head,
        "### 1. Cost of p sensitivities against the plain run (same method and tolerance; "
        "target ≤ 1 + p)",
        table_cost(cost),
        "### 2. Against central finite differences of the same accuracy (same method)",
        table_fd(cost),
        "### 3. Against heyoka.py's `var_ode_sys` (first order) at equal accuracy, double "
        "pendulum (error of the end state and its sensitivities ≤ target; builds excluded; "
        "heyoka ÷ ours > 1: ours is faster)",
        table_heyoka(hey),
        "### 4. Fit-like workload",
        table_fit(fit),
        "Checks:\n\n" + "\n".join(checks),
    ]
    text = "\n\n".join(parts)
    print("\n" + text)
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write("# Forward sensitivities: measured ratios (`benches/sensitivities.py`)\n\n"
                    + __doc__.split("\n\n")[0].replace("\n", " ") + "\n\n" + text + "\n")
    if args.json:
        def clean(x: Any) -> Any:
            if isinstance(x, dict):
                return {k: clean(v) for k, v in x.items() if k not in ("ta", "x0")}
            if isinstance(x, (list, tuple)):
                return [clean(v) for v in x]
            if isinstance(x, np.ndarray):
                return x.tolist()
            if isinstance(x, (np.floating, np.integer)):
                return x.item()
            return x
        with open(args.json, "w") as f:
            json.dump(clean(dict(cost=cost, heyoka=hey, fit=fit, checks=checks, seconds=total,
                                 command=command, date=date)), f, indent=1)


if __name__ == "__main__":
    main()
