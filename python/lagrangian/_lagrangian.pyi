"""The compiled core of the ``lagrangian`` package (Rust, pyo3). Use the public API in
``lagrangian`` instead of this module."""

from typing import Any, Dict, List, Optional, Sequence, Tuple, Type, TypeVar

import numpy as np
import numpy.typing as npt
from typing import final

from typing_extensions import Self, disjoint_base

from ._solution import Solution

__all__ = [
    "ConvergenceError",
    "LagrangianError",
    "NonFiniteError",
    "SingularMassMatrixError",
    "StepSizeError",
    "StiffnessError",
    "TooManyStepsError",
    "NativeModel",
    "DenseSolution",
    "Integrator",
    "NativeSolution",
    "check_options",
    "method_info",
    "methods",
    "scene_catalog",
    "scene_drawing",
    "scene_exact",
    "scene_model",
    "scene_pivot",
    "simulate_many",
    "COUNTERS",
    "__version__",
]

__version__: str
#: The statistics' counter names (``Statistics::COUNTERS`` in Rust), in the order of the
#: counter columns of ``simulate_many``.
COUNTERS: Tuple[str, ...]

_FloatArray = npt.NDArray[np.float64]
_RawNode = Tuple[str, float, int, int]
# (nodes, condition output, reset targets (velocity?, coordinate), reset outputs, parameter
# values, direction, terminal count (0: not terminal), name, interior samples per step)
_EventSpec = Tuple[
    Sequence[_RawNode],
    int,
    Sequence[Tuple[bool, int]],
    Sequence[int],
    Sequence[float],
    int,
    int,
    str,
    int,
]
@disjoint_base
class NativeSolution:
    """The base of ``Solution``: a run whose fields are made when first read, each once, and can
    be assigned (not deleted)."""

    FIELDS: Tuple[str, ...]
    t: Any
    q: Any
    qd: Any
    energy: Any
    stats: Any
    t_events: Any
    q_events: Any
    qd_events: Any
    status: Any
    message: Any
    names: Any
    event_names: Any
    _dense: Any
    _y: Any
    multipliers: Any
    constraint_forces: Any
    sensitivities: Any
    event_sensitivities: Any
    def __new__(cls, *_args: Any, **_kwargs: Any) -> Self: ...

_S = TypeVar("_S", bound=NativeSolution)

@final
class DenseSolution:
    """The continuous solution of a run: every step's interpolant."""

    def eval(self, t: _FloatArray) -> Tuple[_FloatArray, _FloatArray]:
        """(q, qd) at the times t, each of shape (len(t), dof); ValueError outside the span."""
    @property
    def order(self) -> int: ...
    @property
    def interpolant(self) -> str: ...
    @property
    def span(self) -> Optional[Tuple[float, float]]: ...
    @property
    def steps(self) -> int: ...
    def __reduce__(self) -> Tuple[Any, ...]: ...
    @staticmethod
    def _restore(parts: Tuple[Any, ...]) -> "DenseSolution": ...

@final
class Integrator:
    """An integrator standing at a state (t, q, qd), with its method and options: each
    ``propagate_until(t)`` continues from where the last one ended. Made by
    ``Model.integrator``."""

    def propagate_until(self, t: float) -> str:
        """Integrate to ``t`` and stand there: ``"finished"``, or ``"terminated"`` when a
        terminal event stopped the run first (``event`` names it)."""
    @property
    def t(self) -> float: ...
    @t.setter
    def t(self, t: float) -> None: ...
    @property
    def q(self) -> _FloatArray: ...
    @q.setter
    def q(self, q: object) -> None: ...
    @property
    def qd(self) -> _FloatArray: ...
    @qd.setter
    def qd(self, qd: object) -> None: ...
    @property
    def method(self) -> str: ...
    @property
    def event(self) -> Optional[str]: ...
    @property
    def stats(self) -> Optional[Dict[str, Any]]: ...

class LagrangianError(RuntimeError):
    """Base class of the failures of the mathematics. A failure of ``simulate`` during the run
    carries the partial solution (``solution``) and the last accepted state (``t``, ``q``,
    ``qd``); all are ``None`` otherwise."""

    solution: Optional[Solution]
    t: Optional[float]
    q: Optional[_FloatArray]
    qd: Optional[_FloatArray]

class SingularMassMatrixError(LagrangianError):
    """The mass matrix is singular, indefinite or not finite at some state."""

class StepSizeError(LagrangianError):
    """An adaptive step size fell below its floor, or the step budget ran out."""

