"""The expression language: coordinates, velocities, time, parameters and the functions of them.

Expressions are plain Python trees. They are compiled to a flat tape in Rust when a
:class:`~lagrangian.Model` is built, so building them may be slow; evaluating them never runs
Python.
"""

from __future__ import annotations

import builtins
import math
import numbers
from typing import Any, Callable, Dict, Iterable, List, Mapping, NamedTuple, Optional, Sequence, Tuple, TypeVar, Union

import numpy as np

__all__ = [
    "Expr",
    "Coordinate",
    "Parameter",
    "coordinates",
    "parameters",
    "t",
    "sin",
    "cos",
    "tan",
    "exp",
    "log",
    "sqrt",
    "sinh",
    "cosh",
    "tanh",
    "atan2",
    "derivative",
]

#: Anything that can stand for an expression: an :class:`Expr` or a real number.
ExprLike = Union["Expr", float, int]

_LEAVES = ("const", "param", "t", "q", "qd")


class Elementary(NamedTuple):
    """What the Python side needs of one operation besides its Rust row: NumPy's function (for
    drawing and ``np.<ufunc>`` on expressions), SymPy's function of the same name, if any, and
    its derivative rule (for :func:`derivative`)."""

    numpy: Callable[..., Any]
    #: The name of SymPy's function (``None`` where SymPy writes it otherwise: ``sqrt`` is a
    #: power there, ``neg`` a product by −1).
    sympy: Optional[str]
    #: Of one argument: ``rule(a, y)`` = dy/da for y = f(a). Of two: ``rule(a, b, y, da, db)``
    #: = dy for y = f(a, b), given the arguments' differentials.
    derivative: Callable[..., "Expr"]


#: The operations of one argument by their names (the Rust table ``src/expr/functions.rs`` has a
#: row of each name): unary minus, then every function defined below with :func:`_elementary`.
UNARY: Dict[str, Elementary] = {
    "neg": Elementary(np.negative, None, lambda a, y: Expr.lift(-1.0)),
}
#: The operations of two arguments by their names: the arithmetic, then :func:`atan2`.
BINARY: Dict[str, Elementary] = {
    "add": Elementary(np.add, None, lambda a, b, y, da, db: _add(da, db)),
    "sub": Elementary(np.subtract, None, lambda a, b, y, da, db: _sub(da, db)),
    "mul": Elementary(np.multiply, None, lambda a, b, y, da, db: _add(_mul(da, b), _mul(a, db))),
    "div": Elementary(
        np.divide, None, lambda a, b, y, da, db: _sub(_mul(da, 1.0 / b), _mul(db, a / b**2))
    ),
    "pow": Elementary(
        np.power,
        None,
        lambda a, b, y, da, db: (
            _mul(_mul(b, a ** (b - 1.0)), da)
            if _is_const(db, 0.0)
            else _mul(y, _add(_mul(db, _unary("log", a)), _mul(b, da / a)))
        ),
    ),
}

_F = TypeVar("_F", bound=Callable[..., Any])


def _elementary(
    numpy: Callable[..., Any],
    sympy: Optional[str],
    derivative: Callable[..., "Expr"],
    arguments: int = 1,
) -> Callable[[_F], _F]:
    """Register the decorated function of expressions under its own name, with NumPy's and
    SymPy's counterparts and its derivative rule (see :class:`Elementary`): the one place the
    Python side states an elementary function."""

    def register(f: _F) -> _F:
        name = getattr(f, "__name__")
        (BINARY if arguments == 2 else UNARY)[name] = Elementary(numpy, sympy, derivative)
        _FUNCTIONS.append(name)
        return f

    return register


# The functions of expressions, as the package exports them, in the order defined.
_FUNCTIONS: List[str] = []

# Printing precedence: sums < products < unary minus < powers < atoms.
_PREC = {"add": 1, "sub": 1, "mul": 2, "div": 2, "neg": 3, "pow": 4}


