"""Classics stated with rigid bodies (issue 50): each returns a :class:`~lagrangian.Model` made
from :class:`~lagrangian.Body` objects, whose kinetic energy the package derives, instead of a
hand-written T; ``model.bodies`` has them, and :meth:`~lagrangian.Model.body_motion` follows
them along a solution (their arrays and 3D pictures).

The rolling scenes restate the seed's eq. 45–48 and 49–53 (the Rust scenes
:func:`~lagrangian.scenes.rolling_cylinder` and :func:`~lagrangian.scenes.ball_in_sphere`): the
rolling condition is a holonomic relation between the body's angle and its position, either
substituted into the body's orientation (one coordinate, as the Rust scenes) or kept as a
constraint (``constrained=True``, as :mod:`._constrained_scenes`)."""

from __future__ import annotations

from typing import Dict, List

from ._bodies import Body, rotation_z
from ._expr import Expr, coordinates, cos, parameters, sin
from ._frames import Frame
from ._model import Model
from ._validate import real

__all__ = ["spinning_top", "gyroscope", "rolling_cylinder_body", "ball_in_sphere_body"]


def _values(scene: str, positive: List[str], **given: float) -> Dict[str, float]:
    values = {name: real(f"{scene}: parameter {name!r}", v) for name, v in given.items()}
    for name in positive:
        if not values[name] > 0.0:
            raise ValueError(f"{scene}: parameter {name!r} = {values[name]} must be > 0")
    return values


def spinning_top(m: float = 1.0, a: float = 0.02, c: float = 0.03, l: float = 0.3,
                 g: float = 9.81) -> Model:
    """The heavy symmetric top (a gyroscope on a fixed point): mass ``m``, moments ``a`` (about
    the transverse axes through the centre of mass) and ``c`` (about the symmetry axis), its
    centre of mass a distance ``l`` up the symmetry axis from the fixed tip, gravity ``g`` along
    −z. Built from frames: three revolute joints give the ZXZ Euler angles, coordinates ``phi``
    (precession about z), ``th`` (nutation, the tilt from z) and ``psi`` (spin about the
    symmetry axis); the top is :meth:`Frame.body` of the last frame.

    Steady precession at a fixed tilt θ with φ̇ = Ω and spin ω₃ = ψ̇ + Ω cos θ holds when
    A Ω² cos θ − C ω₃ Ω + m g l = 0, A = a + m l² (the moment about the tip), C = c; a fast top
    (C ω₃ large) precesses slowly at Ω → m g l / (C ω₃).

    Raises ``TypeError`` for a parameter that is not a real
    number, ``ValueError`` for one that is not finite, a mass, moment or length that is not
    > 0, or c > 2a (no body has such moments).
    """
    v = _values("spinning_top", ["m", "a", "c", "l"], m=m, a=a, c=c, l=l, g=g)
    phi, th, psi = coordinates("phi th psi")
    m_, a_, c_, l_, g_ = parameters("m a c l g")
    frame = Frame().revolute(phi, axis=(0, 0, 1)).revolute(th, axis=(1, 0, 0)) \
        .revolute(psi, axis=(0, 0, 1))
    top = frame.body(m_, [a_, a_, c_], center=(0.0, 0.0, l_), name="top",
                     gravity=(0.0, 0.0, -g_))
    return Model([phi, th, psi], potential=top.potential, parameters=v, bodies=[top])


def gyroscope(a: float = 0.012, c: float = 0.02, inner: float = 0.004, inner_z: float = 0.003,
              outer: float = 0.006, tau: float = 0.0) -> Model:
    """A gyroscope in gimbals: the outer gimbal turns by ``psi`` about the vertical z, the inner
    gimbal by ``theta`` about the outer one's x axis, and the rotor spins by ``phi`` about the
    inner one's y axis (horizontal at θ = 0); every centre of mass on the pivot, so gravity does
    nothing. The rotor's moments are ``c`` about its spin axis and ``a`` across it; the inner
    gimbal's are ``inner`` about its axis x and ``inner_z`` about z, the outer gimbal's
    ``outer`` about z. A torque ``tau`` acts on the inner gimbal about its axis (a parameter,
    0 by default).

    Spinning at ω (φ̇ = ω) with θ = 0, the gimbals nutate at

        ω_n = C ω / √(A_in A_out),   A_in = a + inner,   A_out = a + inner_z + outer

    (the linearized A_out ψ̈ = −C ω θ̇, A_in θ̈ = C ω ψ̇), and under the torque τ the
    gyroscope precesses about z at the mean rate τ / (C ω), the inner gimbal turning by no
    more than 2 τ A_out / (C ω)² (the gyroscope's stiffness).

    Raises ``TypeError`` for a parameter that is not a real number, ``ValueError`` for one
    that is not finite or a moment that is not > 0 (``inner_z``, ``outer`` may be 0), or a
    rotor with c > 2a.
    """
    v = _values("gyroscope", ["a", "c", "inner"], a=a, c=c, inner=inner, inner_z=inner_z,
                outer=outer, tau=tau)
    for name in ("inner_z", "outer"):
        if not v[name] >= 0.0:
            raise ValueError(f"gyroscope: parameter {name!r} = {v[name]} must be ≥ 0")
    if v["c"] > 2.0 * v["a"]:
        raise ValueError(f"gyroscope: the rotor's moments c = {v['c']} > 2a = {2 * v['a']}: "
                         "no body has them (I₁ + I₂ ≥ I₃)")
    psi, theta, phi = coordinates("psi theta phi")
    a_, c_, i_, iz_, o_, tau_ = parameters("a c inner inner_z outer tau")
    outer_frame = Frame().revolute(psi, axis=(0, 0, 1), name="outer")
    inner_frame = outer_frame.revolute(theta, axis=(1, 0, 0), name="inner")
    rotor_frame = inner_frame.revolute(phi, axis=(0, 1, 0), name="rotor")
    # Each gimbal a flat ring in its plane: moments (x, y, z) with I_x + I_y ≥ I_z and so on.
    bodies = [
        outer_frame.body(0.0, [o_, o_, o_], name="outer gimbal"),
        inner_frame.body(0.0, [i_, i_, iz_], name="inner gimbal"),
        rotor_frame.body(0.0, [a_, c_, a_], name="rotor"),
    ]
    return Model([psi, theta, phi], parameters=v, bodies=bodies, forces=[0.0, tau_, 0.0])