class TooManyStepsError(StepSizeError):
    """The step budget ``max_steps`` ran out before the end of the span."""

class StiffnessError(LagrangianError):
    """An explicit method found the problem stiff."""

class ConvergenceError(LagrangianError):
    """A Newton iteration did not converge."""

class NonFiniteError(LagrangianError):
    """A NaN or an infinity appeared."""

def methods() -> List[str]:
    """The integration method names: "auto" and the registry's."""

def check_options(
    t0: float,
    t_end: float,
    method: str = "auto",
    dt: Optional[float] = None,
    rtol: float = 1e-6,
    atol: float = 1e-9,
) -> None:
    """Check a method and its step options as ``simulate`` does; raises ValueError."""

def simulate_many(
    model: "NativeModel",
    q0: _FloatArray,
    qd0: _FloatArray,
    t_end: float,
    t0: float = 0.0,
    params: Optional[_FloatArray] = None,
    scenes: Optional[Tuple[str, Sequence[Dict[str, Any]]]] = None,
    method: str = "auto",
    dt: Optional[float] = None,
    rtol: float = 1e-6,
    atol: float = 1e-9,
    t_eval: Optional[_FloatArray] = None,
    max_steps: Optional[int] = None,
    final_only: bool = False,
    workers: int = 0,
    events: Sequence[_EventSpec] = ...,
    event_params: Sequence[Optional[_FloatArray]] = ...,
    backend: str = "native",
    error_coordinates: Optional[int] = None,
) -> Any:
    """An ensemble of runs in Rust on ``workers`` threads (0: every core): (t, q, qd, reached,
    counters, method, choice, choices, failures, status, events, residuals, path, paths); see
    ``_ensemble.py``."""

def method_info(name: str) -> Tuple[str, Optional[bool], Optional[int]]:
    """(canonical name, adaptive, order) of a method name; raises ValueError if unknown."""

