"""Vehicles on rolling wheels (issue 50), as constrained models (:class:`~lagrangian.Model`)
stated by their rigid bodies and rolling contacts (:func:`~lagrangian.rolling_contact`): a disc
rolling on the ground, and the Whipple bicycle of the benchmark of Meijaard, Papadopoulos, Ruina
& Schwab (2007) — four bodies, two rolling wheels and the front contact's height."""

from __future__ import annotations

import math
from typing import Dict

from ._bodies import (
    Body,
    matmul,
    plus,
    rotate,
    rotation_x,
    rotation_y,
    rotation_z,
    vector3,
)
from ._contact import rolling_contact
from ._expr import coordinates, parameters
from ._model import Model
from ._validate import real

__all__ = ["rolling_disc", "whipple_bicycle"]

# Meijaard et al. (2007), Table 1, SI units; their axes: x forward, y right, z down.
BENCHMARK: Dict[str, float] = {
    "w": 1.02, "c": 0.08, "lam": math.pi / 10, "g": 9.81,
    "r_r": 0.3, "m_r": 2.0, "i_rxx": 0.0603, "i_ryy": 0.12,
    "x_b": 0.3, "z_b": -0.9, "m_b": 85.0, "i_bxx": 9.2, "i_bxz": 2.4, "i_byy": 11.0,
    "i_bzz": 2.8,
    "x_h": 0.9, "z_h": -0.7, "m_h": 4.0, "i_hxx": 0.05892, "i_hxz": -0.00756, "i_hyy": 0.06,
    "i_hzz": 0.00708,
    "r_f": 0.35, "m_f": 3.0, "i_fxx": 0.1405, "i_fyy": 0.28,
}

def rolling_disc(m: float = 1.0, r: float = 0.3, g: float = 9.81) -> Model:
    """A thin uniform disc (mass ``m``, radius ``r``: moments m r²/2 about its axle, m r²/4
    about a diameter) rolling without slipping on the ground z = 0 (z up, gravity ``g``).

    Coordinates: the contact point ``x``, ``y``, the heading ``psi``, the lean ``phi`` and the
    spin ``theta`` (R = R_z(ψ) R_x(φ) R_y(θ); the centre is r above the contact along the
    lean, so the contact's height needs no row). Velocity rows ``"disc slip 1"``,
    ``"disc slip 2"``: the contact point's material velocity is zero. Upright rolling along x
    at speed v is q = 0, ẋ = v, θ̇ = v/r; it is stable for v² > g r/3.

    Raises ``TypeError`` for a parameter that is not a real number, ``ValueError`` for one
    that is not finite or a mass or radius that is not > 0.
    """
    v = {k: real(f"rolling_disc: parameter {k!r}", x) for k, x in dict(m=m, r=r, g=g).items()}
    for k in ("m", "r"):
        if not v[k] > 0.0:
            raise ValueError(f"rolling_disc: parameter {k!r} = {v[k]} must be > 0")
    x, y, psi, phi, theta = coordinates("x y psi phi theta")
    m_, r_, g_ = parameters("m r g")
    lean = matmul(rotation_z(psi), rotation_x(phi))
    disc = Body(m_, (0.25 * m_ * r_**2, 0.5 * m_ * r_**2, 0.25 * m_ * r_**2),
                plus(vector3((x, y, 0.0), "the contact"), rotate(lean, (0.0, 0.0, r_))),
                matmul(lean, rotation_y(theta)), name="disc", gravity=(0.0, 0.0, -g_))
    contact = rolling_contact(disc, r_, name="disc")
    return Model([x, y, psi, phi, theta], bodies=[disc], potential=disc.potential,
                 parameters=v, velocity_constraints=contact.velocity_constraints)


_POSITIVE = ("w", "r_r", "m_r", "i_rxx", "i_ryy", "m_b", "i_bxx", "i_byy", "i_bzz", "m_h",
             "i_hxx", "i_hyy", "i_hzz", "r_f", "m_f", "i_fxx", "i_fyy")


