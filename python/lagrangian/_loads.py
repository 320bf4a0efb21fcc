"""Loads on rigid bodies, turned into the parts of a model: a force at a point of a body and a
torque on a body give generalized forces by virtual power,

    Qᵢ = F · ∂v_P/∂q̇ᵢ + τ · ∂ω/∂q̇ᵢ,

with the partial velocities taken exactly on the expression graph (∂v_P/∂q̇ᵢ = ∂P/∂qᵢ, and
∂ω/∂q̇ᵢ = vee(∂R/∂qᵢ Rᵀ) in world axes, vee(Rᵀ ∂R/∂qᵢ) in body axes); a spring between two
points adds ½ k (ℓ − ℓ₀)² to the potential, a damper ½ c ℓ̇² to Rayleigh's function.
``Model(loads=[…])`` adds them to its ``forces``, ``potential`` and ``dissipation``
(:func:`with_loads`)."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, List, Mapping, Optional, Sequence, Tuple

from ._bodies import Body, Vector, dot, minus, rotate, vector3
from ._expr import (
    Coordinate,
    Expr,
    ExprLike,
    _add,
    _is_const,
    _mul,
    derivative,
    sqrt,
    time_derivative,
)
from ._frames import Frame

__all__ = ["Force", "Torque", "Spring", "Damper", "Load", "partial_angular_velocity",
           "with_loads"]


# -- partial velocities --------------------------------------------------------------------------
def partial_angular_velocity(body: Body, s: Expr, axes: str = "world") -> Vector:
    """∂ω/∂ṡ of ``body`` for the coordinate ``s`` (or the explicit rate for ``s`` = t): the exact
    coefficient of ṡ in the angular velocity, vee(∂R/∂s Rᵀ) in world axes, vee(Rᵀ ∂R/∂s) in body
    axes — read off the Ω the body's rotation carries when it has one (ω is linear in q̇)."""
    if body.omega is not None and s.op == "q":
        rate = Coordinate(s.args[0]).d
        return tuple(derivative(w, rate) for w in body.angular_velocity(axes))  # type: ignore
    r = body.orientation
    dr = [[derivative(e, s) for e in row] for row in r]

    def w(i: int, j: int) -> Expr:
        acc = Expr.lift(0.0)
        for k in range(3):
            acc = _add(acc, _mul(dr[i][k], r[j][k]) if axes == "world"
                        else _mul(r[k][i], dr[k][j]))
        return acc

    return (w(2, 1), w(0, 2), w(1, 0))


# -- the loads ---------------------------------------------------------------------------------
class Load(ABC):
    """What every load has: an optional ``name`` (errors name the load by it, or by its place in
    ``loads=``), and what each kind gives (:meth:`expressions`, :meth:`parts`)."""

    __slots__ = ("name",)
    kind = "load"

    def __init__(self, name: Optional[str]) -> None:
        if name is not None and not isinstance(name, str):
            raise TypeError(f"a load's name must be a string, got {name!r}")
        self.name = name

    def label(self, index: int) -> str:
        return f"{self.kind} {self.name!r}" if self.name is not None else \
            f"loads[{index}] ({self.kind})"

    @abstractmethod
    def expressions(self) -> List[Tuple[str, Expr, bool]]:
        """(what, expression, may read velocities) for the checks."""

    @abstractmethod
    def parts(self, coordinates: Sequence[Coordinate]) -> Tuple[Optional[List[Expr]],
                                                                Optional[Expr], Optional[Expr]]:
        """(Q per coordinate, U, Φ), each ``None`` where the load adds nothing."""


def _axes(axes: str, what: str) -> str:
    if axes not in ("world", "body"):
        raise ValueError(f"{what}: axes={axes!r}; give 'world' or 'body'")
    return axes


def _body(body: Any, what: str) -> Body:
    if not isinstance(body, Body):
        raise TypeError(f"{what}: expected an lg.Body (or lg.PlanarBody, Frame.body), got "
                        f"{type(body).__name__}")
    return body


