"""Equilibria (``Equilibrium``, from ``Model.equilibrium``), the equations of motion linearized
about a state (``Linearization``, from ``Model.linearize``) and the modes of an equilibrium
(``Modes``, from ``Model.modes``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

__all__ = ["Equilibrium", "Linearization", "Modes"]

FloatArray = npt.NDArray[np.float64]
ComplexArray = npt.NDArray[np.complex128]


def _complex(re: Any, im: Any) -> ComplexArray:
    return np.asarray(re, dtype=np.float64) + 1j * np.asarray(im, dtype=np.float64)


@dataclass(frozen=True)
class Equilibrium:
    """An equilibrium from :meth:`Model.equilibrium`: where a system at rest stays at rest.

    Attributes
    ----------
    q : numpy.ndarray
        The equilibrium configuration.
    stable : bool
        Whether small disturbances stay small (``stability == "stable"``).
    stability : str
        ``"stable"``, ``"unstable"`` or ``"neutral"`` (the linearization does not decide: a zero
        eigenvalue, say), decided from the eigenvalues of the linearized equations of motion
        (``spectrum``); only where the mass matrix is singular (a model for statics alone) from
        the stiffness, by the energy criterion.
    reason : str
        Why, in words: which eigenvalue decided (a positive real part, a zero eigenvalue,
        a positive definite K, gyroscopic stabilization).
    eigenvalues : numpy.ndarray
        Eigenvalues of the symmetric part of the stiffness K, ascending.
    stiffness : numpy.ndarray
        K = ∂r/∂q, r = ∂U/∂q − Q − ∂T/∂q + ∂Φ/∂q̇ at q̇ = 0: the centrifugal stiffness of a
        kinetic energy that does not vanish at rest included.
    residual : float
        |r| at ``q``.
    iterations : int
        Newton iterations taken.
    spectrum : numpy.ndarray or None
        Eigenvalues (complex) of the state matrix A of the linearization at (q, 0); ``None``
        where the mass matrix is singular, and for a constrained model (whose verdict is the
        energy criterion on the constraint manifold: ``eigenvalues`` are then those of the
        reduced Hessian Zᵀ H Z over the virtual displacements Z).
    multipliers : numpy.ndarray or None
        For a constrained model, the Lagrange multipliers λ of the holonomic rows, such that
        r = Gᵀλ (the reactions balance the loads; sign convention of
        :meth:`Model.multipliers`); ``None`` without constraints.
    constraint_forces : numpy.ndarray or None
        The generalized reaction forces Gᵀλ (one per coordinate), or ``None``.
    """

    q: FloatArray
    stable: bool
    stability: str
    eigenvalues: FloatArray
    stiffness: FloatArray
    residual: float
    iterations: int
    reason: str = ""
    spectrum: Optional[ComplexArray] = None
    multipliers: Optional[FloatArray] = None
    constraint_forces: Optional[FloatArray] = None


@dataclass(frozen=True)
class Linearization:
    """The equations of motion linearized about a state, from :meth:`Model.linearize`::

        M (q̈ − a₀) + C δq̇ + K δq = 0,    δẋ = A δx,  x = (q, q̇)

    exact (automatic differentiation) at any state, moving or at rest.

    Attributes
    ----------
    t : float
        Time of the operating point.
    q, qd : numpy.ndarray, shape (dof,)
        The operating point.
    accelerations : numpy.ndarray, shape (dof,)
        a₀ = q̈ there (zero at an equilibrium).
    M : numpy.ndarray, shape (dof, dof)
        Mass matrix ∂²T/∂q̇².
    C : numpy.ndarray, shape (dof, dof)
        −M ∂q̈/∂q̇: Rayleigh damping ∂²Φ/∂q̇², gyroscopic and Coriolis terms.
    K : numpy.ndarray, shape (dof, dof)
        −M ∂q̈/∂q: stiffness, centrifugal part included.
    A : numpy.ndarray, shape (2 dof, 2 dof)
        State matrix [[0, I], [∂q̈/∂q, ∂q̈/∂q̇]].
    eigenvalues : numpy.ndarray, complex
        Eigenvalues of ``A``, by magnitude, then imaginary part.
    B : numpy.ndarray, shape (2 dof, len(inputs)), or None
        Input matrix ∂ẋ/∂u for the parameters named in ``inputs`` (``linearize(...,
        inputs=[...])``), so that δẋ = A δx + B δu: zero rows for q, ∂q̈/∂uⱼ in the rows of q̇,
        exact (differentiated on the expression graph, M⁻¹ (∂f/∂u − (∂M/∂u) q̈)); ``None`` when
        no inputs were asked for.
    inputs : tuple of str
        The parameter names of the columns of ``B`` (empty without ``B``).
    """

    t: float
    q: FloatArray
    qd: FloatArray
    accelerations: FloatArray
    M: FloatArray
    C: FloatArray
    K: FloatArray
    A: FloatArray
    eigenvalues: ComplexArray
    B: Optional[FloatArray] = None
    inputs: Tuple[str, ...] = ()

    @classmethod
    def _from_native(
        cls, raw: Sequence[Any], b: Any = None, inputs: Sequence[str] = ()
    ) -> "Linearization":
        t, q, qd, acc, m, c, k, a, re, im = raw
        return cls(
            t=float(t),
            q=np.asarray(q),
            qd=np.asarray(qd),
            accelerations=np.asarray(acc),
            M=np.asarray(m),
            C=np.asarray(c),
            K=np.asarray(k),
            A=np.asarray(a),
            eigenvalues=_complex(re, im),
            B=None if b is None else np.asarray(b),
            inputs=tuple(inputs),
        )


@dataclass(frozen=True)
class Modes:
    """The modes of small motion about an equilibrium, from :meth:`Model.modes`.

    Each mode is a pair of eigenvalues λ₁, λ₂ of A (a complex pair, or two real ones) with
    λ² + 2ζω λ + ω² = 0. Without damping or gyroscopic terms they come from K φ = ω² M φ
    (``problem == "undamped"``: real ω², real shapes); otherwise from A itself
    (``"state_space"``: whirl frequencies of gyroscopic systems, damped modes).

    Attributes
    ----------
    frequencies : numpy.ndarray
        Natural frequencies √|ω²| in rad/s, ascending (for a damped mode the undamped one, |λ|;
        the damped frequency is ``frequencies * sqrt(1 - damping_ratios**2)``).
    omega_squared : numpy.ndarray
        ω² of each mode; negative for a divergence (λ = ±√(−ω²)), which is not an oscillation.
    damping_ratios : numpy.ndarray
        ζ = −(λ₁ + λ₂)/(2ω): 0 undamped, below 1 underdamped, 1 or more overdamped, negative
        growing.
    shapes : numpy.ndarray, shape (dof, modes)
        Mode shapes as columns, mass-normalized (φᴴ M φ = 1); real for ``"undamped"``, complex
        otherwise.
    eigenvalues : numpy.ndarray, complex
        All eigenvalues of A.
    stable : bool
        Whether the equilibrium is stable (``stability == "stable"``).
    stability : str
        ``"stable"``, ``"unstable"`` or ``"neutral"``.
    reason : str
        Why, in words.
    problem : str
        ``"undamped"`` or ``"state_space"``.
    linearization : Linearization
        The linearization at the equilibrium.
    """

    frequencies: FloatArray
    omega_squared: FloatArray
    damping_ratios: FloatArray
    shapes: npt.NDArray[Any]
    eigenvalues: ComplexArray
    stable: bool
    stability: str
    reason: str
    problem: str
    linearization: Linearization

    @classmethod
    def _from_native(cls, raw: Sequence[Any]) -> "Modes":
        problem, freq, w2, zeta, shapes_re, shapes_im, re, im, stability, reason, lin = raw
        shapes: npt.NDArray[Any] = np.asarray(shapes_re)
        if problem != "undamped":
            shapes = _complex(shapes_re, shapes_im)
        return cls(
            frequencies=np.asarray(freq),
            omega_squared=np.asarray(w2),
            damping_ratios=np.asarray(zeta),
            shapes=shapes,
            eigenvalues=_complex(re, im),
            stable=stability == "stable",
            stability=str(stability),
            reason=str(reason),
            problem=str(problem),
            linearization=Linearization._from_native(lin),
        )
