"""Pictures: :meth:`Solution.plot <lagrangian.Solution.plot>`, :meth:`WorkPrecision.plot
<lagrangian.WorkPrecision.plot>` and :meth:`Model.animate <lagrangian.Model.animate>`.

matplotlib (and pillow, for GIFs) is optional: it is imported here, lazily, only when a picture is
asked for, so ``import lagrangian`` never needs it. Figures are built with
:class:`matplotlib.figure.Figure` directly, not through ``pyplot``: nothing is shown and no global
figure is left open, whatever the backend.

Between the points of a solution, curves and movie frames are cubic Hermite interpolants of q
(the solution has q̇, the exact slope of q, at every point): :func:`trajectory` is the one place
that turns a solution into a smooth curve.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import (
    TYPE_CHECKING,
    Any,
    Callable,
    Dict,
    List,
    Mapping,
    Optional,
    Sequence,
    Tuple,
    Union,
)

import numpy as np
import numpy.typing as npt

from ._drawing import Drawing
from ._expr import Expr, evaluate
from ._protocols import Drawable, FittedModel, PrecisionDiagram, Trajectory
from ._validate import at_least_one, file_suffix, finite_positive

if TYPE_CHECKING:
    from matplotlib.figure import Figure  # type: ignore[import-not-found, unused-ignore]

__all__ = [
    "Drawing",
    "plot_solution",
    "plot_work_precision",
    "plot_fit",
    "method_styles",
    "trajectory",
    "evaluate_drawing",
    "animate",
]

FloatArray = npt.NDArray[np.float64]
PathLike = Union[str, "os.PathLike[str]"]
Positions = Callable[[FloatArray, FloatArray], FloatArray]

_INSTALL = "pip install lagrangian[plot]"
_FIGURE_SUFFIXES = (".png", ".svg", ".pdf")
_MOVIE_SUFFIXES = (".gif", ".mp4")
# Points per curve of Solution.plot when the solution has fewer (Hermite-interpolated).
_CURVE_POINTS = 2000


def _require_matplotlib() -> None:
    """``ImportError`` with the install hint unless matplotlib can be imported."""
    try:
        import matplotlib  # noqa: F401
    except ImportError as e:
        raise ImportError(f"plotting needs matplotlib ({e}): {_INSTALL}") from None


def _solution_arrays(sol: Trajectory) -> Tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
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


def _names(sol: Trajectory, dof: int) -> List[str]:
    names = list(sol.names) if sol.names is not None else []
    if len(names) != dof:
        names = [f"q{i}" for i in range(dof)]
    return names


# -- smooth curves from the points of a solution ------------------------------------------


def _slopes(t: FloatArray, y: FloatArray) -> FloatArray:
    """Second-order estimates of dy/dt at the points (rows of ``y``): the three-point formula
    on an uneven grid, one-sided at the ends."""
    n = t.shape[0]
    if n < 2:
        return np.zeros_like(y)
    h = np.diff(t)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(h != 0.0, np.diff(y, axis=0) / np.where(h != 0.0, h, 1.0), 0.0)
    out = np.empty_like(y)
    out[0], out[-1] = s[0], s[-1]
    if n > 2:
        a, b = h[:-1], h[1:]
        total = a + b
        with np.errstate(divide="ignore", invalid="ignore"):
            mid = np.where(total != 0.0, (b * s[:-1] + a * s[1:]) / np.where(total != 0.0, total, 1.0), 0.0)
        out[1:-1] = mid
    return out


def _second_derivatives(t: FloatArray, q: FloatArray, qd: FloatArray) -> FloatArray:
    """Estimates of q̈ at the points: the second derivative of the cubic Hermite interpolant of
    (q, q̇) on each side, averaged with the shorter interval weighing more."""
    n = t.shape[0]
    if n < 2:
        return np.zeros_like(q)
    h = np.diff(t)[:, None]
    safe = np.where(h != 0.0, h, 1.0)
    dq = np.diff(q, axis=0)
    start = np.where(h != 0.0, 6.0 * dq / safe**2 - (4.0 * qd[:-1] + 2.0 * qd[1:]) / safe, 0.0)
    end = np.where(h != 0.0, -6.0 * dq / safe**2 + (2.0 * qd[:-1] + 4.0 * qd[1:]) / safe, 0.0)
    out = np.empty_like(q)
    out[0], out[-1] = start[0], end[-1]
    if n > 2:
        a, b = np.abs(h[:-1]), np.abs(h[1:])
        total = np.where(a + b > 0.0, a + b, 1.0)
        out[1:-1] = (b * end[:-1] + a * start[1:]) / total
    return out


def _hermite(t: FloatArray, y: FloatArray, dy: FloatArray, times: FloatArray) -> FloatArray:
    """The cubic Hermite interpolant of values ``y`` and slopes ``dy`` (rows at ``t``, which is
    monotone: increasing or decreasing) at ``times``, clamped to the span."""
    if t.shape[0] == 1:
        return np.repeat(y[:1], times.shape[0], axis=0)
    if t[-1] < t[0]:
        t, y, dy = t[::-1], y[::-1], dy[::-1]
    at = np.clip(times, t[0], t[-1])
    k = np.clip(np.searchsorted(t, at, side="right") - 1, 0, t.shape[0] - 2)
    h = (t[k + 1] - t[k])[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(h > 0.0, (at[:, None] - t[k][:, None]) / np.where(h > 0.0, h, 1.0), 0.0)
    s2, s3 = s * s, s * s * s
    return np.asarray(
        (2 * s3 - 3 * s2 + 1) * y[k]
        + (s3 - 2 * s2 + s) * h * dy[k]
        + (-2 * s3 + 3 * s2) * y[k + 1]
        + (s3 - s2) * h * dy[k + 1]
    )


def trajectory(sol: Trajectory, times: FloatArray) -> Tuple[FloatArray, FloatArray]:
    """q and q̇ of the solution at ``times`` within its span (rows), between its points.

    q is the cubic Hermite interpolant of the solution's q and q̇ (third order: q̇ is the exact
    slope of q); q̇ the Hermite interpolant of q̇ with the q̈ of those cubics at the points. The
    solution's own points are reproduced exactly. This is the one function that makes curves
    out of a solution. A solution run with ``dense=True`` is drawn from the method's own
    interpolant instead.
    """
    if getattr(sol, "interpolant", None) is not None:
        return sol(times)
    t, q, qd, _ = _solution_arrays(sol)
    t, (q, qd) = _monotone(t, q, qd)
    return _hermite(t, q, qd, times), _hermite(t, qd, _second_derivatives(t, q, qd), times)


def _monotone(t: FloatArray, *rows: FloatArray) -> Tuple[FloatArray, List[FloatArray]]:
    """``t`` and the ``rows`` at it, sorted by t unless t is monotone already (a solution made
    by hand may be in any order)."""
    if t.shape[0] > 1 and not (np.all(np.diff(t) >= 0.0) or np.all(np.diff(t) <= 0.0)):
        order = np.argsort(t, kind="stable")
        return t[order], [r[order] for r in rows]
    return t, list(rows)


def _curve_times(t: FloatArray, count: int = _CURVE_POINTS) -> FloatArray:
    """The solution's times, each interval cut evenly into pieces so that there are about
    ``count`` in all (the times themselves when there are as many already)."""
    n = t.shape[0]
    if n < 2 or n >= count:
        return t.copy()
    pieces = max(1, math.ceil(count / (n - 1)))
    s = np.arange(pieces) / pieces
    inner = t[:-1, None] + s[None, :] * np.diff(t)[:, None]
    return np.concatenate([inner.ravel(), t[-1:]])


# -- Solution.plot -------------------------------------------------------------------------


def _plain_numbers(ax: Any) -> None:
    """No offset or scientific-notation multiplier on a linear y axis: the tick labels are the
    values."""
    from matplotlib.ticker import ScalarFormatter

    formatter = ScalarFormatter(useOffset=False)
    formatter.set_scientific(False)
    ax.yaxis.set_major_formatter(formatter)


def draw_coordinates(
    ax_q: Any, ax_v: Any, sol: Trajectory, names: Sequence[str]
) -> None:
    """q and q̇ against t on two axes, as smooth curves between the solution's points."""
    t, _ = _monotone(np.asarray(sol.t, dtype=np.float64))
    times = _curve_times(t)
    q, qd = trajectory(sol, times)
    for i, name in enumerate(names):
        (line,) = ax_q.plot(times, q[:, i], label=name, linewidth=1.3)
        ax_v.plot(times, qd[:, i], label=f"d{name}/dt", linewidth=1.3, color=line.get_color())
    shown = ", ".join(names) if len(names) <= 3 else "q"
    ax_q.set_ylabel(f"coordinates {shown}" if len(names) > 1 else names[0])
    ax_v.set_ylabel(
        "velocities " + ", ".join(f"d{n}/dt" for n in names) if 1 < len(names) <= 3
        else (f"d{names[0]}/dt" if len(names) == 1 else "velocities dq/dt")
    )


