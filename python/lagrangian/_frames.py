"""Frames chained by joints: a frame is an orientation R(t, q) (its axes in world coordinates as
columns) and an origin o(t, q) in world coordinates; a joint makes a child frame from its parent
and the joint's coordinates. Bodies hang on frames (:meth:`Frame.body`), so a kinematic tree gives
each body's position and orientation as expressions, and :class:`~lagrangian.Body` derives T.

Closed loops are holonomic constraints (:func:`coincide`); the force and torque a joint
transmits along a run come from Newton–Euler over the bodies beyond it (:func:`joint_reaction`),
and a loop's force from its multipliers (:func:`loop_reaction`)."""

from __future__ import annotations

from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ._bodies import (
    Body,
    Rotation,
    Vector,
    euler_rotation,
    matmul,
    plus,
    quaternion_rotation,
    rotate,
    rotation_about,
    unit,
    vector3,
)
from ._expr import (
    Coordinate,
    Expr,
    ExprLike,
    _add,
    _mul,
    _sub,
    derivative,
    evaluate,
    time_derivative,
)

__all__ = ["Frame", "Joint", "Loop", "Reaction", "coincide", "joint_reaction", "loop_reaction"]

_IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
Matrix = Sequence[Sequence[ExprLike]]


class Joint:
    """What a joint records on its child frame (``frame.joint``): its ``kind`` ("revolute",
    "prismatic", "fixed", "spherical", "universal", "planar", "free"), its ``name``, its
    ``coordinates`` (the expressions it was given, in order), its unit ``axes`` (in the placed
    frame's axes; none for fixed, spherical and free) and its own holonomic ``constraints`` (a
    quaternion's unit norm, by row name; empty otherwise)."""

    __slots__ = ("kind", "name", "coordinates", "axes", "constraints")

    def __init__(self, kind: str, name: str, coordinates: Sequence[ExprLike],
                 axes: Sequence[Tuple[float, float, float]] = (),
                 constraints: Optional[Mapping[str, Expr]] = None) -> None:
        self.kind = kind
        self.name = name
        self.coordinates = tuple(Expr.lift(c) for c in coordinates)
        self.axes = tuple(axes)
        self.constraints: Dict[str, Expr] = dict(constraints or {})

    def __repr__(self) -> str:
        return f"Joint({self.kind!r}, name={self.name!r}, coordinates={self.coordinates!r})"


def _items(values: Any) -> List[Any]:
    """``values`` as a list: a sequence's items, or one value alone."""
    if values is None:
        return []
    if isinstance(values, (Expr, str, bytes)) or not hasattr(values, "__len__"):
        return [values]
    return list(values)


def _label(kind: str, name: Optional[str], *coords: Any) -> str:
    if name is not None:
        if not isinstance(name, str) or not name:
            raise TypeError(f"{kind} joint: name must be a non-empty string, got {name!r}")
        return name
    return f"{kind}({', '.join(str(c) for group in coords for c in _items(group))})"


def _lifted(kind: str, label: str, what: str, values: Any, n: int) -> Tuple[Expr, ...]:
    """``values`` as ``n`` expressions, or a ``ValueError`` naming the joint."""
    if isinstance(values, (Expr, str, bytes)) or not hasattr(values, "__len__"):
        items = None
    else:
        items = list(values)
    if items is None or len(items) != n:
        got = f"{len(items)}" if items is not None else repr(values)
        raise ValueError(f"{kind} joint {label!r}: {what} must be {n} expressions, got {got}")
    try:
        return tuple(Expr.lift(v) for v in items)
    except TypeError as exc:
        raise TypeError(f"{kind} joint {label!r}: {what}: {exc}") from None


def _scalar(kind: str, label: str, what: str, value: Any) -> Expr:
    if isinstance(value, (list, tuple, np.ndarray)):
        raise ValueError(f"{kind} joint {label!r}: {what} must be one expression, got {value!r}")
    try:
        return Expr.lift(value)
    except TypeError as exc:
        raise TypeError(f"{kind} joint {label!r}: {what}: {exc}") from None


