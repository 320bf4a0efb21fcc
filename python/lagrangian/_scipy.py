"""SciPy's ``solve_ivp`` on a first-order right-hand side, timed to a final state: the SciPy rows
of ``lagrangian report``, run on the model's own :meth:`Model.rhs` (and :meth:`Model.jacobian`
for the implicit methods), so they work for any model. SciPy is optional
(``pip install lagrangian[peers]``); without it :func:`scipy_available` is false and the report
skips these rows.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ._validate import FloatArray, real

__all__ = ["SCIPY_METHODS", "IMPLICIT_METHODS", "PeerRun", "run_scipy", "scipy_available"]

Rhs = Callable[[float, FloatArray], FloatArray]
Jacobian = Callable[[float, FloatArray], FloatArray]
StateLike = Union[Sequence[float], FloatArray]

SCIPY_METHODS: Tuple[str, ...] = ("RK45", "DOP853", "Radau", "LSODA")
"""The ``solve_ivp`` methods :func:`run_scipy` accepts: two explicit Runge–Kutta pairs, an
implicit Runge–Kutta method and the stiffness-switching LSODA."""

IMPLICIT_METHODS: Tuple[str, ...] = ("Radau", "LSODA")
"""The methods of :data:`SCIPY_METHODS` that use a Jacobian (``jac``)."""



def scipy_available() -> bool:
    """Whether ``scipy.integrate`` can be imported (SciPy is an optional dependency)."""
    try:
        import scipy.integrate  # type: ignore[import-untyped]  # noqa: F401
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class PeerRun:
    """One ``scipy.integrate.solve_ivp`` run to a final time, from :func:`run_scipy`.

    Attributes
    ----------
    method : str
        The ``solve_ivp`` method.
    rtol, atol : float
        The tolerances it was given.
    t : float
        The time reached: ``t_end`` on success, earlier when the solver gave up.
    q, qd : numpy.ndarray
        The state at ``t``.
    seconds : float
        The median wall time of the repeated ``solve_ivp`` calls (the right-hand side's Python
        cost included; building it and checking the arguments excluded).
    nfev, njev : int
        Right-hand-side and Jacobian evaluations of one run (finite-difference Jacobians of
        Radau and LSODA count in ``nfev`` too, as SciPy reports them).
    steps : int
        Accepted steps, ``len(sol.t) - 1``: no ``t_eval`` is passed, so ``sol.t`` holds the
        initial time and every accepted step.
    success : bool
        ``solve_ivp``'s ``success``.
    message : str
        ``solve_ivp``'s ``message``.
    """

    method: str
    rtol: float
    atol: float
    t: float
    q: FloatArray
    qd: FloatArray
    seconds: float
    nfev: int
    njev: int
    steps: int
    success: bool
    message: str


def _state(what: str, value: object) -> FloatArray:
    arr = np.array(value, dtype=np.float64, ndmin=1)
    if arr.ndim != 1:
        raise ValueError(f"{what} must be a flat sequence of numbers, got shape {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise ValueError(f"{what}[{bad[0]}] = {arr[bad[0]]} is not finite")
    return arr


def run_scipy(
    rhs: Rhs,
    q0: StateLike,
    qd0: StateLike,
    t_end: float,
    method: str,
    rtol: float,
    atol: float,
    t0: float = 0.0,
    repeats: int = 1,
    jac: Optional[Jacobian] = None,
) -> PeerRun:
    """Integrate y = (q, q̇) from ``t0`` to ``t_end`` with ``scipy.integrate.solve_ivp``.

    Only the final state is kept: no ``t_eval``, no dense output, the last column of ``sol.y``.
    The run is repeated ``repeats`` times and the median wall time reported; the counts and the
    state come from the last run (``solve_ivp`` is deterministic, so all runs agree).

    Parameters
    ----------
    rhs : callable
        ``f(t, y) -> dy/dt``, e.g. :meth:`lagrangian.Model.rhs`.
    q0, qd0 : sequence of float
        Initial coordinates and velocities, of equal length.
    t_end : float
        Final time.
    method : str
        One of :data:`SCIPY_METHODS`.
    rtol, atol : float
        ``solve_ivp``'s tolerances (positive).
    t0 : float, optional
        Initial time.
    repeats : int, optional
        Number of timed runs (at least 1).
    jac : callable, optional
        ``jac(t, y) -> ∂f/∂y`` for the implicit methods (:data:`IMPLICIT_METHODS`), e.g.
        :meth:`lagrangian.Model.jacobian`; without it they difference ``rhs``. Ignored by the
        explicit ones.

    Returns
    -------
    PeerRun
        The final state, median time and counts. A solve that fails (``success`` False, e.g.
        the step size underflowed) is returned as such, with the state where it stopped.

    Raises
    ------
    ImportError
        If SciPy is not installed.
    ValueError
        For an unknown method, q0 and qd0 of different lengths, non-finite values,
        non-positive tolerances or ``repeats`` < 1.

    Examples
    --------
    >>> import math
    >>> import lagrangian as lg
    >>> osc = lg.scenes.damped_oscillator(m=1.0, k=1.0, c=0.0)
    >>> run = run_scipy(osc.rhs, [1.0], [0.0], t_end=math.pi, method="Radau", rtol=1e-10,
    ...                 atol=1e-12, jac=osc.jacobian)
    >>> run.success, round(float(run.q[0]), 8), run.njev > 0
    (True, -1.0, True)
    """
    try:
        from scipy.integrate import solve_ivp
    except ImportError as e:
        raise ImportError(
            f"run_scipy needs SciPy, which is not installed ({e}); pip install scipy"
        ) from e
    if method not in SCIPY_METHODS:
        raise ValueError(f"method {method!r} is not one of {', '.join(SCIPY_METHODS)}")
    q = _state("q0", q0)
    qd = _state("qd0", qd0)
    if q.size == 0 or q.size != qd.size:
        raise ValueError(
            f"q0 and qd0 need the same, non-zero length: got {q.size} and {qd.size}"
        )
    t0, t_end = real("t0", t0), real("t_end", t_end)
    rtol, atol = real("rtol", rtol), real("atol", atol)
    if not (rtol > 0.0 and atol > 0.0):
        raise ValueError(f"rtol = {rtol} and atol = {atol} must be positive")
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"repeats = {repeats!r} must be an integer ≥ 1")
    n = q.size
    y0 = np.concatenate([q, qd])
    times: List[float] = []
    sol: Any = None
    for _ in range(repeats):
        start = time.perf_counter()
        extra: Dict[str, Any] = {} if jac is None or method not in IMPLICIT_METHODS else {"jac": jac}
        sol = solve_ivp(rhs, (t0, t_end), y0, method=method, rtol=rtol, atol=atol, **extra)
        times.append(time.perf_counter() - start)
    y_end = np.array(sol.y[:, -1], dtype=np.float64)
    return PeerRun(
        method=method,
        rtol=rtol,
        atol=atol,
        t=float(sol.t[-1]),
        q=y_end[:n],
        qd=y_end[n:],
        seconds=statistics.median(times),
        nfev=int(sol.nfev),
        njev=int(sol.njev),
        steps=len(sol.t) - 1,
        success=bool(sol.success),
        message=str(sol.message),
    )
