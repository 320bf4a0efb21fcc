"""Rigid bodies stated by mass, inertia, position and orientation; their kinetic energy

    T = ½ m ‖ṙ‖² + ½ Ωᵀ I Ω,   Ω = vee(Rᵀ Ṙ)

derived on the expression graph (ṙ and Ṙ are total time derivatives, taken by :func:`derivative`
of ``_expr``), and the rotation helpers that build R."""

from __future__ import annotations

import math
from typing import Any, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ._expr import (
    Coordinate,
    Expr,
    ExprLike,
    _add,
    _mul,
    _sub,
    cos,
    evaluate as evaluate_numpy,
    sin,
    time_derivative,
)

__all__ = [
    "Body",
    "PlanarBody",
    "rotation_x",
    "rotation_y",
    "rotation_z",
    "rotation_about",
    "euler_rotation",
    "quaternion_rotation",
]

Matrix = Tuple[Tuple[Expr, Expr, Expr], Tuple[Expr, Expr, Expr], Tuple[Expr, Expr, Expr]]


# -- numbers of expressions --------------------------------------------------------------------
def evaluate(e: ExprLike, q: Mapping[str, float], params: Mapping[str, float],
             time: float = 0.0) -> float:
    """``e`` at the coordinates' values ``q`` (by name), the parameters' values and ``time``."""
    state = np.array([[float(v) for v in q.values()]]).reshape(1, len(q))
    values = evaluate_numpy([Expr.lift(e)], list(q), params, np.array([time]), state,
                            what="a body's position or orientation")
    return float(values[0, 0])


# -- vectors of expressions ----------------------------------------------------------------------
Vector = Tuple[Expr, Expr, Expr]


def vector3(v: Sequence[ExprLike], what: str) -> Vector:
    items = list(v) if hasattr(v, "__len__") else None
    if items is None or len(items) != 3:
        raise ValueError(f"{what} must be three expressions (x, y, z), got {v!r}")
    return (Expr.lift(items[0]), Expr.lift(items[1]), Expr.lift(items[2]))


def plus(a: Sequence[Expr], b: Sequence[Expr]) -> Vector:
    return (_add(a[0], b[0]), _add(a[1], b[1]), _add(a[2], b[2]))


def minus(a: Sequence[ExprLike], b: Sequence[ExprLike]) -> Vector:
    """a − b for 3-vectors of expressions."""
    return (_sub(a[0], b[0]), _sub(a[1], b[1]), _sub(a[2], b[2]))


def dot(a: Sequence[ExprLike], b: Sequence[ExprLike]) -> Expr:
    """a · b for vectors of expressions (zeros and ones folded away)."""
    acc = Expr.lift(0.0)
    for x, y in zip(a, b):
        acc = _add(acc, _mul(x, y))
    return acc


def cross(a: Sequence[ExprLike], b: Sequence[ExprLike]) -> Vector:
    """a × b for 3-vectors of expressions."""
    return (_sub(_mul(a[1], b[2]), _mul(a[2], b[1])),
            _sub(_mul(a[2], b[0]), _mul(a[0], b[2])),
            _sub(_mul(a[0], b[1]), _mul(a[1], b[0])))


def transpose(m: Sequence[Sequence[ExprLike]]) -> Tuple[Tuple[ExprLike, ...], ...]:
    """The transpose of a 3×3 matrix (rows of expressions)."""
    return tuple(tuple(m[j][i] for j in range(3)) for i in range(3))


def rotate(r: Sequence[Sequence[ExprLike]], v: Sequence[ExprLike]) -> Vector:
    """R v for a 3×3 matrix of expressions ``r`` and a 3-vector ``v``."""
    out = []
    for i in range(3):
        acc = Expr.lift(0.0)
        for k in range(3):
            acc = _add(acc, _mul(r[i][k], v[k]))
        out.append(acc)
    return (out[0], out[1], out[2])


# -- rotations ---------------------------------------------------------------------------------
class Rotation(tuple):  # type: ignore[type-arg]
    """A rotation matrix R as three rows of expressions. From :func:`quaternion_rotation` it
    also carries the quaternion, which a :class:`Body` reads to keep M regular (see there).

    The helpers of this module also give ``omega``, the body-axes angular velocity
    Ω = vee(RᵀṘ), built with R — about a fixed axis k, Ω = k ȧ; of a product AB,
    Ω = Bᵀ Ω_A + Ω_B — so that a body on a chain of n joints gets Ω in O(n) nodes rather than
    by differentiating R's n-fold products (``None``: differentiate R)."""

    quaternion: Optional[Tuple[Expr, Expr, Expr, Expr]] = None
    omega: Optional[Vector] = None