def _axis(kind: str, label: str, axis: Any) -> Tuple[float, float, float]:
    try:
        return unit(axis, f"{kind} joint {label!r}")
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{exc}; give three numbers such as (0, 0, 1)") from None


def _perpendicular(kind: str, label: str, a: Sequence[float], b: Sequence[float]) -> None:
    dot = float(np.dot(a, b))
    if abs(dot) > 1e-12:
        raise ValueError(
            f"{kind} joint {label!r}: the axes {tuple(a)} and {tuple(b)} are not perpendicular "
            f"(cos = {dot:.3g}); give two perpendicular axes"
        )


def _orientation(kind: str, label: str, angles: Any, sequence: str,
                 quaternion: Any) -> Tuple[Rotation, Tuple[Expr, ...], Dict[str, Expr]]:
    """R of three angles or of a quaternion (exactly one given), the coordinates read and the
    quaternion's unit-norm row."""
    if (angles is None) == (quaternion is None):
        raise ValueError(
            f"{kind} joint {label!r}: give either angles=(a, b, c) with sequence=, or "
            "quaternion=(q0, q1, q2, q3)"
        )
    if quaternion is not None:
        qs = _lifted(kind, label, "quaternion", quaternion, 4)
        norm = _sub(_add(_add(_mul(qs[0], qs[0]), _mul(qs[1], qs[1])),
                         _add(_mul(qs[2], qs[2]), _mul(qs[3], qs[3]))), 1.0)
        return quaternion_rotation(*qs), qs, {f"{label}.unit": norm}
    a = _lifted(kind, label, "angles", angles, 3)
    try:
        r = euler_rotation(a, sequence)
    except ValueError as exc:
        raise ValueError(f"{kind} joint {label!r}: {exc}") from None
    return r, a, {}