def _energy_conserved(
    sol: Trajectory, conserved: Optional[bool], h: FloatArray
) -> Tuple[bool, bool]:
    """Whether to show h's relative error (a conserved h) or h itself, and whether that is
    known (asked for, or recorded by the run as ``stats["conserved"]``) rather than judged
    from h (a change under 1e-3 of its size)."""
    if conserved is not None:
        return bool(conserved), True
    recorded = sol.stats.get("conserved") if isinstance(sol.stats, Mapping) else None
    if isinstance(recorded, bool):
        return recorded, True
    finite = h[np.isfinite(h)]
    if finite.size == 0:
        return False, False
    size = max(float(np.max(np.abs(finite))), np.finfo(float).tiny)
    return float(np.max(np.abs(finite - finite[0]))) <= 1e-3 * size, False


def plot_solution(
    sol: Trajectory,
    path: Optional[PathLike] = None,
    *,
    title: Optional[str] = None,
    conserved: Optional[bool] = None,
) -> "Figure":
    """The figure of :meth:`Solution.plot`: q, q̇ and the energy against t in three panels."""
    if path is not None:
        target: Optional[Path] = file_suffix(path, _FIGURE_SUFFIXES, "a figure")
    else:
        target = None
    t, q, qd, h = _solution_arrays(sol)
    _require_matplotlib()
    from matplotlib.figure import Figure

    names = _names(sol, q.shape[1])
    fig = Figure(figsize=(7.5, 7.5), layout="constrained")
    ax_q, ax_v, ax_h = fig.subplots(3, 1, sharex=True)
    draw_coordinates(ax_q, ax_v, sol, names)
    if len(names) > 1:
        columns = max(1, math.ceil(len(names) / 12))
        for ax in (ax_q, ax_v):
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
                      fontsize="small", ncol=columns, frameon=False)
    for ax in (ax_q, ax_v, ax_h):
        ax.grid(True, alpha=0.3)
    for ax in (ax_q, ax_v):
        _plain_numbers(ax)

    flat, known = _energy_conserved(sol, conserved, h)
    if flat:
        scale = abs(float(h[0])) if np.isfinite(h[0]) and h[0] != 0.0 else 0.0
        if scale == 0.0:
            finite = np.abs(h[np.isfinite(h)])
            scale = float(finite.max()) if finite.size and finite.max() > 0.0 else 1.0
        error = np.abs(h - h[0]) / scale
        shown = np.where(error > 0.0, error, np.nan)
        worst = float(np.nanmax(error)) if np.any(np.isfinite(error)) else math.nan
        ax_h.plot(t, shown, color="black", linewidth=1.0)
        what = "|h − h₀| / |h₀|" if h[0] != 0.0 else "|h − h₀| / max|h|"
        # A conserved h's change is the integrator's error; otherwise (judged from h) a change.
        change = "error" if known else "change"
        ax_h.set_ylabel(f"relative energy {change}\n{what}")
        head = ("energy function h, conserved by the system" if known
                else "energy function h, changing by less than 1e-3 of its size")
        if np.any(np.isfinite(shown)):
            ax_h.set_yscale("log")
            note = f"{head}: max relative {change} {worst:.2g}"
        else:
            ax_h.set_ylim(-1.0, 1.0)
            note = f"{head}: h − h₀ = 0 at every point"
    else:
        # h's slope is not in the solution: estimated from the neighbours, for a smooth curve.
        ts, (hh,) = _monotone(t, h[:, None])
        times = _curve_times(ts)
        ax_h.plot(times, _hermite(ts, hh, _slopes(ts, hh), times)[:, 0], color="black",
                  linewidth=1.3)
        ax_h.set_ylabel("energy h = q̇·p − L")
        _plain_numbers(ax_h)
        note = "energy function h (not conserved: the system is forced, damped or time-dependent)"
    ax_h.set_title(note, loc="left", fontsize="small")
    ax_h.set_xlabel("t")
    if title is not None:
        fig.suptitle(title)
    if target is not None:
        fig.savefig(target, dpi=120)
    return fig


