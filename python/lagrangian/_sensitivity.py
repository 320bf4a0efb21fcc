"""Forward sensitivities (``Model.simulate(..., sensitivities=[...])``): the names a user gives,
the directions the native run takes, and its raw arrays named again.

A name is a parameter of the model (one column: ∂(q, q̇)/∂p) or ``"q0"`` / ``"qd0"`` (n columns:
∂(q, q̇)/∂q₀ⱼ for each j). The native run returns the sensitivities as one array of shape
(outputs, columns, 2n) and each event's time sensitivities as (occurrences, columns); here they
become dicts by name, shaped as the docs of ``Model.simulate`` say.
"""

from __future__ import annotations

from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: The names of the initial state's directions.
INITIAL = ("q0", "qd0")

# One requested name and the columns it takes: (name, first column, number of columns).
Layout = List[Tuple[str, int, int]]


def directions(
    names: object,
    parameters: Mapping[str, Any],
    n: int,
    scene: Optional[str] = None,
) -> Tuple[List[Tuple[str, int]], Layout]:
    """The native directions and the columns' layout for the requested ``names``.

    Raises ``ValueError`` for a name that is neither a parameter of the model nor ``"q0"`` /
    ``"qd0"`` (listing what is), a name given twice, or no name; ``TypeError`` for something
    that is not a sequence of strings. A scene's parameters are numbers in its Rust code: only
    the initial state can be differentiated there.
    """
    if isinstance(names, str) or not isinstance(names, (list, tuple)):
        raise TypeError(
            "sensitivities must be a list of names (parameters of the model, 'q0', 'qd0'), "
            f"not {type(names).__name__}"
        )
    if not names:
        raise ValueError("sensitivities=[]: name at least one parameter, or 'q0' or 'qd0'")
    order = list(parameters)
    out: List[Tuple[str, int]] = []
    layout: Layout = []
    seen = set()
    for name in names:
        if not isinstance(name, str):
            raise TypeError(f"a sensitivity is named by a string, not {type(name).__name__}")
        if name in seen:
            raise ValueError(f"sensitivity {name!r} is named twice")
        seen.add(name)
        if name in INITIAL:
            layout.append((name, len(out), n))
            out.extend((name, i) for i in range(n))
        elif scene is None and name in parameters:
            layout.append((name, len(out), 1))
            out.append(("param", order.index(name)))
        elif scene is not None and name in parameters:
            raise ValueError(
                f"{name!r} is an argument of the scene {scene!r}, a number in its Rust code, "
                "which cannot be differentiated: only 'q0' and 'qd0' can; state the system "
                "with lg.Model and lg.parameters to differentiate along its parameters"
            )
        else:
            known = ", ".join(repr(p) for p in ([] if scene else order) + list(INITIAL))
            raise ValueError(f"{name!r} is not a parameter of the model: name one of {known}")
    return out, layout


def named(raw: FloatArray, layout: Layout) -> Dict[str, FloatArray]:
    """``raw`` of shape (outputs, columns, 2n) as {name: (outputs, 2n)} for a parameter and
    {name: (outputs, 2n, n)} for ``"q0"`` / ``"qd0"`` (column j: ∂(q, q̇)/∂q₀ⱼ)."""
    out: Dict[str, FloatArray] = {}
    for name, first, count in layout:
        if name in INITIAL:
            out[name] = np.ascontiguousarray(raw[:, first : first + count, :].transpose(0, 2, 1))
        else:
            out[name] = np.ascontiguousarray(raw[:, first, :])
    return out


def named_events(raw: Sequence[FloatArray], layout: Layout) -> List[Dict[str, FloatArray]]:
    """Each event's (occurrences, columns) as {name: (occurrences,)} for a parameter and
    {name: (occurrences, n)} for ``"q0"`` / ``"qd0"``."""
    out: List[Dict[str, FloatArray]] = []
    for e in raw:
        d: Dict[str, FloatArray] = {}
        for name, first, count in layout:
            d[name] = (
                np.ascontiguousarray(e[:, first : first + count])
                if name in INITIAL
                else np.ascontiguousarray(e[:, first])
            )
        out.append(d)
    return out


class Leading:
    """The continuous solution of a variational run seen as the model's: (q, q̇) of its first n
    coordinates (the rest are the sensitivities)."""

    __slots__ = ("dense", "n")

    def __init__(self, dense: Any, n: int) -> None:
        self.dense, self.n = dense, n

    def eval(self, t: FloatArray) -> Tuple[FloatArray, FloatArray]:
        q, qd = self.dense.eval(t)
        return np.ascontiguousarray(q[:, : self.n]), np.ascontiguousarray(qd[:, : self.n])

    @property
    def interpolant(self) -> str:
        return str(self.dense.interpolant)

    @property
    def order(self) -> int:
        return int(self.dense.order)

    def __reduce__(self) -> Tuple[Any, ...]:
        return Leading, (self.dense, self.n)