class Frame:
    """A reference frame: ``orientation`` R (3×3 expressions; v_world = R v_frame) and ``origin``
    (world coordinates). ``Frame()`` is the world frame. Joints return child frames, which
    remember their ``parent`` and their :class:`Joint` (``joint``)::

        upper = lg.Frame().revolute(th1, axis=(0, 1, 0))
        lower = upper.revolute(th2, axis=(0, 1, 0), offset=(0, 0, -l))

    Every joint is placed first, as :meth:`fixed` places a frame: at ``offset`` (in the parent's
    axes) and turned by ``rotation`` relative to the parent; its axes are given in the placed
    frame's axes. ``name=`` names the joint in errors, constraint rows and reactions (default:
    the kind and its coordinates, such as ``revolute(th1)``).
    """

    __slots__ = ("orientation", "origin", "parent", "joint", "children", "bodies")

    def __init__(self, orientation: Optional[Matrix] = None,
                 origin: Sequence[ExprLike] = (0.0, 0.0, 0.0)) -> None:
        if isinstance(orientation, Rotation):  # keeps the angular velocity it carries
            self.orientation = orientation
        else:
            rows = _IDENTITY if orientation is None else orientation
            if len(rows) != 3:
                raise ValueError(f"a frame's orientation must be 3×3, got {orientation!r}")
            self.orientation = matmul(_IDENTITY, [vector3(r, "a frame's orientation row")
                                                  for r in rows])
        self.origin: Vector = vector3(origin, "a frame's origin")
        self.parent: Optional[Frame] = None
        self.joint: Optional[Joint] = None
        self.children: List[Frame] = []
        self.bodies: List[Body] = []

    # -- where things are ----------------------------------------------------------------------
    def point(self, p: Sequence[ExprLike]) -> Vector:
        """World coordinates o + R p of the point ``p`` given in this frame."""
        return plus(self.origin, self.vector(p))

    def vector(self, v: Sequence[ExprLike]) -> Vector:
        """World components R v of the vector ``v`` given in this frame's axes."""
        return rotate(self.orientation, vector3(v, "a vector"))

    @property
    def constraints(self) -> Dict[str, Expr]:
        """The holonomic rows of the joints from the world down to this frame (a quaternion's
        unit norm), by name: pass them to ``lg.Model(constraints=…)``; merge the dicts of
        several leaves for a tree (``{**a.constraints, **b.constraints}``)."""
        rows: Dict[str, Expr] = {}
        f: Optional[Frame] = self
        while f is not None:
            if f.joint is not None:
                rows = {**f.joint.constraints, **rows}
            f = f.parent
        return rows

    # -- joints ----------------------------------------------------------------------------------
    def _child(self, orientation: Matrix, origin: Sequence[ExprLike], joint: Joint,
               turn: Optional[Rotation] = None) -> "Frame":
        child = Frame(orientation, origin)
        # The nearest quaternion above rides along, so that a body hung below keeps M regular.
        q = getattr(turn, "quaternion", None) or self.orientation.quaternion
        if child.orientation.quaternion is not q:  # a fresh product, not the parent's own R
            child.orientation.quaternion = q
        child.parent, child.joint = self, joint
        self.children.append(child)
        return child

    def _placed(self, offset: Sequence[ExprLike], rotation: Optional[Matrix], kind: str,
                label: str) -> Tuple[Rotation, Vector]:
        try:
            turn = None if rotation is None else Frame(rotation).orientation
            r = self.orientation if turn is None else matmul(self.orientation, turn)
            return r, self.point(offset)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{kind} joint {label!r}: offset or rotation: {exc}") from None

    def fixed(self, offset: Sequence[ExprLike] = (0.0, 0.0, 0.0),
              rotation: Optional[Matrix] = None, name: Optional[str] = None) -> "Frame":
        """The frame at ``offset`` (in this frame's axes), turned by ``rotation`` relative to this
        frame (default none): a fixed joint, and the placement every other joint starts from."""
        label = _label("fixed", name)
        r, o = self._placed(offset, rotation, "fixed", label)
        return self._child(r, o, Joint("fixed", label, ()))

    def revolute(self, angle: ExprLike, axis: Sequence[float] = (0.0, 0.0, 1.0),
                 offset: Sequence[ExprLike] = (0.0, 0.0, 0.0),
                 rotation: Optional[Matrix] = None, name: Optional[str] = None) -> "Frame":
        """A revolute (hinge) joint: the child frame turned by ``angle`` about the unit ``axis``
        (three numbers, in the placed frame's axes), its origin on the axis at the placement."""
        label = _label("revolute", name, angle)
        a = _scalar("revolute", label, "angle", angle)
        k = _axis("revolute", label, axis)
        r, o = self._placed(offset, rotation, "revolute", label)
        return self._child(matmul(r, rotation_about(k, a)), o,
                           Joint("revolute", label, (a,), (k,)))

    def prismatic(self, distance: ExprLike, axis: Sequence[float] = (1.0, 0.0, 0.0),
                  offset: Sequence[ExprLike] = (0.0, 0.0, 0.0),
                  rotation: Optional[Matrix] = None, name: Optional[str] = None) -> "Frame":
        """A prismatic (slider) joint: the child frame moved by ``distance`` along the unit
        ``axis`` (in the placed frame's axes), not turned."""
        label = _label("prismatic", name, distance)
        d = _scalar("prismatic", label, "distance", distance)
        k = _axis("prismatic", label, axis)
        r, o = self._placed(offset, rotation, "prismatic", label)
        return self._child(r, plus(o, rotate(r, tuple(_mul(d, x) for x in k))),
                           Joint("prismatic", label, (d,), (k,)))

    def spherical(self, angles: Optional[Sequence[ExprLike]] = None, sequence: str = "zyx",
                  offset: Sequence[ExprLike] = (0.0, 0.0, 0.0),
                  rotation: Optional[Matrix] = None, name: Optional[str] = None,
                  quaternion: Optional[Sequence[ExprLike]] = None) -> "Frame":
        """A spherical (ball) joint: the child frame turned about the placement by three
        ``angles`` of the intrinsic ``sequence`` (as :func:`~lagrangian.euler_rotation`; the
        default "zyx" — yaw, pitch, roll — is singular at pitch ±90°), or by the
        ``quaternion`` (q0, q1, q2, q3), four coordinates whose unit norm is the row
        ``"<name>.unit"`` of :attr:`constraints`, to pass to the model."""
        label = _label("spherical", name, angles, quaternion)
        turn, coords, rows = _orientation("spherical", label, angles, sequence, quaternion)
        r, o = self._placed(offset, rotation, "spherical", label)
        return self._child(matmul(r, turn), o,
                           Joint("spherical", label, coords, (), rows), turn)

    def universal(self, angles: Sequence[ExprLike],
                  axes: Sequence[Sequence[float]] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
                  offset: Sequence[ExprLike] = (0.0, 0.0, 0.0),
                  rotation: Optional[Matrix] = None, name: Optional[str] = None) -> "Frame":
        """A universal (Hooke, Cardan) joint: two ``angles`` about two perpendicular ``axes``
        (in the placed frame's axes), the second axis carried by the first turn:
        R = R(k₁, a₁) R(k₂, a₂)."""
        label = _label("universal", name, angles)
        a = _lifted("universal", label, "angles", angles, 2)
        if not hasattr(axes, "__len__") or len(axes) != 2:
            raise ValueError(f"universal joint {label!r}: axes must be two axes, got {axes!r}")
        k1, k2 = (_axis("universal", label, k) for k in axes)
        _perpendicular("universal", label, k1, k2)
        r, o = self._placed(offset, rotation, "universal", label)
        turn = matmul(rotation_about(k1, a[0]), rotation_about(k2, a[1]))
        return self._child(matmul(r, turn), o, Joint("universal", label, a, (k1, k2)))

    def planar(self, x: ExprLike, y: ExprLike, angle: ExprLike,
               axes: Sequence[Sequence[float]] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
               offset: Sequence[ExprLike] = (0.0, 0.0, 0.0),
               rotation: Optional[Matrix] = None, name: Optional[str] = None) -> "Frame":
        """A planar joint: the child frame moved by ``x`` and ``y`` along the two perpendicular
        in-plane ``axes`` u, v (in the placed frame's axes) and turned by ``angle`` about the
        plane's normal n = u × v."""
        label = _label("planar", name, x, y, angle)
        xs = (_scalar("planar", label, "x", x), _scalar("planar", label, "y", y),
              _scalar("planar", label, "angle", angle))
        if not hasattr(axes, "__len__") or len(axes) != 2:
            raise ValueError(f"planar joint {label!r}: axes must be two in-plane axes, got "
                             f"{axes!r}")
        u, v = (_axis("planar", label, k) for k in axes)
        _perpendicular("planar", label, u, v)
        n = tuple(float(c) for c in np.cross(u, v))
        r, o = self._placed(offset, rotation, "planar", label)
        shift = tuple(_add(_mul(xs[0], u[i]), _mul(xs[1], v[i])) for i in range(3))
        return self._child(matmul(r, rotation_about(n, xs[2])), plus(o, rotate(r, shift)),
                           Joint("planar", label, xs, (u, v, n)))  # type: ignore[arg-type]

    def free(self, position: Sequence[ExprLike], angles: Optional[Sequence[ExprLike]] = None,
             sequence: str = "zyx", quaternion: Optional[Sequence[ExprLike]] = None,
             offset: Sequence[ExprLike] = (0.0, 0.0, 0.0),
             rotation: Optional[Matrix] = None, name: Optional[str] = None) -> "Frame":
        """A free (six-degree-of-freedom) joint: the child frame at ``position`` (three
        expressions, in the placed frame's axes) and turned by ``angles`` or ``quaternion`` as
        :meth:`spherical` (whose unit-norm row it carries likewise)."""
        label = _label("free", name, position, angles, quaternion)
        p = _lifted("free", label, "position", position, 3)
        turn, coords, rows = _orientation("free", label, angles, sequence, quaternion)
        r, o = self._placed(offset, rotation, "free", label)
        return self._child(matmul(r, turn), plus(o, rotate(r, p)),
                           Joint("free", label, p + coords, (), rows), turn)

    # -- bodies ----------------------------------------------------------------------------------
    def body(self, mass: ExprLike, inertia: Any,
             center: Sequence[ExprLike] = (0.0, 0.0, 0.0), name: Optional[str] = None,
             gravity: Optional[Sequence[ExprLike]] = None) -> Body:
        """A :class:`~lagrangian.Body` fixed in this frame: centre of mass at ``center`` (this
        frame's axes), inertia about it in this frame's axes, oriented as the frame. The frame
        keeps it (``bodies``), for :func:`joint_reaction`."""
        b = Body(mass, inertia, self.point(center), self.orientation, name=name, gravity=gravity)
        self.bodies.append(b)
        return b

    def subtree(self) -> List["Frame"]:
        """This frame and every frame below it, parents first."""
        out: List[Frame] = []
        stack = [self]
        while stack:  # each frame has one parent: a tree, every frame visited once
            f = stack.pop()
            out.append(f)
            stack.extend(reversed(f.children))
        return out

    def __repr__(self) -> str:
        joint = "" if self.joint is None else f", joint={self.joint.name!r}"
        return f"Frame(orientation={self.orientation!r}, origin={self.origin!r}{joint})"