def plot_fit(
    fit: FittedModel,
    path: Optional[PathLike] = None,
    *,
    trial: int = 0,
    title: Optional[str] = None,
) -> "Figure":
    """The figure of :meth:`Fit.plot`: per measured coordinate, the data and the fitted run
    (a smooth curve through its dense output) above, the residuals below."""
    if path is not None:
        target: Optional[Path] = file_suffix(path, _FIGURE_SUFFIXES, "a figure")
    else:
        target = None
    t, data = fit.data(trial)
    q0, qd0 = fit.initial_states[trial]
    run = fit.model.simulate(q0, qd0, float(t[-1]), t0=float(t[0]), dense=True, rtol=1e-10,
                             atol=1e-10)
    times = _curve_times(t)
    curve, _ = run(times)
    residuals = fit.residuals if isinstance(fit.residuals, np.ndarray) else fit.residuals[trial]
    _require_matplotlib()
    from matplotlib.figure import Figure

    names = [c.name for c in fit.model.coordinates]
    fig = Figure(figsize=(7.5, 6.0), layout="constrained")
    ax_q, ax_r = fig.subplots(2, 1, sharex=True, height_ratios=(2.0, 1.0))
    for i, name in enumerate(names):
        colour = f"C{i % 10}"
        ax_q.plot(t, data[:, i], linestyle="none", marker=".", markersize=4, color=colour,
                  alpha=0.6, label=f"{name} measured")
        ax_q.plot(times, curve[:, i], color=colour, linewidth=1.3, label=f"{name} fitted")
        ax_r.plot(t, residuals[:, i], linestyle="none", marker=".", markersize=3,
                  color=colour)
    ax_r.axhline(0.0, color="black", linewidth=0.8)
    values = ", ".join(
        f"{k} = {v:.5g} ± {fit.uncertainties[k]:.2g}" for k, v in fit.parameters.items()
    )
    ax_q.set_title(values, loc="left", fontsize="small")
    ax_q.set_ylabel("q")
    ax_q.legend(loc="upper right", fontsize="small", frameon=False)
    ax_r.set_ylabel("weighted residual")
    ax_r.set_xlabel("t")
    for ax in (ax_q, ax_r):
        ax.grid(True, alpha=0.3)
        _plain_numbers(ax)
    if title is not None:
        fig.suptitle(title)
    if target is not None:
        fig.savefig(target, dpi=120)
    return fig


