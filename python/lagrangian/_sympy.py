"""``from_sympy``: a :class:`~lagrangian.Model` from SymPy expressions. SymPy is imported only
here, when the function is called."""

from __future__ import annotations

import importlib
import math
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence

from ._expr import BINARY, UNARY, Coordinate, Expr, Parameter, atan2, t
from ._model import Model

__all__ = ["from_sympy"]


def from_sympy(
    kinetic: Any,
    potential: Any = None,
    dissipation: Any = None,
    forces: Optional[Sequence[Any]] = None,
    *,
    coordinates: Sequence[Any],
    velocities: Optional[Sequence[Any]] = None,
    time: Any = None,
    parameters: Optional[Mapping[Any, float]] = None,
) -> Model:
    """A :class:`~lagrangian.Model` from SymPy expressions of T, U, Φ and Q.

    ``coordinates`` are SymPy symbols or functions of time (``dynamicsymbols`` from
    ``sympy.physics.mechanics``); ``velocities`` default to their time derivatives when they
    are functions of time, and must be given (as symbols) otherwise. ``time`` defaults to the
    coordinates' argument. Every other symbol must be a key of ``parameters`` (a SymPy symbol or
    its name) with its value.

    Supported: ``+ - * /``, powers, the functions of :mod:`lagrangian` under their SymPy names
    (``sin``, ``log``, ``Abs``, ``atan2``, …; ``sqrt`` is a power in SymPy), ``atan`` (and
    ``sec csc cot``), π and e.

    >>> import sympy as sp
    >>> import lagrangian as lg
    >>> from sympy.physics.mechanics import dynamicsymbols
    >>> q = dynamicsymbols("q")
    >>> m, k = sp.symbols("m k")
    >>> t = dynamicsymbols._t
    >>> model = lg.from_sympy(m*q.diff(t)**2/2, k*q**2/2, coordinates=[q],
    ...                       parameters={m: 2.0, k: 8.0})
    >>> round(float(model.accelerations(0.0, [1.0], [0.0])[0]), 12)
    -4.0

    Raises
    ------
    ValueError
        For a free symbol that is neither a coordinate, a velocity, the time nor a parameter,
        and for functions the compiler does not know.
    """
    sp: Any = importlib.import_module("sympy")

    coords = list(coordinates)
    if not coords:
        raise ValueError("a model needs at least one coordinate")
    names: List[str] = []
    for c in coords:
        if isinstance(c, sp.Symbol):
            names.append(c.name)
        elif isinstance(c, sp.core.function.AppliedUndef):
            names.append(c.func.__name__)
        else:
            raise ValueError(f"{c} is not a symbol or a function of time: it cannot be a coordinate")
    if time is None:
        args = {a for c in coords if isinstance(c, sp.core.function.AppliedUndef) for a in c.args}
        if len(args) == 1:
            time = args.pop()
    if velocities is None:
        if time is None or not all(isinstance(c, sp.core.function.AppliedUndef) for c in coords):
            raise ValueError(
                "velocities must be given when the coordinates are not functions of time"
            )
        velocities = [c.diff(time) for c in coords]
    vels = list(velocities)
    if len(vels) != len(coords):
        raise ValueError(f"{len(vels)} velocities for {len(coords)} coordinates")

    ours = [Coordinate(n) for n in names]
    table: Dict[Any, Expr] = {}
    for c, v, q in zip(coords, vels, ours):
        table[v] = q.d
        table[c] = q
    if time is not None:
        table[time] = t
    values: Dict[str, float] = {}
    for key, value in (parameters or {}).items():
        name = key if isinstance(key, str) else str(key)
        symbol = sp.Symbol(name) if isinstance(key, str) else key
        table[symbol] = Parameter(name)
        values[name] = float(value)

    convert = _Converter(sp, table)
    return Model(
        coordinates=ours,
        kinetic=convert(kinetic, "kinetic energy"),
        potential=None if potential is None else convert(potential, "potential"),
        dissipation=None if dissipation is None else convert(dissipation, "dissipation"),
        forces=None if forces is None else [convert(f, "forces") for f in forces],
        parameters=values,
    )


