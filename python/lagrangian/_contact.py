"""Rolling contact: a wheel (a rigid body, its centre, its axle, its radius) rolling without
slipping on a plane, and a knife edge, as named constraint rows for ``lg.Model(constraints=…,
velocity_constraints=…)``.

The wheel is a thin disc of radius r about its centre c with the unit axle a (world axes). Its
point nearest a plane of upward unit normal u is the contact point

    P = c − r e,   e = (u − (u·a) a) / ‖u − (u·a) a‖

(the wheel's radius in its own plane that points down the plane's normal). Rolling without
slipping holds P's material velocity v_c + ω × (P − c) to zero: its component along u is the
time derivative of the holonomic height row u·P − h = u·c − r √(1 − (u·a)²) − h, and its two
components in the plane are the velocity rows. A knife edge only stops the velocity across its
blade."""

from __future__ import annotations

from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from ._bodies import Body, Vector, cross, dot, rotate, unit, vector3
from ._expr import Expr, ExprLike, _add, _mul, _sub, sqrt

__all__ = ["RollingContact", "rolling_contact", "knife_edge"]


def tangents(up: Sequence[float]) -> Tuple[Tuple[float, float, float], Tuple[float, float, float]]:
    """Two unit vectors t₁, t₂ = u × t₁ spanning the plane of normal ``up``: t₁ the world x axis
    projected onto the plane (the y axis where x is normal to it)."""
    u = np.array(up, dtype=float)
    for e in (np.eye(3)[0], np.eye(3)[1]):
        t1 = e - float(e @ u) * u
        if np.linalg.norm(t1) > 1e-6:
            break
    t1 = t1 / np.linalg.norm(t1)
    t2 = np.cross(u, t1)
    return (float(t1[0]), float(t1[1]), float(t1[2])), (float(t2[0]), float(t2[1]), float(t2[2]))


def _check_body(body: object, what: str) -> Body:
    if not isinstance(body, Body):
        raise TypeError(f"{what}: expected an lg.Body (from lg.Body or Frame.body), got "
                        f"{type(body).__name__}")
    return body


class RollingContact:
    """A wheel rolling without slipping on a plane, from :func:`rolling_contact`.

    Attributes
    ----------
    point : tuple of 3 expressions
        The contact point P = c − r e in world coordinates.
    height : expression
        u·P − h, zero while the wheel touches the plane (holonomic).
    slip : tuple of 3 expressions
        P's material velocity v_c + ω × (P − c) in world axes (linear in q̇).
    constraints : dict
        ``{"<name> height": height}``, for ``Model(constraints=…)``. Leave it out when the
        coordinates already keep the wheel on the plane (its row would be identically zero,
        and a zero row is a dependent one).
    velocity_constraints : dict
        ``{"<name> slip 1": t₁·slip, "<name> slip 2": t₂·slip}``: no slip in the plane, t₁ the
        world x axis projected onto the plane, t₂ = u × t₁ (:attr:`tangents`).
    """

    __slots__ = ("name", "body", "up", "tangents", "point", "height", "slip")

    def __init__(self, name: str, body: Body, up: Tuple[float, float, float],
                 point: Vector, height: Expr, slip: Vector) -> None:
        self.name = name
        self.body = body
        self.up = up
        self.tangents = tangents(up)
        self.point = point
        self.height = height
        self.slip = slip

    @property
    def constraints(self) -> Dict[str, Expr]:
        return {f"{self.name} height": self.height}

    @property
    def velocity_constraints(self) -> Dict[str, Expr]:
        t1, t2 = self.tangents
        return {f"{self.name} slip 1": dot(t1, self.slip),
                f"{self.name} slip 2": dot(t2, self.slip)}

    def __repr__(self) -> str:
        return f"RollingContact(name={self.name!r}, body={self.body.label}, up={self.up})"


