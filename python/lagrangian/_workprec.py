"""Work–precision: the error each method reaches against the time it takes, on one model.

A method is worth what it costs for the error it delivers. :func:`work_precision` runs methods
across tolerances (adaptive ones) or step sizes (fixed-step ones), measures the final-state error
against a reference and the wall time, and returns the rows with a log–log plot.
"""

from __future__ import annotations

import json
import statistics
import time
from dataclasses import asdict, dataclass
from typing import Any, Callable, Dict, Iterator, List, Optional, Sequence, Tuple, Union, overload

import numpy as np

from . import _lagrangian
from ._measure import (
    FINAL_ONLY,
    UNSUPPORTED,
    Reference,
    computed_reference,
    failure,
    final_state,
    state_error,
)
from ._model import Model
from ._protocols import ArrayLike
from ._validate import number, real, vector

__all__ = ["Reference", "Row", "WorkPrecision", "work_precision", "state_error"]

ExactSolution = Callable[[float], Tuple[Any, Any]]
ReferenceLike = Union[None, ExactSolution, Tuple[Sequence[float], Sequence[float]]]

# Samples of the energy along a run (the maximum of |E − E0| is taken over them).
_ENERGY_SAMPLES = 20_000


@dataclass(frozen=True)
class Row:
    """One run of a method at one tolerance or step size.

    Attributes
    ----------
    method : str
        The method's name.
    tolerance : float or None
        rtol = atol of an adaptive run.
    dt : float or None
        The step of a fixed-step run.
    error : float or None
        Relative final-state error (see :func:`state_error`); ``None`` when the run failed.
    energy_error : float or None
        max |E − E0| over the run, when the model conserves its energy function.
    seconds : float or None
        Median wall time of the repeats.
    steps, rhs_evaluations : int
        Accepted steps and right-hand-side evaluations.
    failure : str or None
        The typed error of a failed run (``"StiffnessError: …"``).
    """

    method: str
    tolerance: Optional[float]
    dt: Optional[float]
    error: Optional[float]
    energy_error: Optional[float]
    seconds: Optional[float]
    steps: int
    rhs_evaluations: int
    failure: Optional[str] = None

    @property
    def setting(self) -> str:
        """``"tol=1e-08"`` or ``"dt=0.001"``."""
        return f"tol={self.tolerance:.0e}" if self.tolerance is not None else f"dt={self.dt:.3g}"


class WorkPrecision(Sequence[Row]):
    """The rows of :func:`work_precision` with the reference they were measured against.

    It is the sequence of its rows: ``len(wp)``, ``for row in wp``, ``wp[0]``, ``wp[-1]``; a
    slice ``wp[1:3]`` is a :class:`WorkPrecision` of those rows with the same reference and
    title.

    >>> import lagrangian as lg
    >>> osc = lg.scenes.damped_oscillator(m=1.0, k=1.0, c=0.0)
    >>> wp = lg.work_precision(osc, [1.0], [0.0], 1.0, methods=["rk4"], dts=[0.1, 0.01],
    ...                        repeats=1, reference=([0.5403023058681398], [-0.8414709848078965]))
    >>> len(wp), wp[0].setting, [r.dt for r in wp]
    (2, 'dt=0.1', [0.1, 0.01])
    >>> wp[1:]
    WorkPrecision('', rows=1, methods=['rk4'])
    """

    def __init__(self, rows: List[Row], reference: Reference, title: str = "") -> None:
        self.rows = rows
        self.reference = reference
        self.title = title

    def __repr__(self) -> str:
        return f"WorkPrecision({self.title!r}, rows={len(self.rows)}, methods={self.methods})"

    def __len__(self) -> int:
        return len(self.rows)

    def __iter__(self) -> Iterator[Row]:
        return iter(self.rows)

    @overload
    def __getitem__(self, index: int) -> Row: ...

    @overload
    def __getitem__(self, index: slice) -> "WorkPrecision": ...

    def __getitem__(self, index: Union[int, slice]) -> Union[Row, "WorkPrecision"]:
        if isinstance(index, slice):
            return WorkPrecision(self.rows[index], self.reference, self.title)
        return self.rows[index]

    @property
    def methods(self) -> List[str]:
        """The methods in the order they ran."""
        return list(dict.fromkeys(r.method for r in self.rows))

    def by_method(self, method: str) -> List[Row]:
        """The rows of one method, in the order they ran."""
        return [r for r in self.rows if r.method == method]

    def table(self) -> str:
        """A Markdown table of the rows."""
        head = "| method | setting | error | energy error | time | steps | RHS evals |"
        lines = [head, "|---|---|---|---|---|---|---|"]
        for r in self.rows:
            if r.failure is not None:
                lines.append(f"| {r.method} | {r.setting} | failed: {r.failure} | | | | |")
                continue
            energy = "" if r.energy_error is None else f"{r.energy_error:.2e}"
            lines.append(
                f"| {r.method} | {r.setting} | {r.error:.2e} | {energy} | "
                f"{_format_seconds(r.seconds)} | {r.steps} | {r.rhs_evaluations} |"
            )
        return "\n".join(lines)

    def to_dict(self) -> Dict[str, Any]:
        """Plain data (JSON-ready): title, reference description and agreement, rows."""
        ref = self.reference
        return {
            "title": self.title,
            "reference": {
                "kind": ref.kind,
                "description": ref.description,
                "agreement": ref.agreement,
                "q": ref.q.tolist(),
                "qd": ref.qd.tolist(),
            },
            "rows": [asdict(r) for r in self.rows],
        }

    def to_json(self, **kwargs: Any) -> str:
        """:meth:`to_dict` as JSON."""
        return json.dumps(self.to_dict(), **kwargs)

    def plot(self, path: Optional[str] = None, *, ax: Any = None, peers: Any = None) -> Any:
        """Log error against log wall time, one line per method (matplotlib, ``pip install
        lagrangian[plot]``).

        Every method has its own colour and marker, the same in every figure; each point is
        labelled with its tolerance (adaptive methods, rtol = atol) or step dt (fixed-step
        ones); the legend sits outside the data. The floor the errors can be measured to is
        drawn and labelled — the agreement of the two reference runs, or round-off for an exact
        reference — and errors at or below it are shaded with a caveat: their order is noise.

        ``peers`` may be another :class:`WorkPrecision` (SciPy runs, say), drawn dashed with
        hollow markers. With ``path`` (``.png``, ``.svg`` or ``.pdf``) the figure is also saved;
        with ``ax`` it is drawn on those axes. Returns the :class:`matplotlib.figure.Figure`
        (not registered with ``pyplot``; a notebook displays it).
        """
        from ._plot import plot_work_precision  # not loaded by `import lagrangian`

        return plot_work_precision(self, path, ax=ax, peers=peers)