# -- WorkPrecision.plot --------------------------------------------------------------------

# One look per method, the same in every figure: no two share a colour or a marker. SciPy's
# runs (named "scipy …" by the report) are dashed with hollow markers.
_STYLES: Dict[str, Tuple[str, str]] = {
    "rk4": ("#1f77b4", "o"),
    "dopri5": ("#ff7f0e", "s"),
    "dop853": ("#2ca02c", "^"),
    "stormer_verlet": ("#d62728", "v"),
    "yoshida4": ("#9467bd", "<"),
    "yoshida6": ("#8c564b", ">"),
    "yoshida8": ("#e377c2", "D"),
    "blanes_moan4": ("#7f7f7f", "P"),
    "midpoint": ("#bcbd22", "X"),
    "gauss4": ("#17becf", "*"),
    "gauss6": ("#000080", "h"),
    "radau5": ("#000000", "p"),
    "taylor": ("#d95f02", "$T$"),
    "scipy RK45": ("#e6ab02", "d"),
    "scipy DOP853": ("#1b9e77", "H"),
    "scipy Radau": ("#9e0142", "8"),
    "scipy LSODA": ("#6a3d9a", "x"),
}
_SPARE_COLOURS = ("#a6761d", "#66a61e", "#e7298a", "#386cb0", "#f0027f", "#bf5b17", "#666666")
_SPARE_MARKERS = ("1", "2", "3", "4", "+", "|", "_")
# Relative final-state errors below this are round-off, whatever the reference: a few units of
# round-off per step, summed over the thousands of steps of a run.
_ROUNDOFF = 1000 * float(np.finfo(float).eps)


def method_styles(names: Sequence[str]) -> Dict[str, Tuple[str, str]]:
    """(colour, marker) of each method name: the fixed look of a known method, and for any
    other a colour and a marker that no other name in ``names`` has."""
    out = {n: _STYLES[n] for n in names if n in _STYLES}
    colours = [c for c, _ in _STYLES.values()] + list(_SPARE_COLOURS)
    markers = [m for _, m in _STYLES.values()] + list(_SPARE_MARKERS)
    free_c = [c for c in colours if c not in {c for c, _ in out.values()}]
    free_m = [m for m in markers if m not in {m for _, m in out.values()}]
    for k, n in enumerate(x for x in dict.fromkeys(names) if x not in out):
        out[n] = (free_c[k % len(free_c)], free_m[k % len(free_m)])
    return out


def _setting_label(row: Any) -> str:
    """``1e-8`` for a tolerance, ``0.01`` for a step (the figure says which is which)."""
    if row.tolerance is not None:
        mantissa, exponent = f"{row.tolerance:.0e}".split("e")
        return f"{mantissa}e{int(exponent)}"
    return f"{row.dt:.2g}"