def _is_number(x: object) -> bool:
    return isinstance(x, numbers.Real) and not isinstance(x, Expr)


class Expr:
    """A symbolic expression in the coordinates, their velocities, the time and parameters.

    Build expressions with ``+ - * / **``, unary minus and the functions of this module
    (:func:`sin`, :func:`cos`, …); Python numbers mix freely. Two expressions compare equal
    (``==``) when they have the same structure.

    >>> import lagrangian as lg
    >>> x, = lg.coordinates("x")
    >>> k, = lg.parameters("k")
    >>> 0.5*k*x**2
    0.5*k*x**2
    """

    __slots__ = ("_op", "_args", "_hash")

    _op: str
    _args: Tuple[Any, ...]
    _hash: int

    def __init__(self, op: str, args: Tuple[Any, ...]) -> None:
        if op not in _LEAVES and op not in UNARY and op not in BINARY:
            raise ValueError(f"unknown operation {op!r}")
        self._op = op
        self._args = args
        self._hash = hash((op,) + tuple(hash(a) for a in args))

    # -- construction -------------------------------------------------------------------
    @staticmethod
    def lift(value: ExprLike) -> "Expr":
        """``value`` as an expression: a number becomes a constant.

        Raises ``TypeError`` for anything that is neither an expression nor a real number.
        """
        if isinstance(value, Expr):
            return value
        if _is_number(value):
            x = float(value)
            if not math.isfinite(x):
                raise ValueError(f"the number {x} in an expression is not finite")
            return Expr("const", (x,))
        raise TypeError(
            f"expected an expression or a real number, got {type(value).__name__}: {value!r}"
        )

    def __add__(self, other: ExprLike) -> "Expr":
        return _binary("add", self, other)

    def __radd__(self, other: ExprLike) -> "Expr":
        return _binary("add", other, self)

    def __sub__(self, other: ExprLike) -> "Expr":
        return _binary("sub", self, other)

    def __rsub__(self, other: ExprLike) -> "Expr":
        return _binary("sub", other, self)

    def __mul__(self, other: ExprLike) -> "Expr":
        return _binary("mul", self, other)

    def __rmul__(self, other: ExprLike) -> "Expr":
        return _binary("mul", other, self)

    def __truediv__(self, other: ExprLike) -> "Expr":
        return _binary("div", self, other)

    def __rtruediv__(self, other: ExprLike) -> "Expr":
        return _binary("div", other, self)

    def __pow__(self, other: ExprLike) -> "Expr":
        return _binary("pow", self, other)

    def __rpow__(self, other: ExprLike) -> "Expr":
        return _binary("pow", other, self)

    def __neg__(self) -> "Expr":
        return Expr("neg", (self,))

    def __pos__(self) -> "Expr":
        return self

    def __abs__(self) -> "Expr":
        return Expr("abs", (self,))

    def __array_ufunc__(self, ufunc: Any, method: str, *inputs: Any, **kwargs: Any) -> Any:
        """NumPy's functions on expressions: ``np.cos(x)`` is ``lg.cos(x)``, and a NumPy
        number on the left of an operator (``np.float64(2.0) * x``) is a number. ``==`` and
        ``!=`` with a NumPy number compare as with a Python number (an expression is never
        equal to a number). A ufunc with no expression counterpart, a ufunc method
        (``reduce``, …), ``out=`` or an array operand is a ``TypeError`` that says what to
        use."""
        name = getattr(ufunc, "__name__", repr(ufunc))
        if name in ("equal", "not_equal") and method == "__call__" and len(inputs) == 2:
            a, b = inputs
            same = isinstance(a, Expr) and isinstance(b, Expr) and a.__eq__(b) is True
            return same if name == "equal" else not same
        build = _UFUNCS.get(name)
        if build is None:
            raise TypeError(
                f"numpy.{name} is not defined for expressions: use + - * / ** and the "
                f"functions of lagrangian ({', '.join('lg.' + f for f in _FUNCTIONS)})"
            )
        if method != "__call__":
            raise TypeError(f"numpy.{name}.{method} is not defined for expressions: call "
                            f"numpy.{name} itself, on expressions and numbers")
        if kwargs:
            raise TypeError(f"numpy.{name} with {'=, '.join(kwargs)}= is not defined for "
                            "expressions: give only the operands")
        return build(*(_ufunc_operand(name, x) for x in inputs))

    # -- structure ----------------------------------------------------------------------
    @property
    def op(self) -> str:
        """The operation: ``"const"``, ``"param"``, ``"t"``, ``"q"``, ``"qd"``, ``"add"``, ``"sin"``, …"""
        return self._op

    @property
    def args(self) -> Tuple[Any, ...]:
        """The operands (expressions), or the number or name of a leaf."""
        return self._args

    def free_symbols(self) -> List["Expr"]:
        """The leaves that are not numbers — coordinates, velocities, time, parameters — each
        once, in the order first met."""
        seen: Dict[Expr, None] = {}
        for node in _postorder([self]):
            if node._op in ("param", "t", "q", "qd"):
                seen.setdefault(node, None)
        return list(seen)

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other: object) -> bool:
        if self is other:
            return True
        if not isinstance(other, Expr):
            return NotImplemented
        # Pairs already compared are skipped: distinct copies of a shared subtree (a derivative
        # taken twice) would otherwise be walked once per path to them, exponential in depth.
        stack = [(self, other)]
        compared: "set[Tuple[int, int]]" = set()
        while stack:
            a, b = stack.pop()
            if a is b or (id(a), id(b)) in compared:
                continue
            compared.add((id(a), id(b)))
            if a._hash != b._hash or a._op != b._op or len(a._args) != len(b._args):
                return False
            for x, y in zip(a._args, b._args):
                if isinstance(x, Expr):
                    if not isinstance(y, Expr):
                        return False
                    stack.append((x, y))
                elif isinstance(y, Expr) or x != y:
                    return False
        return True

    def __ne__(self, other: object) -> bool:
        eq = self.__eq__(other)
        return eq if eq is NotImplemented else not eq

    def __bool__(self) -> bool:
        raise TypeError(
            "the truth value of an expression is undefined; compare numbers, not expressions"
        )

    def __reduce__(self) -> Tuple[Any, ...]:
        nodes, roots = serialize([self])
        return (_rebuild_one, (nodes, roots[0]))

    # -- printing -----------------------------------------------------------------------
    def __repr__(self) -> str:
        return _format(self)

    __str__ = __repr__