def _format_seconds(s: Optional[float]) -> str:
    if s is None:
        return ""
    if s >= 1.0:
        return f"{s:.2f} s"
    if s >= 1e-3:
        return f"{s * 1e3:.2f} ms"
    return f"{s * 1e6:.0f} µs"


def _given_reference(reference: ReferenceLike, n: int, t_end: float) -> Reference:
    if callable(reference):
        q, qd = reference(t_end)
        how = "exact solution evaluated at t_end"
    else:
        try:
            q, qd = reference  # type: ignore[misc]
        except (TypeError, ValueError):
            raise ValueError(
                "reference must be None, a callable t -> (q, qd) or a pair (q_end, qd_end)"
            ) from None
        how = "given final state"
    return Reference(
        q=vector("reference q", q, n), qd=vector("reference qd", qd, n), kind="exact",
        description=how,
    )


def work_precision(
    model: Model,
    q0: ArrayLike,
    qd0: ArrayLike,
    t_end: float,
    methods: Optional[Sequence[str]] = None,
    tolerances: ArrayLike = (1e-4, 1e-6, 1e-8, 1e-10),
    dts: ArrayLike = (),
    reference: ReferenceLike = None,
    repeats: int = 3,
    *,
    t0: float = 0.0,
    max_steps: int = 10_000_000,
    title: str = "",
) -> WorkPrecision:
    """Run each method across tolerances (adaptive methods, rtol = atol) or step sizes
    (fixed-step methods) and measure error against wall time.

    >>> import lagrangian as lg
    >>> osc = lg.scenes.damped_oscillator(m=1.0, k=1.0, c=0.0)
    >>> import math
    >>> wp = lg.work_precision(osc, [1.0], [0.0], 6.0, methods=["dop853", "rk4"],
    ...                        tolerances=[1e-6, 1e-9], dts=[0.1, 0.01], repeats=1,
    ...                        reference=lambda t: ([math.cos(t)], [-math.sin(t)]))
    >>> [r.setting for r in wp.rows]
    ['tol=1e-06', 'tol=1e-09', 'dt=0.1', 'dt=0.01']
    >>> wp.by_method("rk4")[1].error < wp.by_method("rk4")[0].error
    True

    Parameters
    ----------
    model : Model
        The system.
    q0, qd0 : array_like, shape (dof,)
        Initial state at ``t0``: sequences or NumPy arrays, as :meth:`Model.simulate` takes.
    t_end : float
        The final time; the error is measured on the state there.
    methods : sequence of str, optional
        Method names (:func:`lagrangian.methods`); by default every method except ``"auto"``.
        Methods that cannot integrate the model (explicit symplectic methods on a non-separable
        one, for instance) get a failed row saying why.
    tolerances : sequence of float
        rtol = atol values for the adaptive methods.
    dts : sequence of float
        Step sizes for the fixed-step methods (a fixed-step method with no ``dts`` is an error).
    reference : callable, pair or None
        The exact solution ``t -> (q, qd)`` or the exact final state ``(q_end, qd_end)``.
        Without it, DOP853 at 1e-13 and Radau IIA at 1e-12 are run; their agreement is reported
        as ``reference.agreement`` and rows of DOP853 are measured against the Radau run.
    repeats : int
        Timed runs per row; the median wall time is reported.
    t0 : float
        Start time.
    max_steps : int
        Step budget of every run.
    title : str
        A name for tables and plots.

    Returns
    -------
    WorkPrecision

    Raises
    ------
    ValueError
        For bad input (unknown methods, empty or non-positive tolerances or steps, a fixed-step
        method without ``dts``, wrong state lengths).
    """
    n = model.dof
    q0v = vector("q0", q0, n)
    qd0v = vector("qd0", qd0, n)
    t0f, t_endf = real("t0", t0), real("t_end", t_end)
    if t_endf == t0f:
        raise ValueError(f"t_end = t0 = {t0f}: the time span is empty")
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"repeats = {repeats!r}: give a positive integer")
    names = list(methods) if methods is not None else [m for m in _lagrangian.methods() if m != "auto"]
    if not names:
        raise ValueError("methods is empty")
    tols = [number("tolerance", x) for x in tolerances]
    steps = [number("dt", x) for x in dts]
    span_sign = 1.0 if t_endf > t0f else -1.0
    plan: List[Tuple[str, Optional[float], Optional[float]]] = []
    for name in names:
        canonical, adaptive, _order = _lagrangian.method_info(name)
        if adaptive is None:
            raise ValueError("'auto' picks a method per run; list the methods to compare")
        if adaptive:
            if not tols:
                raise ValueError(f"{canonical} is adaptive: give tolerances")
            for level in tols:
                # The checks `simulate` makes (in Rust, one message each), before any run.
                _lagrangian.check_options(t0f, t_endf, canonical, rtol=level, atol=level)
            plan += [(canonical, tol, None) for tol in tols]
        else:
            if not steps:
                raise ValueError(f"{canonical} takes fixed steps: give dts")
            for step in steps:
                _lagrangian.check_options(t0f, t_endf, canonical, dt=span_sign * step)
            plan += [(canonical, None, dt) for dt in steps]

    ref = (
        computed_reference(model, q0v, qd0v, t0f, t_endf, max_steps)
        if reference is None
        else _given_reference(reference, n, t_endf)
    )
    structure = model.structure
    conserved = bool(structure["conservative"]) and not bool(structure["time_dependent"])
    rows: List[Row] = []
    unsupported = set()
    for method, tol, dt in plan:
        if method in unsupported:
            continue
        kwargs: Dict[str, Any] = {"t0": t0f, "method": method, "max_steps": max_steps}
        if tol is not None:
            kwargs.update(rtol=tol, atol=tol)
        else:
            kwargs["dt"] = span_sign * float(dt)  # type: ignore[arg-type]
        try:
            times: List[float] = []
            sol = None
            for _ in range(repeats):
                start = time.perf_counter()
                sol = model.simulate(q0v, qd0v, t_endf, output_every=FINAL_ONLY, **kwargs)
                times.append(time.perf_counter() - start)
            assert sol is not None
            q, qd = final_state(sol)
            q_ref, qd_ref = ref.against(method)
            energy_error = None
            if conserved:
                every = max(1, int(sol.stats["accepted_steps"]) // _ENERGY_SAMPLES)
                trace = model.simulate(q0v, qd0v, t_endf, output_every=every, **kwargs)
                energy_error = float(np.max(np.abs(trace.energy - trace.energy[0])))
            rows.append(
                Row(
                    method=method, tolerance=tol, dt=dt, error=state_error(q, qd, q_ref, qd_ref),
                    energy_error=energy_error, seconds=statistics.median(times),
                    steps=int(sol.stats["accepted_steps"]),
                    rhs_evaluations=int(sol.stats["rhs_evaluations"]),
                )
            )
        except (_lagrangian.LagrangianError, ValueError) as e:
            if UNSUPPORTED in str(e):
                # One row says it; the other settings would fail the same way.
                unsupported.add(method)
            rows.append(Row(method, tol, dt, None, None, None, 0, 0, failure(e)))
    return WorkPrecision(rows, ref, title)