@final
class NativeModel:
    """A compiled model (tape or Rust scene)."""

    @staticmethod
    def compile(
        nodes: Sequence[_RawNode],
        dof: int,
        params: Sequence[float],
        kinetic: Optional[int] = None,
        potential: Optional[int] = None,
        dissipation: Optional[int] = None,
        forces: Optional[Sequence[int]] = None,
        positions: Optional[Sequence[int]] = None,
        dim: int = 0,
        masses: Optional[Sequence[int]] = None,
        backend: str = "native",
        constraints: Optional[Sequence[int]] = None,
        velocity_constraints: Optional[Sequence[int]] = None,
        constraint_names: Sequence[str] = ...,
    ) -> "NativeModel": ...
    def with_parameters(self, params: Sequence[float]) -> "NativeModel": ...
    @property
    def dof(self) -> int: ...
    def conserved(self, resets: bool) -> bool: ...
    def structure(self) -> Dict[str, Any]: ...
    def accelerations(self, t: object, q: object, qd: object) -> Any: ...
    @property
    def constraint_names(self) -> List[str]: ...
    @property
    def holonomic_count(self) -> int: ...
    def multipliers(self, t: object, q: object, qd: object) -> Any: ...
    def constraint_forces(self, t: object, q: object, qd: object) -> Any: ...
    def particle_reactions(self, t: object, q: object, qd: object) -> Any: ...
    def project(
        self, t: float, q: List[float], qd: List[float], tol: Optional[float] = None
    ) -> Tuple[List[float], List[float]]: ...
    def check_consistent(
        self,
        t: float,
        q: List[float],
        qd: List[float],
        rtol: Optional[float] = None,
        atol: Optional[float] = None,
    ) -> None: ...
    def mass_matrix(self, t: object, q: object, qd: object) -> Any: ...
    def taylor_series(
        self, t: float, q: List[float], qd: List[float], order: int
    ) -> Tuple[Any, Any]: ...
    def energy(self, t: object, q: object, qd: object) -> Any: ...
    def momenta(self, t: object, q: object, qd: object) -> Any: ...
    def lagrangian(self, t: object, q: object, qd: object) -> Any: ...
    def rhs(self, t: float, y: _FloatArray) -> _FloatArray:
        """dy/dt = (q̇, q̈) at y = (q, q̇), shape (2n,) or (2n, k)."""
    def jacobian(self, t: float, y: _FloatArray) -> _FloatArray:
        """The 2n × 2n Jacobian of ``rhs`` by forward-mode AD."""
    @property
    def has_positions(self) -> bool: ...
    def positions(self, t: _FloatArray, q: _FloatArray) -> Optional[_FloatArray]:
        """Positions at the states (t[i], q[i]): shape (len(t), particles, dim), or None for a
        model stated by its energies only."""
    def simulate(
        self,
        q0: object,
        qd0: object,
        t_end: float,
        t0: float,
        method: str,
        dt: Optional[float],
        rtol: float,
        atol: float,
        t_eval: Optional[_FloatArray],
        max_steps: Optional[int],
        every: Optional[int],
        events: Sequence[_EventSpec],
        dense: bool,
        backend: str,
        solution_type: Type[_S],
        names: Optional[Tuple[str, ...]],
        event_names: Tuple[str, ...],
    ) -> Optional[_S]: ...
    def variational_model(
        self, directions: Sequence[Tuple[str, int]], params: Sequence[float]
    ) -> "NativeModel": ...
    def simulate_sensitivities(
        self,
        q0: Sequence[float],
        qd0: Sequence[float],
        t_end: float,
        t0: float,
        method: str,
        dt: Optional[float],
        rtol: float,
        atol: float,
        t_eval: Optional[_FloatArray],
        max_steps: Optional[int],
        every: Optional[int],
        events: Sequence[_EventSpec],
        dense: bool,
        backend: str,
        solution_type: Type[_S],
        names: Optional[Tuple[str, ...]],
        event_names: Tuple[str, ...],
        directions: Sequence[Tuple[str, int]],
        params: Sequence[float],
        error_all: bool,
        event_reads: Sequence[Sequence[int]],
    ) -> _S: ...
    def integrator(
        self,
        q0: Sequence[float],
        qd0: Sequence[float],
        t0: float,
        method: str,
        dt: Optional[float],
        rtol: float,
        atol: float,
        max_steps: Optional[int],
        events: Sequence[_EventSpec],
        backend: str,
    ) -> Integrator: ...
    def equilibrium(
        self,
        q_guess: Sequence[float],
        t: float = 0.0,
        loads: Optional[Tuple[Sequence[_RawNode], Sequence[int]]] = None,
        params: Sequence[float] = ...,
        max_iterations: int = 100,
        max_step: float = ...,
        frozen: bool = False,
    ) -> Tuple[
        _FloatArray,
        float,
        int,
        str,
        _FloatArray,
        _FloatArray,
        str,
        Optional[_FloatArray],
        Optional[_FloatArray],
        Optional[_FloatArray],
        Optional[_FloatArray],
    ]:
        """(q, residual, iterations, stability, eigenvalues of K's symmetric part, K, reason,
        spectrum re, spectrum im, multipliers, constraint forces); the spectrum is None where M
        is singular and for a constrained model, the last two None without constraints."""
    def linearize(
        self,
        t: float,
        q: Sequence[float],
        qd: Sequence[float],
        inputs: Optional[Sequence[int]] = None,
        params: Sequence[float] = ...,
    ) -> Tuple[
        Tuple[
            float,
            _FloatArray,
            _FloatArray,
            _FloatArray,
            _FloatArray,
            _FloatArray,
            _FloatArray,
            _FloatArray,
            _FloatArray,
            _FloatArray,
        ],
        Optional[_FloatArray],
    ]:
        """((t, q, qd, accelerations, M, C, K, A, eigenvalues re, eigenvalues im), B): B =
        ∂ẋ/∂u (2 dof × len(inputs)) for the parameters of indices ``inputs`` at the values
        ``params``, None without ``inputs``; ValueError for a scene written in Rust."""
    def modes(self, t: float, q: Sequence[float]) -> Tuple[Any, ...]:
        """(problem, frequencies, ω², damping ratios, shapes re, shapes im, eigenvalues re,
        eigenvalues im, stability, reason, linearization tuple)."""

# The scene registry (src/python/scenes.rs).
def scene_catalog() -> List[Dict[str, Any]]: ...
def scene_model(
    name: str, arguments: Dict[str, Any]
) -> Tuple[NativeModel, Dict[str, Any], List[str]]: ...
def scene_drawing(name: str, arguments: Dict[str, Any]) -> Optional[Dict[str, Any]]: ...
def scene_pivot(name: str, arguments: Dict[str, Any], t: _FloatArray) -> _FloatArray: ...
def scene_exact(
    name: str, arguments: Dict[str, Any], q0: Sequence[float], qd0: Sequence[float], t: float
) -> Tuple[_FloatArray, _FloatArray]: ...