def rolling_contact(
    body: Body,
    radius: ExprLike,
    axle: Sequence[ExprLike] = (0.0, 1.0, 0.0),
    center: Sequence[ExprLike] = (0.0, 0.0, 0.0),
    up: Sequence[float] = (0.0, 0.0, 1.0),
    level: ExprLike = 0.0,
    name: str = "wheel",
) -> RollingContact:
    """A wheel of ``radius`` rolling without slipping on the plane u·x = ``level`` (``up`` = u,
    the plane's normal pointing to the wheel's side; default the ground z = 0, z up).

    ``body`` is the wheel; ``center`` its centre and ``axle`` its axle direction (need not be
    unit), both in the body's axes from its centre of mass. The rows come from the body's
    kinematics (:meth:`Body.velocity`, :meth:`Body.angular_velocity`), so the wheel may sit at
    the end of any chain of frames. A wheel lying flat (its axle along ``up``) has no single
    contact point: the rows divide by √(1 − (u·a)²) = 0 there.

    A coin (mass 1, radius 1, moment 1/2 about its axle) kept upright in the x–z plane (z up),
    spun by θ about the world y axis and pushed along x by a unit force: its contact slips by
    ẋ − r θ̇, and rolling gives ẍ = F / (m + I/r²) = 2/3 (the across-row is identically zero
    here, so only the along-row is stated):

    >>> import lagrangian as lg
    >>> x, th = lg.coordinates("x th")
    >>> coin = lg.Body(1.0, (0.25, 0.5, 0.25), (x, 0.0, 1.0), lg.rotation_y(th))
    >>> wheel = lg.rolling_contact(coin, radius=1.0)
    >>> list(wheel.velocity_constraints)
    ['wheel slip 1', 'wheel slip 2']
    >>> rolling = lg.Model([x, th], bodies=[coin], potential=-x,
    ...                    velocity_constraints=[wheel.velocity_constraints["wheel slip 1"]])
    >>> rolling.accelerations(0.0, [0.0, 0.0], [1.0, 1.0]).round(12).tolist()
    [0.666666666667, 0.666666666667]

    Raises
    ------
    TypeError
        For a ``body`` that is not an :class:`~lagrangian.Body`.
    ValueError
        For an ``up`` or ``axle`` that is not a non-zero 3-vector, a non-positive numeric radius.
    """
    body = _check_body(body, "rolling_contact")
    if not isinstance(name, str) or not name:
        raise ValueError(f"rolling_contact: name must be a non-empty string, got {name!r}")
    u = unit(up, "rolling_contact: up")
    r = Expr.lift(radius)
    if r.op == "const" and not float(r.args[0]) > 0.0:
        raise ValueError(f"rolling_contact: radius {r.args[0]} must be > 0")
    a_body = vector3(axle, "rolling_contact: axle")
    if all(e.op == "const" for e in a_body):
        n = float(np.linalg.norm([float(e.args[0]) for e in a_body]))
        if not (np.isfinite(n) and n > 0.0):
            raise ValueError(f"rolling_contact: axle {tuple(axle)!r} is not a non-zero 3-vector")
        a_body = tuple(Expr.lift(float(e.args[0]) / n) for e in a_body)  # type: ignore[assignment]
    else:
        norm = sqrt(dot(a_body, a_body))
        a_body = tuple(e / norm for e in a_body)  # type: ignore[assignment]
    a = rotate(body.orientation, a_body)
    c = body.point(center)
    ua = dot(u, a)
    # e = (u − (u·a) a)/s with s = √(1 − (u·a)²) = ‖u − (u·a) a‖ (a, u unit).
    s = sqrt(1.0 - ua * ua)
    e = tuple(_mul(_sub(u[i], _mul(ua, a[i])), 1.0 / s) for i in range(3))
    arm = tuple(_mul(-1.0, _mul(r, e[i])) for i in range(3))  # P − c
    point = tuple(_add(c[i], arm[i]) for i in range(3))
    height = _sub(_sub(dot(u, c), _mul(r, s)), level)
    vc = body.velocity(center)
    w = body.angular_velocity("world")
    wxr = cross(w, arm)
    slip = tuple(_add(vc[i], wxr[i]) for i in range(3))
    return RollingContact(name, body, u, point, height, slip)  # type: ignore[arg-type]


def knife_edge(
    body: Body,
    blade: Sequence[ExprLike] = (1.0, 0.0, 0.0),
    point: Sequence[ExprLike] = (0.0, 0.0, 0.0),
    up: Sequence[float] = (0.0, 0.0, 1.0),
    name: Optional[str] = None,
) -> Dict[str, Expr]:
    """A knife edge (a skate, a sled's runner, a wheel's ideal line) on the plane of normal
    ``up``: the velocity of the body-fixed ``point`` (body axes) across the ``blade`` direction
    (body axes) within the plane is zero, n·v = 0 with n = u × R b. One named velocity row,
    ``{name or "knife edge": n·v}``, for ``Model(velocity_constraints=…)``.

    The Chaplygin sleigh (mass 1, moment 0.2 about its centre of mass) with its blade a = 0.5
    behind the centre of mass: u̇ = a ω², ω̇ = −m a u ω / (I + m a²) for the speed u along the
    blade and the turning rate ω — here u = 1, ω = 1, heading 0, so the centre of mass
    accelerates sideways by u ω + a ω̇ = 4/9 and ω̇ = −10/9:

    >>> import lagrangian as lg
    >>> x, y, th = lg.coordinates("x y th")
    >>> sled = lg.Body(1.0, (0.1, 0.1, 0.2), (x, y, 0.0), lg.rotation_z(th))
    >>> row = lg.knife_edge(sled, point=(-0.5, 0.0, 0.0))
    >>> sleigh = lg.Model([x, y, th], bodies=[sled], velocity_constraints=row)
    >>> sleigh.accelerations(0.0, [0.0, 0.0, 0.0], [1.0, 0.5, 1.0]).round(12).tolist()
    [0.0, 0.444444444444, -1.111111111111]

    Raises ``TypeError`` for a ``body`` that is not a Body, ``ValueError`` for an ``up`` that
    is not a non-zero 3-vector or a ``blade``/``point`` that is not three expressions.
    """
    body = _check_body(body, "knife_edge")
    u = unit(up, "knife_edge: up")
    b = rotate(body.orientation, vector3(blade, "knife_edge: blade"))
    normal = cross(u, b)
    v = body.velocity(point)
    return {name or "knife edge": dot(normal, v)}
