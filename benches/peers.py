"""Peers for the benchmarks: hand-written NumPy right-hand sides of the scenes, a third statement
of their physics kept with the benchmarks (the product's report runs SciPy on ``Model.rhs``).

Every scene of :mod:`lagrangian.scenes` that moves (the statics scenes do not) has here the
first-order right-hand side a SciPy user would write by hand: the state is y = (q, q̇), and
``f(t, y)`` returns dy/dt = (q̇, q̈) with q̈ from the closed-form equations of motion (the
``closed_form_accelerations`` of ``src/scenes/*.rs``), or from ``numpy.linalg.solve`` of the mass
matrix for the N-link pendulum. They are written the way a careful user writes them: small
systems unpack ``y.tolist()`` into Python floats and use :mod:`math` (about twice as fast as
NumPy scalars), the chain is vectorised. Nothing here uses the Rust engine, so the runs measure
SciPy plus a Python right-hand side.

:func:`run_scipy` (from :mod:`lagrangian._scipy`, re-exported here) integrates such a right-hand
side with ``scipy.integrate.solve_ivp`` and keeps only the final state, for the error-versus-cost
comparison with ``Model.simulate``. Import this file with ``benches/`` on ``sys.path``;
``python3 benches/peers.py [repeats]`` prints SciPy on these right-hand sides against SciPy on
``Model.rhs``.
"""

from __future__ import annotations

import inspect
import math
from typing import Any, Callable, Dict, List, Sequence, Tuple

import numpy as np
import numpy.typing as npt

from lagrangian._scipy import SCIPY_METHODS, PeerRun, run_scipy, scipy_available
from lagrangian._validate import real as _real

__all__ = [
    "NUMPY_SCENES",
    "SCIPY_METHODS",
    "PeerRun",
    "numpy_rhs",
    "run_scipy",
    "scipy_available",
]

FloatArray = npt.NDArray[np.float64]
Rhs = Callable[[float, FloatArray], FloatArray]


# -- parameter checks --------------------------------------------------------------------------


def _positive(what: str, value: object) -> float:
    """``value`` as a float that is finite and > 0 (masses, lengths, radii), else ValueError."""
    x = _real(what, value)
    if not x > 0.0:
        raise ValueError(f"{what} = {x} must be positive (it enters the mass matrix)")
    return x


def _non_negative(what: str, value: object) -> float:
    x = _real(what, value)
    if not x >= 0.0:
        raise ValueError(f"{what} = {x} must not be negative")
    return x


# -- the right-hand sides ----------------------------------------------------------------------
# Each builder takes exactly the keyword parameters of the `lg.scenes` function of the same name
# (same names, same defaults), checks them once and returns f(t, y).


def _simple_pendulum(*, m: float, l: float, g: float) -> Rhs:  # noqa: E741
    _positive("m", m)
    w2 = _real("g", g) / _positive("l", l)

    def f(t: float, y: FloatArray) -> FloatArray:
        th, w = y.tolist()
        return np.array([w, -w2 * math.sin(th)])

    return f


def _double_pendulum(*, m1: float, m2: float, l1: float, l2: float, g: float) -> Rhs:
    m1, m2 = _positive("m1", m1), _positive("m2", m2)
    l1, l2, g = _positive("l1", l1), _positive("l2", l2), _real("g", g)
    a = (m1 + m2) * l1 * l1
    d = m2 * l2 * l2
    k = m2 * l1 * l2
    g1 = (m1 + m2) * g * l1
    g2 = m2 * g * l2

    def f(t: float, y: FloatArray) -> FloatArray:
        th1, th2, w1, w2 = y.tolist()
        s, c = math.sin(th1 - th2), math.cos(th1 - th2)
        # M = [[a, b], [b, d]] q̈ = [e, h], solved by Cramer's rule.
        b = k * c
        e = -k * s * w2 * w2 - g1 * math.sin(th1)
        h = k * s * w1 * w1 - g2 * math.sin(th2)
        det = a * d - b * b
        return np.array([w1, w2, (e * d - b * h) / det, (a * h - b * e) / det])

    return f