# -- closed loops -----------------------------------------------------------------------------
class Loop(Dict[str, Expr]):
    """The rows of a loop closure by name (a ``dict``: pass it as ``constraints=``, or merge
    it); ``frame_a``, ``point_a``, ``frame_b``, ``point_b``, ``components`` and ``name``
    record what was joined, for :func:`loop_reaction`."""

    frame_a: Frame
    frame_b: Frame
    point_a: Vector
    point_b: Vector
    components: str
    name: str


def coincide(frame_a: Frame, point_a: Sequence[ExprLike], frame_b: Frame,
             point_b: Sequence[ExprLike], components: str = "xyz",
             name: str = "loop") -> Loop:
    """Close a loop: the point ``point_a`` of ``frame_a`` (in its axes) and ``point_b`` of
    ``frame_b`` coincide, along the world ``components`` chosen ("xyz" for a ball joint in
    space, "xy" for a pin in the x–y plane…). Returns the rows
    ``{"<name>.x": (a − b)ₓ, …}`` as a :class:`Loop`, to pass as ``constraints=``.

    The multipliers λ of these rows are the force on ``frame_a`` at the point (world
    components; −λ on ``frame_b``): the reaction +Gᵀλ is the generalized force of λ at a and
    −λ at b, since Gᵀλ = Σₖ λₖ ∂(aₖ − bₖ)/∂q."""
    if not isinstance(frame_a, Frame) or not isinstance(frame_b, Frame):
        raise TypeError(f"coincide {name!r}: give two lg.Frame, got {type(frame_a).__name__} "
                        f"and {type(frame_b).__name__}")
    if not isinstance(components, str) or not components or set(components) - set("xyz") \
            or len(set(components)) != len(components):
        raise ValueError(f"coincide {name!r}: components={components!r}; give distinct letters "
                         "of 'xyz', such as 'xyz' or 'xy'")
    if not isinstance(name, str) or not name:
        raise TypeError(f"coincide: name must be a non-empty string, got {name!r}")
    a, b = frame_a.point(point_a), frame_b.point(point_b)
    loop = Loop()
    for c in components:
        i = "xyz".index(c)
        loop[f"{name}.{c}"] = _sub(a[i], b[i])
    loop.frame_a, loop.frame_b, loop.point_a, loop.point_b = frame_a, frame_b, a, b
    loop.components, loop.name = components, name
    return loop