class Coordinate(Expr):
    """A generalized coordinate q; its velocity q̇ is :attr:`d`.

    >>> import lagrangian as lg
    >>> th, = lg.coordinates("th")
    >>> th.d
    th.d
    """

    __slots__ = ()

    def __init__(self, name: str) -> None:
        super().__init__("q", (_check_name(name),))

    @property
    def name(self) -> str:
        """The coordinate's name."""
        return str(self._args[0])

    @property
    def d(self) -> Expr:
        """The velocity q̇ of this coordinate."""
        return Expr("qd", self._args)

    def __reduce__(self) -> Tuple[Any, ...]:
        return (Coordinate, (self.name,))


class Parameter(Expr):
    """A named parameter; its value is given to :class:`~lagrangian.Model`."""

    __slots__ = ()

    def __init__(self, name: str) -> None:
        super().__init__("param", (_check_name(name),))

    @property
    def name(self) -> str:
        """The parameter's name."""
        return str(self._args[0])

    def __reduce__(self) -> Tuple[Any, ...]:
        return (Parameter, (self.name,))


def _check_name(name: object) -> str:
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"a symbol name must be a Python identifier, got {name!r}")
    return name


def _split(names: str) -> List[str]:
    if not isinstance(names, str):
        raise TypeError(f"names must be a string such as \"x y\", got {type(names).__name__}")
    parts = [p for p in names.replace(",", " ").split() if p]
    if not parts:
        raise ValueError("no names given")
    if len(set(parts)) != len(parts):
        raise ValueError(f"repeated names in {names!r}")
    return parts