def _n_pendulum(*, masses: Sequence[float], lengths: Sequence[float], g: float) -> Rhs:
    ms = np.array([_positive("masses", x) for x in masses], dtype=np.float64)
    ls = np.array([_positive("lengths", x) for x in lengths], dtype=np.float64)
    if ms.size == 0 or ms.size != ls.size:
        raise ValueError(
            f"n_pendulum needs one length per mass (at least one): got {ms.size} masses and "
            f"{ls.size} lengths"
        )
    g = _real("g", g)
    n = ms.size
    # μ_ik = Σ_{j ≥ max(i, k)} m_j: the mass below the lower of links i and k.
    tail = np.cumsum(ms[::-1])[::-1]
    idx = np.arange(n)
    mu_ll = tail[np.maximum.outer(idx, idx)] * np.outer(ls, ls)
    grav = tail * g * ls

    def f(t: float, y: FloatArray) -> FloatArray:
        th, w = y[:n], y[n:]
        d = th[:, None] - th[None, :]
        mass = mu_ll * np.cos(d)
        rhs = -(mu_ll * np.sin(d)) @ (w * w) - grav * np.sin(th)
        return np.concatenate([w, np.linalg.solve(mass, rhs)])

    return f


def _forced_two_mass(
    *,
    m1: float,
    m2: float,
    k1: float,
    k2: float,
    f1: float = 0.0,
    f2: float = 0.0,
    omega: float = 0.0,
) -> Rhs:
    m1, m2 = _positive("m1", m1), _positive("m2", m2)
    k1, k2 = _real("k1", k1), _real("k2", k2)
    f1, f2, omega = _real("f1", f1), _real("f2", f2), _real("omega", omega)

    def f(t: float, y: FloatArray) -> FloatArray:
        x1, x2, v1, v2 = y.tolist()
        c = math.cos(omega * t)
        stretch = x2 - x1
        return np.array(
            [v1, v2, (f1 * c - k1 * x1 + k2 * stretch) / m1, (f2 * c - k2 * stretch) / m2]
        )

    return f


def _rolling_cylinder(*, m: float, j: float, r: float, g: float, alpha: float) -> Rhs:
    m, j, r = _positive("m", m), _non_negative("j", j), _positive("r", r)
    acc = _real("g", g) * math.sin(_real("alpha", alpha)) / (1.0 + j / (m * r * r))

    def f(t: float, y: FloatArray) -> FloatArray:
        return np.array([y[1], acc])

    return f


def _ball_in_sphere(*, m: float, j: float, r1: float, r2: float, g: float) -> Rhs:
    m, j = _positive("m", m), _non_negative("j", j)
    r1, r2, g = _real("r1", r1), _positive("r2", r2), _real("g", g)
    if not r1 > r2:
        raise ValueError(f"r1 = {r1} must exceed r2 = {r2} (the ball is inside the sphere)")
    arm = r1 - r2
    w2 = m * g * arm / ((m + j / (r2 * r2)) * arm * arm)

    def f(t: float, y: FloatArray) -> FloatArray:
        th, w = y.tolist()
        return np.array([w, -w2 * math.sin(th)])

    return f


def _damped_oscillator(*, m: float, k: float, c: float) -> Rhs:
    m = _positive("m", m)
    k, c = _real("k", k), _real("c", c)

    def f(t: float, y: FloatArray) -> FloatArray:
        x, v = y.tolist()
        return np.array([v, -(c * v + k * x) / m])

    return f


def _kepler(*, m: float, mu: float) -> Rhs:
    _positive("m", m)
    mu = _real("mu", mu)

    def f(t: float, y: FloatArray) -> FloatArray:
        x, z, vx, vz = y.tolist()
        r2 = x * x + z * z
        s = -mu / (r2 * math.sqrt(r2))
        return np.array([vx, vz, s * x, s * z])

    return f


def _elastic_pendulum(*, m: float, k: float, l0: float, g: float, c: float = 0.0) -> Rhs:
    m = _positive("m", m)
    k, l0, g, c = _real("k", k), _real("l0", l0), _real("g", g), _real("c", c)

    def f(t: float, y: FloatArray) -> FloatArray:
        r, th, rd, thd = y.tolist()
        s, co = math.sin(th), math.cos(th)
        return np.array(
            [
                rd,
                thd,
                r * thd * thd - (k / m) * (r - l0) + g * co - (c / m) * rd,
                -(2.0 * rd * thd + g * s) / r,
            ]
        )

    return f


def _henon_heiles() -> Rhs:
    def f(t: float, y: FloatArray) -> FloatArray:
        x, z, vx, vz = y.tolist()
        return np.array([vx, vz, -x - 2.0 * x * z, -z - x * x + z * z])

    return f


