"""The scenes of the standard report: initial states, spans, step sizes and exact solutions.

Exact solutions come from the Rust scenes through the binding (:meth:`SceneModel.exact
<lagrangian.scenes.SceneModel.exact>`: the seed's eq. 41–48 and §4, and Kepler's equation), so
the report measures errors against the truth where the truth is known and against two
independent high-order runs elsewhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

from . import scenes
from ._model import Model
from ._scene_model import SceneModel

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
        """The scene's model (native Rust, or a constrained model stated in Python)."""
        return getattr(scenes, self.scene)(**self.params)  # type: ignore[no-any-return]


# -- exact solutions --------------------------------------------------------------------------


def _exact(model: SceneModel, q0: Sequence[float], qd0: Sequence[float]) -> Exact:
    """The scene's exact motion from (q0, q̇0) at t = 0, as a function of t."""
    start, rate = [float(x) for x in q0], [float(x) for x in qd0]

    def at(t: float) -> Tuple[FloatArray, FloatArray]:
        return model.exact(t, start, rate)

    return at


def oscillator_exact(m: float, k: float, c: float, x0: float, v0: float) -> Exact:
    """m ẍ + c ẋ + k x = 0 (seed §4), from x(0) = x0, ẋ(0) = v0."""
    return _exact(scenes.damped_oscillator(m=m, k=k, c=c), [x0], [v0])


def cylinder_exact(m: float, j: float, r: float, g: float, alpha: float, x0: float,
                   v0: float) -> Exact:
    """Rolling without slipping (seed eq. 48): ẍ = g sin α / (1 + J / (m r²)), constant."""
    return _exact(scenes.rolling_cylinder(m=m, j=j, r=r, g=g, alpha=alpha), [x0], [v0])


def kepler_exact(mu: float, a: float, e: float) -> Exact:
    """The orbit from periapsis (a(1 − e), 0) moving in +y (see :func:`kepler_periapsis`)."""
    q0, qd0 = kepler_periapsis(mu, a, e)
    return _exact(scenes.kepler(m=1.0, mu=mu), q0, qd0)


def kepler_periapsis(mu: float, a: float, e: float) -> Tuple[Tuple[float, float], Tuple[float, float]]:
    """(q0, q̇0) at periapsis of the orbit with semi-major axis a and eccentricity e."""
    rp = a * (1 - e)
    return (rp, 0.0), (0.0, math.sqrt(mu * (1 + e) / rp))


def two_mass_exact(m1: float, m2: float, k1: float, k2: float, f1: float, f2: float,
                   omega: float, x0: Sequence[float], v0: Sequence[float]) -> Exact:
    """M ẍ + K x = F cos Ω t (seed eq. 43–44) from x(0) = x0, ẋ(0) = v0."""
    model = scenes.forced_two_mass(m1=m1, m2=m2, k1=k1, k2=k2, f1=f1, f2=f2, omega=omega)
    return _exact(model, x0, v0)


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
        # Constrained (issue 41): the bob's x, y under x² + y² = l²; the methods that cannot keep
        # a run on the constraint are listed as not applicable, with their reason.
        Scene("cartesian_pendulum", "Cartesian pendulum, x² + y² = l² (constrained)",
              "cartesian_pendulum", dict(m=1.0, l=1.0, g=9.81),
              (math.sin(1.0), -math.cos(1.0)), (0.0, 0.0), 10.0, 1.0),
    ]