def _point(p: Any, what: str) -> Vector:
    """A world point: three expressions, a body (its centre of mass) or a frame (its origin)."""
    if isinstance(p, Body):
        return (p.position[0], p.position[1], p.position[2])
    if isinstance(p, Frame):
        return p.origin
    try:
        return vector3(p, what)
    except TypeError as exc:
        raise TypeError(f"{what}: {exc}") from None


class Force(Load):
    """A force ``force`` (three expressions of t, q, q̇) acting at the body-fixed point ``point``
    of ``body`` (body axes, from its centre of mass; default the centre of mass). ``axes="world"``:
    the force's components are in world axes; ``axes="body"``: in the body's axes, so that it
    turns with the body (a thrust, a follower force). Its generalized force is
    Qᵢ = F · ∂P/∂qᵢ (= F · ∂v_P/∂q̇ᵢ), P the point's world position.

    >>> import lagrangian as lg
    >>> th, = lg.coordinates("th")
    >>> rod = lg.Body(1.0, [1 / 12, 1 / 12, 0.0], [0.5 * lg.sin(th), 0, -0.5 * lg.cos(th)],
    ...               lg.rotation_y(-th))               # a rod of length 1 hung at the origin
    >>> push = lg.Force([2.0, 0.0, 0.0], rod, point=[0.0, 0.0, -0.5])   # at the tip, along x
    >>> model = lg.Model([th], bodies=[rod], loads=[push])
    >>> round(float(model.accelerations(0.0, [0.0], [0.0])[0]), 12)  # 2 cos θ / (m l²/3)
    6.0
    """

    __slots__ = ("force", "body", "point", "axes")
    kind = "force"

    def __init__(self, force: Sequence[ExprLike], body: Body,
                 point: Sequence[ExprLike] = (0.0, 0.0, 0.0), axes: str = "world",
                 name: Optional[str] = None) -> None:
        super().__init__(name)
        what = self.label(0) if name is not None else "lg.Force"
        self.force = vector3(force, f"{what}: the force")
        self.body = _body(body, what)
        self.point = vector3(point, f"{what}: the point")
        self.axes = _axes(axes, what)

    def expressions(self) -> List[Tuple[str, Expr, bool]]:
        return [("the force", e, True) for e in self.force]

    def world_force(self) -> Vector:
        return self.force if self.axes == "world" else rotate(self.body.orientation, self.force)

    def parts(self, coordinates: Sequence[Coordinate]) -> Tuple[Optional[List[Expr]],
                                                                Optional[Expr], Optional[Expr]]:
        f = self.world_force()
        p = self.body.point(self.point)
        return [dot(f, [derivative(x, c) for x in p]) for c in coordinates], None, None


class Torque(Load):
    """A torque ``torque`` (three expressions of t, q, q̇) on ``body``, in world axes
    (``axes="world"``) or in the body's axes (``axes="body"``, turning with it). Its generalized
    force is Qᵢ = τ · ∂ω/∂q̇ᵢ, with ω in the torque's axes.

    >>> import lagrangian as lg
    >>> a, = lg.coordinates("a")
    >>> rotor = lg.Body(1.0, [0.3, 0.3, 0.5], [0, 0, 0], lg.rotation_z(a))
    >>> spun = lg.Model([a], bodies=[rotor], loads=[lg.Torque([0, 0, 1.5], rotor)])
    >>> round(float(spun.accelerations(0.0, [0.4], [2.0])[0]), 12)           # τ / I₃
    3.0
    """

    __slots__ = ("torque", "body", "axes")
    kind = "torque"

    def __init__(self, torque: Sequence[ExprLike], body: Body, axes: str = "world",
                 name: Optional[str] = None) -> None:
        super().__init__(name)
        what = self.label(0) if name is not None else "lg.Torque"
        self.torque = vector3(torque, f"{what}: the torque")
        self.body = _body(body, what)
        self.axes = _axes(axes, what)

    def expressions(self) -> List[Tuple[str, Expr, bool]]:
        return [("the torque", e, True) for e in self.torque]

    def parts(self, coordinates: Sequence[Coordinate]) -> Tuple[Optional[List[Expr]],
                                                                Optional[Expr], Optional[Expr]]:
        return [dot(self.torque, partial_angular_velocity(self.body, c, self.axes))
                for c in coordinates], None, None


