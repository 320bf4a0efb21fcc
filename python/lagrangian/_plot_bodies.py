"""Pictures of rigid bodies in 3D (matplotlib's ``mplot3d``): each body drawn as the box with its
inertia — the uniform box of the same mass and principal moments, whose half-sizes are
aᵢ² = 3 (I_j + I_k − I_i) / (2 m) — and its principal axes (x red, y green, z blue), at a few
snapshots (:func:`plot_bodies`) or as a movie (:func:`animate_bodies`, blitted like
:meth:`Model.animate`). The poses come from the caller as arrays and a function of (t, q)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, List, Optional, Sequence, Tuple

import numpy as np

from ._plot import Movie, trajectory
from ._protocols import FloatArray, Trajectory
from ._validate import at_least_one, file_suffix, finite_positive

if TYPE_CHECKING:
    from matplotlib.figure import Figure  # type: ignore[import-not-found, unused-ignore]

__all__ = ["box_of", "box_lines", "plot_bodies", "animate_bodies"]

# (times, q) -> (positions (n, k, 3), orientations (n, k, 3, 3)) of k bodies at n states.
Pose = Callable[[FloatArray, FloatArray], Tuple[FloatArray, FloatArray]]
Box = Tuple[FloatArray, FloatArray]          # half-sizes (3,), principal axes (columns, 3×3)

_AXIS_COLOURS = ("tab:red", "tab:green", "tab:blue")
_BODY_COLOURS = ("0.25", "tab:purple", "tab:orange", "tab:brown", "tab:cyan", "tab:olive")
_EDGES = [(a, b) for a in range(8) for b in range(8) if a < b and bin(a ^ b).count("1") == 1]


def box_of(mass: float, inertia: FloatArray) -> Box:
    """The half-sizes and principal axes (columns, body axes) of the uniform box with the body's
    mass and inertia; zero sizes for a massless body."""
    moments, axes = np.linalg.eigh(np.asarray(inertia, dtype=np.float64))
    if not mass > 0.0:
        return np.zeros(3), axes
    total = float(np.sum(moments))
    half2 = 3.0 * (total - 2.0 * moments) / (2.0 * mass)
    return np.sqrt(np.clip(half2, 0.0, None)), axes


def _corners(box: Box) -> FloatArray:
    """The eight corners in body axes (corner k has signs from the bits of k)."""
    half, axes = box
    signs = np.array([[1.0 if k >> i & 1 else -1.0 for i in range(3)] for k in range(8)])
    return np.asarray((signs * half) @ axes.T)


def box_lines(centre: FloatArray, rotation: FloatArray, box: Box,
              axis_length: float) -> Tuple[FloatArray, List[FloatArray]]:
    """The box's twelve edges as one polyline with NaN gaps (36 × 3) and its three principal
    axes as segments from the centre (each 2 × 3), in world coordinates."""
    corners = centre + _corners(box) @ rotation.T
    gap = np.full((1, 3), np.nan)
    edges = np.concatenate([np.stack([corners[a], corners[b]]) if i == 0 else
                            np.concatenate([gap, np.stack([corners[a], corners[b]])])
                            for i, (a, b) in enumerate(_EDGES)])
    half, axes = box
    arms = []
    for k in range(3):
        length = max(1.5 * float(half[k]), axis_length)
        arms.append(np.stack([centre, centre + length * (rotation @ axes[:, k])]))
    return edges, arms


def _extent(positions: FloatArray, rotations: FloatArray, boxes: Sequence[Box],
            extra: FloatArray) -> Tuple[FloatArray, FloatArray, float]:
    """Cube limits holding every box at every pose and the ``extra`` points, and the length of
    the axes drawn for bodies without size (a tenth of the span)."""
    pts = [extra.reshape(-1, 3), positions.reshape(-1, 3)]
    for k, box in enumerate(boxes):
        c = _corners(box)
        pts.append((positions[:, k, None, :] + np.einsum("nij,cj->nci", rotations[:, k], c))
                   .reshape(-1, 3))
    allp = np.concatenate(pts)
    allp = allp[np.all(np.isfinite(allp), axis=1)]
    lo, hi = np.min(allp, axis=0), np.max(allp, axis=0)
    span = float(np.max(hi - lo))
    arm = 0.12 * span if span > 0.0 else 0.3
    half = 0.5 * (span + 2.0 * arm) * 1.08
    middle = 0.5 * (lo + hi)
    return middle - half, middle + half, arm


def _axes3d(fig: Any, lo: FloatArray, hi: FloatArray) -> Any:
    ax = fig.add_subplot(projection="3d")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect((1.0, 1.0, 1.0), zoom=0.9)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    return ax


def _check_solution(sol: Trajectory, dof: int) -> Tuple[FloatArray, FloatArray]:
    t = np.asarray(sol.t, dtype=np.float64)
    q = np.asarray(sol.q, dtype=np.float64)
    if t.ndim != 1 or t.shape[0] == 0:
        raise ValueError("the solution is empty: there is nothing to draw")
    if q.ndim != 2 or q.shape[1] != dof:
        raise ValueError(f"the solution has coordinates of shape {q.shape}; the model has {dof}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))):
        raise ValueError("the solution is not finite: nothing after a blow-up can be drawn")
    return t, q


def plot_bodies(sol: Trajectory, dof: int, pose: Pose, boxes: Sequence[Box],
                names: Sequence[str], path: Optional[Any] = None, *, snapshots: int = 5,
                trail: bool = True) -> "Figure":
    """The bodies at ``snapshots`` evenly spaced times (older ones fainter), with the paths of
    their centres of mass."""
    count = at_least_one("snapshots", snapshots)
    target = None if path is None else file_suffix(path, (".png", ".svg", ".pdf"), "a figure")
    t, _ = _check_solution(sol, dof)
    from matplotlib.figure import Figure

    times = np.linspace(t[0], t[-1], count if t.shape[0] > 1 else 1)
    pos, rot = pose(times, trajectory(sol, times)[0])
    dense_t = np.linspace(t[0], t[-1], max(200, 2 * count))
    dense, _ = pose(dense_t, trajectory(sol, dense_t)[0])
    lo, hi, arm = _extent(pos, rot, boxes, dense if trail else pos)
    fig = Figure(figsize=(5.5, 5.5), layout="constrained")
    ax = _axes3d(fig, lo, hi)
    for k, box in enumerate(boxes):
        colour = _BODY_COLOURS[k % len(_BODY_COLOURS)]
        if trail:
            ax.plot(dense[:, k, 0], dense[:, k, 1], dense[:, k, 2], color=colour,
                    linewidth=0.8, alpha=0.6)
        for i in range(len(times)):
            alpha = 0.25 + 0.75 * (i + 1) / len(times)
            edges, arms = box_lines(pos[i, k], rot[i, k], box, arm)
            ax.plot(edges[:, 0], edges[:, 1], edges[:, 2], color=colour, linewidth=1.0,
                    alpha=alpha, label=names[k] if i == len(times) - 1 else None)
            for a, c in zip(arms, _AXIS_COLOURS):
                ax.plot(a[:, 0], a[:, 1], a[:, 2], color=c, linewidth=1.5, alpha=alpha)
    ax.set_title(f"t = {times[0]:.3g} … {times[-1]:.3g}, {len(times)} snapshots")
    if any(names):
        ax.legend(loc="upper right", fontsize="small")
    if target is not None:
        fig.savefig(target, dpi=120)
    return fig


class BodyMovie(Movie):
    """A movie of bodies: boxes, principal axes, trails of the centres; the writers and the
    blitting are :class:`~lagrangian._plot.Movie`'s."""

    def __init__(self, times: FloatArray, pos: FloatArray, rot: FloatArray,
                 boxes: Sequence[Box], dense_t: FloatArray, dense: FloatArray,
                 trail: bool) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.times, self.pos, self.rot, self.boxes = times, pos, rot, list(boxes)
        self.dense_t, self.dense, self.trail_on = dense_t, dense, trail
        lo, hi, self.arm = _extent(pos, rot, boxes, dense)
        fig = Figure(figsize=(4.8, 4.8), dpi=100)
        fig.subplots_adjust(left=0.0, right=0.9, bottom=0.03, top=1.0)
        self.fig = fig
        self.canvas: Any = FigureCanvasAgg(fig)
        self.ax = ax = _axes3d(fig, lo, hi)
        self.moving: List[Any] = []
        self.box_artists, self.arm_artists, self.trail_artists = [], [], []
        for k in range(len(self.boxes)):
            colour = _BODY_COLOURS[k % len(_BODY_COLOURS)]
            if trail:
                self.trail_artists.append(self._line3(color=colour, linewidth=0.8, alpha=0.6))
            self.box_artists.append(self._line3(color=colour, linewidth=1.5))
            self.arm_artists.append([self._line3(color=c, linewidth=2.0)
                                     for c in _AXIS_COLOURS])
        self.clock = ax.text2D(0.02, 0.95, "", transform=ax.transAxes)
        self.moving.append(self.clock)
        self.forward = times[-1] >= times[0]

    def _line3(self, **style: Any) -> Any:
        artist = self.ax.plot([], [], [], **style)[0]
        self.moving.append(artist)
        return artist

    def update(self, i: int) -> None:
        """Move the artists to frame ``i``."""
        now = self.times[i]
        upto = int(np.count_nonzero(self.dense_t <= now if self.forward else self.dense_t >= now))
        for k, box in enumerate(self.boxes):
            edges, arms = box_lines(self.pos[i, k], self.rot[i, k], box, self.arm)
            self.box_artists[k].set_data_3d(edges[:, 0], edges[:, 1], edges[:, 2])
            for artist, a in zip(self.arm_artists[k], arms):
                artist.set_data_3d(a[:, 0], a[:, 1], a[:, 2])
            if self.trail_on:
                path = np.concatenate([self.dense[:upto, k], self.pos[i, k][None, :]])
                self.trail_artists[k].set_data_3d(path[:, 0], path[:, 1], path[:, 2])
        self.clock.set_text(f"t = {now:.3g}")