def coordinates(names: str) -> Tuple[Coordinate, ...]:
    """Generalized coordinates from a string of names separated by spaces or commas.

    Always returns a tuple: ``x, = lg.coordinates("x")`` for one.

    >>> import lagrangian as lg
    >>> th1, th2 = lg.coordinates("th1 th2")
    >>> th1.d
    th1.d
    """
    return tuple(Coordinate(n) for n in _split(names))


def parameters(names: str) -> Tuple[Parameter, ...]:
    """Named parameters from a string of names; their values are given to ``Model``.

    >>> import lagrangian as lg
    >>> m, g = lg.parameters("m g")
    """
    return tuple(Parameter(n) for n in _split(names))


#: The time t.
t: Expr = Expr("t", ())


def _binary(op: str, a: ExprLike, b: ExprLike) -> Expr:
    return Expr(op, (Expr.lift(a), Expr.lift(b)))


def _unary(op: str, a: ExprLike) -> Expr:
    return Expr(op, (Expr.lift(a),))


@_elementary(np.sin, "sin", lambda a, y: _unary("cos", a))
def sin(x: ExprLike) -> Expr:
    """sin x."""
    return _unary("sin", x)


@_elementary(np.cos, "cos", lambda a, y: -_unary("sin", a))
def cos(x: ExprLike) -> Expr:
    """cos x."""
    return _unary("cos", x)


@_elementary(np.tan, "tan", lambda a, y: 1.0 + y**2)
def tan(x: ExprLike) -> Expr:
    """tan x."""
    return _unary("tan", x)


@_elementary(np.exp, "exp", lambda a, y: y)
def exp(x: ExprLike) -> Expr:
    """eˣ."""
    return _unary("exp", x)


@_elementary(np.log, "log", lambda a, y: 1.0 / a)
def log(x: ExprLike) -> Expr:
    """The natural logarithm ln x."""
    return _unary("log", x)


@_elementary(np.sqrt, None, lambda a, y: 0.5 / y)
def sqrt(x: ExprLike) -> Expr:
    """√x."""
    return _unary("sqrt", x)


@_elementary(np.sinh, "sinh", lambda a, y: _unary("cosh", a))
def sinh(x: ExprLike) -> Expr:
    """sinh x."""
    return _unary("sinh", x)


@_elementary(np.cosh, "cosh", lambda a, y: _unary("sinh", a))
def cosh(x: ExprLike) -> Expr:
    """cosh x."""
    return _unary("cosh", x)


@_elementary(np.tanh, "tanh", lambda a, y: 1.0 - y**2)
def tanh(x: ExprLike) -> Expr:
    """tanh x."""
    return _unary("tanh", x)


@_elementary(
    np.arctan2,
    "atan2",
    lambda a, b, y, da, db: _sub(_mul(da, b), _mul(db, a)) / (a**2 + b**2),
    arguments=2,
)
def atan2(y: ExprLike, x: ExprLike) -> Expr:
    """atan2(y, x): the angle of the point (x, y), in (−π, π]."""
    return _binary("atan2", y, x)


@_elementary(np.abs, "Abs", lambda a, y: a / y)
def abs(x: ExprLike) -> Expr:  # noqa: A001 - mirrors math.fabs / builtins.abs for expressions
    """|x| (``builtins.abs`` works on expressions too)."""
    return _unary("abs", x)


def _ufunc_operand(name: str, x: object) -> ExprLike:
    """An operand of a NumPy ufunc on expressions: an expression, or a real number (a NumPy
    scalar or 0-d array is one)."""
    if isinstance(x, Expr):
        return x
    if isinstance(x, np.ndarray) and x.ndim == 0:
        x = x[()]
    if _is_number(x):
        return float(x)  # type: ignore[arg-type]
    raise TypeError(
        f"numpy.{name} of an expression and {type(x).__name__} {x!r}: expressions combine "
        "with real numbers only (build one expression per element for an array)"
    )


