"""The seed's systems with their constraints kept as equations (issue 41, item 7).

The Rust scenes of :mod:`lagrangian.scenes` eliminate every constraint by hand, as the seed does
(§3.6: x = rθ in eq. 45, (r₁ − r₂)θ₁ = r₂θ₂ in eq. 49; the rhombus links of §3.2 in their one
angle θ). The scenes here keep the eliminated coordinate and state the constraint instead, so
the reaction the seed never sees comes out as the multiplier: the friction force that rolling
needs, a rod's tension, what a closed chain's joint carries. Each returns a
:class:`~lagrangian.Model` stated by its energies with ``constraints={name: g}``; its parameters
are model parameters (:meth:`~lagrangian.Model.with_parameters` changes them). The parameter
names and defaults are those of the Rust scene of the same system.
"""

from __future__ import annotations

from typing import Dict, List

from ._expr import coordinates, cos, parameters, sin
from ._model import Model
from ._validate import real

__all__ = [
    "cartesian_pendulum",
    "rolling_cylinder_constrained",
    "ball_in_sphere_constrained",
    "rhombus_link_constrained",
    "spring_rhombus_constrained",
]


def _values(scene: str, **given: float) -> Dict[str, float]:
    """The parameters as finite floats (``TypeError`` / ``ValueError`` naming the scene and the
    parameter otherwise)."""
    return {name: real(f"{scene}: parameter {name!r}", value) for name, value in given.items()}


def _positive(scene: str, values: Dict[str, float], names: List[str]) -> None:
    for name in names:
        if not values[name] > 0.0:
            raise ValueError(f"{scene}: parameter {name!r} = {values[name]} must be > 0")


def cartesian_pendulum(m: float = 1.0, l: float = 1.0, g: float = 9.81) -> Model:
    """A point mass ``m`` on a rod of length ``l`` under gravity ``g``, in the Cartesian
    coordinates ``x``, ``y`` of the bob (y up, pivot at the origin) under the constraint
    ``"rod"``: x² + y² − l² = 0 — the seed's §2 start, N = 1 particle under f = 1 constraint,
    n = 3N − f after the plane motion's z = 0.

    T = ½ m (ẋ² + ẏ²), U = m g y. With G = ∂g/∂q = (2x, 2y) the reaction is Gᵀλ, and the rod's
    tension is −2 l λ = m (g cos θ + l θ̇²) for the angle θ from the downward vertical; small
    swings have ω² = g / l (``model.modes`` at the bottom (0, −l)), large ones the period
    4 √(l/g) K(sin(θ₀/2)).

    Raises ``TypeError`` for a parameter that is not a real number, ``ValueError`` for one
    that is not finite or not > 0.
    """
    v = _values("cartesian_pendulum", m=m, l=l, g=g)
    _positive("cartesian_pendulum", v, ["m", "l"])
    x, y = coordinates("x y")
    m_, l_, g_ = parameters("m l g")
    return Model([x, y], kinetic=0.5 * m_ * (x.d**2 + y.d**2), potential=m_ * g_ * y,
                 parameters=v, constraints={"rod": x**2 + y**2 - l_**2},
                 drawing=[(0.0, 0.0), (x, y)])


def rolling_cylinder_constrained(m: float = 1.0, j: float = 0.005, r: float = 0.1,
                                 g: float = 9.81, alpha: float = 0.3) -> Model:
    """A cylinder (mass ``m``, moment of inertia ``j`` about its axis, radius ``r``) rolling
    down an incline of angle ``alpha`` (seed §3.6, eq. 45–48) with both the distance ``x``
    and the rotation ``theta`` as coordinates under the rolling constraint ``"rolling"``:
    x − r θ = 0 (eq. 45).

    T = ½ m ẋ² + ½ J θ̇² and U = −m g x sin α (eq. 46–47 before the elimination). The
    constrained motion is eq. 48, ẍ = m g sin α / (m + J/r²), and the multiplier is the
    friction force along the incline that rolling needs (G = (1, −r)):
    λ = −(J/r²) ẍ = −m g sin α · (J/r²) / (m + J/r²), pointing up the slope; its torque −rλ
    spins the cylinder up. The seed's R_x, R_y that "never appear" are this force and the
    normal force m g cos α: the cylinder rolls without slipping while the friction coefficient
    is at least |λ| / (m g cos α) = tan α · (J/r²) / (m + J/r²).

    Raises ``TypeError`` for a parameter that is not a real number, ``ValueError`` for one
    that is not finite, a mass, inertia or radius that is not > 0.
    """
    v = _values("rolling_cylinder_constrained", m=m, j=j, r=r, g=g, alpha=alpha)
    _positive("rolling_cylinder_constrained", v, ["m", "j", "r"])
    x, th = coordinates("x theta")
    m_, j_, r_, g_, a_ = parameters("m j r g alpha")
    return Model([x, th], kinetic=0.5 * m_ * x.d**2 + 0.5 * j_ * th.d**2,
                 potential=-m_ * g_ * x * sin(a_), parameters=v,
                 constraints={"rolling": x - r_ * th})


