"""Every ready-made Rust scene of ``lagrangian::scenes``, with the same parameters.

Each function returns a :class:`~lagrangian.Model` backed by the native Rust system (its
energies written in Rust, not compiled from expressions). Coordinates are named as in the Rust
documentation; ``model.coordinates`` gives them for loads in ``equilibrium``.

>>> import lagrangian as lg
>>> dp = lg.scenes.double_pendulum(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81)
>>> [c.name for c in dp.coordinates]
['th1', 'th2']
"""

from __future__ import annotations

import math
from typing import Any, Dict, Mapping, Optional, Sequence

import numpy as np

from . import _lagrangian
from ._model import Model
from ._plot import Drawing, FloatArray
from ._validate import real as _real

__all__ = [
    "simple_pendulum",
    "double_pendulum",
    "n_pendulum",
    "forced_two_mass",
    "rolling_cylinder",
    "ball_in_sphere",
    "damped_oscillator",
    "kepler",
    "elastic_pendulum",
    "henon_heiles",
    "driven_pendulum",
    "charged_particle",
    "lever",
    "differential_pulley",
    "rhombus_link",
    "spring_rhombus",
    "two_springs",
]


def _make(name: str, coordinates: Sequence[str], **params: float) -> Model:
    values = {k: _real(k, v) for k, v in params.items()}
    native = _lagrangian.NativeModel.scene(name, list(values.values()))
    return Model._from_native(native, coordinates, values, name)


def simple_pendulum(m: float, l: float, g: float) -> Model:  # noqa: E741
    """A point mass ``m`` on a rod of length ``l`` in gravity ``g``; coordinate θ (``theta``)
    from the downward vertical. T = ½ m l² θ̇², U = −m g l cos θ."""
    return _make("simple_pendulum", ["theta"], m=m, l=l, g=g)


def double_pendulum(m1: float, m2: float, l1: float, l2: float, g: float) -> Model:
    """Two point masses on massless rods, coordinates (θ₁, θ₂) = (``th1``, ``th2``) from the
    downward vertical."""
    return _make("double_pendulum", ["th1", "th2"], m1=m1, m2=m2, l1=l1, l2=l2, g=g)


def n_pendulum(masses: Sequence[float], lengths: Sequence[float], g: float) -> Model:
    """A chain of N point masses on rods, coordinates ``th1`` … ``thN`` from the vertical."""
    ms = [_real("masses", m) for m in masses]
    ls = [_real("lengths", x) for x in lengths]
    if not ms or len(ms) != len(ls):
        raise ValueError(
            f"n_pendulum needs one length per mass (at least one): got {len(ms)} masses and "
            f"{len(ls)} lengths"
        )
    native = _lagrangian.NativeModel.scene("n_pendulum", [_real("g", g)] + ms + ls)
    names = [f"th{i + 1}" for i in range(len(ms))]
    params: Dict[str, Any] = {"masses": ms, "lengths": ls, "g": float(g)}
    return Model._from_native(native, names, params, "n_pendulum")


def forced_two_mass(
    m1: float,
    m2: float,
    k1: float,
    k2: float,
    f1: float = 0.0,
    f2: float = 0.0,
    omega: float = 0.0,
) -> Model:
    """Two masses on springs k₁ (ground–m₁) and k₂ (m₁–m₂), forced by fᵢ cos Ω t (seed eq.
    41–44); coordinates ``x1``, ``x2``."""
    return _make(
        "forced_two_mass", ["x1", "x2"], m1=m1, m2=m2, k1=k1, k2=k2, f1=f1, f2=f2, omega=omega
    )


def rolling_cylinder(m: float, j: float, r: float, g: float, alpha: float) -> Model:
    """A cylinder rolling without slipping down a slope of angle ``alpha`` (seed eq. 45–48);
    coordinate ``x`` along the slope."""
    return _make("rolling_cylinder", ["x"], m=m, j=j, r=r, g=g, alpha=alpha)


def ball_in_sphere(m: float, j: float, r1: float, r2: float, g: float) -> Model:
    """A ball of radius ``r2`` rolling inside a sphere of radius ``r1`` (seed eq. 49–53);
    coordinate ``theta`` from the bottom."""
    return _make("ball_in_sphere", ["theta"], m=m, j=j, r1=r1, r2=r2, g=g)


def damped_oscillator(m: float, k: float, c: float) -> Model:
    """m ẍ + c ẋ + k x = 0 from Rayleigh's Φ = ½ c ẋ² (seed eq. 54–55); coordinate ``x``."""
    return _make("damped_oscillator", ["x"], m=m, k=k, c=c)


def kepler(m: float, mu: float) -> Model:
    """A body of mass ``m`` around a centre of gravitational parameter ``mu``; coordinates
    ``x``, ``y``."""
    return _make("kepler", ["x", "y"], m=m, mu=mu)


def elastic_pendulum(m: float, k: float, l0: float, g: float, c: float = 0.0) -> Model:
    """A mass on a spring (stiffness ``k``, natural length ``l0``) swinging in gravity, with an
    optional radial dashpot ``c``; coordinates ``r``, ``theta``."""
    return _make("elastic_pendulum", ["r", "theta"], m=m, k=k, l0=l0, g=g, c=c)