def plot_work_precision(
    wp: PrecisionDiagram,
    path: Optional[PathLike] = None,
    *,
    ax: Any = None,
    peers: Optional[PrecisionDiagram] = None,
) -> "Figure":
    """The figure of :meth:`WorkPrecision.plot`."""
    target = None if path is None else file_suffix(path, _FIGURE_SUFFIXES, "a figure")
    _require_matplotlib()
    from matplotlib.figure import Figure

    if ax is None:
        fig = Figure(figsize=(8.0, 5.0), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    sources = [(wp, False)] + ([(peers, True)] if peers is not None else [])
    styles = method_styles([m for source, _ in sources for m in source.methods])
    lowest = math.inf
    for source, theirs in sources:
        for method in source.methods:
            done = [r for r in source.by_method(method)
                    if r.failure is None and r.error is not None and r.error > 0.0
                    and r.seconds is not None and r.seconds > 0.0]
            if not done:
                continue
            colour, marker = styles[method]
            ax.loglog(
                [r.seconds for r in done], [r.error for r in done],
                linestyle="--" if theirs else "-", linewidth=1.1, color=colour, marker=marker,
                markersize=5.5, markerfacecolor="white" if theirs else colour,
                markeredgecolor=colour, label=method,
            )
            for r in done:
                ax.annotate(_setting_label(r), (r.seconds, r.error), xytext=(3, 2),
                            textcoords="offset points", fontsize=5.5, color=colour, alpha=0.85)
            lowest = min([lowest] + [float(r.error or 0.0) for r in done])
    agreement = wp.reference.agreement
    floor = max(agreement or 0.0, _ROUNDOFF)
    if agreement is not None and agreement >= _ROUNDOFF:
        what = f"reference floor {floor:.1e} (the two reference runs agree to it)"
    else:
        what = f"round-off floor 1000 ε = {floor:.1e}"
        if agreement is not None:
            what += f" (the two reference runs agree to {agreement:.1e})"
    ax.axhline(floor, color="0.35", linewidth=0.9, linestyle=":")
    ax.annotate(what, (0.01, floor), xycoords=("axes fraction", "data"), xytext=(0, 2),
                textcoords="offset points", fontsize=7, color="0.25", va="bottom")
    if lowest <= 3.0 * floor:
        bottom = min(lowest, floor) / 8.0
        ax.axhspan(bottom, floor, color="0.85", alpha=0.5, linewidth=0.0, zorder=0)
        ax.annotate("grey: at round-off or below what the reference resolves, order is noise",
                    (0.01, floor),
                    xycoords=("axes fraction", "data"), xytext=(0, -3),
                    textcoords="offset points", fontsize=6.5, color="0.25", va="top")
        ax.set_ylim(bottom=bottom)
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("relative final-state error")
    if wp.title:
        ax.set_title(wp.title)
    ax.grid(True, which="major", alpha=0.3)
    caption = "point labels:\nrtol = atol (adaptive)\nor dt (fixed step)"
    if peers is not None:
        caption = "solid: lagrangian\ndashed: SciPy solve_ivp\n" + caption
    legend = ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
                       fontsize=7, frameon=False, title=caption, title_fontsize=6.5)
    legend.get_title().set_color("0.3")
    if target is not None:
        fig.savefig(target, dpi=130)
    return fig


# -- positions for drawing: expressions evaluated over many states --------------------------



def evaluate_drawing(
    exprs: Sequence[Expr],
    coordinates: Sequence[str],
    parameters: Mapping[str, float],
    t: FloatArray,
    q: FloatArray,
) -> FloatArray:
    """The drawing's expressions at n states, in NumPy: shape (len(exprs), n)."""
    out: FloatArray = evaluate(exprs, coordinates, parameters, t, q, what="a drawing")
    return out


def expression_positions(
    points: Sequence[Sequence[Expr]], coordinates: Sequence[str], parameters: Mapping[str, float]
) -> Positions:
    """``f(t, q) -> (n, points, dim)`` evaluating drawing points given as expressions."""
    dim = len(points[0])
    flat = [x for p in points for x in p]

    def f(t: FloatArray, q: FloatArray) -> FloatArray:
        v = evaluate_drawing(flat, coordinates, parameters, t, q)
        return np.ascontiguousarray(v.T.reshape(t.shape[0], len(points), dim))

    return f


# -- Model.animate -------------------------------------------------------------------------


def _rigid(a: FloatArray, b: FloatArray) -> bool:
    """Whether the distance between the point paths ``a`` and ``b`` (rows) stays the same (to
    1e-9) and is not zero: a rod joins them."""
    d = np.linalg.norm(a - b, axis=1)
    mean = float(np.mean(d))
    return mean > 0.0 and float(np.max(d) - np.min(d)) <= 1e-9 * mean


def auto_drawing(dense: FloatArray) -> Drawing:
    """Rods wherever the motion keeps a distance: from the origin to the first particle and
    between consecutive particles (a pendulum chain, a dumbbell); points otherwise."""
    count = dense.shape[1]
    origin = np.zeros_like(dense[:, 0])
    rods: List[Tuple[int, int]] = []
    if _rigid(dense[:, 0], origin):
        rods.append((-1, 0))
    rods += [(k - 1, k) for k in range(1, count) if _rigid(dense[:, k], dense[:, k - 1])]
    if not rods:
        return Drawing()
    chain = rods == [(k - 1, k) for k in range(count)]
    marks = ((0.0, 0.0),) if rods[0] == (-1, 0) and dense.shape[2] == 2 else ()
    return Drawing(rods=tuple(rods), marks=marks, trail=(count - 1,) if chain else None)