# NumPy's ufuncs that have an expression counterpart, by name: every operation of the tables
# under its NumPy function's name (``absolute`` for ``abs``, …), and a few more.
_UFUNCS: Dict[str, Callable[..., Expr]] = {
    **{
        e.numpy.__name__: (lambda *a, _op=op: Expr(_op, tuple(Expr.lift(x) for x in a)))
        for table in (UNARY, BINARY)
        for op, e in table.items()
    },
    "divide": lambda a, b: _binary("div", a, b),
    "true_divide": lambda a, b: _binary("div", a, b),
    "float_power": lambda a, b: _binary("pow", a, b),
    "positive": Expr.lift,
    "fabs": abs,
    "square": lambda a: _binary("pow", a, 2),
    "reciprocal": lambda a: _binary("div", 1.0, a),
}

#: NumPy's function of each operation of one argument, by name (drawing evaluates expressions
#: over many states with them).
NUMPY_UNARY: Dict[str, Callable[[Any], Any]] = {op: e.numpy for op, e in UNARY.items()}
#: NumPy's function of each operation of two arguments, by name.
NUMPY_BINARY: Dict[str, Callable[[Any, Any], Any]] = {op: e.numpy for op, e in BINARY.items()}


# -- traversal and serialization ------------------------------------------------------------

Node = Tuple[str, Any, int, int]


def _postorder(roots: Iterable[Expr]) -> List[Expr]:
    """Every distinct node below ``roots``, children before parents, without recursion."""
    order: List[Expr] = []
    seen: Dict[Expr, None] = {}
    for root in roots:
        stack: List[Tuple[Expr, bool]] = [(root, False)]
        while stack:
            node, expanded = stack.pop()
            if node in seen:
                continue
            if expanded or node._op in _LEAVES:
                seen[node] = None
                order.append(node)
                continue
            stack.append((node, True))
            for child in reversed(node._args):
                if child not in seen:
                    stack.append((child, False))
    return order


def serialize(roots: Sequence[Expr]) -> Tuple[List[Node], List[int]]:
    """A flat node list ``(op, payload, i, j)`` (children before parents, equal subtrees once)
    and the index of each root. Leaves carry their number or name as payload."""
    index: Dict[Expr, int] = {}
    nodes: List[Node] = []
    for node in _postorder(roots):
        op, args = node._op, node._args
        if op in _LEAVES:
            payload = args[0] if args else None
            nodes.append((op, payload, -1, -1))
        elif op in UNARY:
            nodes.append((op, None, index[args[0]], -1))
        else:
            nodes.append((op, None, index[args[0]], index[args[1]]))
        index[node] = len(nodes) - 1
    return nodes, [index[r] for r in roots]


def deserialize(nodes: Sequence[Node], roots: Sequence[int]) -> List[Expr]:
    """The inverse of :func:`serialize`."""
    built: List[Expr] = []
    for op, payload, i, j in nodes:
        if op == "q":
            built.append(Coordinate(payload))
        elif op == "param":
            built.append(Parameter(payload))
        elif op == "qd":
            built.append(Expr("qd", (payload,)))
        elif op == "t":
            built.append(t)
        elif op == "const":
            built.append(Expr("const", (float(payload),)))
        elif op in UNARY:
            built.append(Expr(op, (built[i],)))
        else:
            built.append(Expr(op, (built[i], built[j])))
    return [built[r] for r in roots]


def to_raw(
    nodes: Sequence[Node], coordinates: Sequence[Coordinate], params: Sequence[str]
) -> List[Tuple[str, float, int, int]]:
    """Nodes with symbol names replaced by indices, as the Rust side reads them: the one map of
    symbol names to indices, for a model's energies and an event's condition alike."""
    qi = {c.name: i for i, c in enumerate(coordinates)}
    pi = {name: i for i, name in enumerate(params)}
    raw: List[Tuple[str, float, int, int]] = []
    for op, payload, i, j in nodes:
        if op == "const":
            raw.append((op, float(payload), -1, -1))
        elif op in ("q", "qd"):
            raw.append((op, 0.0, qi[payload], -1))
        elif op == "param":
            raw.append((op, 0.0, pi[payload], -1))
        else:
            raw.append((op, 0.0, i, j))
    return raw