# -- reactions --------------------------------------------------------------------------------
class Reaction:
    """Forces along a run: ``t`` (n,), ``force`` and ``torque`` (n, 3) — about ``point``
    (n, 3, world coordinates) — in world axes, or in the child frame's axes for
    ``axes="frame"``."""

    __slots__ = ("t", "force", "torque", "point")

    def __init__(self, t: Any, force: Any, torque: Any, point: Any) -> None:
        self.t, self.force, self.torque, self.point = t, force, torque, point

    def __repr__(self) -> str:
        return f"Reaction({len(self.t)} states)"


def _states(states: Any) -> Tuple[Any, Any, Any]:
    """(t, q, q̇) as arrays (n,), (n, dof), (n, dof) from a solution or a tuple (t, q, q̇)."""
    if hasattr(states, "t") and hasattr(states, "q") and hasattr(states, "qd"):
        t, q, qd = states.t, states.q, states.qd
    else:
        try:
            t, q, qd = states
        except (TypeError, ValueError):
            raise TypeError("give a Solution or a tuple (t, q, qd)") from None
    q2, qd2 = np.atleast_2d(np.asarray(q, float)), np.atleast_2d(np.asarray(qd, float))
    tt = np.broadcast_to(np.asarray(t, float), (q2.shape[0],)).copy()
    if q2.shape != qd2.shape:
        raise ValueError(f"q has shape {q2.shape} but qd {qd2.shape}")
    return tt, q2, qd2