def _node_of(op: str) -> Callable[[Expr], Expr]:
    """The expression ``op(x)`` of an operand ``x``."""
    return lambda x: Expr(op, (x,))


class _Converter:
    """SymPy → :class:`Expr`, without recursion (deep sums stay safe)."""

    def __init__(self, sp: Any, table: Dict[Any, Expr]) -> None:
        self.sp = sp
        self.table = table
        self.memo: Dict[Any, Expr] = {}
        f = sp.functions
        # Every function of one argument that SymPy has under a name of its own (`_expr.UNARY`),
        # and a few that are ours through identities.
        self.unary: Dict[Any, Callable[[Expr], Expr]] = {
            getattr(sp, e.sympy): _node_of(op)
            for op, e in UNARY.items()
            if e.sympy is not None
        }
        self.binary: Dict[Any, str] = {
            getattr(sp, e.sympy): op for op, e in BINARY.items() if e.sympy is not None
        }
        self.unary.update({
            f.atan: lambda x: atan2(x, 1.0),
            f.sec: lambda x: 1.0 / Expr("cos", (x,)),
            f.csc: lambda x: 1.0 / Expr("sin", (x,)),
            f.cot: lambda x: Expr("cos", (x,)) / Expr("sin", (x,)),
        })
        named = [e.sympy for e in (*UNARY.values(), *BINARY.values()) if e.sympy is not None]
        self.supported = ", ".join(["+ - * / **", *named, "sqrt, atan, sec, csc, cot"])

    def __call__(self, expr: Any, what: str) -> Expr:
        sp = self.sp
        root = sp.sympify(expr)
        stack: List[Any] = [root]
        while stack:
            e = stack[-1]
            if e in self.memo:
                stack.pop()
                continue
            leaf = self._leaf(e, what)
            if leaf is not None:
                self.memo[e] = leaf
                stack.pop()
                continue
            pending = [a for a in e.args if a not in self.memo]
            if pending:
                stack.extend(pending)
                continue
            stack.pop()
            self.memo[e] = self._node(e, [self.memo[a] for a in e.args], what)
        return self.memo[root]

    def _leaf(self, e: Any, what: str) -> Optional[Expr]:
        sp = self.sp
        if e in self.table:
            return self.table[e]
        if e.is_Number:
            x = float(e)
            if not math.isfinite(x):
                raise ValueError(f"the number {e} in the {what} is not finite")
            return Expr.lift(x)
        if e is sp.pi or e is sp.E:
            return Expr.lift(float(e))
        if isinstance(e, sp.Symbol):
            raise ValueError(
                f"the free symbol {e} in the {what} is not a coordinate, velocity, the time or "
                f"a parameter: give its value in parameters={{{e}: ...}}"
            )
        if isinstance(e, (sp.core.function.AppliedUndef, sp.Derivative)):
            raise ValueError(
                f"{e} in the {what} is not one of the coordinates or velocities"
            )
        return None

    def _node(self, e: Any, args: List[Expr], what: str) -> Expr:
        sp = self.sp
        if isinstance(e, sp.Add):
            out = args[0]
            for a in args[1:]:
                out = out + a
            return out
        if isinstance(e, sp.Mul):
            out = args[0]
            for a in args[1:]:
                out = out * a
            return out
        if isinstance(e, sp.Pow):
            return args[0] ** args[1]
        for cls, op in self.binary.items():
            if isinstance(e, cls) and len(args) == 2:
                return Expr(op, (args[0], args[1]))
        for cls, make in self.unary.items():
            if isinstance(e, cls) and len(args) == 1:
                return make(args[0])
        raise ValueError(
            f"{type(e).__name__} in the {what} is not supported (use {self.supported})"
        )