def _rebuild_one(nodes: Sequence[Node], root: int) -> Expr:
    return deserialize(nodes, [root])[0]


def _number(x: float) -> str:
    if x.is_integer() and builtins.abs(x) < 1e15:
        return str(int(x))
    return repr(x)


def _prec(e: Expr) -> int:
    if e._op == "const" and e._args[0] < 0:
        return 3
    return _PREC.get(e._op, 5)


def _format(root: Expr) -> str:
    text: Dict[Expr, str] = {}
    for e in _postorder([root]):
        op, args = e._op, e._args
        if op == "const":
            s = _number(args[0])
        elif op in ("param", "q"):
            s = args[0]
        elif op == "qd":
            s = f"{args[0]}.d"
        elif op == "t":
            s = "t"
        elif op == "neg":
            a = args[0]
            s = "-" + (f"({text[a]})" if _prec(a) <= 2 else text[a])
        elif op in UNARY:
            s = f"{op}({text[args[0]]})"
        elif op == "atan2":
            s = f"atan2({text[args[0]]}, {text[args[1]]})"
        else:
            a, b = args
            p = _PREC[op]
            left = text[a] if _prec(a) > p or (_prec(a) == p and op != "pow") else f"({text[a]})"
            if op == "pow":
                right = text[b] if _prec(b) == 5 else f"({text[b]})"
                s = f"{left}**{right}"
            else:
                tight = op in ("sub", "div")
                ok = _prec(b) > p or (_prec(b) == p and not tight)
                right = text[b] if ok else f"({text[b]})"
                sym = {"add": " + ", "sub": " - ", "mul": "*", "div": "/"}[op]
                s = f"{left}{sym}{right}"
        text[e] = s
    return text[root]



def evaluate(
    exprs: Sequence["Expr"],
    coordinates: Sequence[str],
    parameters: Mapping[str, float],
    t: Any,
    q: Any,
    what: str = "an expression",
    qd: Any = None,
) -> Any:
    """The expressions (of t, the coordinates and parameters — and the velocities, given ``qd``)
    at n states, in NumPy: an array of shape (len(exprs), n) from ``t`` (n,), ``q`` and ``qd``
    (n, len(coordinates)). For drawings, checks and outputs only; the dynamics never runs here.
    ``what`` names the expressions in errors."""
    return evaluate_program(serialize(list(exprs)), coordinates, parameters, t, q, what, qd)


def evaluate_program(
    program: Tuple[List[Node], List[int]],
    coordinates: Sequence[str],
    parameters: Mapping[str, float],
    t: Any,
    q: Any,
    what: str = "an expression",
    qd: Any = None,
) -> Any:
    """:func:`evaluate` of expressions already flattened by :func:`serialize` (kept by a caller
    that evaluates the same expressions again and again)."""
    nodes, roots = program
    index = {name: i for i, name in enumerate(coordinates)}
    values: List[Any] = []
    with np.errstate(all="ignore"):
        for op, payload, i, j in nodes:
            if op == "const":
                values.append(float(payload))
            elif op == "t":
                values.append(t)
            elif op == "q":
                if payload not in index:
                    raise ValueError(f"{what} reads {payload}, which is not a coordinate")
                values.append(q[:, index[payload]])
            elif op == "param":
                if payload not in parameters:
                    raise ValueError(f"{what} reads the parameter {payload!r}, which has no value")
                values.append(float(parameters[payload]))
            elif op == "qd":
                if qd is None:
                    raise ValueError(f"{what} cannot depend on the velocity {payload}.d")
                if payload not in index:
                    raise ValueError(f"{what} reads {payload}.d, which is not a velocity")
                values.append(qd[:, index[payload]])
            elif op in UNARY:
                values.append(NUMPY_UNARY[op](values[i]))
            else:
                values.append(NUMPY_BINARY[op](values[i], values[j]))
    out = np.empty((len(roots), np.shape(t)[0]))
    for k, r in enumerate(roots):
        out[k] = values[r]
    return out