def _length(a: Vector, b: Vector) -> Tuple[Vector, Expr]:
    d = minus(a, b)
    return d, dot(d, d)


class Spring(Load):
    """A linear spring of stiffness ``stiffness`` and rest length ``rest_length`` between the
    world points ``a`` and ``b`` (three expressions of t and q each — ``body.point(p)`` for a
    point of a body, a body for its centre of mass, a frame for its origin, numbers for a point
    of the world): the
    potential ½ k (ℓ − ℓ₀)², ℓ = |a − b|. With ℓ₀ = 0 it is ½ k |a − b|², smooth everywhere;
    otherwise ℓ = √(d·d) is not differentiable where the points meet.

    >>> import lagrangian as lg
    >>> x, = lg.coordinates("x")
    >>> block = lg.Body(2.0, [0.1, 0.1, 0.1], [x, 0, 0], lg.rotation_z(0.0))
    >>> model = lg.Model([x], bodies=[block], loads=[lg.Spring(8.0, block, [0, 0, 0])])
    >>> model.potential
    0.5*8*x*x
    """

    __slots__ = ("stiffness", "rest_length", "a", "b")
    kind = "spring"

    def __init__(self, stiffness: ExprLike, a: Any, b: Any, rest_length: ExprLike = 0.0,
                 name: Optional[str] = None) -> None:
        super().__init__(name)
        what = self.label(0) if name is not None else "lg.Spring"
        self.stiffness = Expr.lift(stiffness)
        self.rest_length = Expr.lift(rest_length)
        self.a = _point(a, f"{what}: the end a")
        self.b = _point(b, f"{what}: the end b")

    def expressions(self) -> List[Tuple[str, Expr, bool]]:
        return ([("the stiffness", self.stiffness, False),
                 ("the rest length", self.rest_length, False)]
                + [("the end a", e, False) for e in self.a]
                + [("the end b", e, False) for e in self.b])

    def length(self) -> Expr:
        """ℓ = |a − b|."""
        return sqrt(_length(self.a, self.b)[1])

    def parts(self, coordinates: Sequence[Coordinate]) -> Tuple[Optional[List[Expr]],
                                                                Optional[Expr], Optional[Expr]]:
        _, dd = _length(self.a, self.b)
        if _is_const(self.rest_length, 0.0):
            return None, 0.5 * self.stiffness * dd, None
        return None, 0.5 * self.stiffness * (sqrt(dd) - self.rest_length) ** 2, None


class Damper(Load):
    """A linear damper of coefficient ``damping`` between the world points ``a`` and ``b`` (as
    :class:`Spring`): Rayleigh's function Φ = ½ c ℓ̇², ℓ̇ = (a − b)·(ȧ − ḃ)/ℓ the rate of change
    of the distance — the force −c ℓ̇ along the line between the points (undefined where they
    meet).

    >>> import lagrangian as lg
    >>> x, = lg.coordinates("x")
    >>> block = lg.Body(2.0, [0.1, 0.1, 0.1], [x + 1.0, 0, 0], lg.rotation_z(0.0))
    >>> m = lg.Model([x], bodies=[block], loads=[lg.Damper(0.4, block, [0, 0, 0])])
    >>> round(float(m.accelerations(0.0, [0.5], [3.0])[0]), 12)      # −c ẋ / m
    -0.6
    """

    __slots__ = ("damping", "a", "b")
    kind = "damper"

    def __init__(self, damping: ExprLike, a: Any, b: Any, name: Optional[str] = None) -> None:
        super().__init__(name)
        what = self.label(0) if name is not None else "lg.Damper"
        self.damping = Expr.lift(damping)
        self.a = _point(a, f"{what}: the end a")
        self.b = _point(b, f"{what}: the end b")

    def expressions(self) -> List[Tuple[str, Expr, bool]]:
        return ([("the damping", self.damping, False)]
                + [("the end a", e, False) for e in self.a]
                + [("the end b", e, False) for e in self.b])

    def parts(self, coordinates: Sequence[Coordinate]) -> Tuple[Optional[List[Expr]],
                                                                Optional[Expr], Optional[Expr]]:
        d, dd = _length(self.a, self.b)
        rate = dot(d, [time_derivative(x, coordinates) for x in d]) / sqrt(dd)
        return None, None, 0.5 * self.damping * rate**2