def ball_in_sphere_constrained(m: float = 1.0, j: float = 0.016, r1: float = 1.0,
                               r2: float = 0.2, g: float = 9.81) -> Model:
    """A ball (mass ``m``, moment of inertia ``j``, radius ``r2``) rolling inside a hollow
    sphere of radius ``r1`` in a vertical plane through its centre (seed §3.6, eq. 49–53),
    with the angle ``th1`` of the ball's centre from the bottom and the ball's rotation ``th2``
    as coordinates under the rolling constraint ``"rolling"``: (r₁ − r₂) θ₁ − r₂ θ₂ = 0
    (eq. 49, both sides the distance s the centre travels).

    T = ½ m (r₁ − r₂)² θ̇₁² + ½ J θ̇₂² and U = −m g (r₁ − r₂) cos θ₁ (eq. 50–51 before the
    elimination). The constrained motion is eq. 53; small oscillations about the bottom have
    ω² = g / ((r₁ − r₂)(1 + J/(m r₂²))) (eq. 53 linearized; ``model.modes`` at (0, 0) gives it).
    The multiplier is the friction force R_s along the path of the centre
    (G = (r₁ − r₂, −r₂)): λ = −(J/r₂²) s̈.

    Raises ``TypeError`` for a parameter that is not a real number, ``ValueError`` for one
    that is not finite, a mass, inertia or radius that is not > 0, or r2 ≥ r1.
    """
    v = _values("ball_in_sphere_constrained", m=m, j=j, r1=r1, r2=r2, g=g)
    _positive("ball_in_sphere_constrained", v, ["m", "j", "r1", "r2"])
    if not v["r2"] < v["r1"]:
        raise ValueError(f"ball_in_sphere_constrained: the ball's radius r2 = {v['r2']} must be "
                         f"less than the sphere's r1 = {v['r1']}")
    th1, th2 = coordinates("th1 th2")
    m_, j_, r1_, r2_, g_ = parameters("m j r1 r2 g")
    return Model([th1, th2],
                 kinetic=0.5 * m_ * (r1_ - r2_) ** 2 * th1.d**2 + 0.5 * j_ * th2.d**2,
                 potential=-m_ * g_ * (r1_ - r2_) * cos(th1), parameters=v,
                 constraints={"rolling": (r1_ - r2_) * th1 - r2_ * th2})


def rhombus_link_constrained(l: float = 0.8, p: float = 3.0, q: float = 5.0) -> Model:
    """The seed's rhombus link of §3.2 example 3 as a closed chain in Cartesian coordinates:
    the half-diagonals ``x`` = OA = l cos θ and ``y`` = OB = l sin θ of a rhombus of four links
    ``l`` under the constraint ``"link"``: x² + y² − l² = 0, loaded by the vertical force ``p``
    at A and C and the horizontal force ``q`` at B and D.

    The loads do the virtual work δW = 2(P δx + Q δy), stated as the potential
    U = −2(P x + Q y); ``model.equilibrium`` solves the virtual work with the reaction kept and
    balances at Q = P tan θ (the seed's answer), with λ = −√(P² + Q²) / l and the reaction
    Gᵀλ = (−2P, −2Q) carrying the loads. T = ½ (ẋ² + ẏ²) is nominal (the seed's links are
    massless): the scene is for statics.

    Raises ``TypeError`` for a parameter that is not a real number, ``ValueError`` for one
    that is not finite or a length that is not > 0.
    """
    v = _values("rhombus_link_constrained", l=l, p=p, q=q)
    _positive("rhombus_link_constrained", v, ["l"])
    x, y = coordinates("x y")
    l_, p_, q_ = parameters("l p q")
    return Model([x, y], kinetic=0.5 * (x.d**2 + y.d**2), potential=-2 * (p_ * x + q_ * y),
                 parameters=v, constraints={"link": x**2 + y**2 - l_**2})


def spring_rhombus_constrained(a: float = 0.7, k: float = 300.0, l0: float = 0.5,
                               m: float = 3.0, g: float = 9.81) -> Model:
    """The seed's spring rhombus of §3.2 example 4 as a closed chain in Cartesian coordinates:
    the half-diagonals ``x`` = a sin θ (the spring BD = 2x) and ``y`` = a cos θ (AC = 2y) of a
    rhombus of links ``a`` under the constraint ``"link"``: x² + y² − a² = 0, with a spring
    ``k`` of natural length 2 ``l0`` across BD and a mass ``m`` hanging at C.

    U = ½ k (2L₀ − 2x)² − m g · 2y = 2k(L₀ − x)² − 2 m g y. ``model.equilibrium`` balances at
    m g sin θ = 2k(L₀ − a sin θ) cos θ (the seed's condition) with λ = −m g / (a cos θ).
    T = ½ m (ẋ² + ẏ²) is nominal (the links are massless): the scene is for statics.

    Raises ``TypeError`` for a parameter that is not a real number, ``ValueError`` for one
    that is not finite or a length, stiffness or mass that is not > 0.
    """
    v = _values("spring_rhombus_constrained", a=a, k=k, l0=l0, m=m, g=g)
    _positive("spring_rhombus_constrained", v, ["a", "k", "l0", "m"])
    x, y = coordinates("x y")
    a_, k_, l0_, m_, g_ = parameters("a k l0 m g")
    return Model([x, y], kinetic=0.5 * m_ * (x.d**2 + y.d**2),
                 potential=2 * k_ * (l0_ - x) ** 2 - 2 * m_ * g_ * y, parameters=v,
                 constraints={"link": x**2 + y**2 - a_**2})