def whipple_bicycle(
    w: float = 1.02, c: float = 0.08, lam: float = math.pi / 10, g: float = 9.81,
    r_r: float = 0.3, m_r: float = 2.0, i_rxx: float = 0.0603, i_ryy: float = 0.12,
    x_b: float = 0.3, z_b: float = -0.9, m_b: float = 85.0, i_bxx: float = 9.2,
    i_bxz: float = 2.4, i_byy: float = 11.0, i_bzz: float = 2.8,
    x_h: float = 0.9, z_h: float = -0.7, m_h: float = 4.0, i_hxx: float = 0.05892,
    i_hxz: float = -0.00756, i_hyy: float = 0.06, i_hzz: float = 0.00708,
    r_f: float = 0.35, m_f: float = 3.0, i_fxx: float = 0.1405, i_fyy: float = 0.28,
) -> Model:
    """The Whipple bicycle: rear wheel R, rear frame B with the rider, front frame H (fork and
    handlebar), front wheel F, with the benchmark's parameters as defaults (Meijaard et al.
    2007, Table 1) and their axes: x forward, y right, z down, gravity ``g`` along +z.

    Coordinates: the rear contact point ``x``, ``y``; the yaw ``psi``, lean ``phi`` and pitch
    ``theta`` of the rear frame (R_B = R_z(ψ) R_x(φ) R_y(θ)); the steer angle ``delta`` about
    the steer axis, tilted back by ``lam`` from the vertical; the wheels' rotations ``theta_r``
    (about the rear frame's y axis) and ``theta_f`` (about the fork's). The rear wheel's
    centre is r_R above its contact along the lean, so its height needs no constraint; the
    front contact's height (``"front height"``) is the holonomic row, which fixes the pitch;
    both wheels roll without slipping (``"rear slip 1"``, ``"rear slip 2"``,
    ``"front slip 1"``, ``"front slip 2"``, from :func:`~lagrangian.rolling_contact`). Upright
    straight running at speed v is q = 0, ẋ = v, θ̇_R = −v/r_R, θ̇_F = −v/r_F.

    The wheels are thin discs of inertia (I_xx, I_yy, I_xx) about their centres; B's and H's
    centres of mass are at (x_B, z_B) and (x_H, z_H) in the reference pose (rear contact at the
    origin), their inertia tensors in those axes, (x, z) products only. Every value is a model
    parameter (:meth:`~lagrangian.Model.with_parameters`).

    Raises ``TypeError`` for a parameter that is not a real number, ``ValueError`` for one that
    is not finite, or a mass, radius, wheelbase or moment that is not > 0.
    """
    given = dict(w=w, c=c, lam=lam, g=g, r_r=r_r, m_r=m_r, i_rxx=i_rxx, i_ryy=i_ryy,
                 x_b=x_b, z_b=z_b, m_b=m_b, i_bxx=i_bxx, i_bxz=i_bxz, i_byy=i_byy,
                 i_bzz=i_bzz, x_h=x_h, z_h=z_h, m_h=m_h, i_hxx=i_hxx, i_hxz=i_hxz,
                 i_hyy=i_hyy, i_hzz=i_hzz, r_f=r_f, m_f=m_f, i_fxx=i_fxx, i_fyy=i_fyy)
    v = {k: real(f"whipple_bicycle: parameter {k!r}", x) for k, x in given.items()}
    for k in _POSITIVE:
        if not v[k] > 0.0:
            raise ValueError(f"whipple_bicycle: parameter {k!r} = {v[k]} must be > 0")
    p = dict(zip(BENCHMARK, parameters(" ".join(BENCHMARK))))
    x, y, psi, phi, theta, delta, th_r, th_f = coordinates(
        "x y psi phi theta delta theta_r theta_f")
    zero = 0.0
    lean = matmul(rotation_z(psi), rotation_x(phi))
    centre_r = plus(vector3((x, y, zero), "the rear contact"),
                    rotate(lean, (zero, zero, -p["r_r"])))
    rot_b = matmul(lean, rotation_y(theta))
    steer = matmul(matmul(rotation_y(p["lam"]), rotation_z(delta)), rotation_y(-p["lam"]))
    rot_h = matmul(rot_b, steer)
    axis = (p["w"] + p["c"], zero, p["r_r"])  # a point of the steer axis (ground), from c_R

    def on_fork(pt: tuple) -> tuple:  # type: ignore[type-arg]
        rel = tuple(pt[i] - axis[i] for i in range(3))
        return plus(plus(centre_r, rotate(rot_b, axis)), rotate(rot_h, rel))

    gravity = (zero, zero, p["g"])
    rear = Body(p["m_r"], (p["i_rxx"], p["i_ryy"], p["i_rxx"]), centre_r,
                matmul(lean, rotation_y(th_r)), name="R", gravity=gravity)
    frame = Body(p["m_b"], ((p["i_bxx"], zero, p["i_bxz"]), (zero, p["i_byy"], zero),
                            (p["i_bxz"], zero, p["i_bzz"])),
                 plus(centre_r, rotate(rot_b, (p["x_b"], zero, p["z_b"] + p["r_r"]))), rot_b,
                 name="B", gravity=gravity)
    fork = Body(p["m_h"], ((p["i_hxx"], zero, p["i_hxz"]), (zero, p["i_hyy"], zero),
                           (p["i_hxz"], zero, p["i_hzz"])),
                on_fork((p["x_h"], zero, p["z_h"] + p["r_r"])), rot_h, name="H",
                gravity=gravity)
    front = Body(p["m_f"], (p["i_fxx"], p["i_fyy"], p["i_fxx"]),
                 on_fork((p["w"], zero, p["r_r"] - p["r_f"])), matmul(rot_h, rotation_y(th_f)),
                 name="F", gravity=gravity)
    up = (0.0, 0.0, -1.0)
    rear_contact = rolling_contact(rear, p["r_r"], up=up, name="rear")
    front_contact = rolling_contact(front, p["r_f"], up=up, name="front")
    bodies = [rear, frame, fork, front]
    potential = bodies[0].potential
    for b in bodies[1:]:
        potential = potential + b.potential
    return Model(
        [x, y, psi, phi, theta, delta, th_r, th_f],
        bodies=bodies,
        potential=potential,
        parameters={k: v[k] for k in BENCHMARK},
        constraints=front_contact.constraints,
        velocity_constraints={**rear_contact.velocity_constraints,
                              **front_contact.velocity_constraints},
    )
