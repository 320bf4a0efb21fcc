"""Checking what the user gives: state vectors, numbers, coordinates, parameters and the symbols
of expressions. Each check raises ``TypeError`` or ``ValueError`` with a message that says what
to give instead; the integrator options are not checked here but in Rust (one message each)."""

from __future__ import annotations

import math
import numbers
from typing import Any, Dict, Mapping, Optional, Tuple

import numpy as np
import numpy.typing as npt

from ._expr import Coordinate, Expr

__all__ = [
    "FloatArray",
    "check_coordinates",
    "check_parameters",
    "check_symbols",
    "integer",
    "number",
    "real",
    "states",
    "vector",
]

FloatArray = npt.NDArray[np.float64]


def _not_a_number(what: str, value: object, n: int) -> None:
    """Reject a string or ``None`` (which NumPy would read as characters or as NaN)."""
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{what} must be a sequence of {n} numbers, got a string")
    if value is None:
        raise ValueError(f"{what} is None, which is not a number: give a sequence of {n} numbers")


def _non_finite(what: str, value: object, arr: FloatArray) -> ValueError:
    """The error for the first entry of ``arr`` that is not finite: an entry given as ``None``
    (NaN to NumPy) is named as such."""
    index = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
    label = f"{what}[{', '.join(map(str, index))}]"
    try:
        given = np.asarray(value, dtype=object)
        entry = given[index] if given.shape == arr.shape else given.reshape(arr.shape)[index]
    except (TypeError, ValueError, IndexError):
        entry = arr[index]
    if entry is None:
        return ValueError(f"{label} is None, which is not a number")
    return ValueError(f"{label} = {arr[index]} is not finite")


def vector(what: str, value: object, n: int) -> FloatArray:
    """``value`` as a float vector of length ``n``, or a ``ValueError`` that says why not."""
    _not_a_number(what, value, n)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{what} must be a sequence of {n} numbers: {e}") from None
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1 or arr.shape[0] != n:
        raise ValueError(
            f"{what} has shape {arr.shape} but the model has {n} coordinates"
        )
    if not np.isfinite(arr).all():
        raise _non_finite(what, value, arr)
    return np.ascontiguousarray(arr)


def states(what: str, value: object, n: int) -> FloatArray:
    """``value`` as one state (a float vector of length ``n``) or ``k`` states as the rows of a
    float array of shape ``(k, n)``, or a ``ValueError`` that says why not."""
    _not_a_number(what, value, n)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{what} must be a sequence of {n} numbers: {e}") from None
    if arr.ndim != 2:
        return vector(what, value, n)
    if arr.shape[1] != n:
        raise ValueError(
            f"{what} has shape {arr.shape} but needs ({n},) or (k, {n}) for k states: "
            f"the model has {n} coordinates"
        )
    if not np.isfinite(arr).all():
        raise _non_finite(what, value, arr)
    return np.ascontiguousarray(arr)


def real(what: str, value: object) -> float:
    """``value`` as a finite float: ``TypeError`` for a non-number, ``ValueError`` if not finite."""
    if type(value) is float:  # the common case, without the ABC check below
        x = value
    elif isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{what} must be a real number, got {value!r}")
    else:
        x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{what} = {x} is not finite")
    return x


def check_coordinates(coordinates: object) -> Tuple[Coordinate, ...]:
    """The model's coordinates as a tuple: distinct ``Coordinate`` objects, at least one."""
    if isinstance(coordinates, Expr) or not isinstance(coordinates, (list, tuple)):
        raise TypeError(
            "coordinates must be a list of coordinates from lagrangian.coordinates(...)"
        )
    coords = tuple(coordinates)
    if not coords:
        raise ValueError("a model needs at least one coordinate")
    for c in coords:
        if not isinstance(c, Coordinate):
            raise TypeError(
                f"{c!r} is not a coordinate: make coordinates with lagrangian.coordinates(...)"
            )
    names = [c.name for c in coords]
    if len(set(names)) != len(names):
        raise ValueError(f"repeated coordinate names in {names}")
    return coords


def check_parameters(parameters: Optional[Mapping[str, float]]) -> Dict[str, float]:
    """Parameter values by name (a ``Parameter`` key is read as its name), each finite."""
    if parameters is None:
        return {}
    if not isinstance(parameters, Mapping):
        raise TypeError("parameters must be a mapping of names to numbers")
    values: Dict[str, float] = {}
    for k, v in parameters.items():
        name = k.name if isinstance(k, Expr) and k.op == "param" else k
        if not isinstance(name, str):
            raise TypeError(f"parameter names must be strings, got {k!r}")
        values[name] = real(f"parameter {name!r}", v)
    return values


def check_symbols(
    what: str,
    e: Expr,
    coordinates: Any,
    values: Mapping[str, Any],
    velocities: bool,
    used: Dict[str, None],
) -> None:
    """Check the free symbols of ``e`` (the ``what`` of a model): coordinates of the model,
    velocities only where ``velocities``, parameters with a value; record the parameters in
    ``used``."""
    for s in e.free_symbols():
        if s.op in ("q", "qd"):
            name = s.args[0]
            if name not in coordinates:
                raise ValueError(
                    f"{s!r} in the {what} is not a coordinate of this model "
                    f"(coordinates: {', '.join(sorted(coordinates))})"
                )
            if s.op == "qd" and not velocities:
                raise ValueError(
                    f"the {what} depends on the velocity {s!r}: velocity-dependent terms belong "
                    "in the kinetic energy (or the forces)"
                )
        elif s.op == "param":
            name = s.args[0]
            if name not in values:
                raise ValueError(
                    f"parameter {name!r} in the {what} has no value: pass "
                    f"parameters={{{name!r}: ...}}"
                )
            used.setdefault(name, None)


def number(what: str, value: object) -> float:
    """``value`` as a float, checking its type only (``TypeError`` for a non-number): for the
    options, whose values are validated in Rust."""
    if type(value) is float:
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{what} must be a real number, got {value!r}")
    return float(value)


def integer(what: str, value: object) -> int:
    """``value`` as an int, checking its type only (``TypeError`` for a non-integer)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{what} must be an integer, got {value!r}")
    return int(value)