def _driven_pendulum(*, m: float, l: float, g: float, a: float, omega: float) -> Rhs:  # noqa: E741
    _positive("m", m)
    l = _positive("l", l)  # noqa: E741
    g, a, omega = _real("g", g), _real("a", a), _real("omega", omega)
    aw2 = a * omega * omega

    def f(t: float, y: FloatArray) -> FloatArray:
        th, w = y.tolist()
        # The pivot's acceleration ÿ_p = −a ω² cos ω t adds to gravity.
        return np.array([w, -(g - aw2 * math.cos(omega * t)) / l * math.sin(th)])

    return f


def _charged_particle(*, m: float, e: float, b: float, ex: float = 0.0, ey: float = 0.0) -> Rhs:
    m = _positive("m", m)
    e, b, ex, ey = _real("e", e), _real("b", b), _real("ex", ex), _real("ey", ey)
    s = e / m

    def f(t: float, y: FloatArray) -> FloatArray:
        _, _, vx, vy = y.tolist()
        return np.array([vx, vy, s * (b * vy + ex), s * (-b * vx + ey)])

    return f


def _spatial_chain(*, masses: Sequence[float], lengths: Sequence[float], radius: float,
                   g: float) -> Rhs:
    # Newton–Euler in world axes, by hand (the crate's route works in body axes from dual
    # numbers): joint k turns about its parent's x (k odd: y) axis a_k, so link k's centre has
    # J_v[:, i] = a_i × (c_k − p_i) and J_ω[:, i] = a_i for i ≤ k, and at q̈ = 0 its centre
    # accelerates by Σ (ȧ_i × (c_k − p_i) + a_i × (ċ_k − ṗ_i)) q̇_i with ȧ_i = ω_parent × a_i.
    ms = np.array([_positive("masses", x) for x in masses], dtype=np.float64)
    ls = np.array([_positive("lengths", x) for x in lengths], dtype=np.float64)
    if ms.size == 0 or ms.size != ls.size:
        raise ValueError(
            f"spatial_chain needs one length per mass (at least one): got {ms.size} masses and "
            f"{ls.size} lengths"
        )
    a, g = _non_negative("radius", radius), _real("g", g)
    n = ms.size
    side = ms * (3 * a * a + ls * ls) / 12.0
    body = [np.diag([side[k], side[k], 0.5 * ms[k] * a * a]) for k in range(n)]
    weight = np.array([0.0, 0.0, -g])

    def f(t: float, y: FloatArray) -> FloatArray:
        q, w = y[:n], y[n:]
        rot, p, v, om = np.eye(3), np.zeros(3), np.zeros(3), np.zeros(3)
        axes, adot, joints, jvel = (np.zeros((n, 3)) for _ in range(4))
        mass, rhs = np.zeros((n, n)), np.zeros(n)
        for k in range(n):
            axes[k] = rot[:, 0] if k % 2 == 0 else rot[:, 1]
            adot[k], joints[k], jvel[k] = np.cross(om, axes[k]), p, v
            c, s = math.cos(q[k]), math.sin(q[k])
            turn = ([[1, 0, 0], [0, c, -s], [0, s, c]] if k % 2 == 0
                    else [[c, 0, s], [0, 1, 0], [-s, 0, c]])
            rot = rot @ np.array(turn, dtype=np.float64)
            om = om + axes[k] * w[k]
            centre = p - 0.5 * ls[k] * rot[:, 2]
            cvel = v + np.cross(om, centre - p)
            jv, jw = np.zeros((3, n)), np.zeros((3, n))
            acc, alpha = np.zeros(3), np.zeros(3)
            for i in range(k + 1):
                r, rd = centre - joints[i], cvel - jvel[i]
                jv[:, i], jw[:, i] = np.cross(axes[i], r), axes[i]
                acc += (np.cross(adot[i], r) + np.cross(axes[i], rd)) * w[i]
                alpha += adot[i] * w[i]
            inertia = rot @ body[k] @ rot.T
            mass += ms[k] * jv.T @ jv + jw.T @ inertia @ jw
            rhs += jv.T @ (ms[k] * (weight - acc))
            rhs -= jw.T @ (inertia @ alpha + np.cross(om, inertia @ om))
            nxt = p - ls[k] * rot[:, 2]
            p, v = nxt, v + np.cross(om, nxt - p)
        return np.concatenate([w, np.linalg.solve(mass, rhs)])

    return f