def _suffix(names: Sequence[str]) -> str:
    s = "__dd"
    while any(n.endswith(s) for n in names):
        s += "_"
    return s


class _Evaluator:
    """Expressions of t, q, q̇ and q̈ at many states, in NumPy (``_expr.evaluate``): q̈ stands
    in as extra coordinates."""

    def __init__(self, model: Any, t: Any, q: Any, qd: Any, qdd: Any) -> None:
        self.coords: List[Coordinate] = list(model.coordinates)
        names = [c.name for c in self.coords]
        s = _suffix(names)
        self.acc = [Coordinate(n + s) for n in names]
        self.names = names + [c.name for c in self.acc]
        self.params = {k: float(v) for k, v in model.parameters.items()}
        self.t, self.q, self.qd = t, np.hstack([q, qdd]), np.hstack([qd, np.zeros_like(qd)])

    def second(self, e: ExprLike) -> Expr:
        """d²e/dt² for e(t, q): time_derivative of ė plus Σ ∂ė/∂q̇ᵢ q̈ᵢ."""
        return self.dot(time_derivative(e, self.coords))

    def dot(self, e: ExprLike) -> Expr:
        """de/dt for e(t, q, q̇)."""
        out = time_derivative(e, self.coords)
        for c, a in zip(self.coords, self.acc):
            out = _add(out, _mul(derivative(e, c.d), a))
        return out

    def __call__(self, exprs: Sequence[ExprLike], what: str) -> Any:
        return evaluate([Expr.lift(e) for e in exprs], self.names, self.params, self.t, self.q,
                        what, qd=self.qd)


def _cross(a: Any, b: Any) -> Any:
    return np.cross(a, b, axis=-1)


def _bodies_below(frame: Frame, bodies: Optional[Sequence[Body]]) -> List[Body]:
    if bodies is None:
        return [b for f in frame.subtree() for b in f.bodies]
    items: List[Any] = [bodies] if isinstance(bodies, Body) else list(bodies)
    for b in items:
        if not isinstance(b, Body):
            raise TypeError(f"bodies: expected lg.Body, got {type(b).__name__}")
    return items