def _rows(rows: Sequence[Sequence[ExprLike]], omega: Optional[Sequence[ExprLike]] = None
          ) -> Rotation:
    r = Rotation(tuple(tuple(Expr.lift(x) for x in row) for row in rows))
    if omega is not None:
        r.omega = (Expr.lift(omega[0]), Expr.lift(omega[1]), Expr.lift(omega[2]))
    elif all(x.op == "const" for row in r for x in row):
        r.omega = (Expr.lift(0.0), Expr.lift(0.0), Expr.lift(0.0))
    return r


def rotation_x(a: ExprLike) -> Rotation:
    """R of a rotation by the angle ``a`` about the x axis (right-handed)."""
    c, s = cos(a), sin(a)
    return _rows(((1.0, 0.0, 0.0), (0.0, c, -s), (0.0, s, c)), (time_derivative(a), 0.0, 0.0))


def rotation_y(a: ExprLike) -> Rotation:
    """R of a rotation by the angle ``a`` about the y axis (right-handed)."""
    c, s = cos(a), sin(a)
    return _rows(((c, 0.0, s), (0.0, 1.0, 0.0), (-s, 0.0, c)), (0.0, time_derivative(a), 0.0))


def rotation_z(a: ExprLike) -> Rotation:
    """R of a rotation by the angle ``a`` about the z axis (right-handed)."""
    c, s = cos(a), sin(a)
    return _rows(((c, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0)), (0.0, 0.0, time_derivative(a)))


def matmul(a: Sequence[Sequence[ExprLike]], b: Sequence[Sequence[ExprLike]]) -> Rotation:
    rows = []
    for i in range(3):
        row = []
        for j in range(3):
            acc = Expr.lift(0.0)
            for k in range(3):
                acc = _add(acc, _mul(a[i][k], b[k][j]))
            row.append(acc)
        rows.append(tuple(row))
    omega = None
    wa, wb = omega_of(a), omega_of(b)
    if wa is not None and wb is not None:  # Ω of AB = Bᵀ Ω_A + Ω_B
        omega = plus(rotate(transpose(b), wa), wb)
    return _rows(rows, omega)


def omega_of(r: Sequence[Sequence[ExprLike]]) -> Optional[Vector]:
    """The body-axes angular velocity a :class:`Rotation` carries, zero for a matrix of numbers,
    else ``None``."""
    omega = getattr(r, "omega", None)
    if omega is not None:
        return omega  # type: ignore[no-any-return]
    if all(Expr.lift(x).op == "const" for row in r for x in row):
        zero = Expr.lift(0.0)
        return (zero, zero, zero)
    return None


def unit(axis: Sequence[float], what: str) -> Tuple[float, float, float]:
    """``axis`` (three numbers) normalized, or a ``ValueError`` naming ``what``."""
    try:
        k = np.array([float(x) for x in axis])
    except (TypeError, ValueError):
        raise ValueError(f"{what}: axis must be three numbers, got {axis!r}") from None
    norm = float(np.linalg.norm(k)) if k.shape == (3,) else 0.0
    if not (np.isfinite(norm) and norm > 0.0):
        raise ValueError(f"{what}: axis {axis!r} is not a non-zero finite 3-vector")
    return (float(k[0] / norm), float(k[1] / norm), float(k[2] / norm))


def rotation_about(axis: Sequence[float], a: ExprLike) -> Rotation:
    """R of a rotation by the angle ``a`` about the fixed ``axis`` (three numbers, normalized
    here; right-handed): Rodrigues' formula R = cos a I + sin a [k]× + (1 − cos a) k kᵀ; about
    ±x, ±y, ±z it is :func:`rotation_x` (…) of ±a."""
    k = unit(axis, "rotation_about")
    for i, about in enumerate((rotation_x, rotation_y, rotation_z)):
        if abs(k[i]) == 1.0:
            return about(a if k[i] > 0 else -Expr.lift(a))
    c, s = cos(a), sin(a)
    c1 = 1.0 - c
    cross = ((0.0, -k[2], k[1]), (k[2], 0.0, -k[0]), (-k[1], k[0], 0.0))
    rows = tuple(
        tuple(_add(_add(c if i == j else 0.0, _mul(s, cross[i][j])), _mul(c1, k[i] * k[j]))
              for j in range(3))
        for i in range(3)
    )
    rate = time_derivative(a)
    return _rows(rows, (_mul(k[0], rate), _mul(k[1], rate), _mul(k[2], rate)))