def rolling_cylinder_body(m: float = 1.0, j: float = 0.005, r: float = 0.1, g: float = 9.81,
                          alpha: float = 0.3, constrained: bool = False
                          ) -> Model:
    """The seed's cylinder rolling down a slope of angle ``alpha`` (eq. 45–48) as a body: mass
    ``m``, moment ``j`` about its axis (z), radius ``r``; its centre at x (cos α, −sin α, 0), a
    distance ``x`` down the slope, under gravity −g ŷ. Rolling turns it by −x/r about z: substituted
    (coordinate ``x``, the Rust scene's), or with ``constrained=True`` the angle ``theta`` is a
    coordinate under the constraint ``"rolling"``: x + r θ = 0. Either way
    ẍ = m g sin α / (m + J/r²).

    Raises as :func:`rolling_cylinder_constrained`.
    """
    v = _values("rolling_cylinder_body", ["m", "j", "r"], m=m, j=j, r=r, g=g, alpha=alpha)
    m_, j_, r_, g_, a_ = parameters("m j r g alpha")
    x, theta = coordinates("x theta")
    coords = [x, theta] if constrained else [x]
    angle: Expr = theta if constrained else -x / r_
    cylinder = Body(m_, [0.5 * j_, 0.5 * j_, j_], (x * cos(a_), -x * sin(a_), 0.0),
                    rotation_z(angle), name="cylinder", gravity=(0.0, -g_, 0.0))
    return Model(coords, potential=cylinder.potential, parameters=v, bodies=[cylinder],
                  constraints={"rolling": x + r_ * angle} if constrained else None)


def ball_in_sphere_body(m: float = 1.0, j: float = 0.016, r1: float = 1.0, r2: float = 0.2,
                        g: float = 9.81, constrained: bool = False) -> Model:
    """The seed's ball rolling inside a hollow sphere (eq. 49–53) as a body: a ball of mass
    ``m``, moment ``j`` about every axis, radius ``r2``, its centre at angle ``theta`` from the
    bottom of the sphere of radius ``r1`` in the x–y plane (y up), under gravity −g ŷ. Rolling
    on the inside turns the ball by −(r₁ − r₂) θ / r₂ about z: substituted (coordinate
    ``theta``, the Rust scene's), or with ``constrained=True`` the ball's angle ``phi`` is a
    coordinate under the constraint ``"rolling"``: (r₁ − r₂) θ + r₂ φ = 0.

    Raises as :func:`ball_in_sphere_constrained`.
    """
    v = _values("ball_in_sphere_body", ["m", "j", "r1", "r2"], m=m, j=j, r1=r1, r2=r2, g=g)
    if not v["r2"] < v["r1"]:
        raise ValueError(f"ball_in_sphere_body: the ball's radius r2 = {v['r2']} must be less "
                         f"than the sphere's r1 = {v['r1']}")
    m_, j_, r1_, r2_, g_ = parameters("m j r1 r2 g")
    th, phi = coordinates("theta phi")
    coords = [th, phi] if constrained else [th]
    angle: Expr = phi if constrained else -(r1_ - r2_) * th / r2_
    ball = Body(m_, [j_, j_, j_], ((r1_ - r2_) * sin(th), -(r1_ - r2_) * cos(th), 0.0),
                rotation_z(angle), name="ball", gravity=(0.0, -g_, 0.0))
    return Model(coords, potential=ball.potential, parameters=v, bodies=[ball],
                  constraints={"rolling": (r1_ - r2_) * th + r2_ * angle} if constrained
                  else None)