def joint_reaction(model: Any, states: Any, frame: Frame,
                   bodies: Optional[Sequence[Body]] = None,
                   gravity: Optional[Sequence[float]] = None,
                   loops: Sequence[Loop] = (), axes: str = "world",
                   applied: Sequence[Tuple[Sequence[ExprLike], Sequence[ExprLike]]] = (),
                   applied_torques: Sequence[Sequence[ExprLike]] = (),
                   elsewhere: Sequence[str] = ()) -> Reaction:
    """The force and torque the parent exerts on ``frame``'s side of its joint along a run, by
    Newton–Euler over the bodies beyond it:

        F = Σ m (a − g) − Σ F_loop,   τ = Σ [(r − o) × m (a − g) + d/dt(I ω)] − Σ (p − o) × F_loop

    about the joint point o (the frame's origin), a the centres' accelerations (q̈ from the
    model), d/dt(I ω) = R (I Ω̇ + Ω × I Ω) of each body. ``bodies``: the bodies beyond the joint
    (default: those hung by :meth:`Frame.body` on ``frame`` and the frames below it);
    ``gravity``: g (default each body's own ``gravity=``, else none); ``loops``: the loop
    closures (:func:`coincide`) whose force acts on that side, from the run's multipliers.
    ``applied``: other forces on that side, as pairs (point, force) of world expressions of
    t, q and q̇ (a spring's pull at its end, a load); ``applied_torques``: torques on that side,
    world expressions (a motor, an ``lg.Torque``); forces and torques not listed are not counted
    — those the model has as ``forces=`` or ``loads=`` included. Every constraint row of the
    model must be accounted for: a row of ``loops``, a quaternion's unit norm (``….unit``,
    which exerts nothing on the bodies), or named in ``elsewhere`` (rows whose forces act only
    on the parent's side); otherwise a ``ValueError`` names the rows, since their forces (a
    wheel's contact, a hand-written constraint) would be missing from the reaction.
    ``states``: a ``Solution`` or a
    tuple (t, q, q̇). ``axes="frame"`` gives the components in ``frame``'s axes.

    Along a frictionless joint's free directions the reaction is zero (a revolute joint's
    torque about its axis, a prismatic joint's force along it): a check of the model."""
    if not isinstance(frame, Frame):
        raise TypeError(f"joint_reaction: frame must be an lg.Frame, got {type(frame).__name__}")
    if axes not in ("world", "frame"):
        raise ValueError(f"joint_reaction: axes={axes!r}; give 'world' or 'frame'")
    items = _bodies_below(frame, bodies)
    if not items:
        raise ValueError(
            f"joint_reaction: no bodies beyond {frame.joint.name if frame.joint else 'the frame'!r}"
            ": hang them with frame.body(...) or pass bodies=[...]"
        )
    t, q, qd = _states(states)
    n = len(t)
    qdd = np.array([model.accelerations(float(t[i]), q[i], qd[i]) for i in range(n)])
    ev = _Evaluator(model, t, q, qd, qdd)
    o = ev(frame.origin, "the joint point").T
    force, torque = np.zeros((n, 3)), np.zeros((n, 3))
    for b in items:
        g = gravity if gravity is not None else b.gravity
        gv = np.zeros(3) if g is None else ev(list(g), f"body {b.label}'s gravity").T
        r_b = b.position
        acc = [ev.second(x) for x in r_b]
        omega = b.angular_velocity("body")  # the Ω its rotation carries, if any
        omega_dot = [ev.dot(w) for w in omega]
        rot = [x for row in b.orientation for x in row]
        inertia = [x for row in b.inertia for x in row]
        vals = ev([b.mass, *r_b, *acc, *omega, *omega_dot, *rot, *inertia], f"body {b.label}")
        m = vals[0][:, None]
        r, a = vals[1:4].T, vals[4:7].T
        w, wd = vals[7:10].T, vals[10:13].T
        rr = vals[13:22].T.reshape(n, 3, 3)
        ii = vals[22:31].T.reshape(n, 3, 3)
        f = m * (a - gv)
        iw = np.einsum("nij,nj->ni", ii, w)
        hdot_body = np.einsum("nij,nj->ni", ii, wd) + _cross(w, iw)
        force += f
        torque += _cross(r - o, f) + np.einsum("nij,nj->ni", rr, hdot_body)
    below = set(id(f) for f in frame.subtree())
    names = list(model.constraint_names)
    for loop in loops:
        if not isinstance(loop, Loop):
            raise TypeError(f"loops: expected what lg.coincide returns, got {type(loop).__name__}")
        _loop_force(loop, names, np.zeros((0, len(names))))  # its rows are the model's
    covered = {row for loop in loops for row in loop} | set(elsewhere)
    missing = [row for row in names if row not in covered and not row.endswith(".unit")]
    if missing:
        raise ValueError(
            f"joint_reaction: the model's constraint rows {missing} are not accounted for: their "
            "forces would be missing from the reaction. Pass the loop closures as loops=[...], "
            "or name rows whose forces act only on the parent's side in elsewhere=[...]"
        )
    if loops:
        lam_all = np.array([model.multipliers(float(t[i]), q[i], qd[i]) for i in range(n)])
        lam_all = lam_all.reshape(n, -1)
    for loop in loops:
        f_a = _loop_force(loop, names, lam_all)
        for side, sign in ((loop.frame_a, 1.0), (loop.frame_b, -1.0)):
            if id(side) in below:
                p = ev(loop.point_a if sign > 0 else loop.point_b, "a loop's point").T
                force -= sign * f_a
                torque -= _cross(p - o, sign * f_a)
    for k, pair in enumerate(applied):
        try:
            point, load = pair
            p = ev(list(vector3(point, "a point")), f"applied force {k}'s point").T
            f = ev(list(vector3(load, "a force")), f"applied force {k}").T
        except (TypeError, ValueError) as exc:
            raise ValueError(f"joint_reaction: applied[{k}]: {exc}; give (point, force), each "
                             "three expressions in world coordinates") from None
        force -= f
        torque -= _cross(p - o, f)
    for k, moment in enumerate(applied_torques):
        try:
            tau = ev(list(vector3(moment, "a torque")), f"applied torque {k}").T
        except (TypeError, ValueError) as exc:
            raise ValueError(f"joint_reaction: applied_torques[{k}]: {exc}; give three "
                             "expressions in world axes") from None
        torque -= tau
    if axes == "frame":
        rf = ev([x for row in frame.orientation for x in row], "the frame").T.reshape(n, 3, 3)
        force = np.einsum("nji,nj->ni", rf, force)
        torque = np.einsum("nji,nj->ni", rf, torque)
    return Reaction(t, force, torque, o)