_AXES = {"x": rotation_x, "y": rotation_y, "z": rotation_z}


def euler_rotation(angles: Sequence[ExprLike], sequence: str = "zxz") -> Rotation:
    """R of three intrinsic rotations: ``sequence`` "zxz" gives R = R_z(a₀) R_x(a₁) R_z(a₂) — the
    first about the world axis, the next about the once-turned axis, and so on. Proper Euler
    ("zxz", "xyx", …) and Tait–Bryan ("zyx", "xyz", …) sequences: three of x, y, z with no two
    neighbours equal."""
    if not isinstance(sequence, str) or len(sequence) != 3 or set(sequence) - set("xyz") \
            or sequence[0] == sequence[1] or sequence[1] == sequence[2]:
        raise ValueError(
            f"euler_rotation: sequence {sequence!r} is not an Euler or Tait–Bryan sequence: give "
            "three of 'x', 'y', 'z' with no two neighbours equal, such as 'zxz' or 'zyx'"
        )
    angles = list(angles)
    if len(angles) != 3:
        raise ValueError(f"euler_rotation: {len(angles)} angles; give three")
    r = _AXES[sequence[0]](angles[0])
    r = matmul(r, _AXES[sequence[1]](angles[1]))
    return matmul(r, _AXES[sequence[2]](angles[2]))


def quaternion_rotation(q0: ExprLike, q1: ExprLike, q2: ExprLike, q3: ExprLike) -> Rotation:
    """R of the quaternion q₀ + q₁i + q₂j + q₃k (scalar first), divided by ‖q‖² so that it is a
    rotation for every q ≠ 0 and the usual one on ‖q‖ = 1. State ‖q‖ = 1 as a constraint
    (``constraints=[q0**2 + q1**2 + q2**2 + q3**2 - 1]``)."""
    w, x, y, z = (Expr.lift(v) for v in (q0, q1, q2, q3))
    n = w**2 + x**2 + y**2 + z**2
    rows = (
        (w**2 + x**2 - y**2 - z**2, 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)),
        (2.0 * (x * y + w * z), w**2 - x**2 + y**2 - z**2, 2.0 * (y * z - w * x)),
        (2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w**2 - x**2 - y**2 + z**2),
    )
    wd, xd, yd, zd = (time_derivative(v) for v in (w, x, y, z))
    # Ω = 2 G(q) q̇ / ‖q‖² (G q = 0, so the length's rate drops out: exact off ‖q‖ = 1 too).
    omega = (2.0 * (-x * wd + w * xd + z * yd - y * zd) / n,
             2.0 * (-y * wd - z * xd + w * yd + x * zd) / n,
             2.0 * (-z * wd + y * xd - x * yd + w * zd) / n)
    r = _rows(tuple(tuple(e / n for e in row) for row in rows), omega)
    r.quaternion = (w, x, y, z)
    return r


# -- bodies ------------------------------------------------------------------------------------
def _lift(name: str, what: str, value: Any) -> Expr:
    try:
        return Expr.lift(value)
    except TypeError as exc:
        raise TypeError(f"body {name}: {what}: {exc}") from None


def _shape(name: str, what: str, value: Any, shape: Tuple[int, ...]) -> Any:
    try:
        arr = np.empty(shape, dtype=object)
        arr[...] = [list(r) for r in value] if len(shape) == 2 else list(value)
        if len(shape) == 2 and any(len(r) != shape[1] for r in value):
            raise ValueError
        if len(value) != shape[0]:
            raise ValueError
    except (TypeError, ValueError):
        size = "×".join(str(s) for s in shape)
        raise ValueError(
            f"body {name}: {what} must be {size} (nested row by row), got {value!r}"
        ) from None
    return arr