def henon_heiles() -> Model:
    """The Hénon–Heiles system; coordinates ``x``, ``y``."""
    return _make("henon_heiles", ["x", "y"])


def driven_pendulum(m: float, l: float, g: float, a: float, omega: float) -> Model:  # noqa: E741
    """A pendulum whose pivot moves as a cos ω t (T depends on t); coordinate ``theta``."""
    return _make("driven_pendulum", ["theta"], m=m, l=l, g=g, a=a, omega=omega)


def charged_particle(m: float, e: float, b: float, ex: float = 0.0, ey: float = 0.0) -> Model:
    """A charge ``e`` of mass ``m`` in a magnetic field ``b`` normal to the plane and an
    electric field (``ex``, ``ey``); coordinates ``x``, ``y``."""
    return _make("charged_particle", ["x", "y"], m=m, e=e, b=b, ex=ex, ey=ey)


def lever(l1: float, l2: float, p: float, q: float) -> Model:
    """Seed §3.2 example 1: a lever with a vertical force ``p`` on arm ``l1`` and a horizontal
    force ``q`` on arm ``l2``; coordinate ``theta``. Statics only (massless)."""
    return _make("lever", ["theta"], l1=l1, l2=l2, p=p, q=q)


def differential_pulley(r1: float, r2: float, p: float, q: float, k: float) -> Model:
    """Seed §3.2 example 2: a chain block with sheaves ``r1`` > ``r2``, effort ``p``, load ``q``
    and a spring balance ``k``; coordinate ``theta``. Statics only."""
    return _make("differential_pulley", ["theta"], r1=r1, r2=r2, p=p, q=q, k=k)


def rhombus_link(l: float, p: float, q: float) -> Model:  # noqa: E741
    """Seed §3.2 example 3: four links ``l`` with forces ``p`` (vertical) and ``q``
    (horizontal); coordinate ``theta`` (half of ∠BCD). Statics only."""
    return _make("rhombus_link", ["theta"], l=l, p=p, q=q)


def spring_rhombus(a: float, k: float, l0: float, m: float, g: float) -> Model:
    """Seed §3.2 example 4: a rhombus of links ``a`` with a spring ``k`` (natural length 2
    ``l0``) and a hanging mass ``m``; coordinate ``theta``."""
    return _make("spring_rhombus", ["theta"], a=a, k=k, l0=l0, m=m, g=g)


def two_springs(m1: float, m2: float, k1: float, k2: float, f1: float, f2: float) -> Model:
    """Seed §3.2 example 5: two masses on two springs with loads ``f1``, ``f2``; coordinates
    ``x1``, ``x2``."""
    return _make("two_springs", ["x1", "x2"], m1=m1, m2=m2, k1=k1, k2=k2, f1=f1, f2=f2)


# -- drawing hooks (Model.animate) -----------------------------------------------------------


def _drawing(name: str, p: Mapping[str, Any]) -> Optional[Drawing]:
    """How to draw the scene ``name`` with parameters ``p``, in the particle order of its Rust
    ``Particles`` implementation; ``None`` draws points with trails."""
    if name in ("simple_pendulum", "elastic_pendulum"):
        return Drawing.chain(1)
    if name == "double_pendulum":
        return Drawing.chain(2)
    if name == "n_pendulum":
        return Drawing.chain(len(p["masses"]))
    if name == "driven_pendulum":
        a, omega = float(p["a"]), float(p["omega"])

        def pivot(t: FloatArray) -> FloatArray:
            # The pivot at (0, a cos ω t), as in the Rust scene.
            return np.stack([np.zeros_like(t), a * np.cos(omega * t)], axis=1)

        return Drawing.chain(1, pivot=pivot)
    if name == "rolling_cylinder":
        # The slope is the line through −r n, n = (sin α, cos α), along (cos α, −sin α).
        r, alpha = float(p["r"]), float(p["alpha"])
        sa, ca = math.sin(alpha), math.cos(alpha)
        return Drawing(bodies=((0, 1, 2),), lines=((-r * sa, -r * ca, ca, -sa),), trail=(0,))
    if name == "ball_in_sphere":
        return Drawing(
            bodies=((0, 1, 2),), circles=((0.0, 0.0, float(p["r1"])),), marks=((0.0, 0.0),),
            trail=(0,),
        )
    if name == "kepler":
        return Drawing(marks=((0.0, 0.0),))
    if name == "lever":
        return Drawing(rods=((-1, 0), (-1, 1)), marks=((0.0, 0.0),))
    if name == "rhombus_link":
        return Drawing(rods=((0, 1), (1, 2), (2, 3), (3, 0)))
    if name == "differential_pulley":
        r1, r2 = float(p["r1"]), float(p["r2"])
        return Drawing(circles=((0.0, 0.0, r1), (0.0, 0.0, r2)), marks=((0.0, 0.0),))
    return None
