"""The trajectory of a model (``Solution``, from ``Model.simulate``); equilibria, linearizations
and modes are in ``_linear``."""

from __future__ import annotations

import copyreg
import os
from typing import TYPE_CHECKING, Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import _lagrangian
from ._sensitivity import Leading

if TYPE_CHECKING:
    from matplotlib.figure import Figure  # type: ignore[import-not-found, unused-ignore]

__all__ = ["Solution", "keep_leading"]

FloatArray = npt.NDArray[np.float64]
PathLike = Union[str, "os.PathLike[str]"]


class Solution(_lagrangian.NativeSolution):
    """A trajectory from :meth:`Model.simulate`.

    With ``simulate(..., dense=True)`` the solution is callable: ``sol(t)`` gives (q, q̇)
    anywhere in the span from the method's own interpolant (see :meth:`__call__`).

    The fields of a native run are made when first read (a short run's fixed cost is most of
    what it costs): the arrays take the run's memory without a copy, and a field read again is
    the same object. Each can be assigned.

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
        failures; for a constrained model the steps projected back onto the constraints
        (``projections``) and the worst constraint residual after an accepted step
        (``constraint_residual``, 0 without constraints).
    multipliers : numpy.ndarray, shape (n, k), or None
        For a constrained model (``Model(..., constraints=...)``), the Lagrange multipliers
        at each output, one column per row in the order of :attr:`Model.constraint_names`
        (see :meth:`Model.multipliers`); ``None`` without constraints.
    constraint_forces : numpy.ndarray, shape (n, dof), or None
        The generalized reaction forces Gᵀλ at each output, or ``None``.
    sensitivities : dict of str to numpy.ndarray, or None
        With ``simulate(..., sensitivities=[...])``: ∂(q, q̇)/∂p at each output for each
        parameter named, shape (n, 2 dof), and for ``"q0"`` / ``"qd0"`` shape (n, 2 dof, dof)
        (column j: the derivative along q0[j] or qd0[j]); ``None`` otherwise.
    event_sensitivities : list of dict, or None
        With sensitivities, per event the derivatives of its times t* by the implicit function
        theorem, {name: (k,)} for a parameter and (k, dof) for ``"q0"`` / ``"qd0"``.
    names : tuple of str, optional
        The coordinate names (from the model), used to label plots.
    y : numpy.ndarray, shape (2 dof, n)
        The states in SciPy's ``solve_ivp`` layout: rows q then q̇, one column per time
        (see :attr:`y`).
    t_events : list of numpy.ndarray
        The times of each event's occurrences (``simulate(..., events=[...])``), one array per
        event in the order given — SciPy's ``t_events``.
    q_events, qd_events : list of numpy.ndarray, each of shape (k, dof)
        The coordinates and velocities at those times (before any reset).
    event_names : tuple of str
        The events' names, in the same order.
    status : int
        0: the run reached ``t_end``; 1: a terminal event stopped it; −1: the run failed (a
        partial solution carried by an exception).
    message : str
        ``"reached t_end"``, ``"terminal event <name> at t = …"``, or the failure.
    """

    # The fields are the native base's (getters and setters); nothing is added per instance.
    __slots__ = ()

    t: FloatArray
    q: FloatArray
    qd: FloatArray
    energy: FloatArray
    stats: Dict[str, Any]
    names: Optional[Tuple[str, ...]]
    t_events: List[FloatArray]
    q_events: List[FloatArray]
    qd_events: List[FloatArray]
    event_names: Tuple[str, ...]
    status: int
    message: str
    _dense: Any
    _y: Optional[FloatArray]
    multipliers: Optional[FloatArray]
    sensitivities: Optional[Dict[str, FloatArray]]
    event_sensitivities: Optional[List[Dict[str, FloatArray]]]
    constraint_forces: Optional[FloatArray]

    def __init__(
        self,
        t: FloatArray,
        q: FloatArray,
        qd: FloatArray,
        energy: FloatArray,
        stats: Dict[str, Any],
        names: Optional[Sequence[str]] = None,
        *,
        events: Sequence[Tuple[FloatArray, FloatArray, FloatArray]] = (),
        event_names: Sequence[str] = (),
        status: int = 0,
        message: str = "reached t_end",
        dense: Any = None,
    ) -> None:
        self.t, self.q, self.qd, self.energy, self.stats = t, q, qd, energy, stats
        self.names = None if names is None else tuple(map(str, names))
        self.t_events, self.q_events, self.qd_events = [], [], []
        for te, qe, qde in events:
            self.t_events.append(np.asarray(te))
            self.q_events.append(np.asarray(qe))
            self.qd_events.append(np.asarray(qde))
        self.event_names = tuple(map(str, event_names))
        self.status, self.message = status, message
        self._dense = dense
        self._y = None
        self.multipliers = self.constraint_forces = None
        self.sensitivities = self.event_sensitivities = None

    def __reduce__(self) -> Tuple[Any, ...]:
        # Every protocol rebuilds a solution from its fields (``Solution.__new__``, then
        # ``__setstate__``); by default protocols 0 and 1 would try to pickle the native base.
        new = copyreg.__newobj__  # type: ignore[attr-defined]
        return new, (type(self),), self.__getstate__()

    def __getstate__(self) -> Dict[str, Any]:
        # Every field made (a run's memory is not pickled as such), for pickle and copy.
        state = {name: getattr(self, name) for name in self.FIELDS}
        state["_y"] = None
        return state

    def __setstate__(self, state: Any) -> None:
        if isinstance(state, tuple):  # (None, slots): the pickles of earlier versions
            state = state[1]
        for name, value in state.items():
            setattr(self, name, value)

    def __call__(self, t: Union[float, "npt.ArrayLike"]) -> Tuple[FloatArray, FloatArray]:
        """(q, q̇) at time(s) ``t`` anywhere in the span, from the method's own interpolant
        (needs ``simulate(..., dense=True)``): for a scalar t two arrays of shape (dof,), for
        an array of times two of shape (len(t), dof). See :attr:`interpolant` for what
        interpolates and its order.

        Raises
        ------
        ValueError
            Outside the span, for a non-finite time, or without ``dense=True``.
        """
        if self._dense is None:
            raise ValueError(
                "this solution keeps no interpolant: run simulate(..., dense=True) to call it"
            )
        times = np.asarray(t, dtype=np.float64)
        if times.ndim > 1:
            raise ValueError(f"t must be a number or a 1-D array, got shape {times.shape}")
        q, qd = self._dense.eval(np.ascontiguousarray(times.reshape(-1)))
        if times.ndim == 0:
            return q[0], qd[0]
        return q, qd

    @property
    def interpolant(self) -> Optional[Tuple[str, int]]:
        """(what interpolates between the steps, its order) when the solution is callable
        (``dense=True``): Hairer's continuous extension for DOPRI5 (order 4) and DOP853 (7),
        the Taylor polynomial of each step for ``taylor`` (its order, exact to the method's
        accuracy anywhere in the step), the quintic Hermite polynomial through q, q̇, q̈ at the
        ends of each step for every other method (order 5 in q, 4 in q̇); ``None`` otherwise."""
        if self._dense is None:
            return None
        return str(self._dense.interpolant), int(self._dense.order)

    @property
    def constraint_power(self) -> Optional[FloatArray]:
        """The reactions' power Gᵀλ·q̇ at each output, shape (n,), or ``None`` without
        constraints: zero for constraints that hold still (the seed's R does no work), the
        energy a moving constraint feeds in otherwise, so that dh/dt = Gᵀλ·q̇ + Q″·q̇ −
        q̇·∂Φ/∂q̇ − ∂L/∂t along the run (see :meth:`Model.constraint_power`)."""
        if self.constraint_forces is None:
            return None
        return np.einsum("ij,ij->i", self.constraint_forces, self.qd)  # type: ignore[no-any-return]

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
        from ._plot import plot_solution  # not loaded by `import lagrangian`

        return plot_solution(self, path, title=title, conserved=conserved)


def keep_leading(sol: Solution, n: int) -> None:
    """Make a variational run's interpolant the model's: (q, q̇) of its first ``n`` coordinates
    (the rest are the sensitivities)."""
    if sol._dense is not None:
        sol._dense = Leading(sol._dense, n)