class Body:
    """A rigid body: its mass, its inertia tensor about the centre of mass in body axes, the
    centre of mass r(t, q) in world coordinates and the orientation R(t, q), whose columns are
    the body axes in world coordinates (v_world = R v_body). Given to
    :class:`~lagrangian.Model` as ``bodies=[…]``, it adds

        T = ½ m ‖ṙ‖² + ½ Ωᵀ I Ω,   Ω = vee(Rᵀ Ṙ)  (the body-frame angular velocity)

    to the model's kinetic energy, ṙ and Ṙ taken as total time derivatives on the expression
    graph. ``mass`` is a number or parameter expression; ``inertia`` a 3×3 tensor (nested
    sequences) or the three principal moments. Numbers are accepted wherever an expression is.

    With an orientation from :func:`quaternion_rotation`, T is blind to the quaternion's length
    and M would be singular along q; the body then adds ½ c (q·q̇)² with c = 4 tr(I)/3, which
    vanishes with its force on ‖q‖ = 1 (where q·q̇ = 0 and q·q̈ + ‖q̇‖² = 0): the motion on the
    constraint is unchanged, and M is regular.

    ``gravity`` (optional, a 3-vector g, e.g. ``(0, 0, -9.81)``): :attr:`potential` is then
    −m g·r, to add to the model's potential.
    """

    __slots__ = ("name", "mass", "inertia", "position", "orientation", "quaternion", "omega",
                 "gravity")

    def __init__(
        self,
        mass: ExprLike,
        inertia: Any,
        position: Sequence[ExprLike],
        orientation: Sequence[Sequence[ExprLike]],
        name: Optional[str] = None,
        gravity: Optional[Sequence[ExprLike]] = None,
    ) -> None:
        label = repr(name) if name is not None else "(unnamed)"
        self.name = name
        self.mass = _lift(label, "mass", mass)
        try:
            n_inertia = len(inertia)
        except TypeError:
            n_inertia = -1
        if n_inertia == 3 and all(not hasattr(r, "__len__") for r in inertia):
            moments = [_lift(label, "inertia", v) for v in inertia]
            z = Expr.lift(0.0)
            rows: Any = [[moments[0], z, z], [z, moments[1], z], [z, z, moments[2]]]
        else:
            rows = _shape(label, "inertia", inertia, (3, 3)).tolist()
        self.inertia = tuple(tuple(_lift(label, "inertia", v) for v in r) for r in rows)
        pos = list(position) if hasattr(position, "__len__") else None
        if pos is None or len(pos) != 3:
            raise ValueError(
                f"body {label}: position must be three expressions (x, y, z) of the "
                f"coordinates and t, got {position!r}"
            )
        self.position = tuple(_lift(label, "position", x) for x in pos)
        rr = _shape(label, "orientation", orientation, (3, 3)).tolist()
        self.orientation = tuple(tuple(_lift(label, "orientation", v) for v in r) for r in rr)
        self.quaternion = getattr(orientation, "quaternion", None)
        self.omega = getattr(orientation, "omega", None)
        self.gravity = None if gravity is None else tuple(
            _lift(label, "gravity", g) for g in _shape(label, "gravity", gravity, (3,)).tolist()
        )
        free = [s for s in self.mass.free_symbols() if s.op != "param"]
        if free:
            raise ValueError(
                f"body {label}: the mass depends on {free[0]!r}: give a number or parameters"
            )
        if all(e.op == "const" for r in self.inertia for e in r) and self.mass.op == "const":
            self.check_values({})

    @property
    def label(self) -> str:
        return repr(self.name) if self.name is not None else "(unnamed)"

    @property
    def potential(self) -> Expr:
        """−m g·r, for ``gravity=g`` (``ValueError`` without it)."""
        if self.gravity is None:
            raise ValueError(f"body {self.label} has no gravity=: give gravity=(gx, gy, gz)")
        acc = Expr.lift(0.0)
        for g, x in zip(self.gravity, self.position):
            acc = _sub(acc, _mul(_mul(self.mass, g), x))
        return acc

    def check_values(self, params: Mapping[str, float]) -> None:
        """The mass and inertia at the parameters' values: m ≥ 0; I symmetric, positive
        semidefinite, its principal moments obeying the triangle inequality."""
        m = evaluate(self.mass, {}, params)
        if not m >= 0.0:
            raise ValueError(f"body {self.label}: the mass is {m}; give a mass ≥ 0")
        inertia = np.array([[evaluate(e, {}, params) for e in r] for r in self.inertia])
        if not np.all(np.isfinite(inertia)):
            raise ValueError(f"body {self.label}: the inertia has a non-finite entry: {inertia}")
        scale = max(float(np.max(np.abs(inertia))), 1e-300)
        tol = 1e-12 * scale
        if np.max(np.abs(inertia - inertia.T)) > tol:
            raise ValueError(
                f"body {self.label}: the inertia tensor is not symmetric: {inertia.tolist()}"
            )
        moments = np.linalg.eigvalsh(inertia)
        if moments[0] < -tol:
            raise ValueError(
                f"body {self.label}: the inertia tensor is not positive semidefinite: principal "
                f"moments {moments.tolist()}"
            )
        if moments[0] + moments[1] < moments[2] - 1e-9 * scale:
            raise ValueError(
                f"body {self.label}: the principal moments {moments.tolist()} break the triangle "
                "inequality I₁ + I₂ ≥ I₃ (no mass distribution has them; a flat plate has "
                "I₁ + I₂ = I₃)"
            )

    def check_rotation(self, coordinates: Sequence[Coordinate], params: Mapping[str, float],
                       samples: int = 3, seed: int = 0) -> None:
        """RᵀR = I and det R = 1 at a few random states (coordinates in [−π, π], t in [0, 1])."""
        rng = np.random.default_rng(seed)
        for _ in range(samples):
            q = {c.name: float(v) for c, v in zip(coordinates, rng.uniform(-np.pi, np.pi,
                                                                           len(coordinates)))}
            time = float(rng.uniform(0.0, 1.0))
            r = np.array([[evaluate(e, q, params, time) for e in row]
                          for row in self.orientation])
            err = float(np.max(np.abs(r.T @ r - np.eye(3)))) if np.all(np.isfinite(r)) else math.inf
            det = float(np.linalg.det(r)) if np.all(np.isfinite(r)) else math.nan
            if not (err <= 1e-9 and abs(det - 1.0) <= 1e-9):
                raise ValueError(
                    f"body {self.label}: the orientation is not a rotation at q = {q}, t = "
                    f"{time:.3g}: max |RᵀR − I| = {err:.3g}, det R = {det:.6g}; give R with "
                    "orthonormal columns (the body axes in world coordinates) and det R = 1, "
                    "e.g. from lg.rotation_z or lg.euler_rotation"
                )

    # -- kinematics: what loads, constraints and outputs read ---------------------------------
    def point(self, p: Sequence[ExprLike]) -> Vector:
        """World coordinates r + R p of the body-fixed point ``p`` (body axes, from the centre of
        mass)."""
        return plus(self.position, rotate(self.orientation, vector3(p, "point")))

    def velocity(self, p: Sequence[ExprLike] = (0.0, 0.0, 0.0),
                 coordinates: Optional[Sequence[Coordinate]] = None) -> Vector:
        """World velocity of the body-fixed point ``p`` (default the centre of mass): the total
        time derivative of :meth:`point`, linear in q̇."""
        return tuple(time_derivative(x, coordinates) for x in self.point(p))  # type: ignore

    def angular_velocity(self, axes: str = "body",
                         coordinates: Optional[Sequence[Coordinate]] = None) -> Vector:
        """The angular velocity: Ω = vee(RᵀṘ) in body axes (``axes="body"``), or ω = R Ω in world
        axes (``axes="world"``)."""
        if axes not in ("body", "world"):
            raise ValueError(f"angular_velocity: axes={axes!r}; give 'body' or 'world'")
        r = self.orientation
        if self.omega is not None and coordinates is None:
            return self.omega if axes == "body" else rotate(r, self.omega)
        rdot = [[time_derivative(e, coordinates) for e in row] for row in r]

        def w(i: int, j: int) -> Expr:  # (RᵀṘ)[i][j] = Σ_k R[k][i] Ṙ[k][j]
            acc = Expr.lift(0.0)
            for k in range(3):
                acc = _add(acc, _mul(r[k][i], rdot[k][j]))
            return acc

        omega = (w(2, 1), w(0, 2), w(1, 0))
        return omega if axes == "body" else rotate(r, omega)

    def kinetic(self, coordinates: Sequence[Coordinate]) -> Expr:
        """T = ½ m |ṙ|² + ½ Ωᵀ I Ω of this body, Ω = vee(RᵀṘ)."""
        rd = [time_derivative(x, coordinates) for x in self.position]
        omega = self.angular_velocity("body", None if self.omega is not None else coordinates)
        trans = Expr.lift(0.0)
        for v in rd:
            trans = _add(trans, _mul(v, v))
        rot = Expr.lift(0.0)
        for i in range(3):
            for j in range(3):
                rot = _add(rot, _mul(_mul(omega[i], self.inertia[i][j]), omega[j]))
        total = _add(_mul(_mul(0.5, self.mass), trans), _mul(0.5, rot))
        if self.quaternion is not None:
            c = _mul(4.0 / 3.0, _add(_add(self.inertia[0][0], self.inertia[1][1]),
                                     self.inertia[2][2]))
            qq = Expr.lift(0.0)
            for e in self.quaternion:
                qq = _add(qq, _mul(e, time_derivative(e, coordinates)))
            total = _add(total, _mul(_mul(0.5, c), _mul(qq, qq)))
        return total

    def __repr__(self) -> str:
        return (f"Body(mass={self.mass!r}, inertia={self.inertia!r}, position={self.position!r}, "
                f"orientation={self.orientation!r}, name={self.name!r})")


