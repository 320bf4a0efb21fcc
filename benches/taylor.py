"""The Taylor method (``method="taylor"``) against heyoka.py's ``taylor_adaptive``, side by side in
one run on one machine, with our DOP853 as a reference row.

Sides
    heyoka.py
        The system from ``heyoka.lagrangian(L, qs, qdots)`` (parameters as numbers), integrated by
        ``heyoka.taylor_adaptive(sys, x0, tol=τ)`` (default mode, not compact mode). heyoka fixes
        the order from τ when the integrator is built, so every tolerance is a separate build.
        Timed: ``ta.propagate_until(t_end)`` after resetting ``ta.time`` and ``ta.state`` (the
        reset is not timed).
    ours, taylor, Integrator
        ``lg.Model(...)`` from the same energies (parameters as ``lg.parameters`` bound to the
        same values), ``ig = model.integrator(q0, qd0, method="taylor", rtol=τ, atol=τ)``: the
        interface heyoka's is. Timed: ``ig.propagate_until(t_end)`` and the final state read
        (``ig.q``, ``ig.qd``) after resetting ``ig.t``, ``ig.q``, ``ig.qd`` (not timed).
    ours, taylor, simulate
        The same model through ``model.simulate(q0, qd0, t_end, method="taylor", rtol=τ,
        atol=τ, output_every=2**62)``: the whole call is timed, its fixed cost included
        (printed below the table, with the integrator's and heyoka's). ``output_every`` keeps
        only the initial and the final state (the cheapest output holding the end state:
        ``t_eval=[t_end]`` would evaluate the dense output there besides).
    ours, dop853
        The same call with ``method="dop853"``, as a reference row.

Scenes (the same energies, initial state and t_end on every side; those shared with
``benches/compiled_models.py`` use its parameters and initial states, the spans of the two
cheapest doubled so that a run takes 0.1 ms or more at 1e-6)
    double pendulum       unit masses and lengths, g = 9.81, q0 = (1, 0.5), q̇0 = 0, t ∈ [0, 10]
    ball in a sphere      seed eq. 49–53: m = 1, J = 0.016, R₁ = 1, R₂ = 0.2, θ0 = 1, t ∈ [0, 20]
    forced two-mass       seed eq. 41–44: m = (1, 0.5), k = (10, 5), F = (1, 0.5) cos 2t,
                          x0 = (0.1, −0.05), ẋ0 = (0, 0.3), t ∈ [0, 20]. heyoka.lagrangian
                          documents L as depending on qs and qdots only, so its system is the
                          free one and the forcing is added to the accelerations it returns:
                          ẍᵢ += Fᵢ cos(Ω t) / mᵢ with ``heyoka.time`` (M = diag(m₁, m₂) is
                          constant). Ours states the forcing as generalized forces Q.
    Kepler, e = 0.6       polar coordinates, T = ½(ṙ² + r²θ̇²), U = −μ/r, μ = a = 1, from the
                          pericentre r = a(1 − e), θ = 0, ṙ = 0, θ̇ = √(μa(1 − e²))/r²,
                          over 5 periods (t ∈ [0, 10π])
    N-pendulum            N = 4, 8, 16 equal links (m = l = 1, g = 9.81), θᵢ0 = 0.5 sin 0.7i,
                          θ̇ᵢ0 = 0.3 cos 1.3i, t ∈ [0, 2]

References (the end state at t_end)
    Kepler: the orbital elements from the (float64) initial state, Kepler's equation
    E − e sin E = M solved by Newton, then r, θ (unwrapped over the revolutions), ṙ, θ̇ in
    closed form. Forced two-mass: the closed form of src/scenes/forced_two_mass.rs (steady
    response plus modal free vibration). Both are written here once over an arithmetic and
    evaluated in 40-digit mpmath for the reference: in float64 they are off by 1e-15 to 1e-14
    themselves (the phases ωt, the sensitivity of the orbit), which the 1e-15 target would
    feel. Printed: the float64 evaluation's deviation, and the agreement with heyoka in
    extended precision. The other scenes: heyoka in extended precision, compact mode —
    ``real128`` at tol 1e-28 up to two degrees of freedom, ``np.longdouble`` (80-bit on x86-64)
    at tol 1e-19 above (``--reference``) — with its spread against a second run at a 1000×
    looser tolerance printed. The constants of every reference are the float64 values both
    sides use. Sanity check, printed: our DOP853 at 1e-14 against the reference (it should
    agree to about 1e-12). Also printed: the amplification A of an initial perturbation over
    the span (relative change of the end state over a relative 1e-8 change of the initial
    state, by our DOP853): a rounding of 1e-16 anywhere becomes about A·1e-16 at t_end, so a
    target below that is out of reach of any float64 integrator.

Method
    The error of an end state y = (q, q̇) is maxᵢ |yᵢ − refᵢ| / max(1, |refᵢ|). For each target
    (1e-6, 1e-9, 1e-12, 1e-15) every side gets the loosest tolerance of the ladder 1e-4,
    10^-4.5, …, 1e-16 (rtol = atol = τ; heyoka's tol = τ) whose end state is within the target,
    as in ``benches/compiled_models.py``. Because each heyoka tolerance costs a build (seconds
    to minutes for the N-pendulum), the ladder is searched near each target rather than walked
    rung by rung: the search starts at a rung, goes looser while the target is still met and
    tighter until it is met, which finds the loosest rung when the error falls as the
    tolerance tightens. Our sides start at the rung predicted from the previous target (the
    target's own at first). heyoka starts at the rung our Taylor side found (both implement
    Jorba & Zou's order and step: they take the same steps at the same orders, and their end
    states at equal tolerances agree to rounding, printed), and a looser rung is built only
    where our Taylor error there was within 10× of the target. A target no rung meets is "not
    reached", with the best error seen. Then each side is timed at its rung, best of R rounds,
    the rounds alternating between the sides so that a change of load hits all of them; a
    round repeats a short run up to about ``--round-seconds`` (at most 20 times) and keeps the
    best run. A timed run ends with its final state read as arrays (``ig.q`` and ``ig.qd``;
    ``sol.q[-1]`` and ``sol.qd[-1]``, made from the run then; heyoka's ``ta.state``). The times
    include the fixed cost of a call (printed below the table), which weighs on the shortest
    runs: a ``simulate`` also checks its arguments and options and builds a ``Solution``. The
    two taylor sides take the same steps.

Build time (separate column)
    heyoka: ``heyoka.lagrangian`` plus the ``taylor_adaptive`` construction (LLVM JIT; heyoka
    compiles in parallel threads by default), at the rung of that row (the order grows with
    the tolerance, and the build with the order). Each heyoka build runs in a worker process
    (``multiprocessing``, spawn; heyoka's caches of compiled code in memory and on disk
    switched off there, so that every build is a real one) with a hard limit of 150 s: past it
    the worker is terminated and the cell says "did not build in 150 s"; the integrator built
    comes back pickled (heyoka serializes the compiled code, so loading it does not
    recompile). A scene's heyoka builds stop when the next one would likely take them past
    ``--heyoka-budget`` seconds together (spent + last build ≥ budget): the remaining targets
    say "build budget spent".
    Ours: ``lg.Model(...)`` (derivation, and the Cranelift compilation of the accelerations that
    the other methods use) plus the first ``simulate(method="taylor")`` at tol 1e-6 minus a second
    identical call on the same model (the Taylor recurrences are compiled at the first Taylor
    run, for every order at once), best of R, each round on a new model. Once a model has
    expanded 10⁴ times to one order, its whole expansion to that order is compiled unrolled
    (about the break-even of compiling it): our taylor side is warmed up past that at each rung
    before it is timed, so that both sides are timed in their steady state, and that compile
    is printed below the table (slowest warm-up run less the fastest).

Run from the repository root after installing the Python module (``maturin develop --profile
ci`` or ``pip install .``) into an environment with heyoka.py:

    python3 benches/taylor.py [--rounds R] [--scenes a,b,...] [--heyoka-budget S] [--json FILE]

It takes about 7 minutes on a 2-core machine, most of it heyoka's builds for N = 8 and 16 (a
single build for N = 16 at order 8 took about 2 minutes); ``--heyoka-budget 30`` makes it about
2 minutes at the cost of heyoka's tighter targets on those scenes. Not a test: timings depend on
the machine and its load.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing as mp
import multiprocessing.connection
import os
import pickle
import sys
import time
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

# numpy's BLAS threads spin while idle and would take a core from the runs being timed.
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import lagrangian as lg  # noqa: E402

TARGETS: Tuple[float, ...] = (1e-6, 1e-9, 1e-12, 1e-15)
LADDER: List[float] = [10.0 ** (-k / 2) for k in range(8, 33)]  # 1e-4 … 1e-16
# output_every: keep only the initial and the final state.
EVERY = 2**62
BUILD_LIMIT = 150.0  # seconds, one heyoka build
REFERENCE_LIMIT = 150.0  # seconds, one reference run in extended precision
MAX_INNER = 20

Vector = List[float]


# ---------------------------------------------------------------------------------------------
# The scenes, stated once for both sides: `energy(q, v, p, f)` gives (T, U) from coordinates q,
# velocities v, parameters p (lg.parameters, or floats for heyoka) and functions f (cos, sin).


@dataclass
class Scene:
    name: str
    params: Dict[str, float]
    q0: Vector
    qd0: Vector
    t_end: float
    energy: Callable[[Sequence[Any], Sequence[Any], Dict[str, Any], Any], Tuple[Any, Any]]
    # Generalized forces Q(p, t, f), and the accelerations they add, M⁻¹Q (heyoka's side).
    forces: Optional[Callable[[Dict[str, Any], Any, Any], List[Any]]] = None
    accelerations: Optional[Callable[[Dict[str, Any], Any, Any], List[Any]]] = None
    # The exact end state in the arithmetic given (`math` or `mpmath`).
    exact: Optional[Callable[[Any], List[Any]]] = None

    @property
    def dof(self) -> int:
        return len(self.q0)

    @property
    def x0(self) -> Vector:
        return list(self.q0) + list(self.qd0)


def double_pendulum(q: Sequence[Any], v: Sequence[Any], p: Dict[str, Any], f: Any
                    ) -> Tuple[Any, Any]:
    th1, th2 = q
    w1, w2 = v
    m1, m2, l1, l2, g = (p[k] for k in ("m1", "m2", "l1", "l2", "g"))
    T = (0.5 * (m1 + m2) * l1**2 * w1**2 + 0.5 * m2 * l2**2 * w2**2
         + m2 * l1 * l2 * w1 * w2 * f.cos(th1 - th2))
    U = -g * ((m1 + m2) * l1 * f.cos(th1) + m2 * l2 * f.cos(th2))
    return T, U


def ball_in_sphere(q: Sequence[Any], v: Sequence[Any], p: Dict[str, Any], f: Any
                   ) -> Tuple[Any, Any]:
    (th,), (w,) = q, v
    m, j, r1, r2, g = (p[k] for k in ("m", "j", "r1", "r2", "g"))
    T = 0.5 * (m + j / r2**2) * (r1 - r2) ** 2 * w**2
    U = -m * g * (r1 - r2) * f.cos(th)
    return T, U


def two_mass(q: Sequence[Any], v: Sequence[Any], p: Dict[str, Any], f: Any) -> Tuple[Any, Any]:
    x1, x2 = q
    v1, v2 = v
    T = 0.5 * p["m1"] * v1**2 + 0.5 * p["m2"] * v2**2
    U = 0.5 * p["k1"] * x1**2 + 0.5 * p["k2"] * (x2 - x1) ** 2
    return T, U


def two_mass_forces(p: Dict[str, Any], t: Any, f: Any) -> List[Any]:
    c = f.cos(p["omega"] * t)
    return [p["f1"] * c, p["f2"] * c]


def two_mass_accelerations(p: Dict[str, Any], t: Any, f: Any) -> List[Any]:
    c = f.cos(p["omega"] * t)
    return [p["f1"] / p["m1"] * c, p["f2"] / p["m2"] * c]


def kepler(q: Sequence[Any], v: Sequence[Any], p: Dict[str, Any], f: Any) -> Tuple[Any, Any]:
    r, _th = q
    vr, vth = v
    return 0.5 * (vr**2 + r**2 * vth**2), -p["mu"] / r


def n_pendulum(q: Sequence[Any], v: Sequence[Any], p: Dict[str, Any], f: Any
               ) -> Tuple[Any, Any]:
    """A chain of equal links: the bobs at running sums of l (sin θⱼ, −cos θⱼ)."""
    m, l, g = p["m"], p["l"], p["g"]
    y: Any = 0.0
    vx: Any = 0.0
    vy: Any = 0.0
    T: Any = 0.0
    U: Any = 0.0
    for qi, wi in zip(q, v):
        c, s = f.cos(qi), f.sin(qi)
        y = y - l * c
        vx, vy = vx + l * c * wi, vy + l * s * wi
        T = T + 0.5 * m * (vx**2 + vy**2)
        U = U + m * g * y
    return T, U


KEPLER_E = 0.6
KEPLER_PERIODS = 5
EXACT_DIGITS = 40


def kepler_exact(t: float, x0: Sequence[float], mu: float, m: Any = math) -> List[Any]:
    """(r, θ, ṙ, θ̇) at time t of the Kepler orbit through the state x0 = (r, θ, ṙ, θ̇) at t = 0,
    θ unwrapped over the revolutions: the elements from x0, then Kepler's equation
    E − e sin E = M by Newton. `m` is the arithmetic: `math` (float64) or `mpmath`."""
    one = m.mpf(1) if m is not math else 1.0
    r0, th0, rd0, thd0 = (one * x for x in x0)
    mu = one * mu
    h = r0 * r0 * thd0
    energy = (rd0 * rd0 + r0 * r0 * thd0 * thd0) / 2 - mu / r0
    a = -mu / (2 * energy)
    e = m.sqrt(1 - h * h / (mu * a))
    n = m.sqrt(mu / a**3)
    ecc0 = m.atan2(r0 * rd0 / m.sqrt(mu * a), 1 - r0 / a)

    def true_anomaly(ecc: Any) -> Any:
        return 2 * m.atan2(m.sqrt(1 + e) * m.sin(ecc / 2), m.sqrt(1 - e) * m.cos(ecc / 2))

    omega = th0 - true_anomaly(ecc0)
    mean = ecc0 - e * m.sin(ecc0) + n * t
    turns = m.floor((mean + m.pi) / (2 * m.pi))
    mm = mean - 2 * m.pi * turns  # in [−π, π)
    # Newton from E = M + e sin M, which converges for e < 1.
    eps = one * (2.0**-52 if m is math else m.mpf(10) ** (-m.mp.dps))
    ecc = mm + e * m.sin(mm)
    for _ in range(100):
        step = (ecc - e * m.sin(ecc) - mm) / (1 - e * m.cos(ecc))
        ecc -= step
        if abs(step) <= 4 * eps * max(one, abs(ecc)):
            break
    r = a * (1 - e * m.cos(ecc))
    return [r, omega + true_anomaly(ecc) + 2 * m.pi * turns, m.sqrt(mu * a) * e * m.sin(ecc) / r,
            h / (r * r)]


def forced_exact(t: float, x0: Sequence[float], p: Dict[str, float], m: Any = math
                 ) -> List[Any]:
    """(x, ẋ) at time t of seed eq. 43–44 from x0 = (x, ẋ) at t = 0: the steady response
    X cos Ωt with (K − Ω² M) X = F, plus the modal free vibration matching x0 (the closed form
    of src/scenes/forced_two_mass.rs). `m` is the arithmetic: `math` (float64) or `mpmath`."""
    one = m.mpf(1) if m is not math else 1.0
    m1, m2, k1, k2, f1, f2, om = (one * p[k] for k in ("m1", "m2", "k1", "k2", "f1", "f2",
                                                       "omega"))
    t = one * t
    b = m1 * k2 + m2 * (k1 + k2)
    root = m.sqrt(b * b - 4 * m1 * m2 * k1 * k2)
    w2_high = (b + root) / (2 * m1 * m2)
    w2_low = k1 * k2 / (m1 * m2 * w2_high)
    w2 = om * om
    aa, bb, dd = k1 + k2 - w2 * m1, -k2, k2 - w2 * m2
    det = aa * dd - bb * bb
    amp = [(dd * f1 - bb * f2) / det, (aa * f2 - bb * f1) / det]
    x = [amp[0] * m.cos(om * t), amp[1] * m.cos(om * t)]
    v = [-amp[0] * om * m.sin(om * t), -amp[1] * om * m.sin(om * t)]
    dx = [one * x0[0] - amp[0], one * x0[1] - amp[1]]
    v0 = [one * x0[2], one * x0[3]]
    for wi in (m.sqrt(w2_low), m.sqrt(w2_high)):
        r = (k1 + k2 - wi * wi * m1) / k2
        norm = m1 + m2 * r * r
        a = (m1 * dx[0] + m2 * r * dx[1]) / norm
        bi = (m1 * v0[0] + m2 * r * v0[1]) / (norm * wi)
        c, s = m.cos(wi * t), m.sin(wi * t)
        mode_x, mode_v = a * c + bi * s, wi * (bi * c - a * s)
        x = [x[0] + mode_x, x[1] + r * mode_x]
        v = [v[0] + mode_v, v[1] + r * mode_v]
    return x + v


def precise(f: Callable[[Any], List[Any]]) -> Vector:
    """f evaluated with mpmath at EXACT_DIGITS digits, rounded to float64."""
    import mpmath

    with mpmath.workdps(EXACT_DIGITS):
        return [float(x) for x in f(mpmath)]


def make_scenes() -> Dict[str, Scene]:
    out: Dict[str, Scene] = {}
    out["double_pendulum"] = Scene(
        "double_pendulum", dict(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81),
        [1.0, 0.5], [0.0, 0.0], 10.0, double_pendulum)
    out["ball_in_sphere"] = Scene(
        "ball_in_sphere", dict(m=1.0, j=0.016, r1=1.0, r2=0.2, g=9.81),
        [1.0], [0.0], 20.0, ball_in_sphere)
    forced = Scene(
        "forced_two_mass", dict(m1=1.0, m2=0.5, k1=10.0, k2=5.0, f1=1.0, f2=0.5, omega=2.0),
        [0.1, -0.05], [0.0, 0.3], 20.0, two_mass, forces=two_mass_forces,
        accelerations=two_mass_accelerations)
    forced.exact = lambda m: forced_exact(forced.t_end, forced.x0, forced.params, m)
    out["forced_two_mass"] = forced
    e, a, mu = KEPLER_E, 1.0, 1.0
    r0 = a * (1.0 - e)
    kep = Scene(
        "kepler", dict(mu=mu), [r0, 0.0], [0.0, math.sqrt(mu * a * (1.0 - e * e)) / r0**2],
        KEPLER_PERIODS * 2.0 * math.pi * math.sqrt(a**3 / mu), kepler)
    kep.exact = lambda m: kepler_exact(kep.t_end, kep.x0, kep.params["mu"], m)
    out["kepler"] = kep
    for n in (4, 8, 16):
        out[f"n_pendulum_{n}"] = Scene(
            f"n_pendulum_{n}", dict(m=1.0, l=1.0, g=9.81),
            [0.5 * math.sin(0.7 * i) for i in range(n)],
            [0.3 * math.cos(1.3 * i) for i in range(n)], 2.0, n_pendulum)
    return out


SCENES = make_scenes()


# ---------------------------------------------------------------------------------------------
# heyoka's side: systems, and the worker process that builds them under a time limit


def heyoka_system(s: Scene) -> List[Tuple[Any, Any]]:
    import heyoka as hy

    qs = [hy.make_vars(f"q{i}") for i in range(s.dof)]
    vs = [hy.make_vars(f"v{i}") for i in range(s.dof)]
    f = SimpleNamespace(cos=hy.cos, sin=hy.sin)
    T, U = s.energy(qs, vs, s.params, f)
    sys_ = list(hy.lagrangian(T - U, qs, vs))
    if s.accelerations is not None:
        extra = s.accelerations(s.params, hy.time, f)
        for i, a in enumerate(extra):
            var, rhs = sys_[s.dof + i]
            sys_[s.dof + i] = (var, rhs + a)
    return sys_


def _worker(conn: multiprocessing.connection.Connection) -> None:
    """Serve ("build", scene, tol) and ("reference", scene, fp, tol) until None."""
    import heyoka as hy

    # Every build a real one: no compiled code from heyoka's caches in memory or on disk.
    hy.llvm_state.set_memcache_limit(0)
    hy.llvm_state.set_diskcache_enabled(False)
    while True:
        try:
            msg = conn.recv()
        except EOFError:
            return
        if msg is None:
            return
        try:
            s = SCENES[msg[1]]
            if msg[0] == "build":
                tol = msg[2]
                start = time.perf_counter()
                ta = hy.taylor_adaptive(heyoka_system(s), s.x0, tol=tol)
                seconds = time.perf_counter() - start
                conn.send(("ok", pickle.dumps(ta), seconds, ta.order))
            elif msg[0] == "reference":
                fp, tol = msg[2], msg[3]
                conv: Callable[[Any], Any]
                if fp == "real128":
                    conv, fp_type = hy.real128, hy.real128
                else:
                    conv, fp_type = np.longdouble, np.longdouble
                start = time.perf_counter()
                ta = hy.taylor_adaptive(heyoka_system(s), [conv(x) for x in s.x0],
                                        tol=conv(tol), fp_type=fp_type, compact_mode=True)
                out = ta.propagate_until(conv(s.t_end))
                if str(out[0]) != "taylor_outcome.time_limit":
                    raise RuntimeError(f"propagate_until ended with {out[0]}")
                conn.send(("ok", [float(x) for x in ta.state], time.perf_counter() - start,
                           ta.order))
            else:
                conn.send(("error", f"unknown request {msg[0]!r}"))
        except Exception as e:  # noqa: BLE001 - reported to the caller
            conn.send(("error", f"{type(e).__name__}: {e}"))


class TimedOut(Exception):
    pass


class Worker:
    """One heyoka worker process; a request that takes longer than its limit terminates it."""

    def __init__(self) -> None:
        self.proc: Optional[Any] = None
        self.conn: Optional[multiprocessing.connection.Connection] = None

    def _start(self) -> None:
        ctx = mp.get_context("spawn")
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_worker, args=(child,), daemon=True)
        self.proc.start()
        child.close()

    def ask(self, msg: Tuple[Any, ...], limit: float) -> Tuple[Any, ...]:
        if self.proc is None or not self.proc.is_alive():
            self._start()
        assert self.conn is not None
        self.conn.send(msg)
        if not self.conn.poll(limit):
            self.stop(force=True)
            raise TimedOut(f"no answer in {limit:.0f} s")
        try:
            answer: Tuple[Any, ...] = self.conn.recv()
        except EOFError:
            self.stop(force=True)
            return ("error", "the heyoka worker process died")
        return answer

    def stop(self, force: bool = False) -> None:
        if self.proc is None:
            return
        if not force and self.proc.is_alive() and self.conn is not None:
            try:
                self.conn.send(None)
            except OSError:
                pass
            self.proc.join(10)
        if self.proc.is_alive():
            self.proc.terminate()
            self.proc.join(10)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join(10)
        if self.conn is not None:
            self.conn.close()
        self.proc, self.conn = None, None


# ---------------------------------------------------------------------------------------------
# Our side


def our_model(s: Scene) -> Any:
    qs = lg.coordinates(" ".join(f"q{i}" for i in range(s.dof)))
    names = list(s.params)
    syms = lg.parameters(" ".join(names))
    p = dict(zip(names, syms))
    T, U = s.energy(qs, [q.d for q in qs], p, lg)
    extra: Dict[str, Any] = {}
    if s.forces is not None:
        extra["forces"] = s.forces(p, lg.t, lg)
    return lg.Model(coordinates=list(qs), kinetic=T, potential=U, parameters=dict(s.params),
                    **extra)


def error(end: Sequence[float], ref: Sequence[float]) -> float:
    y, r = np.asarray(end, dtype=float), np.asarray(ref, dtype=float)
    return float(np.max(np.abs(y - r) / np.maximum(1.0, np.abs(r))))


# ---------------------------------------------------------------------------------------------
# Runs, the ladder search and the timing


@dataclass
class Result:
    """One run (or the best of several) at one tolerance."""
    seconds: float
    end: Optional[Vector]
    error: Optional[float]
    steps: int = 0
    failure: Optional[str] = None
    build: Optional[float] = None  # heyoka: the build at this tolerance
    order: Optional[int] = None


class Side:
    """A way to integrate a scene; `run(i, inner)` at LADDER[i], best of `inner` runs."""

    label = ""

    def __init__(self, scene: Scene, ref: Vector) -> None:
        self.scene = scene
        self.ref = ref
        self.stopped: Optional[str] = None  # why no further tolerance can be tried

    def run(self, i: int, inner: int) -> Result:
        raise NotImplementedError


# A model's Taylor expansions to one order run order by order until it has expanded to that
# order this many times, then the whole expansion is compiled unrolled (`UNROLL_AFTER` in
# src/taylor/kernel.rs, about the break-even of compiling).
UNROLL_AFTER = 10_000


class Ours(Side):
    """`model.simulate`, or with ``integrator=True`` a `model.integrator` per rung, reset to the
    initial state (not timed, as heyoka's reset is not) and ``propagate_until(t_end)``."""

    def __init__(self, scene: Scene, ref: Vector, model: Any, method: str,
                 integrator: bool = False,
                 warm: Optional[Dict[int, Tuple[int, float]]] = None) -> None:
        super().__init__(scene, ref)
        self.model, self.method = model, method
        self.label = f"ours {method}" + (" integrator" if integrator else "")
        self.integrators: Optional[Dict[int, Any]] = {} if integrator else None
        # Per rung, for taylor: the warm-up's runs and its estimate of the unrolled compile
        # (shared by the sides of one model: its expansions are compiled once).
        self.warm: Dict[int, Tuple[int, float]] = {} if warm is None else warm

    def warm_up(self, i: int) -> None:
        """Run taylor at rung i until the model has expanded UNROLL_AFTER times there (each
        accepted step is one expansion), so that the timed runs are the steady state heyoka's
        are (its compilation is not timed either). The compile is estimated as the slowest
        warm-up run less the fastest."""
        s, tol = self.scene, LADDER[i]
        steps, times = 0, []
        while steps <= UNROLL_AFTER and len(times) < 100_000:
            start = time.perf_counter()
            sol = self.model.simulate(s.q0, s.qd0, s.t_end, method=self.method, rtol=tol,
                                      atol=tol, output_every=EVERY)
            times.append(time.perf_counter() - start)
            steps += int(sol.stats["accepted_steps"])
        for _ in range(3):
            start = time.perf_counter()
            self.model.simulate(s.q0, s.qd0, s.t_end, method=self.method, rtol=tol, atol=tol,
                                output_every=EVERY)
            times.append(time.perf_counter() - start)
        self.warm[i] = (len(times), max(times) - min(times))

    def run(self, i: int, inner: int) -> Result:
        s, tol = self.scene, LADDER[i]
        if self.method == "taylor" and i not in self.warm:
            try:
                self.warm_up(i)
            except (lg.LagrangianError, ValueError):
                self.warm[i] = (0, 0.0)
        if self.integrators is not None:
            return self.propagate(i, inner)
        best = math.inf
        for _ in range(max(1, inner)):
            start = time.perf_counter()
            try:
                sol = self.model.simulate(s.q0, s.qd0, s.t_end, method=self.method, rtol=tol,
                                          atol=tol, output_every=EVERY)
                q, qd = sol.q[-1], sol.qd[-1]
            except (lg.LagrangianError, ValueError) as e:
                return Result(math.inf, None, None, failure=f"{type(e).__name__}: {e}")
            best = min(best, time.perf_counter() - start)
        end = [float(x) for x in q] + [float(x) for x in qd]
        return Result(best, end, error(end, self.ref), steps=int(sol.stats["accepted_steps"]))

    def propagate(self, i: int, inner: int) -> Result:
        s, tol = self.scene, LADDER[i]
        assert self.integrators is not None
        try:
            if i not in self.integrators:
                self.integrators[i] = self.model.integrator(s.q0, s.qd0, method=self.method,
                                                            rtol=tol, atol=tol)
            ig = self.integrators[i]
            best = math.inf
            for _ in range(max(1, inner)):
                ig.t, ig.q, ig.qd = 0.0, s.q0, s.qd0
                start = time.perf_counter()
                ig.propagate_until(s.t_end)
                q, qd = ig.q, ig.qd
                best = min(best, time.perf_counter() - start)
        except (lg.LagrangianError, ValueError) as e:
            return Result(math.inf, None, None, failure=f"{type(e).__name__}: {e}")
        end = [float(x) for x in q] + [float(x) for x in qd]
        return Result(best, end, error(end, self.ref), steps=int(ig.stats["accepted_steps"]))


class Heyoka(Side):
    label = "heyoka"

    def __init__(self, scene: Scene, ref: Vector, worker: Worker, budget: float) -> None:
        super().__init__(scene, ref)
        self.worker, self.budget, self.spent, self.last = worker, budget, 0.0, 0.0
        self.built: Dict[int, Tuple[Any, float, int]] = {}

    def integrator(self, i: int) -> Optional[Tuple[Any, float, int]]:
        if i in self.built:
            return self.built[i]
        if self.stopped is not None:
            return None
        if self.spent + self.last >= self.budget:
            # The next build would likely end past the budget (builds grow with the order).
            self.stopped = f"build budget of {self.budget:.0f} s spent"
            return None
        start = time.perf_counter()
        try:
            answer = self.worker.ask(("build", self.scene.name, LADDER[i]), BUILD_LIMIT)
        except TimedOut:
            self.stopped = f"did not build in {BUILD_LIMIT:.0f} s"
            print(f"  heyoka at tol {LADDER[i]:.3g}: {self.stopped}", file=sys.stderr,
                  flush=True)
            return None
        finally:
            self.spent += time.perf_counter() - start
        if answer[0] != "ok":
            self.stopped = f"build failed: {answer[1]}"
            return None
        _, blob, seconds, order = answer
        self.last = seconds
        self.built[i] = (pickle.loads(blob), seconds, order)
        print(f"  heyoka built at tol {LADDER[i]:.3g} (order {order}) in {seconds:.2f} s",
              file=sys.stderr, flush=True)
        return self.built[i]

    def run(self, i: int, inner: int) -> Result:
        got = self.integrator(i)
        if got is None:
            return Result(math.inf, None, None, failure=self.stopped)
        ta, build, order = got
        s = self.scene
        x0 = np.asarray(s.x0, dtype=float)
        best = math.inf
        out: Any = None
        for _ in range(max(1, inner)):
            ta.time = 0.0
            ta.state[:] = x0
            start = time.perf_counter()
            out = ta.propagate_until(s.t_end)
            state = ta.state
            best = min(best, time.perf_counter() - start)
        if str(out[0]) != "taylor_outcome.time_limit":
            return Result(math.inf, None, None, failure=f"propagate_until: {out[0]}",
                          build=build, order=order)
        end = [float(x) for x in state]
        return Result(best, end, error(end, self.ref), steps=int(out[3]), build=build,
                      order=order)


def rung(tol: float) -> int:
    return min(range(len(LADDER)), key=lambda i: abs(math.log10(LADDER[i] / tol)))


def search(side: Side, start: Optional[Dict[float, Optional[int]]] = None,
           worth: Optional[Callable[[int, float], bool]] = None
           ) -> Tuple[Dict[float, Optional[int]], Dict[int, Result]]:
    """For each target the loosest rung meeting it (None if none does), searched near the target
    (see the module docstring), and every run made. `start` gives the rung to start from per
    target (else the target's own, shifted as the previous target's was); `worth(i, target)`
    whether a looser rung i is worth trying (else every one is)."""
    tried: Dict[int, Result] = {}

    def err(i: int) -> float:
        if i not in tried:
            tried[i] = side.run(i, 1)
            r = tried[i]
            if r.failure:
                print(f"  {side.label} at tol {LADDER[i]:.3g}: {r.failure}", file=sys.stderr,
                      flush=True)
        e = tried[i].error
        return math.inf if e is None else e

    found: Dict[float, Optional[int]] = {}
    shift = 0
    for target in TARGETS:
        first = None if start is None else start.get(target)
        i = first if first is not None else max(0, min(len(LADDER) - 1, rung(target) + shift))
        if err(i) <= target:
            while i > 0 and (worth is None or worth(i - 1, target)) and err(i - 1) <= target:
                i -= 1
        else:
            while i + 1 < len(LADDER) and err(i) > target and side.stopped is None:
                i += 1
        if err(i) <= target:
            found[target] = i
            shift = i - rung(target)
        else:
            found[target] = None
    return found, tried


def best_error(tried: Dict[int, Result]) -> Optional[float]:
    errors = [r.error for r in tried.values() if r.error is not None]
    return min(errors) if errors else None


def time_sides(sides: List[Side], found: Dict[str, Dict[float, Optional[int]]],
               tried: Dict[str, Dict[int, Result]], rounds: int, round_seconds: float
               ) -> Dict[Tuple[str, float], Result]:
    """Best of `rounds` rounds per side and target, the rounds alternating between the sides."""
    timings: Dict[Tuple[str, float], Result] = {}
    for target in TARGETS:
        for _ in range(rounds):
            for side in sides:
                i = found[side.label][target]
                if i is None:
                    continue
                once = tried[side.label][i].seconds
                inner = max(1, min(MAX_INNER, int(round_seconds / max(once, 1e-9))))
                r = side.run(i, inner)
                key = (side.label, target)
                if key not in timings or r.seconds < timings[key].seconds:
                    timings[key] = r
    return timings


def our_build(s: Scene, rounds: int) -> Tuple[float, float, float]:
    """Best of `rounds`: (model + Taylor compilation, model alone, Taylor compilation)."""
    best = (math.inf, math.inf, math.inf)
    for _ in range(rounds):
        t0 = time.perf_counter()
        model = our_model(s)
        t1 = time.perf_counter()
        model.simulate(s.q0, s.qd0, s.t_end, method="taylor", rtol=1e-6, atol=1e-6,
                       output_every=EVERY)
        t2 = time.perf_counter()
        model.simulate(s.q0, s.qd0, s.t_end, method="taylor", rtol=1e-6, atol=1e-6,
                       output_every=EVERY)
        t3 = time.perf_counter()
        compile_ = max(0.0, (t2 - t1) - (t3 - t2))
        total = (t1 - t0) + compile_
        if total < best[0]:
            best = (total, t1 - t0, compile_)
    return best


# ---------------------------------------------------------------------------------------------
# One scene


def reference(s: Scene, worker: Worker, precision: str) -> Dict[str, Any]:
    """The reference end state and how far it can be trusted."""
    out: Dict[str, Any] = {}
    if precision == "auto":
        precision = "real128" if s.dof <= 2 else "longdouble"
    tight = 1e-28 if precision == "real128" else 1e-19
    hey: List[Optional[Vector]] = []
    for tol in (tight, tight * 1e3) if s.exact is None else (tight,):
        try:
            ans = worker.ask(("reference", s.name, precision, tol), REFERENCE_LIMIT)
        except TimedOut:
            ans = ("error", f"did not finish in {REFERENCE_LIMIT:.0f} s")
        if ans[0] == "ok":
            hey.append(ans[1])
            print(f"  heyoka {precision} reference at tol {tol:g} (order {ans[3]}): "
                  f"{ans[2]:.2f} s", file=sys.stderr, flush=True)
        else:
            hey.append(None)
            out["heyoka_reference_failure"] = ans[1]
            print(f"  heyoka {precision} reference at tol {tol:g}: {ans[1]}", file=sys.stderr,
                  flush=True)
    if s.exact is not None:
        exact = s.exact
        out["kind"] = f"exact ({EXACT_DIGITS} digits)"
        out["state"] = precise(exact)
        out["float64_exact_vs_exact"] = error(exact(math), out["state"])
        if hey[0] is not None:
            out["exact_vs_heyoka"] = error(hey[0], out["state"])
        out["heyoka_precision"] = precision
    elif hey[0] is not None:
        out["kind"] = f"heyoka {precision}, tol {tight:g}, compact mode"
        out["state"] = hey[0]
        if hey[1] is not None:
            out["spread"] = error(hey[1], hey[0])
    else:
        # No extended-precision reference: our DOP853 at 1e-15 stands in (the 1e-15 target is
        # then not meaningful).
        sol = our_model(s).simulate(s.q0, s.qd0, s.t_end, method="dop853", rtol=1e-15,
                                    atol=1e-15, output_every=EVERY)
        out["kind"] = "our DOP853 at 1e-15 (fallback: no heyoka reference)"
        out["state"] = [float(x) for x in sol.q[-1]] + [float(x) for x in sol.qd[-1]]
    return out


def amplification(model: Any, s: Scene) -> float:
    """Relative change of the end state over a relative 1e-8 change of the initial state."""
    delta = 1e-8

    def end(q0: Vector, qd0: Vector) -> Vector:
        sol = model.simulate(q0, qd0, s.t_end, method="dop853", rtol=1e-13, atol=1e-13,
                             output_every=EVERY)
        return [float(x) for x in sol.q[-1]] + [float(x) for x in sol.qd[-1]]

    base = end(s.q0, s.qd0)
    bump = [x + delta * max(1.0, abs(x)) * (1 if k % 2 == 0 else -1)
            for k, x in enumerate(s.x0)]
    return error(end(bump[: s.dof], bump[s.dof:]), base) / delta


def measure(s: Scene, worker: Worker, rounds: int, round_seconds: float, budget: float,
            precision: str) -> Dict[str, Any]:
    row: Dict[str, Any] = {"scene": s.name, "dof": s.dof, "t_end": s.t_end, "q0": s.q0,
                           "qd0": s.qd0, "params": s.params}
    build, build_model, build_taylor = our_build(s, rounds)
    row["build_ours"] = {"total": build, "model": build_model, "taylor_kernel": build_taylor}
    model = our_model(s)
    ref = reference(s, worker, precision)
    row["reference"] = ref
    r = Ours(s, ref["state"], model, "dop853").run(rung(1e-14), 1)
    row["dop853_1e-14_vs_reference"] = r.error
    row["amplification"] = amplification(model, s)
    taylor = Ours(s, ref["state"], model, "taylor")
    sides: List[Side] = [Heyoka(s, ref["state"], worker, budget), taylor,
                         Ours(s, ref["state"], model, "dop853"),
                         Ours(s, ref["state"], model, "taylor", integrator=True,
                              warm=taylor.warm)]
    found: Dict[str, Dict[float, Optional[int]]] = {}
    tried: Dict[str, Dict[int, Result]] = {}
    for side in sides[1:]:
        found[side.label], tried[side.label] = search(side)
    # heyoka: every rung is a build. Start where our Taylor side met the target (the two take
    # the same steps at the same orders), and build a looser rung only where our Taylor error
    # there was within 10× of the target.
    ours_taylor, ours_tried = sides[1], tried["ours taylor"]

    def worth(i: int, target: float) -> bool:
        if i not in ours_tried:
            ours_tried[i] = ours_taylor.run(i, 1)
        e = ours_tried[i].error
        return e is not None and e <= 10.0 * target

    found["heyoka"], tried["heyoka"] = search(sides[0], found["ours taylor"], worth)
    # The two Taylor sides integrate the same system: their end states at equal tolerances, the
    # loosest and the tightest both ran (no extra heyoka build).
    agree: Dict[str, float] = {}
    common = sorted(i for i, a in tried["heyoka"].items()
                    if a.end is not None and i in tried["ours taylor"]
                    and tried["ours taylor"][i].end is not None)
    for i in sorted({common[0], common[-1]}) if common else []:
        a, b = tried["heyoka"][i].end, tried["ours taylor"][i].end
        assert a is not None and b is not None
        agree[fmt_tol(LADDER[i])] = error(a, b)
    row["heyoka_vs_ours_taylor"] = agree
    timings = time_sides(sides, found, tried, rounds, round_seconds)
    assert isinstance(ours_taylor, Ours)
    row["unrolled_compile"] = {fmt_tol(LADDER[i]): c for i, (n, c) in
                               sorted(ours_taylor.warm.items()) if n}
    cells: Dict[str, Dict[str, Any]] = {}
    for side in sides:
        for target in TARGETS:
            at = found[side.label][target]
            cell: Dict[str, Any] = {"tol": None if at is None else LADDER[at]}
            if at is None:
                cell["best_error"] = best_error(tried[side.label])
                cell["stopped"] = side.stopped
                failures = {r.failure for r in tried[side.label].values() if r.failure}
                cell["failures"] = sorted(failures)
            else:
                t = timings[(side.label, target)]
                first = tried[side.label][at]
                cell.update(seconds=t.seconds, error=first.error, steps=first.steps,
                            build=first.build, order=first.order)
            cells[f"{side.label}@{target:g}"] = cell
    row["cells"] = cells
    row["failures"] = {side.label: sorted({r.failure for r in tried[side.label].values()
                                           if r.failure}) for side in sides}
    row["heyoka_build_seconds_spent"] = sides[0].spent  # type: ignore[attr-defined]
    row["tried"] = {side.label: {f"{LADDER[i]:.3g}": r.error for i, r in
                                 sorted(tried[side.label].items())} for side in sides}
    return row


# ---------------------------------------------------------------------------------------------
# The table


def ms(seconds: Optional[float]) -> str:
    if seconds is None or not math.isfinite(seconds):
        return "—"
    if seconds < 1e-3:
        return f"{seconds * 1e3:.3f} ms"
    if seconds < 1.0:
        return f"{seconds * 1e3:.2f} ms" if seconds < 0.1 else f"{seconds * 1e3:.0f} ms"
    return f"{seconds:.1f} s"


def fmt_tol(tol: float) -> str:
    k = -2.0 * math.log10(tol)
    return f"1e-{round(k / 2)}" if round(k) % 2 == 0 else f"{tol:.1e}"


def cell_text(cell: Dict[str, Any]) -> str:
    if cell["tol"] is None:
        best = cell.get("best_error")
        stopped: Optional[str] = cell.get("stopped")
        if stopped:
            return stopped + ("" if best is None else f" (best error so far {best:.1e})")
        return "not reached" + ("" if best is None else f" (best {best:.1e})")
    return f"{ms(cell['seconds'])} @ {fmt_tol(cell['tol'])}"


def table(rows: List[Dict[str, Any]]) -> str:
    lines = ["| scene | target | heyoka `taylor_adaptive` | ours `taylor`, `Integrator` | "
             "heyoka ÷ ours | ours `taylor`, `simulate` | heyoka ÷ ours `simulate` | "
             "ours `dop853` | build: heyoka (order) | build: ours |",
             "|---|---|---|---|---|---|---|---|---|---|"]

    def ratio(a: Dict[str, Any], b: Dict[str, Any]) -> str:
        if a["tol"] is None or b["tol"] is None:
            return "—"
        return f"{a['seconds'] / b['seconds']:.2f}×"

    for row in rows:
        name = row["scene"].replace("n_pendulum_", "N-pendulum N = ").replace("_", " ")
        for k, target in enumerate(TARGETS):
            c = row["cells"]
            h, i, o, d = (c[f"{side}@{target:g}"] for side in (
                "heyoka", "ours taylor integrator", "ours taylor", "ours dop853"))
            hb = ("—" if h["tol"] is None else f"{ms(h['build'])} ({h['order']})")
            ob = ms(row["build_ours"]["total"]) if k == 0 else ""
            lines.append(f"| {name if k == 0 else ''} | {target:g} | {cell_text(h)} | "
                         f"{cell_text(i)} | {ratio(h, i)} | {cell_text(o)} | {ratio(h, o)} | "
                         f"{cell_text(d)} | {hb} | {ob} |")
    return "\n".join(lines)


def checks(rows: List[Dict[str, Any]]) -> str:
    out = []
    for row in rows:
        ref = row["reference"]
        parts = [f"reference: {ref['kind']}"]
        if "spread" in ref:
            parts.append(f"spread vs 1000× looser tol {ref['spread']:.1e}")
        if "float64_exact_vs_exact" in ref:
            parts.append(f"the same in float64 off by {ref['float64_exact_vs_exact']:.1e}")
        if "exact_vs_heyoka" in ref:
            parts.append(f"exact vs heyoka {ref['heyoka_precision']} {ref['exact_vs_heyoka']:.1e}")
        if "heyoka_reference_failure" in ref:
            parts.append(f"heyoka reference failed: {ref['heyoka_reference_failure']}")
        e = row["dop853_1e-14_vs_reference"]
        parts.append("our DOP853 at 1e-14 vs reference " + ("failed" if e is None else f"{e:.1e}"))
        agree = row["heyoka_vs_ours_taylor"]
        parts.append("heyoka vs ours (taylor) at equal tol: " + (", ".join(
            f"{v:.1e} at {k}" for k, v in agree.items()) or "—"))
        parts.append(f"amplification ×{row['amplification']:.0f}")
        b = row["build_ours"]
        parts.append(f"our build {ms(b['model'])} model + {ms(b['taylor_kernel'])} Taylor kernel")
        parts.append("our unrolled expansion, compiled after 10⁴ expansions (slowest warm-up run "
                     "less fastest): " + (", ".join(f"{ms(c)} at {k}" for k, c in
                                                    row["unrolled_compile"].items()) or "—"))
        for label, failures in row["failures"].items():
            if failures:
                parts.append(f"{label} runs not made or failed: " + " | ".join(failures))
        name = row["scene"]
        out.append(f"- {name}: " + "; ".join(parts))
    return "\n".join(out)


def fixed_costs(worker: Worker, rounds: int) -> Tuple[float, float, float]:
    """A run of 1e-9 on the double pendulum: our `simulate` call, our `Integrator`'s
    `propagate_until` and heyoka's, each with its final state read as the timed runs read it."""
    s = SCENES["double_pendulum"]
    model = our_model(s)
    # Past the unrolled compile at this order, as the timed runs are (one expansion a call).
    for _ in range(UNROLL_AFTER + 1):
        model.simulate(s.q0, s.qd0, 1e-9, method="taylor", rtol=1e-9, atol=1e-9,
                       output_every=EVERY)
    ours = math.inf
    for _ in range(100 * rounds):
        start = time.perf_counter()
        sol = model.simulate(s.q0, s.qd0, 1e-9, method="taylor", rtol=1e-9, atol=1e-9,
                             output_every=EVERY)
        sol.q[-1], sol.qd[-1]
        ours = min(ours, time.perf_counter() - start)
    ig = model.integrator(s.q0, s.qd0, method="taylor", rtol=1e-9, atol=1e-9)
    ours_ig = math.inf
    for _ in range(100 * rounds):
        ig.t, ig.q, ig.qd = 0.0, s.q0, s.qd0
        start = time.perf_counter()
        ig.propagate_until(1e-9)
        ig.q, ig.qd
        ours_ig = min(ours_ig, time.perf_counter() - start)
    hey = math.nan
    try:
        ans = worker.ask(("build", s.name, 1e-9), BUILD_LIMIT)
    except TimedOut:
        return ours, ours_ig, hey
    if ans[0] == "ok":
        ta = pickle.loads(ans[1])
        hey = math.inf
        for _ in range(100 * rounds):
            ta.time = 0.0
            ta.state[:] = s.x0
            start = time.perf_counter()
            ta.propagate_until(1e-9)
            ta.state
            hey = min(hey, time.perf_counter() - start)
    return ours, ours_ig, hey


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=3, help="timing rounds per side (best of)")
    ap.add_argument("--round-seconds", type=float, default=0.02,
                    help=f"repeat short runs within a round to about this long (≤ {MAX_INNER})")
    ap.add_argument("--scenes", default=None, help="comma-separated subset of " + ", ".join(SCENES))
    ap.add_argument("--heyoka-budget", type=float, default=180.0,
                    help="seconds of heyoka builds per scene; no build is started past it (one build "
                    f"is stopped at {BUILD_LIMIT:.0f} s regardless)")
    ap.add_argument("--reference", choices=("auto", "real128", "longdouble"), default="auto",
                    help="heyoka's extended precision for the references (auto: real128 up to "
                    "two degrees of freedom, longdouble above)")
    ap.add_argument("--json", default=None, help="also write the raw measurements here")
    args = ap.parse_args()
    names = list(SCENES)
    if args.scenes:
        names = args.scenes.split(",")
        unknown = set(names) - set(SCENES)
        if unknown:
            ap.error(f"unknown scenes {sorted(unknown)}; known: {', '.join(SCENES)}")
    import heyoka as hy  # noqa: F401 - to unpickle the integrators the worker builds

    started = time.perf_counter()
    worker = Worker()
    rows = []
    try:
        for name in names:
            print(f"{name} …", file=sys.stderr, flush=True)
            rows.append(measure(SCENES[name], worker, args.rounds, args.round_seconds,
                                args.heyoka_budget, args.reference))
        ours_call, ours_ig, hey_call = fixed_costs(worker, args.rounds)
    finally:
        worker.stop()
    total = time.perf_counter() - started
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"targets": TARGETS, "ladder": LADDER, "rounds": args.rounds,
                       "heyoka": hy.__version__, "rows": rows,
                       "fixed_cost": {"ours_simulate": ours_call, "ours_propagate": ours_ig,
                                      "heyoka_propagate": hey_call},
                       "seconds": total}, f, indent=1)
    print(f"\nheyoka.py {hy.__version__} against lagrangian {getattr(lg, '__version__', '?')}; "
          f"best of {args.rounds} rounds, alternating sides; total {total:.0f} s. Each cell: "
          "time of one run @ the loosest tolerance of the ladder reaching the target; "
          "heyoka ÷ ours > 1: ours is faster.\n")
    print(table(rows))
    print(f"\nFixed cost of a call (a run of 1e-9 s on the double pendulum), inside the times "
          f"above: our `model.simulate` {ours_call * 1e6:.1f} µs, our `Integrator.propagate_until` "
          f"{ours_ig * 1e6:.1f} µs, heyoka's `propagate_until` {hey_call * 1e6:.1f} µs.\n")
    print("Checks:\n")
    print(checks(rows))


if __name__ == "__main__":
    main()
