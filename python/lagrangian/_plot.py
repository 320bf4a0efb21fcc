"""Pictures of trajectories: :meth:`Solution.plot <lagrangian.Solution.plot>` and
:meth:`Model.animate <lagrangian.Model.animate>`.

matplotlib (and pillow, for GIFs) is optional: it is imported here, lazily, only when a picture is
asked for, so ``import lagrangian`` never needs it. Figures are built with
:class:`matplotlib.figure.Figure` directly, not through ``pyplot``: nothing is shown and no global
figure is left open, whatever the backend.
"""

from __future__ import annotations

import math
import numbers
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from matplotlib.figure import Figure  # type: ignore[import-not-found, unused-ignore]

    from ._model import Model
    from ._solution import Solution

__all__ = ["Drawing", "plot_solution", "animate"]

FloatArray = npt.NDArray[np.float64]
PathLike = Union[str, "os.PathLike[str]"]

_INSTALL = "pip install lagrangian[plot]"
_FIGURE_SUFFIXES = (".png", ".svg", ".pdf")
_MOVIE_SUFFIXES = (".gif", ".mp4")


def _require_matplotlib() -> None:
    """``ImportError`` with the install hint unless matplotlib can be imported."""
    try:
        import matplotlib  # noqa: F401
    except ImportError as e:
        raise ImportError(f"plotting needs matplotlib ({e}): {_INSTALL}") from None


@dataclass(frozen=True)
class Drawing:
    """How :meth:`Model.animate` draws a model's particles, beyond points with trails.

    Particles are referred to by their index in :meth:`Model.positions`; index −1 is the pivot.

    Attributes
    ----------
    rods : tuple of (int, int)
        Segments drawn between two particles (or a particle and the pivot): a pendulum chain is
        ``((-1, 0), (0, 1), …)``.
    pivot : callable, optional
        Pivot positions at the given times, ``f(t) -> array of shape (len(t), 2)``; the origin
        when ``None``.
    bodies : tuple of (int, int, int)
        Rolling bodies as (centre, rim point, opposite rim point): drawn as a circle through the
        rim points with the diameter between them, which shows the rotation.
    circles : tuple of (x, y, radius)
        Fixed circles (a hollow sphere the ball rolls in).
    lines : tuple of (x, y, dx, dy)
        Fixed infinite lines through (x, y) along (dx, dy) (a slope).
    marks : tuple of (x, y)
        Fixed points (a centre of attraction, a pivot).
    trail : tuple of int, optional
        The particles that leave a trail; by default every particle that is not a body's rim
        point.
    """

    rods: Tuple[Tuple[int, int], ...] = ()
    pivot: Optional[Callable[[FloatArray], FloatArray]] = None
    bodies: Tuple[Tuple[int, int, int], ...] = ()
    circles: Tuple[Tuple[float, float, float], ...] = ()
    lines: Tuple[Tuple[float, float, float, float], ...] = ()
    marks: Tuple[Tuple[float, float], ...] = ()
    trail: Optional[Tuple[int, ...]] = None

    @staticmethod
    def chain(links: int, pivot: Optional[Callable[[FloatArray], FloatArray]] = None) -> "Drawing":
        """A pendulum chain of ``links`` bobs: rods from the pivot through the bobs in order, the
        last bob trailed."""
        rods = tuple((k - 1, k) for k in range(links))
        return Drawing(rods=rods, pivot=pivot, marks=((0.0, 0.0),) if pivot is None else (),
                       trail=(links - 1,))


def _suffix(path: PathLike, allowed: Sequence[str], what: str) -> Path:
    p = Path(os.fspath(path))
    if p.suffix.lower() not in allowed:
        raise ValueError(
            f"cannot tell how to write {what} to {str(p)!r}: the file name must end in "
            + ", ".join(allowed)
        )
    return p


def _checked(sol: "Solution") -> Tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    t = np.asarray(sol.t, dtype=np.float64)
    q = np.asarray(sol.q, dtype=np.float64)
    qd = np.asarray(sol.qd, dtype=np.float64)
    h = np.asarray(sol.energy, dtype=np.float64)
    if t.ndim != 1 or t.shape[0] == 0:
        raise ValueError("the solution is empty: there is nothing to draw")
    n = t.shape[0]
    if q.ndim != 2 or q.shape[0] != n or qd.shape != q.shape or h.shape != (n,):
        raise ValueError(
            f"inconsistent solution: t {t.shape}, q {q.shape}, qd {qd.shape}, energy {h.shape}"
        )
    return t, q, qd, h