# -- into a model --------------------------------------------------------------------------------
def _check(load: Load, label: str, names: Sequence[str],
           parameters: Mapping[str, Any]) -> None:
    for what, e, velocities in load.expressions():
        for sym in e.free_symbols():
            if sym.op == "t":
                continue
            name = sym.args[0]
            if sym.op == "qd" and not velocities:
                raise ValueError(f"{label}: {what} reads the velocity {name}.d: state it in t, "
                                 "the coordinates and parameters")
            if sym.op in ("q", "qd") and name not in names:
                raise ValueError(f"{label}: {what} reads {name!r}, which is not a coordinate "
                                 f"of the model (coordinates: {', '.join(names)})")
            if sym.op == "param" and name not in parameters:
                raise ValueError(f"{label}: {what} reads the parameter {name!r}, which has no "
                                 "value: give it in parameters=")
    body = getattr(load, "body", None)
    if body is not None:
        for e in (*body.position, *(x for r in body.orientation for x in r)):
            for sym in e.free_symbols():
                if sym.op == "qd":
                    raise ValueError(f"{label}: its body {body.label} is placed by the velocity "
                                     f"{sym.args[0]}.d: state it in t, the coordinates and "
                                     "parameters")
                if sym.op == "q" and sym.args[0] not in names:
                    raise ValueError(f"{label}: its body {body.label} moves with "
                                     f"{sym.args[0]!r}, which is not a coordinate of the model")


def with_loads(loads: Any, coordinates: Sequence[Coordinate],
               parameters: Optional[Mapping[str, Any]], potential: Optional[ExprLike],
               dissipation: Optional[ExprLike], forces: Optional[Sequence[ExprLike]]
               ) -> Tuple[Optional[ExprLike], Optional[ExprLike], Optional[List[Expr]]]:
    """``Model``'s ``potential, dissipation, forces`` with the loads' parts added."""
    items: List[Any] = [loads] if isinstance(loads, Load) else list(loads)
    coords = list(coordinates)
    names = [c.name for c in coords]
    params = dict(parameters or {})
    q_total: Optional[List[Expr]] = None
    if forces is not None:
        q_total = [Expr.lift(f) for f in forces]
        if len(q_total) != len(coords):
            raise ValueError(f"forces: {len(q_total)} expressions for {len(coords)} coordinates; "
                             "give one generalized force per coordinate")
    for index, load in enumerate(items):
        if not isinstance(load, Load):
            raise TypeError(f"loads[{index}]: expected lg.Force, lg.Torque, lg.Spring or "
                            f"lg.Damper, got {type(load).__name__}")
        label = load.label(index)
        _check(load, label, names, params)
        q_load, u_load, phi_load = load.parts(coords)
        if q_load is not None:
            q_total = q_load if q_total is None else [_add(a, b) for a, b in zip(q_total,
                                                                                  q_load)]
        if u_load is not None:
            potential = u_load if potential is None else Expr.lift(potential) + u_load
        if phi_load is not None:
            dissipation = phi_load if dissipation is None else Expr.lift(dissipation) + phi_load
    return potential, dissipation, q_total