def PlanarBody(  # noqa: N802 - a constructor by its use
    mass: ExprLike,
    inertia: ExprLike,
    position: Sequence[ExprLike],
    angle: ExprLike,
    name: Optional[str] = None,
) -> Body:
    """A body moving in the x–y plane: centre of mass (x, y), turned by ``angle`` about z, with
    the moment of inertia ``inertia`` about its centre of mass: the :class:`Body` with z = 0,
    R = R_z(angle) and inertia (0, 0, I) — whose T is ½ m (ẋ² + ẏ²) + ½ I θ̇²."""
    pos = list(position) if hasattr(position, "__len__") else None
    label = repr(name) if name is not None else "(unnamed)"
    if pos is None or len(pos) != 2:
        raise ValueError(
            f"body {label}: a planar body's position is two expressions (x, y), got {position!r}"
        )
    half = _mul(0.5, inertia)
    return Body(mass, [half, half, inertia],
                (pos[0], pos[1], 0.0), rotation_z(angle), name=name)


def bodies_kinetic(bodies: Any, coordinates: Sequence[Coordinate],
                   params: Mapping[str, float]) -> Optional[Expr]:
    """Σ T of ``bodies`` (each checked: mass, inertia, a rotation at sample states), or ``None``
    for no bodies."""
    if bodies is None:
        return None
    items: List[Any] = list(bodies) if not isinstance(bodies, Body) else [bodies]
    total: Optional[Expr] = None
    for b in items:
        if not isinstance(b, Body):
            raise TypeError(f"bodies: expected lg.Body or lg.PlanarBody, got {type(b).__name__}")
        missing = [s for e in (b.mass, *(x for r in b.inertia for x in r))
                   for s in e.free_symbols() if s.op == "param" and s.args[0] not in params]
        if missing:
            raise ValueError(f"body {b.label}: the parameter {missing[0]!r} has no value")
        names = {c.name for c in coordinates}
        for what, exprs in (("position", b.position),
                            ("orientation", [x for r in b.orientation for x in r])):
            for e in exprs:
                for sym in e.free_symbols():
                    if sym.op == "qd":
                        raise ValueError(
                            f"body {b.label}: the {what} reads the velocity {sym!r}: state it "
                            "in t, the coordinates and parameters (the velocities are derived)"
                        )
                    if sym.op == "q" and sym.args[0] not in names:
                        raise ValueError(
                            f"body {b.label}: the {what} reads {sym!r}, which is not a "
                            "coordinate of the model"
                        )
        b.check_values(params)
        b.check_rotation(coordinates, {k: float(v) for k, v in params.items()})
        t_b = b.kinetic(coordinates)
        total = t_b if total is None else total + t_b
    return total