def _limits(points: FloatArray) -> Tuple[FloatArray, FloatArray]:
    """Equal-aspect limits holding every point (rows), with a margin."""
    lo = np.min(points, axis=0)
    hi = np.max(points, axis=0)
    span = float(np.max(hi - lo))
    pad = 0.08 * span if span > 0.0 else max(1.0, float(np.max(np.abs(points))))
    middle = 0.5 * (lo + hi)
    half = 0.5 * span + pad
    return middle - half, middle + half


def _frame_times(t: FloatArray, frames: int) -> FloatArray:
    """Evenly spaced times over the solution's span: ``frames`` of them, or one per point of a
    solution with fewer points (a movie runs at an even pace either way)."""
    count = min(frames, t.shape[0])
    return np.linspace(t[0], t[-1], count)


def animate(
    model: Drawable,
    sol: Trajectory,
    path: PathLike,
    *,
    fps: float = 30,
    max_frames: int = 300,
    trail: bool = True,
    drawing: Optional[Drawing] = None,
    chain: Optional[bool] = None,
    points: Optional[Sequence[Sequence[Expr]]] = None,
) -> Path:
    """The movie of :meth:`Model.animate`.

    The particles are ``points`` (expressions, for drawing only) when given, else the model's
    positions. ``drawing`` says how to draw them; ``chain=True`` draws them as a pendulum chain
    from the origin, ``chain=False`` as points; by default (``drawing`` and ``chain`` both
    ``None``) rods join the particles whose distance the motion keeps.
    """
    target = file_suffix(path, _MOVIE_SUFFIXES, "a movie")
    fps = finite_positive("fps", fps)
    frames = at_least_one("max_frames", max_frames)
    position: Positions
    if points is not None:
        position = expression_positions(points, [c.name for c in model.coordinates],
                                        model.parameters)
    else:
        if not model.has_positions:
            model.positions(0.0, np.zeros(model.dof))  # raises the model's own ValueError
        position = model.positions
    t, q, qd, _ = _solution_arrays(sol)
    if q.shape[1] != model.dof:
        raise ValueError(
            f"the solution has {q.shape[1]} coordinates but the model has {model.dof}: "
            "animate a solution of this model"
        )
    finite = np.isfinite(t) & np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(qd), axis=1)
    bad = np.flatnonzero(~finite)
    if bad.size:
        raise ValueError(
            f"the solution is not finite at point {bad[0]} (t = {t[bad[0]]}): "
            "nothing after a blow-up can be drawn"
        )
    _require_matplotlib()

    times = _frame_times(t, frames)
    frame_pos = position(times, trajectory(sol, times)[0])
    count, dim = frame_pos.shape[1], frame_pos.shape[2]
    # Trails and limits from the whole trajectory at ten points per frame.
    dense_t = np.linspace(t[0], t[-1], max(10 * len(times), 2))
    dense = position(dense_t, trajectory(sol, dense_t)[0])
    if not (np.all(np.isfinite(dense)) and np.all(np.isfinite(frame_pos))):
        raise ValueError("the positions are not finite along the solution")
    if chain:
        draw = Drawing.chain(count)
    elif drawing is not None and chain is None:
        draw = drawing
    elif chain is None:
        draw = auto_drawing(dense)
    else:
        draw = Drawing()
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
    movie = _Movie(draw, times, frame_pos, dense_t, dense, trailed)
    if target.suffix.lower() == ".gif":
        movie.write_gif(target, float(fps))
    else:
        movie.write_mp4(target, float(fps))
    return target


def _colour_table(palette: npt.NDArray[np.int64]) -> npt.NDArray[np.uint8]:
    """For each 15-bit colour (5 bits a channel, red highest), the index of the nearest palette
    entry to the colour it stands for."""
    levels = (np.arange(32) * 255 + 15) // 31
    r, g, b = np.meshgrid(levels, levels, levels, indexing="ij")
    colours = np.stack([r.ravel(), g.ravel(), b.ravel()], axis=1)
    best = np.zeros(colours.shape[0], dtype=np.uint8)
    nearest = np.full(colours.shape[0], np.iinfo(np.int64).max)
    for k, entry in enumerate(palette):
        d = np.sum((colours - entry) ** 2, axis=1)
        closer = d < nearest
        best[closer] = k
        nearest[closer] = d[closer]
    return best


