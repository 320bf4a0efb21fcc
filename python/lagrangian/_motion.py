"""Bodies along a solution: each body's position, orientation, velocities and energy as arrays
(``Model.body_motion``), and their 3D pictures. Everything is evaluated vectorized by the NumPy
evaluator of expressions; velocities come from the exact partials (expressions of t and q):
v = Σ ∂r/∂qᵢ q̇ᵢ + ∂r/∂t and ω = Σ vee(∂R/∂qᵢ Rᵀ) q̇ᵢ + vee(∂R/∂t Rᵀ)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import (TYPE_CHECKING, Any, Dict, List, Mapping, Optional, Protocol, Sequence, Tuple,
                    Union)

import numpy as np

from ._bodies import Body
from ._expr import Coordinate, Expr, derivative, evaluate, t as time_symbol
from ._loads import partial_angular_velocity
from ._protocols import Drawable, FloatArray, Trajectory

if TYPE_CHECKING:
    from matplotlib.figure import Figure  # type: ignore[import-not-found, unused-ignore]

__all__ = ["BodyMotion", "Motion", "body_motion"]

PathLike = Union[str, "os.PathLike[str]"]


class WithBodies(Drawable, Protocol):
    """A model as :func:`body_motion` reads it: coordinates, parameters and its bodies."""

    @property
    def bodies(self) -> Tuple[Body, ...]: ...


class _Kinematics:
    """A body's pose and the partials of its velocities, evaluated at many states."""

    def __init__(self, body: Body, names: Sequence[str], params: Mapping[str, float]) -> None:
        coords = [Coordinate(n) for n in names]
        self.body, self.names, self.params = body, list(names), dict(params)
        wrt: List[Expr] = [*coords, time_symbol]
        exprs: List[Expr] = list(body.position) + [x for r in body.orientation for x in r]
        for s in wrt:
            exprs += [derivative(x, s) for x in body.position]
        for s in wrt:
            exprs += list(partial_angular_velocity(body, s, "world"))
        self.exprs = exprs
        self.count = len(wrt)

    def pose(self, t: FloatArray, q: FloatArray) -> Tuple[FloatArray, FloatArray]:
        v = evaluate(self.exprs[:12], self.names, self.params, t, q, what=self.what)
        return v[:3].T, v[3:12].T.reshape(-1, 3, 3)

    @property
    def what(self) -> str:
        return f"body {self.body.label}"

    def all(self, t: FloatArray, q: FloatArray, qd: FloatArray) -> Dict[str, FloatArray]:
        v = evaluate(self.exprs, self.names, self.params, t, q, what=self.what)
        n, k = t.shape[0], self.count
        rates = np.concatenate([qd, np.ones((n, 1))], axis=1)           # (q̇, 1): the t partial
        dr = v[12:12 + 3 * k].reshape(k, 3, n)
        dw = v[12 + 3 * k:].reshape(k, 3, n)
        return {
            "position": np.ascontiguousarray(v[:3].T),
            "orientation": np.ascontiguousarray(v[3:12].T.reshape(n, 3, 3)),
            "velocity": np.einsum("kin,nk->ni", dr, rates),
            "angular_velocity": np.einsum("kin,nk->ni", dw, rates),
        }


def _number(e: Expr, params: Mapping[str, float], what: str) -> float:
    return float(evaluate([e], [], params, np.zeros(1), np.zeros((1, 0)), what=what)[0, 0])


class BodyMotion:
    """One body along a solution (``n`` points, as ``sol.t``).

    Attributes
    ----------
    body : Body
    t : ndarray, shape (n,)
    position : ndarray, shape (n, 3)
        The centre of mass r in world coordinates.
    orientation : ndarray, shape (n, 3, 3)
        R, whose columns are the body axes in world coordinates.
    velocity : ndarray, shape (n, 3)
        ṙ.
    angular_velocity : ndarray, shape (n, 3)
        ω in world axes.
    angular_velocity_body : ndarray, shape (n, 3)
        Ω = Rᵀω in body axes.
    kinetic : ndarray, shape (n,)
        ½ m |ṙ|² + ½ Ωᵀ I Ω.
    potential : ndarray, shape (n,)
        −m g·r for a body with ``gravity=``, else zeros.
    """

    __slots__ = ("body", "t", "position", "orientation", "velocity", "angular_velocity",
                 "angular_velocity_body", "kinetic", "potential", "mass", "inertia")

    def __init__(self, body: Body, t: FloatArray, arrays: Dict[str, FloatArray],
                 params: Mapping[str, float], names: Sequence[str], q: FloatArray) -> None:
        self.body, self.t = body, t
        self.position = arrays["position"]
        self.orientation = arrays["orientation"]
        self.velocity = arrays["velocity"]
        self.angular_velocity = arrays["angular_velocity"]
        self.angular_velocity_body = np.einsum("nji,nj->ni", self.orientation,
                                               self.angular_velocity)
        what = f"body {body.label}"
        self.mass = _number(body.mass, params, what)
        self.inertia = np.array([[_number(e, params, what) for e in r] for r in body.inertia])
        w = self.angular_velocity_body
        self.kinetic = 0.5 * self.mass * np.sum(self.velocity**2, axis=1) + 0.5 * np.einsum(
            "ni,ij,nj->n", w, self.inertia, w)
        if body.gravity is None:
            self.potential = np.zeros_like(t)
        else:
            self.potential = evaluate([body.potential], names, params, t, q, what=what)[0]

    @property
    def energy(self) -> FloatArray:
        """kinetic + potential of this body."""
        out: FloatArray = self.kinetic + self.potential
        return out

    def __repr__(self) -> str:
        return f"BodyMotion(body {self.body.label}, {self.t.shape[0]} points)"