def with_bodies(bodies: Any, coordinates: Any, parameters: Optional[Mapping[str, Any]],
                kinetic: Any, positions: Any, masses: Any, drawing: Any
                ) -> Tuple[Any, Any, Any, Any]:
    """``Model``'s ``kinetic, positions, masses, drawing`` with the bodies' T added: to
    ``kinetic``, or — with particles — to the particles' T derived here, the particles then
    kept as drawing points."""
    coords = list(coordinates)
    params = dict(parameters or {})
    total = bodies_kinetic(bodies, coords, params)
    if total is None:
        return kinetic, positions, masses, drawing
    if kinetic is not None:
        total = Expr.lift(kinetic) + total
    if positions is not None and masses is not None:
        for r, m in zip(positions, masses):
            speed2 = Expr.lift(0.0)
            for x in r:
                v = time_derivative(x, coords)
                speed2 = _add(speed2, _mul(v, v))
            total = total + _mul(_mul(0.5, Expr.lift(m)), speed2)
        if len(list(masses)) != len(list(positions)):
            raise ValueError(
                f"{len(list(masses))} masses for {len(list(positions))} positions: give one "
                "mass per position"
            )
        drawing = list(drawing or ()) + [tuple(r) for r in positions]
        positions = masses = None
    return total, positions, masses, drawing
