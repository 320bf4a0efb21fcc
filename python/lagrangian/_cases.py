"""The scenes of the standard report: initial states, spans, step sizes and exact solutions.

Exact solutions are written out here from the closed forms (the seed's eq. 41–48 and §4, and
Kepler's equation), so the report measures errors against the truth where the truth is known and
against two independent high-order runs elsewhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

from . import scenes
from ._model import Model

FloatArray = npt.NDArray[np.float64]
Exact = Callable[[float], Tuple[FloatArray, FloatArray]]


@dataclass(frozen=True)
class Scene:
    """One scene of the report.

    ``scale`` is the time scale of the fastest motion (a period, or the time to cross the
    scene), from which the fixed steps are chosen; ``exact`` the exact solution when known.
    """

    key: str
    title: str
    scene: str
    params: Dict[str, Any]
    q0: Tuple[float, ...]
    qd0: Tuple[float, ...]
    t_end: float
    scale: float
    exact: Optional[Exact] = None
    peers: bool = False
    notes: str = ""
    extra: Dict[str, Any] = field(default_factory=dict)

    def model(self) -> Model:
        """The scene's model (native Rust)."""
        return getattr(scenes, self.scene)(**self.params)  # type: ignore[no-any-return]


# -- exact solutions --------------------------------------------------------------------------


def oscillator_exact(m: float, k: float, c: float, x0: float, v0: float) -> Exact:
    """m ẍ + c ẋ + k x = 0 (seed §4): x = e^{−γt}(x0 f + (v0 + γ x0) g) with (f, g) =
    (cos ω_d t, sin ω_d t / ω_d), (1, t) or (cosh βt, sinh βt / β)."""
    gamma, w02 = c / (2 * m), k / m
    beta2 = gamma * gamma - w02

    def at(t: float) -> Tuple[FloatArray, FloatArray]:
        if beta2 < 0:
            wd = math.sqrt(-beta2)
            f, g = math.cos(wd * t), math.sin(wd * t) / wd
        elif beta2 > 0:
            b = math.sqrt(beta2)
            f, g = math.cosh(b * t), math.sinh(b * t) / b
        else:
            f, g = 1.0, t
        decay = math.exp(-gamma * t)
        x = decay * (x0 * f + (v0 + gamma * x0) * g)
        v = decay * (v0 * f - (w02 * x0 + gamma * v0) * g)
        return np.array([x]), np.array([v])

    return at


def cylinder_exact(m: float, j: float, r: float, g: float, alpha: float, x0: float,
                   v0: float) -> Exact:
    """Rolling without slipping (seed eq. 48): ẍ = g sin α / (1 + J / (m r²)), constant."""
    a = g * math.sin(alpha) / (1 + j / (m * r * r))

    def at(t: float) -> Tuple[FloatArray, FloatArray]:
        return np.array([x0 + v0 * t + 0.5 * a * t * t]), np.array([v0 + a * t])

    return at


def kepler_exact(mu: float, a: float, e: float) -> Exact:
    """The orbit from periapsis (a(1 − e), 0) moving in +y: Kepler's equation E − e sin E = n t
    by Newton, q = a(cos E − e, √(1−e²) sin E), q̇ = a n (−sin E, √(1−e²) cos E)/(1 − e cos E)."""
    n = math.sqrt(mu / a**3)
    b = math.sqrt(1 - e * e)

    def at(t: float) -> Tuple[FloatArray, FloatArray]:
        mean = math.fmod(n * t, 2 * math.pi)
        ecc = math.pi if e > 0.8 else mean + e * math.sin(mean)
        for _ in range(100):
            step = (ecc - e * math.sin(ecc) - mean) / (1 - e * math.cos(ecc))
            ecc -= step
            if abs(step) < 1e-16:
                break
        s, co = math.sin(ecc), math.cos(ecc)
        rate = n / (1 - e * co)
        return np.array([a * (co - e), a * b * s]), np.array([-a * s * rate, a * b * co * rate])

    return at


def kepler_periapsis(mu: float, a: float, e: float) -> Tuple[Tuple[float, float], Tuple[float, float]]:
    """(q0, q̇0) at periapsis of the orbit with semi-major axis a and eccentricity e."""
    rp = a * (1 - e)
    return (rp, 0.0), (0.0, math.sqrt(mu * (1 + e) / rp))