def animate_bodies(sol: Trajectory, dof: int, pose: Pose, boxes: Sequence[Box], path: Any, *,
                   fps: float = 30, max_frames: int = 300, trail: bool = True) -> Path:
    """Write the movie of the bodies (``.gif`` or ``.mp4``); frames evenly spaced in t, q between
    the solution's points by :func:`~lagrangian._plot.trajectory`."""
    target = file_suffix(path, (".gif", ".mp4"), "a movie")
    rate = finite_positive("fps", fps)
    frames = at_least_one("max_frames", max_frames)
    t, _ = _check_solution(sol, dof)
    import matplotlib  # noqa: F401 - the install hint comes from the caller's ImportError

    times = np.linspace(t[0], t[-1], min(frames, t.shape[0]))
    pos, rot = pose(times, trajectory(sol, times)[0])
    dense_t = np.linspace(t[0], t[-1], max(10 * len(times), 2))
    dense, _ = pose(dense_t, trajectory(sol, dense_t)[0])
    if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(rot)) and np.all(np.isfinite(dense))):
        raise ValueError("the bodies' poses are not finite along the solution")
    movie = BodyMovie(times, pos, rot, boxes, dense_t, dense, trail)
    if target.suffix.lower() == ".gif":
        movie.write_gif(target, float(rate))
    else:
        movie.write_mp4(target, float(rate))
    return target
