"""The trajectory of a model (``Solution``, from ``Model.simulate``); equilibria, linearizations
and modes are in ``_linear``."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from matplotlib.figure import Figure  # type: ignore[import-not-found, unused-ignore]

__all__ = ["Solution"]

FloatArray = npt.NDArray[np.float64]
PathLike = Union[str, "os.PathLike[str]"]


class Solution:
    """A trajectory from :meth:`Model.simulate`.

    Attributes
    ----------
    t : numpy.ndarray, shape (n,)
        Output times.
    q, qd : numpy.ndarray, shape (n, dof)
        Coordinates and velocities at those times.
    energy : numpy.ndarray, shape (n,)
        The energy function h = q̇·p − L (T + U for natural systems; conserved when nothing
        drives or damps the system).
    stats : dict
        The method that ran (and why, for ``"auto"``) and the work it took: accepted and
        rejected steps, right-hand-side and Jacobian evaluations, factorizations, Newton
        failures.
    names : tuple of str, optional
        The coordinate names (from the model), used to label plots.
    y : numpy.ndarray, shape (2 dof, n)
        The states in SciPy's ``solve_ivp`` layout: rows q then q̇, one column per time
        (see :attr:`y`).
    """

    __slots__ = ("t", "q", "qd", "energy", "stats", "names", "_y")

    t: FloatArray
    q: FloatArray
    qd: FloatArray
    energy: FloatArray
    stats: Dict[str, Any]
    names: Optional[Tuple[str, ...]]

    def __init__(
        self,
        t: FloatArray,
        q: FloatArray,
        qd: FloatArray,
        energy: FloatArray,
        stats: Dict[str, Any],
        names: Optional[Sequence[str]] = None,
    ) -> None:
        self.t, self.q, self.qd, self.energy, self.stats = t, q, qd, energy, stats
        self.names = None if names is None else tuple(str(n) for n in names)
        self._y: Optional[FloatArray] = None

    @property
    def y(self) -> FloatArray:
        """The states in SciPy's ``solve_ivp`` layout, shape (2 dof, n): rows q₁ … q_dof then
        q̇₁ … q̇_dof, column k at ``t[k]`` — ``np.vstack([q.T, qd.T])``. Built once on first
        access (one copy of q and q̇) and read-only: it does not follow later changes to
        ``q`` or ``qd``.
        """
        if self._y is None:
            y = np.vstack([self.q.T, self.qd.T])
            y.flags.writeable = False
            self._y = y
        return self._y

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def __repr__(self) -> str:
        span = f"[{float(self.t[0])!r}, {float(self.t[-1])!r}]" if len(self) else "[]"
        return (
            f"Solution(points={len(self)}, t={span}, method={self.stats['method']!r}, "
            f"steps={self.stats['accepted_steps']})"
        )

    def plot(
        self,
        path: Optional[PathLike] = None,
        *,
        title: Optional[str] = None,
        conserved: Optional[bool] = None,
    ) -> "Figure":
        """A figure of the trajectory in three stacked panels against t: the coordinates q and
        the velocities q̇, labelled with the coordinates' names and drawn as smooth curves
        between the solution's points (cubic Hermite interpolation of q with its slope q̇), and
        the energy function h.

        When h is conserved the third panel shows the relative energy error
        |h − h₀| / |h₀| on a logarithmic axis; for a forced, damped or time-dependent system,
        whose h changes by right, it shows h itself (no offset notation on any axis).

        Needs matplotlib (``pip install lagrangian[plot]``); the figure is a
        :class:`matplotlib.figure.Figure` not registered with ``pyplot``, so nothing is shown
        unless asked for (a notebook displays it).

        Parameters
        ----------
        path : str or path-like, optional
            Also save the figure there; the suffix (``.png``, ``.svg``, ``.pdf``) picks the
            format.
        title : str, optional
            A title above the panels.
        conserved : bool, optional
            Whether h is conserved (``model.structure["conservative"]`` and not
            ``"time_dependent"``); by default ``stats["conserved"]`` when the run recorded it,
            else judged from h (a change below 1e-3 of its size counts as conserved).

        Returns
        -------
        matplotlib.figure.Figure

        Raises
        ------
        ValueError
            For an empty solution or a path with another suffix.
        ImportError
            Without matplotlib.
        """
        from ._plot import plot_solution

        return plot_solution(self, path, title=title, conserved=conserved)