# -- exact differentiation ---------------------------------------------------------------------
def _is_const(e: ExprLike, value: float) -> bool:
    if not isinstance(e, Expr):
        return float(e) == value
    return e.op == "const" and e.args[0] == value


def _add(a: ExprLike, b: ExprLike) -> Expr:
    """a + b, with a zero folded away (the derivatives' graphs stay small)."""
    a, b = Expr.lift(a), Expr.lift(b)
    if _is_const(a, 0.0):
        return b
    if _is_const(b, 0.0):
        return a
    return a + b


def _sub(a: ExprLike, b: ExprLike) -> Expr:
    """a − b, with a zero folded away."""
    a, b = Expr.lift(a), Expr.lift(b)
    if _is_const(b, 0.0):
        return a
    if _is_const(a, 0.0):
        return -b
    return a - b


def _mul(a: ExprLike, b: ExprLike) -> Expr:
    """a b, with zeros and ones folded away."""
    a, b = Expr.lift(a), Expr.lift(b)
    if _is_const(a, 0.0) or _is_const(b, 0.0):
        return Expr.lift(0.0)
    if _is_const(a, 1.0):
        return b
    if _is_const(b, 1.0):
        return a
    return a * b


def derivative(e: ExprLike, s: Expr) -> Expr:
    """∂e/∂s, exact, for ``s`` a coordinate, a velocity ``q.d`` or the time ``lg.t`` (every other
    symbol is held fixed), by each operation's rule in :data:`UNARY` / :data:`BINARY`. Each node
    is differentiated once (the graph's shared subtrees stay shared); zeros and ones are
    folded."""
    if s.op not in _LEAVES[2:]:
        raise ValueError(f"derivative with respect to {s!r}: give a coordinate, a velocity or t")
    return tangent(e, {s: Expr.lift(1.0)})


def tangent(e: ExprLike, seeds: Mapping[Expr, Expr]) -> Expr:
    """The forward-mode derivative Σ ∂e/∂s · seeds[s] over the symbols ``s`` of ``seeds`` (every
    other symbol held fixed), in one sweep over ``e``'s graph."""
    e = Expr.lift(e)
    zero = Expr.lift(0.0)
    d: Dict[Expr, Expr] = {}
    for node in _postorder([e]):
        args = node.args
        if node.op in _LEAVES:
            d[node] = seeds.get(node, zero)
        elif node.op in UNARY:
            da = d[args[0]]
            d[node] = zero if _is_const(da, 0.0) else _mul(
                UNARY[node.op].derivative(args[0], node), da
            )
        else:  # BINARY: Expr accepts no other operation
            a, b = args
            da, db = d[a], d[b]
            both_zero = _is_const(da, 0.0) and _is_const(db, 0.0)
            d[node] = zero if both_zero else BINARY[node.op].derivative(a, b, node, da, db)
    return d[e]


def time_derivative(e: ExprLike, coordinates: Optional[Sequence[Coordinate]] = None) -> Expr:
    """The total time derivative Σ ∂e/∂qᵢ q̇ᵢ + ∂e/∂t of ``e`` (an expression of t and q), over
    ``coordinates`` (default: every coordinate ``e`` reads), in one sweep."""
    e = Expr.lift(e)
    if coordinates is None:
        coordinates = [Coordinate(s.args[0]) for s in e.free_symbols() if s.op == "q"]
    seeds: Dict[Expr, Expr] = {t: Expr.lift(1.0)}
    for q in coordinates:
        seeds[q] = q.d
    return tangent(e, seeds)