def _names(sol: "Solution", dof: int) -> List[str]:
    names = list(sol.names) if sol.names is not None else []
    if len(names) != dof:
        names = [f"q{i}" for i in range(dof)]
    return names


def plot_solution(
    sol: "Solution", path: Optional[PathLike] = None, *, title: Optional[str] = None
) -> "Figure":
    """The figure of :meth:`Solution.plot`: q, q̇ and h against t in three stacked panels."""
    if path is not None:
        target: Optional[Path] = _suffix(path, _FIGURE_SUFFIXES, "a figure")
    else:
        target = None
    t, q, qd, h = _checked(sol)
    _require_matplotlib()
    from matplotlib.figure import Figure

    names = _names(sol, q.shape[1])
    fig = Figure(figsize=(8.0, 8.0), layout="constrained")
    ax_q, ax_v, ax_h = fig.subplots(3, 1, sharex=True)
    columns = max(1, math.ceil(len(names) / 8))
    for i, name in enumerate(names):
        ax_q.plot(t, q[:, i], label=name)
        ax_v.plot(t, qd[:, i], label=f"d{name}/dt")
    ax_q.set_ylabel("coordinates q")
    ax_v.set_ylabel("velocities q̇")
    for ax in (ax_q, ax_v):
        ax.legend(loc="upper right", fontsize="small", ncol=columns)
        ax.grid(True, alpha=0.3)

    (energy_line,) = ax_h.plot(t, h, color="black", label="h")
    ax_h.set_ylabel("energy h")
    ax_h.set_xlabel("t")
    ax_h.grid(True, alpha=0.3)
    drift = np.abs(h - h[0])
    finite = drift[np.isfinite(drift)]
    worst = float(finite.max()) if finite.size else math.nan
    twin = ax_h.twinx()
    shown = np.where(drift > 0.0, drift, np.nan)
    (drift_line,) = twin.plot(
        t, shown, color="tab:red", linewidth=0.8, alpha=0.8,
        label=f"|h − h₀| (max {worst:.3g})",
    )
    if np.any(np.isfinite(shown)):
        twin.set_yscale("log")
    twin.set_ylabel("drift |h − h₀|", color="tab:red")
    twin.tick_params(axis="y", colors="tab:red")
    ax_h.legend(handles=[energy_line, drift_line], loc="upper left", fontsize="small")
    if title is not None:
        fig.suptitle(title)
    if target is not None:
        fig.savefig(target)
    return fig


def _resample(
    t: FloatArray, q: FloatArray, count: int, refine: bool = False
) -> Tuple[FloatArray, FloatArray]:
    """``count`` states evenly spaced in t over the solution's span, linear in q in between;
    the solution's own points if it has no more than ``count`` and ``refine`` is off."""
    if count >= t.shape[0] and not refine:
        return t.copy(), q.copy()
    times = np.linspace(t[0], t[-1], count)
    order = np.argsort(t, kind="stable")
    ts = t[order]
    out = np.empty((count, q.shape[1]))
    for i in range(q.shape[1]):
        out[:, i] = np.interp(times, ts, q[order, i])
    return times, out