class Motion(Sequence[BodyMotion]):
    """Bodies along a solution: a sequence of :class:`BodyMotion` (indexed by position or by a
    body's name), with their 3D pictures :meth:`plot` and :meth:`animate`."""

    def __init__(self, items: Sequence[BodyMotion], kinematics: Sequence[_Kinematics],
                 sol: Trajectory, dof: int) -> None:
        self._items = tuple(items)
        self._kinematics = tuple(kinematics)
        self._sol, self._dof = sol, dof

    def __len__(self) -> int:
        return len(self._items)

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, str):
            for m in self._items:
                if m.body.name == key:
                    return m
            raise KeyError(f"no body named {key!r}: the bodies are "
                           f"{[m.body.name for m in self._items]}")
        return self._items[key]

    def _pose(self, t: FloatArray, q: FloatArray) -> Tuple[FloatArray, FloatArray]:
        poses = [k.pose(t, q) for k in self._kinematics]
        return (np.stack([p for p, _ in poses], axis=1), np.stack([r for _, r in poses], axis=1))

    def _boxes(self) -> List[Any]:
        from ._plot_bodies import box_of

        return [box_of(m.mass, m.inertia) for m in self._items]

    def plot(self, path: Optional[PathLike] = None, *, snapshots: int = 5,
             trail: bool = True) -> "Figure":
        """A 3D figure of the bodies at ``snapshots`` evenly spaced times (older ones fainter):
        each as the uniform box with its mass and principal moments and its principal axes
        (x red, y green, z blue), with the paths of the centres of mass (``trail``). Saved to
        ``path`` (``.png``, ``.svg``, ``.pdf``) when given. Needs matplotlib."""
        from ._plot_bodies import plot_bodies

        names = [m.body.name or "" for m in self._items]
        return plot_bodies(self._sol, self._dof, self._pose, self._boxes(), names, path,
                           snapshots=snapshots, trail=trail)

    def animate(self, path: PathLike, *, fps: float = 30, max_frames: int = 300,
                trail: bool = True) -> Path:
        """A movie of the bodies (``.gif`` with pillow, ``.mp4`` with ffmpeg): frames evenly
        spaced in t (``max_frames`` at most), q between the solution's points by its cubic
        Hermite interpolant; boxes and principal axes as in :meth:`plot`, trails of the centres
        (``trail``). Needs matplotlib."""
        from ._plot_bodies import animate_bodies

        return animate_bodies(self._sol, self._dof, self._pose, self._boxes(), path, fps=fps,
                              max_frames=max_frames, trail=trail)

    def __repr__(self) -> str:
        return f"Motion({', '.join(m.body.label for m in self._items)})"


def body_motion(model: WithBodies, sol: Trajectory, bodies: Any = None) -> Motion:
    """The bodies along the solution ``sol`` of this model — ``bodies`` (a body or a sequence),
    by default the model's own (``bodies=`` of the model): a :class:`Motion`, a sequence of
    one :class:`BodyMotion` per body (``motion[0]`` or ``motion["name"]``) with the arrays
    ``position`` (n, 3), ``orientation`` (n, 3, 3), ``velocity``, ``angular_velocity`` (world
    axes), ``angular_velocity_body``, ``kinetic``, ``potential`` and ``energy`` at the solution's
    points, and the 3D pictures :meth:`Motion.plot` and :meth:`Motion.animate`.

    >>> import lagrangian as lg
    >>> a, = lg.coordinates("a")
    >>> wheel = lg.Body(2.0, [0.3, 0.3, 0.5], [0, 0, 0], lg.rotation_z(a), name="wheel")
    >>> model = lg.Model([a], bodies=[wheel])
    >>> sol = model.simulate([0.0], [4.0], 1.0)
    >>> motion = model.body_motion(sol)
    >>> motion["wheel"].angular_velocity[-1].round(12).tolist()
    [0.0, 0.0, 4.0]
    >>> motion[0].orientation.shape[1:]
    (3, 3)

    Raises ``TypeError`` for something that is not a body, ``ValueError`` for a body that moves
    with a symbol that is not a coordinate of the model or a parameter without a value, or a
    solution of another model.
    """
    if bodies is None:
        bodies = model.bodies
        if not bodies:
            raise ValueError("this model has no bodies: give the bodies to follow, "
                             "body_motion(sol, [body, ...])")
    items: List[Any] = [bodies] if isinstance(bodies, Body) else list(bodies)
    names = [c.name for c in model.coordinates]
    params = {k: float(v) for k, v in model.parameters.items()}
    t = np.asarray(sol.t, dtype=np.float64)
    q = np.asarray(sol.q, dtype=np.float64)
    qd = np.asarray(sol.qd, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != len(names) or qd.shape != q.shape or t.shape != q.shape[:1]:
        raise ValueError(f"the solution has q of shape {q.shape}; the model has {len(names)} "
                         "coordinates: give a solution of this model")
    kin, out = [], []
    for i, b in enumerate(items):
        if not isinstance(b, Body):
            raise TypeError(f"bodies[{i}]: expected lg.Body, got {type(b).__name__}")
        k = _Kinematics(b, names, params)
        kin.append(k)
        out.append(BodyMotion(b, t, k.all(t, q, qd), params, names, q))
    return Motion(out, kin, sol, len(names))