class _Movie:
    """The frames of a movie: the still parts (axes, grid, fixed lines and circles) are drawn
    once; each frame restores them and draws only the moving artists (blitting) into the Agg
    buffer, which goes to the file as it is."""

    def __init__(
        self,
        draw: Drawing,
        times: FloatArray,
        frame_pos: FloatArray,
        dense_t: FloatArray,
        dense: FloatArray,
        trailed: List[int],
    ) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.patches import Circle

        self.draw, self.times, self.frame_pos = draw, times, frame_pos
        self.dense_t, self.dense, self.trailed = dense_t, dense, trailed
        count, dim = frame_pos.shape[1], frame_pos.shape[2]
        self.dim = dim
        self.uses_pivot = any(-1 in rod for rod in draw.rods)
        if draw.pivot is not None:
            self.pivot = np.asarray(draw.pivot(times), dtype=np.float64).reshape(len(times), 2)
            pivot_dense = np.asarray(draw.pivot(dense_t), dtype=np.float64).reshape(len(dense_t), 2)
        else:
            self.pivot = np.zeros((len(times), dim))
            pivot_dense = np.zeros((1, dim))

        extent: List[FloatArray] = [dense.reshape(-1, dim), frame_pos.reshape(-1, dim)]
        if self.uses_pivot:
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

        # A fixed layout: every draw of the figure puts the axes in the same place.
        fig = Figure(figsize=(4.8, 4.8), dpi=100)
        if dim == 3:
            fig.subplots_adjust(left=0.0, right=0.9, bottom=0.03, top=1.0)
        else:
            fig.subplots_adjust(left=0.13, right=0.97, bottom=0.1, top=0.97)
        self.fig = fig
        self.canvas: Any = FigureCanvasAgg(fig)
        if dim == 3:
            ax = fig.add_subplot(projection="3d")
            ax.set_zlim(lo[2], hi[2])
            ax.set_box_aspect((1.0, 1.0, 1.0), zoom=0.9)
            ax.set_zlabel("z")
        else:
            ax = fig.add_subplot()
            ax.set_aspect("equal")
            ax.grid(True, alpha=0.3)
        self.ax = ax
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        if dim == 2:
            for x, y, dx, dy in draw.lines:
                ax.axline((x, y), (x + dx, y + dy), color="0.4", linewidth=1.5)
            for x, y, r in draw.circles:
                ax.add_patch(Circle((x, y), r, fill=False, color="0.4", linewidth=1.5))
            if draw.marks:
                m = np.array(draw.marks, dtype=np.float64)
                ax.plot(m[:, 0], m[:, 1], marker="+", color="0.3", markersize=10,
                        linestyle="none")
        self.moving: List[Any] = []
        self.trails = [self._line(linewidth=0.8, alpha=0.6) for _ in trailed]
        self.rods = self._line(color="0.2", linewidth=2.0, solid_capstyle="round")
        self.moving_pivot = self._line(marker="s", color="0.3", markersize=6, linestyle="none")
        self.circles = []
        self.spokes = self._line(color="tab:red", linewidth=1.5)
        for _ in draw.bodies:
            circle = Circle((0.0, 0.0), 1.0, fill=False, color="tab:blue", linewidth=2.0)
            ax.add_patch(circle)
            self.circles.append(circle)
            self.moving.append(circle)
        self.loose = [k for k in range(count) if not any(k in body for body in draw.bodies)]
        self.points = self._line(marker="o", color="tab:blue", markersize=8, linestyle="none")
        self.centres = self._line(marker=".", color="tab:blue", markersize=6, linestyle="none")
        if dim == 3:
            self.clock = ax.text2D(0.02, 0.95, "", transform=ax.transAxes)
        else:
            self.clock = ax.text(0.02, 0.95, "", transform=ax.transAxes)
        self.moving.append(self.clock)
        self.forward = times[-1] >= times[0]
        self.gap = np.full((1, dim), np.nan)

    def _line(self, **style: Any) -> Any:
        if self.dim == 3:
            artist = self.ax.plot([], [], [], **style)[0]
        else:
            artist = self.ax.plot([], [], **style)[0]
        self.moving.append(artist)
        return artist

    def _put(self, artist: Any, xyz: FloatArray) -> None:
        if self.dim == 3:
            artist.set_data_3d(xyz[:, 0], xyz[:, 1], xyz[:, 2])
        else:
            artist.set_data(xyz[:, 0], xyz[:, 1])

    def update(self, i: int) -> None:
        """Move the artists to frame ``i``."""
        draw, r, dim, gap = self.draw, self.frame_pos[i], self.dim, self.gap
        if draw.rods:
            segments = []
            for a, b in draw.rods:
                start = self.pivot[i, :dim] if a == -1 else r[a]
                end = self.pivot[i, :dim] if b == -1 else r[b]
                segments.extend([start[None, :], end[None, :], gap])
            self._put(self.rods, np.concatenate(segments, axis=0))
            if self.uses_pivot and draw.pivot is not None:
                self._put(self.moving_pivot, self.pivot[i : i + 1, :dim])
        if self.loose:
            self._put(self.points, r[self.loose])
        if draw.bodies:
            self._put(self.centres, r[[c for c, _, _ in draw.bodies]])
            segments = []
            for circle, (c, r1, r2) in zip(self.circles, draw.bodies):
                circle.center = (float(r[c, 0]), float(r[c, 1]))
                circle.set_radius(float(np.linalg.norm(r[r1] - r[c])))
                segments.extend([r[r1][None, :], r[r2][None, :], gap])
            self._put(self.spokes, np.concatenate(segments, axis=0))
        if self.trailed:
            # The dense points already passed, in the order of integration.
            now = self.times[i]
            upto = int(np.count_nonzero(self.dense_t <= now if self.forward
                                        else self.dense_t >= now))
            for artist, k in zip(self.trails, self.trailed):
                self._put(artist, np.concatenate([self.dense[:upto, k], r[k][None, :]], axis=0))
        self.clock.set_text(f"t = {self.times[i]:.3g}")

    def frames(self) -> Any:
        """Each frame as the canvas's RGBA buffer (height, width, 4), drawn by blitting; the
        array is a view that the next frame overwrites."""
        for artist in self.moving:
            artist.set_animated(True)
        self.canvas.draw()
        background = self.canvas.copy_from_bbox(self.fig.bbox)
        for i in range(len(self.times)):
            self.canvas.restore_region(background)
            self.update(i)
            for artist in self.moving:
                self.ax.draw_artist(artist)
            yield np.asarray(self.canvas.buffer_rgba())

    def write_gif(self, target: Path, fps: float) -> None:
        """A looping GIF. One palette for every frame, made from the first and the last frame
        (which has every trail); pixels map to it through a table over 15-bit colours, without
        dithering, so still pixels stay still and the encoder stores only what changes."""
        from PIL import Image

        last = len(self.times) - 1
        self.update(last)
        for artist in self.moving:
            artist.set_animated(False)
        self.canvas.draw()
        final = np.array(self.canvas.buffer_rgba())[:, :, :3]
        images = []
        table: Optional[npt.NDArray[np.uint8]] = None
        palette: List[int] = []
        for rgba in self.frames():
            if table is None:
                both = np.concatenate([rgba[:, :, :3], final], axis=0)
                quantized = Image.fromarray(np.ascontiguousarray(both)).quantize(
                    colors=255, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE
                )
                palette = list(quantized.getpalette() or [])[: 3 * 256]
                table = _colour_table(np.array(palette, dtype=np.int64).reshape(-1, 3))
            key = (
                (rgba[:, :, 0].astype(np.uint16) >> 3) << 10
                | (rgba[:, :, 1].astype(np.uint16) >> 3) << 5
                | rgba[:, :, 2].astype(np.uint16) >> 3
            )
            image = Image.fromarray(table[key])
            image.putpalette(palette)
            images.append(image)
        duration = max(20, int(round(1000.0 / fps)))
        images[0].save(target, save_all=True, append_images=images[1:], duration=duration,
                       loop=0, optimize=False)

    def write_mp4(self, target: Path, fps: float) -> None:
        """An H.264 MP4: the frames piped to ffmpeg as raw RGB."""
        import subprocess

        from matplotlib import animation, rcParams

        if not animation.FFMpegWriter.isAvailable():
            raise RuntimeError(
                f"writing {str(target)!r} needs ffmpeg, which is not on the PATH: install "
                "ffmpeg or write a .gif instead"
            )
        width, height = self.canvas.get_width_height()
        command = [
            str(rcParams["animation.ffmpeg_path"]), "-y", "-loglevel", "error",
            "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{width}x{height}", "-r", f"{fps}",
            "-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-vcodec", "libx264",
            "-pix_fmt", "yuv420p", str(target),
        ]
        with subprocess.Popen(command, stdin=subprocess.PIPE, stderr=subprocess.PIPE) as proc:
            assert proc.stdin is not None and proc.stderr is not None
            for rgba in self.frames():
                proc.stdin.write(np.ascontiguousarray(rgba[:, :, :3]).tobytes())
            proc.stdin.close()
            message = proc.stderr.read().decode(errors="replace")
            if proc.wait() != 0:
                raise RuntimeError(f"ffmpeg could not write {str(target)!r}: {message.strip()}")


# The movie machinery (blitting, GIF and MP4 writers), public for the bodies' movie
# (``_plot_bodies.BodyMovie``), which draws other artists.
Movie = _Movie