def _positive_int(what: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{what} must be an integer, got {value!r}")
    if int(value) < 1:
        raise ValueError(f"{what} = {value} must be at least 1")
    return int(value)


def _limits(points: FloatArray) -> Tuple[FloatArray, FloatArray]:
    """Equal-aspect limits holding every point (rows), with a margin."""
    lo = np.min(points, axis=0)
    hi = np.max(points, axis=0)
    span = float(np.max(hi - lo))
    pad = 0.08 * span if span > 0.0 else max(1.0, float(np.max(np.abs(points))))
    middle = 0.5 * (lo + hi)
    half = 0.5 * span + pad
    return middle - half, middle + half


def animate(
    model: "Model",
    sol: "Solution",
    path: PathLike,
    *,
    fps: float = 30,
    max_frames: int = 300,
    trail: bool = True,
    drawing: Optional[Drawing] = None,
    chain: bool = False,
) -> Path:
    """The movie of :meth:`Model.animate`; ``drawing`` says how to draw the particles,
    ``chain`` draws them as a pendulum chain instead."""
    target = _suffix(path, _MOVIE_SUFFIXES, "a movie")
    if isinstance(fps, bool) or not isinstance(fps, numbers.Real):
        raise TypeError(f"fps must be a number, got {fps!r}")
    if not (math.isfinite(float(fps)) and float(fps) > 0.0):
        raise ValueError(f"fps = {fps} must be finite and > 0")
    frames = _positive_int("max_frames", max_frames)
    if not model.has_positions:
        model.positions(0.0, np.zeros(model.dof))  # raises the model's own ValueError
    t, q, _, _ = _checked(sol)
    if q.shape[1] != model.dof:
        raise ValueError(
            f"the solution has {q.shape[1]} coordinates but the model has {model.dof}: "
            "animate a solution of this model"
        )
    bad = np.flatnonzero(~(np.isfinite(t) & np.all(np.isfinite(q), axis=1)))
    if bad.size:
        raise ValueError(
            f"the solution is not finite at point {bad[0]} (t = {t[bad[0]]}): "
            "nothing after a blow-up can be drawn"
        )
    _require_matplotlib()
    from matplotlib import animation
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    times, qf = _resample(t, q, frames)
    frame_pos = model.positions(times, qf)
    count, dim = frame_pos.shape[1], frame_pos.shape[2]
    if chain:
        draw = Drawing.chain(count)
    else:
        draw = drawing if drawing is not None else Drawing()
    for a, b in draw.rods:
        for k in (a, b):
            if not -1 <= k < count:
                raise ValueError(f"rod ({a}, {b}) names particle {k} of {count}")
    for body in draw.bodies:
        if not all(0 <= k < count for k in body):
            raise ValueError(f"body {body} names a particle outside 0…{count - 1}")
    rims = {k for body in draw.bodies for k in body[1:]}
    trailed = [k for k in range(count) if k not in rims] if draw.trail is None else list(draw.trail)
    if not all(0 <= k < count for k in trailed):
        raise ValueError(f"trail {draw.trail} names a particle outside 0…{count - 1}")
    if not trail:
        trailed = []
    # Trails and limits from the whole trajectory at ten points per frame: thinned, or refined
    # (linear in q) so that a trail follows its curve between the points of a coarse solution.
    dense_t, dense_q = _resample(t, q, 10 * len(times), refine=True)
    dense = model.positions(dense_t, dense_q)
    if not (np.all(np.isfinite(dense)) and np.all(np.isfinite(frame_pos))):
        raise ValueError("the model's positions are not finite along the solution")
    uses_pivot = any(-1 in rod for rod in draw.rods)
    pivot: FloatArray
    if draw.pivot is not None:
        pivot = np.asarray(draw.pivot(times), dtype=np.float64).reshape(len(times), 2)
        pivot_dense = np.asarray(draw.pivot(dense_t), dtype=np.float64).reshape(len(dense_t), 2)
    else:
        pivot = np.zeros((len(times), dim))
        pivot_dense = np.zeros((1, dim))

    extent: List[FloatArray] = [dense.reshape(-1, dim), frame_pos.reshape(-1, dim)]
    if uses_pivot:
        extent.append(pivot_dense[:, :dim])
    if dim == 2:
        for c, r1, _ in draw.bodies:
            radius = np.linalg.norm(dense[:, r1] - dense[:, c], axis=1)[:, None]
            for sign in (-1.0, 1.0):
                extent.append(dense[:, c] + sign * radius)
        for x, y, r in draw.circles:
            extent.append(np.array([[x - r, y - r], [x + r, y + r]]))
        if draw.marks:
            extent.append(np.array(draw.marks, dtype=np.float64))
    lo, hi = _limits(np.concatenate(extent, axis=0))

    fig = Figure(figsize=(6.0, 6.0), layout="constrained")
    if dim == 3:
        ax = fig.add_subplot(projection="3d")
        ax.set_zlim(lo[2], hi[2])
        ax.set_box_aspect((1.0, 1.0, 1.0))
        ax.set_zlabel("z")
    else:
        ax = fig.add_subplot()
        ax.set_aspect("equal")
        ax.grid(True, alpha=0.3)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_xlabel("x")
    ax.set_ylabel("y")

    def line(**style: Any) -> Any:
        if dim == 3:
            return ax.plot([], [], [], **style)[0]
        return ax.plot([], [], **style)[0]

    def put(artist: Any, xyz: FloatArray) -> None:
        if dim == 3:
            artist.set_data_3d(xyz[:, 0], xyz[:, 1], xyz[:, 2])
        else:
            artist.set_data(xyz[:, 0], xyz[:, 1])

    if dim == 2:
        for x, y, dx, dy in draw.lines:
            ax.axline((x, y), (x + dx, y + dy), color="0.4", linewidth=1.5)
        for x, y, r in draw.circles:
            ax.add_patch(Circle((x, y), r, fill=False, color="0.4", linewidth=1.5))
        if draw.marks:
            m = np.array(draw.marks, dtype=np.float64)
            ax.plot(m[:, 0], m[:, 1], marker="+", color="0.3", markersize=10, linestyle="none")
    trails = [line(linewidth=0.8, alpha=0.6) for _ in trailed]
    rods = line(color="0.2", linewidth=2.0, solid_capstyle="round")
    moving_pivot = line(marker="s", color="0.3", markersize=6, linestyle="none")
    circles = []
    spokes = line(color="tab:red", linewidth=1.5)
    for _ in draw.bodies:
        circle = Circle((0.0, 0.0), 1.0, fill=False, color="tab:blue", linewidth=2.0)
        ax.add_patch(circle)
        circles.append(circle)
    loose = [k for k in range(count) if not any(k in body for body in draw.bodies)]
    points = line(marker="o", color="tab:blue", markersize=8, linestyle="none")
    centres = line(marker=".", color="tab:blue", markersize=6, linestyle="none")
    clock = ax.text2D(0.02, 0.95, "", transform=ax.transAxes) if dim == 3 else ax.text(
        0.02, 0.95, "", transform=ax.transAxes
    )
    forward = t[-1] >= t[0]
    gap = np.full((1, dim), np.nan)

    def update(i: int) -> None:
        r = frame_pos[i]
        if draw.rods:
            segments = []
            for a, b in draw.rods:
                start = pivot[i, :dim] if a == -1 else r[a]
                end = pivot[i, :dim] if b == -1 else r[b]
                segments.extend([start[None, :], end[None, :], gap])
            put(rods, np.concatenate(segments, axis=0))
            if uses_pivot and draw.pivot is not None:
                put(moving_pivot, pivot[i : i + 1, :dim])
        if loose:
            put(points, r[loose])
        if draw.bodies:
            put(centres, r[[c for c, _, _ in draw.bodies]])
            segments = []
            for circle, (c, r1, r2) in zip(circles, draw.bodies):
                circle.center = (float(r[c, 0]), float(r[c, 1]))
                circle.set_radius(float(np.linalg.norm(r[r1] - r[c])))
                segments.extend([r[r1][None, :], r[r2][None, :], gap])
            put(spokes, np.concatenate(segments, axis=0))
        if trailed:
            # The dense points already passed, in the order of integration.
            upto = np.flatnonzero(dense_t <= times[i] if forward else dense_t >= times[i])
            for artist, k in zip(trails, trailed):
                put(artist, np.concatenate([dense[upto, k], r[k][None, :]], axis=0))
        clock.set_text(f"t = {times[i]:.3g}")

    if target.suffix.lower() == ".gif":
        writer: Any = animation.PillowWriter(fps=float(fps))
    else:
        if not animation.FFMpegWriter.isAvailable():
            raise RuntimeError(
                f"writing {str(target)!r} needs ffmpeg, which is not on the PATH: install "
                "ffmpeg or write a .gif instead"
            )
        writer = animation.FFMpegWriter(fps=float(fps))
    with writer.saving(fig, str(target), dpi=100):
        for i in range(len(times)):
            update(i)
            writer.grab_frame()
    return target
