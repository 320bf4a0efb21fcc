"""What the workers read of the objects they are handed: small protocols of public members only.

A worker (a picture, an ensemble, a fit, an equilibrium) sits below the class whose method hands
it the work, and names its argument by one of these protocols instead of importing that class:
the imports then run one way, down (``tests/python/test_imports.py``). ``Model``, ``Solution``,
``Fit`` and ``WorkPrecision`` satisfy them structurally (mypy checks it where they are passed).
"""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Protocol, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from ._expr import Coordinate, Expr

__all__ = [
    "ArrayLike",
    "Drawable",
    "FittedModel",
    "FloatArray",
    "ModelLike",
    "PrecisionDiagram",
    "PrecisionRow",
    "Run",
    "Trajectory",
]

FloatArray = npt.NDArray[np.float64]
ArrayLike = Union[Sequence[float], FloatArray]


class Trajectory(Protocol):
    """A solution as pictures read it: its points, names and statistics, and (``dense=True``) its
    interpolant."""

    @property
    def t(self) -> FloatArray: ...

    @property
    def q(self) -> FloatArray: ...

    @property
    def qd(self) -> FloatArray: ...

    @property
    def energy(self) -> FloatArray: ...

    @property
    def names(self) -> Optional[Tuple[str, ...]]: ...

    @property
    def stats(self) -> Dict[str, Any]: ...

    @property
    def interpolant(self) -> Optional[Tuple[str, int]]: ...

    def __call__(self, t: Any) -> Tuple[FloatArray, FloatArray]: ...


class Run(Trajectory, Protocol):
    """A solution as a fit reads it: a trajectory with its message and sensitivities."""

    @property
    def message(self) -> str: ...

    @property
    def sensitivities(self) -> Optional[Dict[str, FloatArray]]: ...


class Drawable(Protocol):
    """A model as a movie reads it: its coordinates, parameters and particles."""

    @property
    def dof(self) -> int: ...

    @property
    def coordinates(self) -> Tuple[Coordinate, ...]: ...

    @property
    def parameters(self) -> Dict[str, Any]: ...

    @property
    def has_positions(self) -> bool: ...

    def positions(self, t: Any, q: Any) -> FloatArray: ...


class ModelLike(Drawable, Protocol):
    """A model as the workers below it read it (ensembles, fits, equilibria, linearizations):
    its statement, its compiled system and the runs it makes — public members only."""

    @property
    def backend(self) -> str: ...

    @property
    def scene(self) -> Optional[str]: ...

    @property
    def native(self) -> Any: ...

    @property
    def kinetic(self) -> Optional[Expr]: ...

    @property
    def position_expressions(self) -> Optional[Tuple[Tuple[Expr, ...], ...]]: ...

    @property
    def constraint_names(self) -> Tuple[str, ...]: ...

    @property
    def constraints(self) -> Dict[str, Expr]: ...

    @property
    def velocity_constraints(self) -> Dict[str, Expr]: ...

    def with_parameters(self, **values: float) -> "ModelLike": ...

    def energy(self, t: float, q: ArrayLike, qd: ArrayLike) -> Any: ...

    # Any arguments: the keywords are stated once, on ``Model.simulate``.
    def simulate(self, *args: Any, **kwargs: Any) -> Run: ...


class FittedModel(Protocol):
    """What a picture of a fit reads of it (``Fit``)."""

    @property
    def model(self) -> ModelLike: ...

    @property
    def parameters(self) -> Dict[str, float]: ...

    @property
    def uncertainties(self) -> Dict[str, float]: ...

    @property
    def initial_states(self) -> List[Tuple[FloatArray, FloatArray]]: ...

    @property
    def residuals(self) -> Any: ...

    def data(self, trial: int = ...) -> Tuple[FloatArray, FloatArray]: ...


class PrecisionRow(Protocol):
    """One point of a work–precision diagram (``Row``)."""

    @property
    def tolerance(self) -> Optional[float]: ...

    @property
    def dt(self) -> Optional[float]: ...

    @property
    def error(self) -> Optional[float]: ...

    @property
    def seconds(self) -> Optional[float]: ...

    @property
    def failure(self) -> Optional[str]: ...


class Agreement(Protocol):
    """A reference as the diagram shows it: how far its two runs agree (``Reference``)."""

    @property
    def agreement(self) -> Optional[float]: ...


class PrecisionDiagram(Protocol):
    """The rows of a work–precision diagram by method, with their reference (``WorkPrecision``)."""

    @property
    def methods(self) -> List[str]: ...

    @property
    def title(self) -> str: ...

    @property
    def reference(self) -> Agreement: ...

    def by_method(self, method: str) -> Sequence[PrecisionRow]: ...