def two_mass_exact(m1: float, m2: float, k1: float, k2: float, f1: float, f2: float,
                   omega: float, x0: Sequence[float], v0: Sequence[float]) -> Exact:
    """M ẍ + K x = F cos Ω t (seed eq. 43–44): the forced response (K − Ω² M)⁻¹ F cos Ω t plus
    the free vibration in the normal modes K v = ω² M v that matches the initial state."""
    mass = np.diag([m1, m2])
    stiff = np.array([[k1 + k2, -k2], [-k2, k2]])
    forced = np.linalg.solve(stiff - omega**2 * mass, np.array([f1, f2]))
    root = np.diag([1 / math.sqrt(m1), 1 / math.sqrt(m2)])
    w2, modes = np.linalg.eigh(root @ stiff @ root)
    shapes = root @ modes  # columns: mode shapes, M-orthonormal
    w = np.sqrt(w2)
    a = shapes.T @ mass @ (np.asarray(x0, dtype=float) - forced)
    b = shapes.T @ mass @ np.asarray(v0, dtype=float)

    def at(t: float) -> Tuple[FloatArray, FloatArray]:
        x = shapes @ (a * np.cos(w * t) + b / w * np.sin(w * t)) + forced * math.cos(omega * t)
        v = shapes @ (-a * w * np.sin(w * t) + b * np.cos(w * t)) - forced * omega * math.sin(
            omega * t
        )
        return x, v

    return at


# -- the report's scenes ----------------------------------------------------------------------


def report_scenes() -> List[Scene]:
    """The seed's scenes and the reference scenes, in report order."""
    kq0, kqd0 = kepler_periapsis(1.0, 1.0, 0.6)
    two = dict(m1=1.0, m2=0.5, k1=10.0, k2=5.0, f1=1.0, f2=0.5, omega=2.0)
    cyl = dict(m=1.0, j=0.005, r=0.1, g=9.81, alpha=0.3)
    osc = dict(m=1.0, k=4.0, c=0.4)
    return [
        Scene("double_pendulum", "Double pendulum (θ = 1.0, 0.5)", "double_pendulum",
              dict(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81), (1.0, 0.5), (0.0, 0.0), 10.0, 1.0,
              peers=True),
        Scene("forced_two_mass", "2-DOF forced spring–mass (seed eq. 41–44)", "forced_two_mass",
              two, (0.1, 0.0), (0.0, 0.0), 20.0, 0.8,
              exact=two_mass_exact(**two, x0=(0.1, 0.0), v0=(0.0, 0.0)), peers=True),
        Scene("ball_in_sphere", "Ball rolling in a sphere (seed eq. 49–53)", "ball_in_sphere",
              dict(m=1.0, j=0.016, r1=1.0, r2=0.2, g=9.81), (1.0,), (0.0,), 10.0, 1.7,
              peers=True),
        Scene("rolling_cylinder", "Cylinder rolling down an incline (seed eq. 45–48)",
              "rolling_cylinder", cyl, (0.0,), (0.5,), 2.0, 0.5,
              exact=cylinder_exact(**cyl, x0=0.0, v0=0.5), peers=True),
        Scene("damped_oscillator", "Damped oscillator, Rayleigh Φ (seed §4)", "damped_oscillator",
              osc, (1.0,), (0.0,), 10.0, 3.1,
              exact=oscillator_exact(**osc, x0=1.0, v0=0.0), peers=True),
        Scene("kepler", "Kepler problem, e = 0.6 (two orbits)", "kepler",
              dict(m=1.0, mu=1.0), kq0, kqd0, 4 * math.pi, 0.4,
              exact=kepler_exact(1.0, 1.0, 0.6), peers=True),
        Scene("elastic_pendulum", "Elastic pendulum (k = 40)", "elastic_pendulum",
              dict(m=1.0, k=40.0, l0=1.0, g=9.81), (1.1, 0.5), (0.0, 0.0), 10.0, 1.0,
              peers=True),
        Scene("n_pendulum", "N-pendulum, N = 4", "n_pendulum",
              dict(masses=[1.0] * 4, lengths=[0.5] * 4, g=9.81), (0.4, 0.3, 0.2, 0.1),
              (0.0,) * 4, 5.0, 0.5, peers=True),
    ]