_BUILDERS: Dict[str, Callable[..., Rhs]] = {
    "simple_pendulum": _simple_pendulum,
    "double_pendulum": _double_pendulum,
    "n_pendulum": _n_pendulum,
    "forced_two_mass": _forced_two_mass,
    "rolling_cylinder": _rolling_cylinder,
    "ball_in_sphere": _ball_in_sphere,
    "damped_oscillator": _damped_oscillator,
    "kepler": _kepler,
    "elastic_pendulum": _elastic_pendulum,
    "henon_heiles": _henon_heiles,
    "driven_pendulum": _driven_pendulum,
    "charged_particle": _charged_particle,
    "spatial_chain": _spatial_chain,
}

NUMPY_SCENES: Tuple[str, ...] = tuple(_BUILDERS)
"""The scenes :func:`numpy_rhs` knows: every dynamic scene of :mod:`lagrangian.scenes`."""


def numpy_rhs(scene: str, **params: Any) -> Rhs:
    """The hand-written first-order right-hand side of a scene, for ``scipy.integrate``.

    Parameters
    ----------
    scene : str
        One of :data:`NUMPY_SCENES`, named as in :mod:`lagrangian.scenes`.
    **params
        Exactly the keyword parameters of the ``lagrangian.scenes`` function of that name, with
        the same defaults (``n_pendulum`` takes the sequences ``masses`` and ``lengths``).

    Returns
    -------
    callable
        ``f(t, y)`` with y = (q, q̇) of length 2·dof, returning dy/dt = (q̇, q̈) as a new float
        array. q̈ is the scene's closed form (``numpy.linalg.solve`` of the mass matrix for
        ``n_pendulum``), so it agrees with ``lg.scenes.<scene>(**params).accelerations`` to
        rounding.

    Raises
    ------
    ValueError
        For an unknown scene, a missing or unknown parameter, a non-finite value, or a mass,
        length or radius that is not positive (which would leave the mass matrix singular).
    TypeError
        For a parameter that is not a real number.

    Examples
    --------
    >>> import numpy as np
    >>> f = numpy_rhs("damped_oscillator", m=2.0, k=8.0, c=0.4)
    >>> f(0.0, np.array([1.0, 0.5])).tolist()
    [0.5, -4.1]
    """
    builder = _BUILDERS.get(scene)
    if builder is None:
        raise ValueError(
            f"numpy_rhs has no scene {scene!r}; the scenes are {', '.join(NUMPY_SCENES)}"
        )
    signature = inspect.signature(builder).parameters
    required = [k for k, p in signature.items() if p.default is inspect.Parameter.empty]
    missing = [k for k in required if k not in params]
    extra = sorted(k for k in params if k not in signature)
    if missing or extra:
        problems: List[str] = []
        if missing:
            problems.append(f"is missing {', '.join(missing)}")
        if extra:
            problems.append(f"does not take {', '.join(extra)}")
        takes = ", ".join(signature) or "no parameters"
        raise ValueError(f"numpy_rhs({scene!r}) {' and '.join(problems)} (it takes {takes})")
    return builder(**params)


def _compare(repeats: int = 3) -> None:
    """SciPy on the hand-written NumPy right-hand side against SciPy on ``Model.rhs`` (and
    ``Model.jacobian`` for the implicit methods), double pendulum, rtol = atol = 1e-8."""
    import lagrangian as lg
    from lagrangian._scipy import IMPLICIT_METHODS

    params = dict(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81)
    model = lg.scenes.double_pendulum(**params)
    hand = numpy_rhs("double_pendulum", **params)
    print("double pendulum, q0 = (1.0, 0.5), t_end = 10, rtol = atol = 1e-8\n")
    print("| method | NumPy RHS | model.rhs | ratio | evaluations (NumPy / model) |")
    print("|---|---|---|---|---|")
    for method in SCIPY_METHODS:
        jac = model.jacobian if method in IMPLICIT_METHODS else None
        a = run_scipy(hand, [1.0, 0.5], [0.0, 0.0], 10.0, method, 1e-8, 1e-8, repeats=repeats)
        b = run_scipy(model.rhs, [1.0, 0.5], [0.0, 0.0], 10.0, method, 1e-8, 1e-8,
                      repeats=repeats, jac=jac)
        print(f"| {method} | {a.seconds * 1e3:.1f} ms | {b.seconds * 1e3:.1f} ms | "
              f"{b.seconds / a.seconds:.2f} | {a.nfev} / {b.nfev} |")


if __name__ == "__main__":
    import sys

    _compare(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