def _loop_force(loop: Loop, names: Sequence[str], lam: Any) -> Any:
    out = np.zeros((lam.shape[0], 3))
    for c in loop.components:
        row = f"{loop.name}.{c}"
        if row not in names:
            raise ValueError(f"loop {loop.name!r}: the model has no constraint row {row!r}; "
                             "pass the loop as constraints= (or merged into them)")
        out[:, "xyz".index(c)] = lam[:, names.index(row)]
    return out


def loop_reaction(model: Any, states: Any, loop: Loop) -> Reaction:
    """The force on ``loop.frame_a`` at its point (world axes; −force on ``frame_b``) along a
    run, from the multipliers of the loop's rows (sign: reaction +Gᵀλ, see :func:`coincide`):
    components not constrained are zero, and the torque about that point is zero."""
    if not isinstance(loop, Loop):
        raise TypeError(f"loop_reaction: expected what lg.coincide returns, got "
                        f"{type(loop).__name__}")
    t, q, qd = _states(states)
    n = len(t)
    names = list(model.constraint_names)
    _loop_force(loop, names, np.zeros((0, len(names))))
    lam = np.array([model.multipliers(float(t[i]), q[i], qd[i]) for i in range(n)])
    force = _loop_force(loop, names, lam.reshape(n, -1))
    ev = _Evaluator(model, t, q, qd, np.zeros_like(q))
    return Reaction(t, force, np.zeros((n, 3)), ev(loop.point_a, "a loop's point").T)
