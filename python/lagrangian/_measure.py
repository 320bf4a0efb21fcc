"""Measuring a run: the reference state errors are measured against (computed when no exact one
is known), the distance between two states, and the conventions of a timed run. Shared by the
work–precision diagram (:mod:`lagrangian._workprec`) and the stability matrix
(:mod:`lagrangian._stability`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Tuple

import numpy as np

from . import _lagrangian
from ._model import Model
from ._solution import Solution
from ._validate import FloatArray

__all__ = [
    "FINAL_ONLY",
    "UNSUPPORTED",
    "Reference",
    "computed_reference",
    "failure",
    "final_state",
    "state_error",
    "unsupported_reason",
]

# Output every this many steps: keeps only the initial and the final state of a timed run.
FINAL_ONLY = 1 << 62
# How the error of a method that cannot integrate the system begins.
UNSUPPORTED = "cannot integrate this system"
# The two computed references: different high-order methods at tight tolerances.
_REFERENCE_RUNS = (("dop853", 1e-13), ("radau5", 1e-12))


def unsupported_reason(message: str) -> Optional[str]:
    """Why a method cannot integrate the system, as the Rust fit check of that method says it
    (``"<method> cannot integrate this system: <why>; methods that fit: […]"``), or ``None`` for
    another failure."""
    start = message.find(UNSUPPORTED + ": ")
    if start < 0:
        return None
    why = message[start + len(UNSUPPORTED) + 2:]
    end = why.find("; methods that fit")
    return why if end < 0 else why[:end]


def state_error(q: FloatArray, qd: FloatArray, q_ref: FloatArray, qd_ref: FloatArray) -> float:
    """The relative distance ‖x − x_ref‖₂ / ‖x_ref‖₂ of the states x = (q, q̇) (absolute when
    the reference state is zero)."""
    diff = math.hypot(float(np.linalg.norm(q - q_ref)), float(np.linalg.norm(qd - qd_ref)))
    size = math.hypot(float(np.linalg.norm(q_ref)), float(np.linalg.norm(qd_ref)))
    return diff / size if size > 0.0 else diff


@dataclass(frozen=True)
class Reference:
    """The state the errors are measured against.

    Attributes
    ----------
    q, qd : numpy.ndarray
        Reference coordinates and velocities at ``t_end``.
    kind : str
        ``"exact"`` (given by the caller) or ``"computed"``.
    description : str
        How it was obtained.
    agreement : float or None
        For computed references: the relative distance between the two reference runs (the
        smallest error the rows can resolve); ``None`` for an exact reference or when only one
        reference run succeeded.
    alternate : tuple of (method, q, qd) or None
        The second reference run, used for the rows of the first reference's own method.
    """

    q: FloatArray
    qd: FloatArray
    kind: str
    description: str
    agreement: Optional[float] = None
    method: Optional[str] = None
    alternate: Optional[Tuple[str, FloatArray, FloatArray]] = None

    def against(self, method: str) -> Tuple[FloatArray, FloatArray]:
        """The reference state for rows of ``method``: never a run of that same method."""
        if self.method == method and self.alternate is not None:
            return self.alternate[1], self.alternate[2]
        return self.q, self.qd


def failure(e: Exception) -> str:
    """A failed run's typed error as rows show it: ``"StiffnessError: …"``."""
    return f"{type(e).__name__}: {e}"


def final_state(sol: Solution) -> Tuple[FloatArray, FloatArray]:
    """The last (q, q̇) of a solution."""
    return np.asarray(sol.q[-1]), np.asarray(sol.qd[-1])


def computed_reference(
    model: Model, q0: FloatArray, qd0: FloatArray, t0: float, t_end: float, max_steps: int
) -> Reference:
    """The reference state at ``t_end`` from two different high-order methods at tight
    tolerances (DOP853 at 1e-13, Radau IIA at 1e-12) and their agreement; ``ConvergenceError``
    when neither run succeeds."""
    runs: List[Tuple[str, FloatArray, FloatArray]] = []
    notes: List[str] = []
    for method, tol in _REFERENCE_RUNS:
        try:
            sol = model.simulate(
                q0, qd0, t_end, t0=t0, method=method, rtol=tol, atol=tol,
                output_every=FINAL_ONLY, max_steps=max_steps,
            )
        except (_lagrangian.LagrangianError, ValueError) as e:
            notes.append(f"{method} at tol {tol:.0e} failed ({failure(e)})")
            continue
        q, qd = final_state(sol)
        runs.append((method, q, qd))
        notes.append(f"{method} at rtol = atol = {tol:.0e} ({sol.stats['accepted_steps']} steps)")
    if not runs:
        raise _lagrangian.ConvergenceError(
            "no reference could be computed: " + "; ".join(notes)
            + " — pass reference=(q_end, qd_end) or an exact solution"
        )
    (method, q, qd) = runs[0]
    agreement = None
    alternate = None
    if len(runs) > 1:
        alternate = runs[1]
        agreement = state_error(alternate[1], alternate[2], q, qd)
    return Reference(
        q=q, qd=qd, kind="computed", description="; ".join(notes), agreement=agreement,
        method=method, alternate=alternate,
    )
