"""Statics and small oscillations: equilibria (``Equilibrium``, from ``Model.equilibrium``), the
equations of motion linearized about a state (``Linearization``, from ``Model.linearize``) and
the modes of an equilibrium (``Modes``, from ``Model.modes``) — the results and the functions
that find them, which ``Model`` binds as those methods (they read the model by its public
members, ``_protocols.ModelLike``)."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

from . import _lagrangian
from ._expr import ExprLike, serialize, to_raw
from ._protocols import ArrayLike, ModelLike
from ._validate import at_least_one, check_symbols, expressions, input_names, positive, real, vector

__all__ = ["Equilibrium", "Linearization", "Modes", "equilibrium", "linearize", "modes"]

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


# -- the methods of Model that find them (``Model.equilibrium = equilibrium``, ...) ----------


def equilibrium(
    self: ModelLike,
    q_guess: ArrayLike,
    loads: Optional[Sequence[ExprLike]] = None,
    *,
    t: Optional[float] = None,
    max_iterations: int = 100,
    max_step: float = math.inf,
) -> Equilibrium:
    """An equilibrium near ``q_guess``: where the system at rest (q̇ = 0) stays at rest,
    q̈ = 0, that is ∂L/∂q + Q − ∂Φ/∂q̇ = 0 at q̇ = 0.

    When the kinetic energy is a quadratic form in q̇ this is the principle of virtual work
    (seed §3), ∂U/∂q = Q. When it has a part T₀ that does not vanish at rest (a bead on a
    spinning hoop, coordinates in a rotating frame) its centrifugal force −∂T₀/∂q counts
    too: the relative equilibria of U − T₀. Stability is decided from the eigenvalues of
    the equations of motion linearized there (see :meth:`modes`), with the reason given.

    >>> import lagrangian as lg
    >>> th, = lg.coordinates("th")
    >>> R, W, g = 0.5, 7.0, 9.81   # a hoop spinning at W about its vertical diameter
    >>> bead = lg.Model(coordinates=[th],
    ...                 kinetic=0.5 * R**2 * (th.d**2 + W**2 * lg.sin(th)**2),
    ...                 potential=-g * R * lg.cos(th))
    >>> eq = bead.equilibrium([1.0])
    >>> round(float(eq.q[0]), 6), eq.stability   # cos θ* = g/(R W²)
    (1.158834, 'stable')
    >>> bead.equilibrium([0.0]).stability
    'unstable'

    Parameters
    ----------
    q_guess : array_like, shape (dof,)
        Where Newton's method starts.
    loads : sequence of expressions, optional
        Extra generalized loads, one per coordinate, added to the model's forces — the
        virtual work of the applied loads per unit δqᵢ (expressions in the coordinates,
        time and the model's parameters, or numbers).
    t : float, optional
        The time to solve at, for forces that change with time: the balance of the forces
        frozen at that instant. Without it the model must not depend on time (a steady
        rotation written with time in it is fine); otherwise a ``ValueError`` says that no
        static equilibrium exists in general.
    max_iterations : int
        Newton iteration budget.
    max_step : float
        Largest change of any coordinate in one iteration (keeps angles in one well).

    Raises
    ------
    ConvergenceError
        When no equilibrium is found from this guess.
    ValueError
        For bad input, and when the forces change with time and ``t`` is not given.
    """
    n = self.dof
    guess = vector("q_guess", q_guess, n).tolist()
    load_spec = None
    params: List[float] = []
    if loads is not None:
        exprs = list(expressions("loads", loads, n))
        numeric = {k: v for k, v in self.parameters.items() if isinstance(v, numbers.Real)}
        used: Dict[str, None] = {}
        names = {c.name for c in self.coordinates}
        for i, e in enumerate(exprs):
            check_symbols(f"load on {self.coordinates[i].name}", e, names, numeric, True, used)
        nodes, roots = serialize(exprs)
        order = list(used)
        load_spec = (to_raw(nodes, self.coordinates, order), roots)
        params = [float(numeric[k]) for k in order]
    iterations = at_least_one("max_iterations", max_iterations)
    step = positive("max_step", max_step)
    at = 0.0 if t is None else real("t", t)
    try:
        found = self.native.equilibrium(
            guess,
            t=at,
            loads=load_spec,
            params=params,
            max_iterations=iterations,
            max_step=step,
            frozen=t is not None,
        )
    except _lagrangian.ConvergenceError as e:
        raise _lagrangian.ConvergenceError(f"{e} (forces at t = {at})") from None
    q, residual, iterations, stability, eigenvalues, stiffness, reason, re, im, lam, gl = found
    spectrum = None if re is None else np.asarray(re) + 1j * np.asarray(im)
    return Equilibrium(
        q=np.asarray(q),
        stable=stability == "stable",
        stability=str(stability),
        eigenvalues=np.asarray(eigenvalues),
        stiffness=np.asarray(stiffness),
        residual=float(residual),
        iterations=int(iterations),
        reason=str(reason),
        spectrum=spectrum,
        multipliers=None if lam is None else np.asarray(lam),
        constraint_forces=None if gl is None else np.asarray(gl),
    )


def linearize(
    self: ModelLike,
    q: ArrayLike,
    qd: Optional[ArrayLike] = None,
    t: float = 0.0,
    inputs: Optional[Sequence[str]] = None,
) -> Linearization:
    """The equations of motion linearized about the state (t, q, q̇)::

        M (q̈ − a₀) + C δq̇ + K δq = 0,    δẋ = A δx (+ B δu),  x = (q, q̇)

    M, C = −M ∂q̈/∂q̇ (damping, gyroscopic and Coriolis terms), K = −M ∂q̈/∂q (stiffness,
    centrifugal part included) and the 2n × 2n state matrix A are exact — automatic
    differentiation of the equations of motion — at any state, moving or at rest.

    The seed's two masses on two springs (eq. 41–44): K is the spring matrix.

    >>> import lagrangian as lg
    >>> lin = lg.scenes.forced_two_mass(m1=1.0, m2=2.0, k1=30.0, k2=20.0).linearize([0.0, 0.0])
    >>> lin.K.tolist()
    [[50.0, -20.0], [-20.0, 20.0]]

    With ``inputs``, parameters of the model (by name) are inputs u and the linearization
    has the input matrix ``B`` = ∂ẋ/∂u too (2n × len(inputs): zero rows for q, ∂q̈/∂uⱼ in
    the rows of q̇), exact — differentiated on the expression graph, whether a parameter
    enters a generalized force, the potential or M itself. A pendulum driven by a torque τ:

    >>> th, = lg.coordinates("theta")
    >>> m, l, g, tau = lg.parameters("m l g tau")
    >>> model = lg.Model(
    ...     [th],
    ...     kinetic=m * l**2 * th.d**2 / 2,
    ...     potential=-m * g * l * lg.cos(th),
    ...     forces=[tau],
    ...     parameters={m: 2.0, l: 0.5, g: 9.81, tau: 0.0},
    ... )
    >>> lin = model.linearize([0.0], inputs=["tau"])
    >>> lin.B.tolist()  # ∂θ̈/∂τ = 1/(m l²)
    [[0.0], [2.0]]

    Parameters
    ----------
    q : array_like, shape (dof,)
        Coordinates of the operating point.
    qd : array_like, shape (dof,), optional
        Velocities (default zero).
    t : float
        Time.
    inputs : sequence of str, optional
        Names of parameters (``parameters={...}`` of the model; a ``Parameter`` stands for
        its name) to take as inputs; the columns of ``B``, in this order. Without it ``B``
        is ``None``.

    Raises
    ------
    ValueError
        For bad input: an input that is not a parameter of the model, inputs for a model
        without parameters, or for a ready-made scene of :mod:`lagrangian.scenes` (written in
        Rust: state it as a ``Model`` with ``parameters=`` to differentiate by them).
    SingularMassMatrixError
        Where M cannot be inverted.
    """
    n = self.dof
    qv = vector("q", q, n).tolist()
    qdv = [0.0] * n if qd is None else vector("qd", qd, n).tolist()
    at = real("t", t)
    if inputs is None:
        raw, _ = self.native.linearize(at, qv, qdv)
        return Linearization._from_native(raw)
    stated = self.kinetic is not None or self.position_expressions is not None
    names = input_names(inputs, self.parameters, stated)
    order = list(self.parameters)
    raw, b = self.native.linearize(
        at,
        qv,
        qdv,
        inputs=[order.index(k) for k in names],
        params=[float(v) for v in self.parameters.values()],
    )
    return Linearization._from_native(raw, b, names)


def modes(self: ModelLike, q_eq: ArrayLike, t: float = 0.0) -> Modes:
    """The modes of small oscillation about the equilibrium ``q_eq`` (at rest, time ``t``):
    natural frequencies (rad/s, ascending), mass-normalized shapes, damping ratios, the
    eigenvalues of the linearization and the stability they imply, with the reason.

    Without damping or gyroscopic terms the modes solve K φ = ω² M φ; otherwise they come
    from the eigenvalues of the state matrix A (whirl frequencies, damped modes).

    The seed's two masses on two springs (eq. 41–44): the forced response resonates at
    the natural frequencies, the roots of det(K − ω² M) = 2ω⁴ − 120ω² + 600 = 0.

    >>> import lagrangian as lg
    >>> two = lg.scenes.forced_two_mass(m1=1.0, m2=2.0, k1=30.0, k2=20.0)
    >>> modes = two.modes([0.0, 0.0])
    >>> [round(float(w), 6) for w in modes.frequencies]
    [2.346295, 7.382066]

    Forced by F cos Ωt with F = (1, 0), the amplitude (K − Ω² M)⁻¹ F near ω₁ dwarfs the
    static deflection:

    >>> import numpy as np
    >>> lin = modes.linearization
    >>> amplitude = lambda w: np.linalg.norm(np.linalg.solve(lin.K - w**2 * lin.M, [1.0, 0.0]))
    >>> bool(amplitude(modes.frequencies[0] * (1 + 1e-6)) > 1e5 * amplitude(0.0))
    True

    Parameters
    ----------
    q_eq : array_like, shape (dof,)
        An equilibrium (from :meth:`equilibrium`, say).
    t : float
        Time.

    Raises
    ------
    ValueError
        For bad input, and when ``q_eq`` is not an equilibrium.
    SingularMassMatrixError
        Where M cannot be inverted.
    """
    qv = vector("q_eq", q_eq, self.dof).tolist()
    return Modes._from_native(self.native.modes(real("t", t), qv))
