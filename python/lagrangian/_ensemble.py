"""Ensembles (``Model.simulate_many``): many runs of one model — initial states and parameter
values swept together — in Rust on all cores of this machine, or split into chunks on a Dask
cluster or any ``concurrent.futures.Executor``; and ``Ensemble``, what they return. Also
``Model.batch_integrator`` and its ``BatchIntegrator``. :func:`simulate_many` and
:func:`batch_integrator` are those methods (``Model`` binds them); they read the model by its
public members (``_protocols.ModelLike``)."""

from __future__ import annotations

import builtins
import concurrent.futures
import hashlib
import os
import pickle
import threading
from collections import OrderedDict
from typing import (
    Any,
    Dict,
    List,
    Mapping,
    NamedTuple,
    Optional,
    Sequence,
    Tuple,
    Union,
)

import numpy as np
import numpy.typing as npt

from . import _lagrangian, _sensitivity
from ._events import Event, event_specs
from ._protocols import ArrayLike, ModelLike
from ._solution import Solution
from ._validate import (
    at_least_one,
    flag,
    parameter_columns,
    run_count,
    run_options,
    states,
    sweep_parameters,
)

__all__ = ["BatchIntegrator", "Ensemble", "Failure", "batch_integrator", "simulate_many"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

# What the native `simulate_many` returns: (t, q, qd, reached, counters, method, choice,
# choices, failures, status, events, constraint residuals, scene path, scene paths); see
# src/python/ensemble.rs.
Raw = Tuple[
    Any, Any, Any, IntArray, IntArray, IntArray, IntArray, List[str], List[Any], Any, List[Any],
    FloatArray, IntArray, List[str],
]

# The statistics' counters, as the columns of the native `simulate_many` (the one list is
# `Statistics::COUNTERS` in Rust).
COUNTERS: Tuple[str, ...] = tuple(_lagrangian.COUNTERS)


class Failure(NamedTuple):
    """Why a run of an :class:`Ensemble` failed."""

    error: str
    """The name of the exception :meth:`Model.simulate` would raise for this run:
    ``"SingularMassMatrixError"``, ``"StepSizeError"``, ``"ValueError"``, …"""
    message: str
    """Its message."""
    t: Optional[float]
    """The last accepted time (the run's data end there), or ``None`` when it failed before
    its first step (then it has no data)."""


class Ensemble:
    """The runs of :meth:`Model.simulate_many`, in input order.

    Attributes
    ----------
    t : numpy.ndarray or list of numpy.ndarray
        With ``t_eval``: the output times, shared by every run. With ``final_only``: the final
        time of each run, shape (k,). Otherwise a list of each run's output times.
    q, qd : numpy.ndarray or list of numpy.ndarray
        Coordinates and velocities: shape (k, len(t), dof) with ``t_eval``, (k, dof) with
        ``final_only``, otherwise a list of each run's (points, dof) arrays.
    reached : numpy.ndarray of int, shape (k,)
        How many output points each run filled: all of them for a run that finished.
    status : numpy.ndarray of int8, shape (k,)
        As :attr:`Solution.status`: 0 for a run that reached ``t_end``, 1 for one a terminal
        event stopped, −1 for one that failed (see :attr:`failures`).
    failures : dict of int to Failure
        Why each failed run failed, by run index.
    stats : dict of str to numpy.ndarray
        Per-run statistics, one array of length k per key of ``Solution.stats``: ``method``
        (the method that ran; ``""`` where a run failed before starting), ``choice`` (why
        ``"auto"`` chose it, else ``None``), ``accepted_steps``, ``rejected_steps``,
        ``rhs_evaluations``, ``jacobian_evaluations``, ``factorizations``,
        ``newton_failures``, ``projections`` (steps a constrained model projected back onto its
        constraints) and, for a constrained model, ``constraint_residual`` (floats); for a
        scene, ``scene_path`` (its route, as ``Solution.stats``; ``None`` for a Taylor run). :meth:`run_stats` gives one run's as ``Solution.stats`` does.
    t_events : list of list of numpy.ndarray
        With ``events``: ``t_events[j][i]`` the times of event j's occurrences in run i
        (:attr:`Solution.t_events` of run i is ``[t_events[j][i] for j ...]``).
    q_events, qd_events : list of list of numpy.ndarray
        The states there, each of shape (occurrences, dof).
    event_counts : numpy.ndarray of int, shape (k, number of events)
        How many times each event occurred in each run.
    event_names : tuple of str
        The events' names, in the order given.
    parameters : dict of str to numpy.ndarray
        The swept parameters' values, one per run.
    names : tuple of str
        The coordinate names.
    output : str
        ``"t_eval"``, ``"final"`` or ``"steps"``: which of the layouts above.
    sensitivities : dict of str to numpy.ndarray or list, or None
        With ``simulate_many(..., sensitivities=[...])``: ∂(q, q̇)/∂θ by name, in the layout
        of ``q`` with 2 dof columns (∂q, then ∂q̇), and a trailing axis of dof for ``"q0"``
        and ``"qd0"`` (see :meth:`Model.simulate_many`); masked where ``q`` is.

    A failed run keeps what it computed up to its last accepted step, and only that: with
    ``t_eval`` its rows past the failure are masked, as are the rows past a terminal event
    (``q`` and ``qd`` are then :class:`numpy.ma.MaskedArray`, only when some run failed or
    stopped early; the hidden entries are zeros, never NaN), with ``final_only`` its row is its last accepted state at ``t[i]`` (masked
    if it failed before its first step), and otherwise its arrays are just shorter.
    """

    __slots__ = (
        "t",
        "q",
        "qd",
        "reached",
        "status",
        "failures",
        "stats",
        "t_events",
        "q_events",
        "qd_events",
        "event_counts",
        "event_names",
        "parameters",
        "names",
        "output",
        "sensitivities",
        "_model",
        "_events",
        "_terminal",
        "_conserved",
    )

    t: Any
    q: Any
    qd: Any
    reached: IntArray
    status: npt.NDArray[np.int8]
    failures: Dict[int, Failure]
    stats: Dict[str, Any]
    t_events: List[List[FloatArray]]
    q_events: List[List[FloatArray]]
    qd_events: List[List[FloatArray]]
    event_counts: IntArray
    event_names: Tuple[str, ...]
    parameters: Dict[str, FloatArray]
    names: Tuple[str, ...]
    output: str
    sensitivities: Optional[Dict[str, Any]]

    def __init__(
        self,
        raw: Raw,
        model: Optional[ModelLike],
        mode: str,
        parameters: Optional[Mapping[str, FloatArray]] = None,
        events: Sequence[Event] = (),
    ) -> None:
        t, q, qd, reached, counters, method, choice, choices, failures, status, found = raw[:11]
        k = len(reached)
        self.reached = np.asarray(reached, dtype=np.int64)
        self.failures = {
            int(i): Failure(str(name), str(msg), None if ti is None else float(ti))
            for i, name, msg, ti in failures
        }
        self.status = np.asarray(status, dtype=np.int8)
        self._events = list(events)
        self.event_names = tuple(e.name for e in self._events)
        m = len(self.event_names)
        self.t_events = [[np.asarray(run[j][0]) for run, _ in found] for j in range(m)]
        self.q_events = [[np.asarray(run[j][1]) for run, _ in found] for j in range(m)]
        self.qd_events = [[np.asarray(run[j][2]) for run, _ in found] for j in range(m)]
        self._terminal = {i: str(why) for i, (_, why) in enumerate(found) if why is not None}
        self.event_counts = np.zeros((k, m), dtype=np.int64)
        for j, times in enumerate(self.t_events):
            self.event_counts[:, j] = [len(x) for x in times]
        names = np.array(list(_lagrangian.methods()) + [""])
        self.stats = {
            "method": names[np.asarray(method, dtype=np.int64)],
            "choice": np.array(list(choices) + [None], dtype=object)[
                np.asarray(choice, dtype=np.int64)
            ],
        }
        counters = np.asarray(counters, dtype=np.int64).reshape(k, len(COUNTERS))
        for j, key in enumerate(COUNTERS):
            self.stats[key] = counters[:, j].copy()
        if model is not None and model.constraint_names:
            self.stats["constraint_residual"] = np.asarray(raw[11], dtype=np.float64)
        path = np.asarray(raw[12], dtype=np.int64)
        if (path >= 0).any():  # a scene's runs: their routes
            self.stats["scene_path"] = np.array(list(raw[13]) + [None], dtype=object)[path]
        if mode == "t_eval" and (self.reached < len(t)).any():  # failed or stopped early
            rows = np.arange(len(t))[None, :] >= self.reached[:, None]
            mask = np.broadcast_to(rows[:, :, None], q.shape).copy()
            q, qd = np.ma.masked_array(q, mask), np.ma.masked_array(qd, mask)
        elif mode == "final" and (self.reached == 0).any():
            empty = self.reached == 0
            t = np.ma.masked_array(t, empty)
            mask = np.broadcast_to(empty[:, None], q.shape).copy()
            q, qd = np.ma.masked_array(q, mask), np.ma.masked_array(qd, mask)
        self.t, self.q, self.qd = t, q, qd
        self.names = () if model is None else tuple(c.name for c in model.coordinates)
        self.output = mode
        self.sensitivities = None
        self.parameters = dict(parameters or {})
        self._model = model
        # h = q̇·p − L is a constant of each run by the rule `simulate` follows (in Rust).
        resets = any(e.reset for e in self._events)
        self._conserved = None if model is None else bool(model.native.conserved(resets))

    @property
    def ok(self) -> npt.NDArray[np.bool_]:
        """Whether each run finished (reached ``t_end`` or a terminal event), shape (k,)."""
        ok: npt.NDArray[np.bool_] = self.status >= 0
        return ok

    def __len__(self) -> int:
        return int(self.reached.shape[0])

    def __repr__(self) -> str:
        return f"Ensemble(runs={len(self)}, failed={len(self.failures)})"

    def run_stats(self, i: int) -> Dict[str, Any]:
        """Run ``i``'s statistics, as ``Solution.stats`` has them."""
        out: Dict[str, Any] = {"method": str(self.stats["method"][i])}
        out["choice"] = self.stats["choice"][i]
        for key in COUNTERS:
            out[key] = int(self.stats[key][i])
        if self._conserved is not None:
            out["conserved"] = self._conserved
        if "constraint_residual" in self.stats:
            out["constraint_residual"] = float(self.stats["constraint_residual"][i])
        if "scene_path" in self.stats and self.stats["scene_path"][i] is not None:
            out["scene_path"] = self.stats["scene_path"][i]
        return out

    def error(self, i: int) -> Optional[Exception]:
        """The exception :meth:`Model.simulate` would raise for run ``i`` (its class and
        message), or ``None`` for a run that finished."""
        failure = self.failures.get(i)
        if failure is None:
            return None
        cls = getattr(_lagrangian, failure.error, None) or getattr(builtins, failure.error, None)
        if not (isinstance(cls, type) and issubclass(cls, Exception)):
            cls = RuntimeError
        err: Exception = cls(failure.message)
        return err

    def solution(self, i: int) -> Solution:
        """Run ``i`` as a :class:`Solution` (its energy evaluated now): what
        :meth:`Model.simulate` returns for it, or for a failed run the part computed."""
        if self._model is None:
            raise ValueError("this ensemble has no model to evaluate the energy with")
        rows = int(self.reached[i])
        if self.output == "steps":
            t, q, qd = self.t[i], self.q[i], self.qd[i]
        elif self.output == "t_eval":
            t = np.asarray(self.t)[:rows]
            q = np.ma.getdata(self.q)[i, :rows]
            qd = np.ma.getdata(self.qd)[i, :rows]
        else:
            t = np.ma.getdata(self.t)[i : i + rows]
            q = np.ma.getdata(self.q)[i : i + rows]
            qd = np.ma.getdata(self.qd)[i : i + rows]
        model = self._model
        if self.parameters:
            model = model.with_parameters(
                **{name: float(v[i]) for name, v in self.parameters.items()}
            )
        energy = np.array(
            [model.energy(float(t[j]), q[j], qd[j]) for j in range(rows)], dtype=np.float64
        )
        failure = self.failures.get(i)
        status = int(self.status[i])
        if failure is not None:
            message = failure.message
        else:
            message = self._terminal.get(i, "reached t_end")
        sol = Solution(
            np.ascontiguousarray(t, dtype=np.float64),
            np.ascontiguousarray(q, dtype=np.float64),
            np.ascontiguousarray(qd, dtype=np.float64),
            energy,
            self.run_stats(i),
            names=self.names,
            events=[
                (self.t_events[j][i], self.q_events[j][i], self.qd_events[j][i])
                for j in range(len(self.event_names))
            ],
            event_names=self.event_names,
            status=status,
            message=message,
        )
        if self.sensitivities is not None:
            sol.sensitivities = {
                name: np.ascontiguousarray(_run_rows(self.output, values, i, rows))
                for name, values in self.sensitivities.items()
            }
            sol.event_sensitivities = None
        return sol


def _run_rows(output: str, values: Any, i: int, rows: int) -> FloatArray:
    """Run ``i``'s ``rows`` points of a per-run quantity in an ensemble's layout."""
    if output == "steps":
        return np.asarray(values[i], dtype=np.float64)
    data = np.ma.getdata(values)
    if output == "t_eval":
        return np.asarray(data[i, :rows], dtype=np.float64)
    return np.asarray(data[i : i + rows], dtype=np.float64)


def simulate_many(
    self: ModelLike,
    q0: Any,
    qd0: Any,
    t_end: float,
    *,
    parameters: Optional[Mapping[str, Any]] = None,
    t_eval: Optional[ArrayLike] = None,
    t0: float = 0.0,
    method: str = "auto",
    dt: Optional[float] = None,
    rtol: float = 1e-6,
    atol: float = 1e-9,
    max_steps: Optional[int] = None,
    final_only: bool = False,
    events: Optional[Sequence[Event]] = None,
    workers: Optional[int] = None,
    executor: Any = None,
    chunks: Optional[int] = None,
    timeout: Optional[float] = None,
    sensitivities: Optional[Sequence[str]] = None,
    sensitivity_error_control: bool = True,
) -> Ensemble:
    """Integrate many runs at once: initial states and parameter values swept together.

    Run i is exactly what :meth:`simulate` computes from ``(q0[i], qd0[i])`` with the
    parameters ``{name: parameters[name][i]}`` — bit for bit, whatever the number of
    threads. The runs go in Rust on a thread pool with the GIL released (Ctrl-C stops them
    with ``KeyboardInterrupt``), or, with ``executor``, in chunks on a Dask cluster or any
    :class:`concurrent.futures.Executor`. A run that fails does not stop the others: the
    :class:`Ensemble` marks it, with its error, and keeps what it computed.

    >>> import numpy as np, lagrangian as lg
    >>> pendulum = lg.scenes.simple_pendulum(m=1.0, l=1.0, g=9.81)
    >>> ens = pendulum.simulate_many(np.linspace(0.1, 3.0, 50)[:, None], [0.0], 2.0,
    ...                              t_eval=np.linspace(0.0, 2.0, 21), rtol=1e-9)
    >>> ens.q.shape, bool(ens.ok.all())
    ((50, 21, 1), True)

    Parameters
    ----------
    q0, qd0 : array_like, shape (k, dof) or (dof,)
        Initial coordinates and velocities, one row per run; a single row is used for
        every run.
    t_end : float
        End time, shared by the runs (before ``t0``: backwards).
    parameters : mapping of str to float or array_like of shape (k,), optional
        Parameter values: one per run (a sweep), or one for all. The model is compiled
        once and bound to each run's values (a scene is built for each run).
    t_eval : array_like, optional
        Output times shared by every run (as in :meth:`simulate`): ``q`` and ``qd`` are
        then arrays of shape (k, len(t_eval), dof).
    t0, method, dt, rtol, atol, max_steps
        As in :meth:`simulate`, for every run, with its checks and messages.
    final_only : bool
        Keep only each run's final state: ``t`` of shape (k,), ``q`` and ``qd`` of shape
        (k, dof), so that millions of runs fit in memory. Not with ``t_eval``.
    events : sequence of Event, optional
        As in :meth:`simulate`, in every run: the occurrences are in the ensemble's
        ``t_events``, ``q_events`` and ``qd_events`` (``[j][i]``: event j in run i) and
        ``event_counts``; a run a terminal event stopped has status 1. An event that reads a
        swept parameter takes each run's value (compiled once). With ``final_only``, the
        events are the sweep's whole output: a period, a first passage, an escape time.
    workers : int, optional
        Threads of this machine (default: every core); with ``executor``, threads per chunk
        on its worker (default 1: the executor's own workers give the parallelism).
    executor : dask.distributed.Client or concurrent.futures.Executor, optional
        Run the ensemble there, in ``chunks`` chunks of consecutive runs: the model is
        pickled once (Dask sends it to each worker once; every worker process compiles it
        once), each chunk runs ``simulate_many`` on a worker, and the results are gathered
        in order, identical to a local run. ``pip install lagrangian[dask]`` for Dask.
    chunks : int, optional
        Number of chunks for ``executor`` (default: 4 per executor thread).
    timeout : float, optional
        Seconds to wait for each chunk's result from ``executor`` before
        :class:`TimeoutError` (default: no limit).
    sensitivities, sensitivity_error_control
        As in :meth:`simulate`, for every run (with its own parameter values): the
        ensemble's ``sensitivities[name]`` holds them in the layout of ``q`` with 2 dof
        columns (∂q, ∂q̇) — (k, len(t_eval), 2 dof) with ``t_eval``, (k, 2 dof) with
        ``final_only``, else a list per run — and a trailing axis of dof for ``"q0"`` and
        ``"qd0"``. The events' times have no sensitivities here (``simulate`` gives them).

    Returns
    -------
    Ensemble

    Raises
    ------
    ValueError
        For bad input, as :meth:`simulate` (and before any run): shapes, non-finite values,
        runs that do not agree in number, unknown parameters, invalid options.
    KeyboardInterrupt
        On Ctrl-C.
    """
    model = self
    n = model.dof
    q, qd = states("q0", q0, n), states("qd0", qd0, n)
    fixed, sweep = sweep_parameters(parameters, model.parameters)
    k = run_count(q, qd, sweep)
    q = np.ascontiguousarray(np.broadcast_to(q, (k, n)))
    qd = np.ascontiguousarray(np.broadcast_to(qd, (k, n)))
    base = model.with_parameters(**fixed) if fixed else model
    t_end, options = _options(t0, t_end, method, dt, rtol, atol, t_eval, max_steps, final_only)
    event_specs(events or (), base.coordinates, base.parameters)  # checked before any run
    _check_consistent(base, q, qd, options, sweep)
    events = list(events or ())
    if workers is not None:
        workers = at_least_one("workers", workers, "thread")
    mode = "final" if final_only else "steps" if t_eval is None else "t_eval"
    runner: Runner = base
    if sensitivities is not None:
        runner = Variational(base, sensitivities, flag("sensitivity_error_control",
                                                       sensitivity_error_control))
        if any(e.reset for e in events):
            raise ValueError(
                "an event that resets the state would move the sensitivities by its own "
                "derivatives, which are not derived: run without the reset, or without "
                "sensitivities"
            )
        if sweep and base.scene is not None:
            raise ValueError(
                "a scene's arguments are numbers in its Rust code: sweep them without "
                "sensitivities, or state the system with lg.Model"
            )
        q, qd = runner.initial_states(q, qd)
        options = {**options, "error_coordinates": runner.error_coordinates}
    if executor is None or k == 0:
        raw = _run(runner, q, qd, t_end, sweep, options, events, workers or 0)
    else:
        raw = _run_on(
            executor, runner, q, qd, t_end, sweep, options, events, workers, chunks, timeout
        )
    ensemble = Ensemble(raw, base, mode, sweep, events)
    if isinstance(runner, Variational):
        runner.split(ensemble)
    return ensemble


class Variational:
    """A model's variational system along named directions, as an ensemble runs it in the
    model's place: the native model of n(1 + m) coordinates, the runs' initial states, and the
    split of the results into the model's states and the sensitivities. Pickled as the model
    and the names (a chunk's worker compiles it again)."""

    __slots__ = ("base", "names", "control", "wanted", "layout", "native")

    def __init__(self, base: ModelLike, names: Sequence[str], control: bool) -> None:
        self.base, self.names, self.control = base, names, control
        scene, values = base.scene, base.parameters
        self.wanted, self.layout = _sensitivity.directions(names, values, base.dof, scene)
        params = [float(v) for v in values.values()] if scene is None else []
        self.native = base.native.variational_model(self.wanted, params)

    def __reduce__(self) -> Tuple[Any, ...]:
        return Variational, (self.base, self.names, self.control)

    @property
    def error_coordinates(self) -> Optional[int]:
        """The coordinates whose error is controlled: all (``None``) or the model's own."""
        return None if self.control else self.base.dof

    def initial_states(self, q: FloatArray, qd: FloatArray) -> Tuple[FloatArray, FloatArray]:
        """Each run's (q₀, q̇₀) with the sensitivities' initial values: zero along a
        parameter, a unit vector along q₀ᵢ or q̇₀ᵢ."""
        k, n = q.shape
        size = n * (1 + len(self.wanted))
        big_q, big_qd = np.zeros((k, size)), np.zeros((k, size))
        big_q[:, :n], big_qd[:, :n] = q, qd
        for j, (kind, i) in enumerate(self.wanted):
            if kind == "q0":
                big_q[:, n + j * n + i] = 1.0
            elif kind == "qd0":
                big_qd[:, n + j * n + i] = 1.0
        return big_q, big_qd

    def split(self, ens: "Ensemble") -> None:
        """The model's coordinates back into ``ens.q`` and ``ens.qd`` (and the events'), the
        rest into ``ens.sensitivities`` by name."""
        n, m = self.base.dof, len(self.wanted)

        def parts(q: Any, qd: Any) -> Tuple[Any, Any, Any]:
            # (..., n(1 + m)) → (..., n), (..., n), (..., m, 2n)
            lead = q.shape[:-1]
            s_q = q[..., n:].reshape(lead + (m, n))
            s_qd = qd[..., n:].reshape(lead + (m, n))
            cat = np.ma.concatenate if np.ma.isMaskedArray(q) else np.concatenate
            return q[..., :n], qd[..., :n], cat([s_q, s_qd], axis=-1)

        if isinstance(ens.q, list):
            split = [parts(q, qd) for q, qd in zip(ens.q, ens.qd)]
            ens.q = [a for a, _, _ in split]
            ens.qd = [b for _, b, _ in split]
            ens.sensitivities = {
                name: [_sensitivity.named(np.asarray(s), self.layout)[name] for _, _, s in split]
                for name, _, _ in self.layout
            }
        else:
            ens.q, ens.qd, raw = parts(ens.q, ens.qd)
            flat = raw.reshape((-1,) + raw.shape[-2:])
            named = _sensitivity.named(np.ma.getdata(flat), self.layout)
            ens.sensitivities = {}
            for name, values in named.items():
                values = values.reshape(raw.shape[:-2] + values.shape[1:])
                if np.ma.isMaskedArray(raw):
                    rows = np.ma.getmaskarray(ens.q)[..., :1]
                    mask = np.broadcast_to(
                        rows.reshape(rows.shape + (1,) * (values.ndim - rows.ndim)), values.shape
                    )
                    values = np.ma.masked_array(values, mask.copy())
                ens.sensitivities[name] = values
        ens.q_events = [[x[:, :n] for x in e] for e in ens.q_events]
        ens.qd_events = [[x[:, :n] for x in e] for e in ens.qd_events]


def _check_consistent(
    base: ModelLike,
    q: FloatArray,
    qd: FloatArray,
    options: Mapping[str, Any],
    sweep: Mapping[str, FloatArray],
) -> None:
    """Refuse, before any run, an initial state off a constrained model's constraints (with
    each run's parameters), naming the run: as :meth:`Model.simulate` refuses it, to the
    tolerance a run holds its steps to (the native check applies the run's rule)."""
    if not base.constraint_names:
        return
    rtol = None if "dt" in options else float(options["rtol"])
    atol = None if "dt" in options else float(options["atol"])
    for i in range(q.shape[0]):
        values = {k: float(v[i]) for k, v in sweep.items()}
        model = base.with_parameters(**values) if sweep else base
        try:
            model.native.check_consistent(
                float(options["t0"]), q[i].tolist(), qd[i].tolist(), rtol, atol
            )
        except ValueError as e:
            raise ValueError(f"run {i}: {e} (Model.project repairs a state)") from None


def _options(
    t0: float,
    t_end: float,
    method: str,
    dt: Optional[float],
    rtol: float,
    atol: float,
    t_eval: Optional[ArrayLike],
    max_steps: Optional[int],
    final_only: bool,
) -> Tuple[float, Dict[str, Any]]:
    """``t_end`` and the other run options as the native ``simulate_many`` takes them, checked
    as ``simulate`` checks them (:func:`run_options`)."""
    t0, t_end_, method, dt, rtol, atol, times, max_steps, _ = run_options(
        t0, t_end, method, dt, rtol, atol, t_eval, max_steps
    )
    options: Dict[str, Any] = {
        "t0": t0, "method": method, "rtol": rtol, "atol": atol,
        "final_only": flag("final_only", final_only),
    }
    for key, value in (("dt", dt), ("t_eval", times), ("max_steps", max_steps)):
        if value is not None:
            options[key] = value
    assert t_end_ is not None
    return t_end_, options


# What the runs are of: a model, or its variational system (``sensitivities=``).
Runner = Union[ModelLike, "Variational"]


def _sweep_arguments(model: ModelLike, sweep: Mapping[str, FloatArray], k: int) -> Dict[str, Any]:
    """The native ``simulate_many``'s arguments that bind k runs to the values ``sweep`` (the
    other parameters fixed): a row of parameter values per run for a compiled model; a scene
    is built per run from its arguments instead."""
    values = model.parameters
    if model.scene is None:
        return {"params": parameter_columns(list(values), sweep, values, k)}
    columns = {name: v.tolist() for name, v in sweep.items()}
    each = [{**values, **{c: v[i] for c, v in columns.items()}} for i in range(k)]
    return {"scenes": (model.scene, each)}


def _run(
    runner: Runner,
    q: FloatArray,
    qd: FloatArray,
    t_end: float,
    sweep: Mapping[str, FloatArray],
    options: Mapping[str, Any],
    events: Sequence[Event],
    workers: int,
) -> Raw:
    """The runs on this machine, on ``workers`` threads (0: every core)."""
    model = runner.base if isinstance(runner, Variational) else runner
    k = len(q)
    per_run: Dict[str, Any] = {}
    if events:
        values = model.parameters
        specs, reads = event_specs(events, model.coordinates, values)
        per_run["events"] = specs
        per_run["backend"] = model.backend
        # An event that reads a swept parameter is bound to each run's value.
        per_run["event_params"] = [
            parameter_columns(names, sweep, values, k) if set(names) & set(sweep) else None
            for names in reads
        ]
    if sweep:
        per_run.update(_sweep_arguments(model, sweep, k))
    raw: Raw = _lagrangian.simulate_many(
        runner.native, q, qd, t_end, **per_run, **options, workers=workers
    )
    return raw


# Models unpickled by the chunks run in this process, by the hash of their pickle: a worker
# compiles each model once, however many chunks it runs.
_MODELS: "OrderedDict[str, Any]" = OrderedDict()
_MODELS_LOCK = threading.Lock()


def _run_chunk(
    key: str,
    blob: bytes,
    q: FloatArray,
    qd: FloatArray,
    t_end: float,
    sweep: Mapping[str, FloatArray],
    options: Mapping[str, Any],
    events: Sequence[Event],
    workers: int,
    packed: bool,
) -> Union[Raw, bytes]:
    """One chunk of runs, on an executor's worker; pickled when ``packed``."""
    with _MODELS_LOCK:
        model = _MODELS.get(key)
        if model is None:
            model = pickle.loads(blob)
            _MODELS[key] = model
            while len(_MODELS) > 8:
                _MODELS.popitem(last=False)
    raw = _run(model, q, qd, t_end, sweep, options, events, workers)
    # One pickle of the whole chunk: Dask would serialize each run's small event arrays one by
    # one, measured 7x slower than pickle (benches/ensemble.py, a run with an event).
    return pickle.dumps(raw, protocol=5) if packed else raw


def _run_on(
    executor: Any,
    runner: Runner,
    q: FloatArray,
    qd: FloatArray,
    t_end: float,
    sweep: Mapping[str, FloatArray],
    options: Mapping[str, Any],
    events: Sequence[Event],
    workers: Optional[int],
    chunks: Optional[int],
    timeout: Optional[float],
) -> Raw:
    """The runs split into chunks on ``executor`` (a ``dask.distributed.Client`` or a
    ``concurrent.futures.Executor``), gathered in order."""
    dask = hasattr(executor, "scatter") and hasattr(executor, "nthreads")
    if not dask and not isinstance(executor, concurrent.futures.Executor):
        raise TypeError(
            "executor must be a dask.distributed.Client or a concurrent.futures.Executor, "
            f"got {executor!r}"
        )
    k = len(q)
    if chunks is None:
        if dask:
            threads = sum(executor.nthreads().values())
        else:
            threads = getattr(executor, "_max_workers", None) or os.cpu_count() or 1
        chunks = 4 * max(1, int(threads))
    else:
        chunks = at_least_one("chunks", chunks)
    bounds = np.linspace(0, k, min(chunks, k) + 1).round().astype(int)
    blob = pickle.dumps(runner)
    key = hashlib.sha256(blob).hexdigest()
    # Dask sends the pickled model to every worker once; other executors send its bytes with
    # each chunk (the worker still compiles it once, see `_MODELS`). `hash=False`: a key of its
    # own for each ensemble, since the same model's key from the last ensemble may be in the
    # middle of being released (its chunks then fail with "lost dependencies").
    shipped: Any = executor.scatter(blob, broadcast=True, hash=False) if dask else blob
    submit_options = {"pure": False} if dask else {}
    packed = not isinstance(executor, concurrent.futures.ThreadPoolExecutor)
    futures = [
        executor.submit(
            _run_chunk,
            key,
            shipped,
            q[a:b],
            qd[a:b],
            t_end,
            {name: v[a:b] for name, v in sweep.items()},
            options,
            events,
            workers or 1,
            packed,
            **submit_options,
        )
        for a, b in zip(bounds[:-1], bounds[1:])
    ]
    try:
        results = [f.result(timeout=timeout) for f in futures]
        parts: List[Raw] = [pickle.loads(r) if packed else r for r in results]
    except BaseException:
        for f in futures:
            f.cancel()
        raise
    return _concat(parts, "t_eval" in options)


def _concat(parts: List[Raw], shared_t: bool) -> Raw:
    """The raw results of consecutive chunks as one."""
    t: List[Any] = []
    q: List[Any] = []
    qd: List[Any] = []
    reached: List[IntArray] = []
    counters: List[IntArray] = []
    method: List[IntArray] = []
    choice: List[IntArray] = []
    choices: List[str] = []
    failures: List[Any] = []
    status: List[Any] = []
    found: List[Any] = []
    residuals: List[FloatArray] = []
    path: List[IntArray] = []
    paths: List[str] = []
    offset = 0
    for part in parts:
        pt, pq, pqd, preached, pcounters, pmethod, pchoice, pchoices, pfailures = part[:9]
        status.append(part[9])
        found.extend(part[10])
        residuals.append(part[11])
        known = {c: j for j, c in enumerate(paths)}
        moved = np.array([known.setdefault(c, len(known)) for c in part[13]] + [-1])
        paths = list(known)
        path.append(moved[np.asarray(part[12], dtype=np.int64)])
        index = {c: j for j, c in enumerate(choices)}
        remap = np.array([index.setdefault(c, len(index)) for c in pchoices] + [-1])
        choices = list(index)
        if isinstance(pt, list):
            t.extend(pt)
            q.extend(pq)
            qd.extend(pqd)
        else:
            t.append(pt)
            q.append(pq)
            qd.append(pqd)
        reached.append(preached)
        counters.append(pcounters)
        method.append(pmethod)
        choice.append(remap[np.asarray(pchoice, dtype=np.int64)])
        failures.extend((i + offset, *rest) for i, *rest in pfailures)
        offset += len(preached)
    if isinstance(parts[0][0], list):
        return (
            t, q, qd, *_stack(reached, counters, method, choice), choices, failures,
            np.concatenate(status), found, np.concatenate(residuals), np.concatenate(path), paths,
        )
    return (
        parts[0][0] if shared_t else np.concatenate(t),
        np.concatenate(q),
        np.concatenate(qd),
        *_stack(reached, counters, method, choice),
        choices,
        failures,
        np.concatenate(status),
        found,
        np.concatenate(residuals),
        np.concatenate(path),
        paths,
    )


def _stack(
    reached: List[IntArray], counters: List[IntArray], method: List[IntArray], choice: List[IntArray]
) -> Tuple[IntArray, IntArray, IntArray, IntArray]:
    """The per-run columns of consecutive chunks, joined."""
    return (
        np.concatenate(reached),
        np.concatenate(counters),
        np.concatenate(method),
        np.concatenate(choice),
    )


class BatchIntegrator:
    """Many runs of one model standing at a common time, advanced together
    (``Model.batch_integrator``): ``propagate_until(t)`` integrates every run still going to
    ``t`` with one :meth:`Model.simulate_many` from their states (final states only, so Taylor
    runs go through the SIMD lanes), and they stand there. Run i after each call is bit for bit
    what :meth:`Model.integrator` started from ``(q0[i], qd0[i])`` gives after the same calls.

    ``t``, ``q`` (runs × coordinates) and ``qd`` read the state (copies); ``ok[i]`` is False
    once run i has failed, ``error(i)`` its exception (what ``Integrator.propagate_until``
    raises), and a failed run stays at the state and time it stood at before the call that
    failed (``t_failed[i]``), out of the later calls.
    """

    def __init__(self, model: ModelLike, q0: Any, qd0: Any, *, t0: float, options: Dict[str, Any],
                 parameters: Optional[Mapping[str, Any]], workers: Optional[int]) -> None:
        self._model = model
        self._q = np.array(q0, dtype=float, ndmin=2)
        self._qd = np.array(qd0, dtype=float, ndmin=2)
        self._t = float(t0)
        self._options = options
        self._parameters = dict(parameters) if parameters is not None else None
        self._workers = workers
        k = len(self._q)
        self._ok = np.ones(k, dtype=bool)
        self._t_failed = np.full(k, np.nan)
        self._errors: Dict[int, Exception] = {}

    @property
    def t(self) -> float:
        return self._t

    @property
    def q(self) -> npt.NDArray[np.float64]:
        return self._q.copy()

    @property
    def qd(self) -> npt.NDArray[np.float64]:
        return self._qd.copy()

    @property
    def ok(self) -> npt.NDArray[np.bool_]:
        return self._ok.copy()

    @property
    def t_failed(self) -> npt.NDArray[np.float64]:
        """The time each failed run stood at before its failing call (NaN: not failed)."""
        return self._t_failed.copy()

    def error(self, i: int) -> Optional[Exception]:
        """The exception run i failed with, or ``None``."""
        return self._errors.get(i)

    def __len__(self) -> int:
        return len(self._q)

    def __repr__(self) -> str:
        return f"BatchIntegrator(runs={len(self)}, t={self._t}, failed={int((~self._ok).sum())})"

    def propagate_until(self, t: float) -> None:
        """Integrate every run still going from ``self.t`` to ``t`` and stand there."""
        t = float(t)
        if not np.isfinite(t):
            raise ValueError(f"t = {t}: give a finite time to integrate to")
        going = np.flatnonzero(self._ok)
        if t == self._t or len(going) == 0:
            self._t = t
            return
        parameters = None
        if self._parameters is not None:
            parameters = {name: (np.asarray(v)[going] if np.ndim(v) else v)
                          for name, v in self._parameters.items()}
        ens = simulate_many(
            self._model, self._q[going], self._qd[going], t, t0=self._t, final_only=True,
            parameters=parameters, workers=self._workers, **self._options)
        for j, i in enumerate(going):
            if ens.ok[j]:
                self._q[i], self._qd[i] = ens.q[j], ens.qd[j]
            else:
                self._ok[i] = False
                self._t_failed[i] = self._t
                error = ens.error(j)
                assert error is not None
                self._errors[int(i)] = error
        self._t = t


def batch_integrator(
    self: ModelLike,
    q0: Any,
    qd0: Any,
    *,
    t0: float = 0.0,
    method: str = "taylor",
    rtol: float = 1e-6,
    atol: float = 1e-9,
    max_steps: Optional[int] = None,
    parameters: Optional[Mapping[str, Any]] = None,
    workers: Optional[int] = None,
) -> BatchIntegrator:
    """Many runs standing at ``t0`` (rows of ``q0``, ``qd0``), taken piece by piece
    together: ``bi.propagate_until(t)`` advances every run to ``t`` at once — Taylor runs
    16 at a time per thread in the lanes of the machine's vectors — and ``bi.q``, ``bi.qd``
    (runs × coordinates) read where they stand. Each run is bit for bit what
    :meth:`integrator` gives it; ``parameters`` sweeps as in :meth:`simulate_many`.

    >>> import lagrangian as lg
    >>> th, = lg.coordinates("th")
    >>> pendulum = lg.Model(coordinates=[th], kinetic=0.5 * th.d**2, potential=-lg.cos(th))
    >>> bi = pendulum.batch_integrator([[0.1], [0.2], [0.3]], [[0.0]] * 3, rtol=1e-12,
    ...                                atol=1e-12)
    >>> bi.propagate_until(0.5); bi.propagate_until(1.0)
    >>> ig = pendulum.integrator([0.3], [0.0], method="taylor", rtol=1e-12, atol=1e-12)
    >>> [ig.propagate_until(t) for t in (0.5, 1.0)]
    ['finished', 'finished']
    >>> bool(bi.q[2, 0] == ig.q[0]), bool(bi.ok.all())
    (True, True)
    """
    options: Dict[str, Any] = dict(method=method, rtol=rtol, atol=atol, max_steps=max_steps)
    return BatchIntegrator(self, q0, qd0, t0=t0, options=options, parameters=parameters,
                           workers=workers)
