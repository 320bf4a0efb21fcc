"""Linearization of a constrained model about a steady motion, in independent coordinates and
speeds (``Model.linearize_steady``): the reduced M, C, K of

    M_r ÿ + C_r ẏ + K_r y = 0

for the chosen independent coordinates y, with the dependent positions following from the
holonomic rows, the dependent speeds from every constraint row, and the cyclic coordinates
(those neither chosen nor solved for) dropped. Built on :func:`_linear.linearize`'s exact state
matrix A of the constrained accelerations: a consistent perturbation (δq, δq̇) = (P δy,
Q δy + N δẏ) is tangent to the constraint manifold, where the index-1 accelerations are the
motion's own, so δÿ = A_y (P δy) + A_ẏ (Q δy + N δẏ) exactly."""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

from ._expr import (
    Coordinate,
    Expr,
    derivative,
    evaluate_program,
    serialize,
    time_derivative,
)
from ._linear import linearize
from ._protocols import ArrayLike, ModelLike
from ._validate import real, vector

__all__ = ["SteadyLinearization", "linearize_steady"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class SteadyLinearization:
    """A constrained model linearized about a steady motion, from
    :meth:`Model.linearize_steady`::

        M ÿ + C ẏ + K y = 0   in the independent coordinates y (``coordinates``).

    Attributes
    ----------
    coordinates : tuple of str
        The independent coordinates y, in order.
    M, C, K : numpy.ndarray, shape (m, m)
        M = Nᵀ M_q N (the kinetic energy in the independent speeds), C = −M ∂ÿ/∂ẏ and
        K = −M ∂ÿ/∂y along consistent perturbations.
    A : numpy.ndarray, shape (2m, 2m)
        State matrix [[0, I], [−M⁻¹K, −M⁻¹C]] of (y, ẏ).
    eigenvalues : numpy.ndarray, complex
        Eigenvalues of ``A``, by real part, largest first.
    P : numpy.ndarray, shape (dof, m)
        δq = P δy: the dependent positions from the linearized holonomic rows, the cyclic ones
        zero.
    N : numpy.ndarray, shape (dof, m)
        The velocity map: δq̇ = Q δy + N δẏ, every constraint row's linearization solved for
        the dependent speeds, the steady speeds held.
    Q : numpy.ndarray, shape (dof, m)
        The part of the dependent speeds that a change of position makes.
    dependent : tuple of str
        The coordinates solved from the holonomic rows.
    dependent_speeds : tuple of str
        The coordinates whose speeds are solved from the constraint rows.
    steady : tuple of str
        The coordinates whose speeds are held at their steady values.
    cyclic : tuple of str
        The coordinates dropped (held at their reference values).
    accelerations : numpy.ndarray, shape (m,)
        ÿ at the reference: zero for a steady motion.
    linearization : Linearization
        The full linearization of :meth:`Model.linearize` at the reference.
    """

    coordinates: Tuple[str, ...]
    M: FloatArray
    C: FloatArray
    K: FloatArray
    A: FloatArray
    eigenvalues: npt.NDArray[np.complex128]
    P: FloatArray
    N: FloatArray
    Q: FloatArray
    dependent: Tuple[str, ...]
    dependent_speeds: Tuple[str, ...]
    steady: Tuple[str, ...]
    cyclic: Tuple[str, ...]
    accelerations: FloatArray
    linearization: Any


@lru_cache(maxsize=16)
def row_jacobians(coords: Tuple[Coordinate, ...], holo: Tuple[Expr, ...],
                  vel: Tuple[Expr, ...]) -> Tuple[List[Any], List[int]]:
    """The flat program of ∂g/∂q of the holonomic rows g, then ∂r/∂q and ∂r/∂q̇ of every row r
    (ġ for the holonomic ones, then the velocity rows), row by row; kept per model's rows, so
    that a sweep over speeds differentiates once."""
    rows = [time_derivative(g, coords) for g in holo] + list(vel)
    grads = [derivative(g, c) for g in holo for c in coords]
    grads += [derivative(r, c) for r in rows for c in coords]
    grads += [derivative(r, c.d) for r in rows for c in coords]
    return serialize(grads)


def _names(what: str, given: Optional[Sequence[Any]], known: Sequence[str]) -> List[str]:
    if given is None:
        return []
    if isinstance(given, (str, Expr)):
        given = [given]
    out: List[str] = []
    for g in given:
        name = g.name if isinstance(g, Coordinate) else g
        if not isinstance(name, str) or name not in known:
            raise ValueError(f"linearize_steady: {what} names {g!r}, which is not a coordinate "
                             f"of the model (its coordinates: {', '.join(known)})")
        if name in out:
            raise ValueError(f"linearize_steady: {what} names {name!r} twice")
        out.append(name)
    return out


def _solve(what: str, a: FloatArray, b: FloatArray, cols: Sequence[str]) -> FloatArray:
    if a.shape[0] != a.shape[1]:
        raise ValueError(what)
    if a.size and np.linalg.cond(a) > 1e12:
        raise ValueError(f"{what} (the rows are singular in {', '.join(cols)})")
    if not a.size:
        return np.zeros((0, b.shape[1]))
    return np.asarray(np.linalg.solve(a, b), dtype=np.float64)


def linearize_steady(
    self: ModelLike,
    q: ArrayLike,
    qd: ArrayLike,
    independent: Sequence[Any],
    steady: Optional[Sequence[Any]] = None,
    dependent: Optional[Sequence[Any]] = None,
    t: float = 0.0,
) -> SteadyLinearization:
    """A constrained model (holonomic and velocity rows) linearized about a steady motion
    (q, q̇) — cyclic coordinates moving at constant rates, the rest still — in the
    ``independent`` coordinates y and their speeds: M ÿ + C ẏ + K y = 0, exact (the constrained
    model's state matrix by automatic differentiation, the rows' Jacobians on the expression
    graph).

    - Dependent positions follow from the holonomic rows, linearized (``dependent`` names them;
      by default the best-conditioned choice among the other coordinates); every other
      coordinate is cyclic and dropped.
    - Dependent speeds follow from all constraint rows, linearized in position and speed; the
      ``steady`` coordinates' speeds (a wheel's spin: the motion's rates) are held, so that
      the independent speeds and the steady ones leave one dependent speed per row.
    - M = Nᵀ M_q N with δq̇ = N δẏ at fixed y (the kinetic energy in the independent speeds);
      C = −M ∂ÿ/∂ẏ and K = −M ∂ÿ/∂y along consistent perturbations.

    A thin disc (m = 1, r = 0.3) rolling upright at 1.2 m/s, in its lean φ and heading ψ (the
    spin θ steady; x, y cyclic): M = diag(I_d + m r², I_d), and above √(g r/3) ≈ 0.99 m/s the
    lean only wobbles (:doc:`bicycle` derives it):

    >>> import lagrangian as lg
    >>> disc = lg.scenes.rolling_disc(m=1.0, r=0.3)
    >>> lin = disc.linearize_steady([0.0] * 5, [1.2, 0.0, 0.0, 0.0, 4.0],
    ...                             independent=["phi", "psi"], steady=["theta"])
    >>> lin.M.round(12).tolist()
    [[0.1125, 0.0], [0.0, 0.0225]]
    >>> lin.cyclic, bool(abs(lin.eigenvalues.real).max() < 1e-12)
    (('x', 'y', 'theta'), True)

    Parameters
    ----------
    q, qd : array_like, shape (dof,)
        The reference motion's state (consistent with the constraints).
    independent : sequence of coordinates or names
        The reduced coordinates y.
    steady : sequence of coordinates or names, optional
        The coordinates whose speeds are held (needed when the independent speeds do not
        exhaust the motion's freedom).
    dependent : sequence of coordinates or names, optional
        The coordinates the holonomic rows are solved for (one per row).
    t : float
        Time.

    Raises
    ------
    ValueError
        For bad input, a model without constraints, a name that is not a coordinate, the wrong
        number of steady or dependent coordinates, or rows that cannot be solved for the
        dependent positions or speeds (choose other independent coordinates).
    """
    holo = dict(self.constraints)
    vel = dict(self.velocity_constraints)
    if not (holo or vel):
        raise ValueError("linearize_steady needs a constrained model (constraints= or "
                         "velocity_constraints=); use Model.linearize otherwise")
    coords = list(self.coordinates)
    names = [c.name for c in coords]
    n = len(names)
    qv = vector("q", q, n)
    qdv = vector("qd", qd, n)
    at = real("t", t)
    ind = _names("independent", independent, names)
    if not ind:
        raise ValueError("linearize_steady: give at least one independent coordinate")
    held = _names("steady", steady, names)
    if set(held) & set(ind):
        raise ValueError("linearize_steady: a steady coordinate is independent too: "
                         f"{sorted(set(held) & set(ind))}")
    params = {k: float(v) for k, v in self.parameters.items() if isinstance(v, numbers.Real)}
    kh, k = len(holo), len(holo) + len(vel)
    program = row_jacobians(tuple(coords), tuple(holo.values()), tuple(vel.values()))
    flat = evaluate_program(program, names, params, np.array([at]), np.array([qv]),
                            "linearize_steady: the constraint rows' Jacobians",
                            qd=np.array([qdv]))[:, 0]
    if not np.all(np.isfinite(flat)):
        raise ValueError(
            f"linearize_steady: the constraint rows' Jacobians are not finite at t = {at}, "
            f"q = {[float(x) for x in qv]}, q̇ = {[float(x) for x in qdv]} (a wheel lying flat, "
            "a singular row): linearize "
            "about another state"
        )
    gh = flat[: kh * n].reshape(kh, n)
    z = flat[kh * n: kh * n + k * n].reshape(k, n)
    w = flat[kh * n + k * n:].reshape(k, n)
    i_ind = [names.index(s) for s in ind]
    rest = [i for i in range(n) if i not in i_ind]
    # Positions: δq = P δy.
    dep = _names("dependent", dependent, names)
    if dependent is None:
        dep_i: List[int] = []
        cand = [i for i in rest if names[i] not in held] or rest
        g_rest = gh[:, cand]
        for _ in range(kh):  # greedy column pivoting, bounded by the rows
            resid = g_rest if not dep_i else g_rest - gh[:, dep_i] @ np.linalg.lstsq(
                gh[:, dep_i], g_rest, rcond=None)[0]
            best = int(np.argmax(np.linalg.norm(resid, axis=0)))
            dep_i.append(cand[best])
        dep = [names[i] for i in dep_i]
    if len(dep) != kh or set(dep) & set(ind):
        raise ValueError(f"linearize_steady: dependent names {len(dep)} coordinates (none of "
                         f"them independent); give one per holonomic row ({kh})")
    i_dep = [names.index(s) for s in dep]
    m = len(ind)
    p = np.zeros((n, m))
    p[i_ind, range(m)] = 1.0
    p[i_dep] = -_solve("linearize_steady: the holonomic rows cannot be solved for the "
                       "dependent coordinates", gh[:, i_dep], gh[:, i_ind], dep)
    cyclic = [names[i] for i in rest if i not in i_dep]
    # Speeds: δq̇ = Q δy + N δẏ, the steady speeds held.
    i_held = [names.index(s) for s in held]
    i_spd = [i for i in rest if i not in i_held]
    if len(i_spd) != k:
        raise ValueError(
            f"linearize_steady: {len(i_spd)} speeds left to solve from {k} constraint rows: "
            f"name {len(i_spd) - k} more steady coordinate(s) (whose rates the motion holds), "
            "or fewer" if len(i_spd) > k else
            f"linearize_steady: {len(i_spd)} speeds left to solve from {k} constraint rows: "
            "name fewer steady or independent coordinates")
    spd = [names[i] for i in i_spd]
    ws = w[:, i_spd]
    nmat = np.zeros((n, m))
    nmat[i_ind, range(m)] = 1.0
    nmat[i_spd] = -_solve("linearize_steady: the constraint rows cannot be solved for the "
                          "dependent speeds", ws, w[:, i_ind], spd)
    qmat = np.zeros((n, m))
    qmat[i_spd] = -np.linalg.solve(ws, z @ p) if k else 0.0
    lin = linearize(self, qv, qdv, at)
    a_q = lin.A[n:, :n][i_ind]
    a_v = lin.A[n:, n:][i_ind]
    jy = a_q @ p + a_v @ qmat
    ju = a_v @ nmat
    mr = nmat.T @ lin.M @ nmat
    mr = 0.5 * (mr + mr.T)
    state = np.block([[np.zeros((m, m)), np.eye(m)], [jy, ju]])
    eig = np.linalg.eigvals(state)
    eig = eig[np.lexsort((eig.imag, -eig.real))]
    return SteadyLinearization(
        coordinates=tuple(ind),
        M=mr,
        C=-mr @ ju,
        K=-mr @ jy,
        A=state,
        eigenvalues=eig,
        P=p,
        N=nmat,
        Q=qmat,
        dependent=tuple(dep),
        dependent_speeds=tuple(spd),
        steady=tuple(held),
        cyclic=tuple(cyclic),
        accelerations=np.asarray(lin.accelerations)[i_ind],
        linearization=lin,
    )
