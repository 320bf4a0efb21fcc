"""Property-based tests (hypothesis) of the expression language and `simulate`: random
expressions over every function of the language (and NumPy's ufuncs on them), random states with
extreme and non-finite values, every method of :func:`lagrangian.methods`.

The invariant, whatever the input: a finite result or a typed error (``ValueError`` for bad
input, a subclass of ``LagrangianError`` for a failure of the mathematics) — never a NaN or an
infinity handed back, never another exception, never a hang — and the model still gives the
same answers afterwards.

Bounded in time: a fixed seed (``derandomize``), few examples, short spans and small step
budgets, so that the whole file runs in seconds and the same examples run every time.
"""

from __future__ import annotations

import math
import operator
from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import lagrangian as lg  # noqa: E402

TYPED = (ValueError, lg.LagrangianError)

X, Y = lg.coordinates("x y")
K, = lg.parameters("k")

# Every function of the language, and NumPy's ufuncs that dispatch to them.
UNARY: List[Callable[[Any], Any]] = [
    lg.sin, lg.cos, lg.tan, lg.exp, lg.log, lg.sqrt, lg.sinh, lg.cosh, lg.tanh, lg.abs,
    operator.neg, np.cos, np.exp, np.sqrt, np.abs,
]
BINARY: List[Callable[[Any, Any], Any]] = [
    operator.add, operator.sub, operator.mul, operator.truediv, operator.pow, lg.atan2,
    np.arctan2,
]

# Numbers that expressions contain: ordinary ones, and the edges of the doubles.
NUMBERS = st.one_of(
    st.floats(-4.0, 4.0, allow_nan=False, allow_infinity=False),
    st.sampled_from([0.0, -0.0, 1.0, 2.0, 3.0, 0.5, 1e-300, 1e300, -1e300]),
)

# State values: mostly ordinary, else extreme but finite, or not finite.
ORDINARY = st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False)
VALUES = st.one_of(
    ORDINARY, ORDINARY, ORDINARY,
    st.sampled_from([0.0, 1e-300, 1e155, -1e155, 1e200, -1e300, 1.7e308,
                     math.nan, math.inf, -math.inf]),
)
SETTINGS = settings(max_examples=300, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _unary(f: Callable[[Any], Any], a: Any) -> Any:
    return f(lg.Expr.lift(a))


def _binary(f: Callable[[Any, Any], Any], a: Any, b: Any) -> Any:
    # Lifting the left operand keeps Python's own float arithmetic (which raises on overflow)
    # out of the way: the expression is what is tested.
    return f(lg.Expr.lift(a), b)


def expressions(leaves: List[lg.Expr]) -> Any:
    """Random expressions over ``leaves`` and numbers, through every function."""
    base = st.one_of(st.sampled_from(leaves), NUMBERS)

    def extend(children: Any) -> Any:
        return st.one_of(
            st.builds(_unary, st.sampled_from(UNARY), children),
            st.builds(_binary, st.sampled_from(BINARY), children, children),
        )

    return st.recursive(base, extend, max_leaves=6).map(lg.Expr.lift)


POSITION = expressions([X, Y, lg.t, K])
ANY = expressions([X, Y, X.d, Y.d, lg.t, K])


@st.composite
def models(draw: Any) -> Tuple[Dict[str, Any], Optional[lg.Model]]:
    """Arguments of a random two-coordinate model, and the model (``None`` when building it
    raised a typed error: that is a valid outcome too)."""
    kinetic = draw(st.sampled_from(["unit", "position", "random"]))
    if kinetic == "unit":
        t_expr = 0.5 * (X.d**2 + Y.d**2)
    elif kinetic == "position":
        t_expr = 0.5 * (1 + draw(POSITION) ** 2) * X.d**2 + 0.5 * Y.d**2
    else:
        t_expr = 0.5 * (X.d**2 + Y.d**2) + 0.1 * draw(ANY) * X.d * Y.d
    args: Dict[str, Any] = dict(coordinates=[X, Y], kinetic=t_expr, potential=draw(POSITION),
                                backend=draw(st.sampled_from(["native", "interpreter"])))
    if draw(st.booleans()):
        args["forces"] = [draw(ANY), draw(ANY)]
    if draw(st.booleans()):
        args["dissipation"] = 0.5 * draw(ANY) ** 2 * X.d**2
    parts = [t_expr, args["potential"], args.get("dissipation", 0.0), *args.get("forces", [])]
    if any(K in lg.Expr.lift(e).free_symbols() for e in parts):
        args["parameters"] = {"k": draw(VALUES)}
    try:
        return args, lg.Model(**args)
    except TYPED:
        return args, None


def _outcome(f: Callable[[], Any]) -> Tuple[str, Any]:
    """("value", v) with every number of v finite, or ("error", its class): the invariant. Any
    other exception propagates and fails the test."""
    try:
        value = f()
    except TYPED as e:
        assert str(e), type(e)
        return "error", type(e)
    arrays = value if isinstance(value, tuple) else (value,)
    for a in arrays:
        if a is not None:
            assert np.all(np.isfinite(np.asarray(a, dtype=np.float64))), value
    return "value", value


def _probe(model: lg.Model) -> Tuple[str, Any]:
    """A benign evaluation whose answer must not change after hostile ones."""
    def all_of() -> Any:
        q, qd = [0.1, -0.2], [0.3, 0.05]
        return (model.energy(0.0, q, qd), model.accelerations(0.0, q, qd))
    kind, value = _outcome(all_of)
    if kind == "value":
        return kind, (float(value[0]), tuple(value[1].tolist()))
    return kind, value


@SETTINGS
@given(models(), st.lists(VALUES, min_size=5, max_size=5))
def test_evaluations_are_finite_or_typed_errors(built: Any, values: List[float]) -> None:
    _, model = built
    if model is None:
        return
    before = _probe(model)
    t, q, qd = values[0], values[1:3], values[3:5]
    for name in ("energy", "momenta", "lagrangian", "mass_matrix", "accelerations"):
        evaluate = getattr(model, name)
        _outcome(lambda: evaluate(t, q, qd))
        _outcome(lambda: evaluate(t, [q, [0.1, 0.2]], [qd, [0.0, 0.0]]))
    _outcome(lambda: model.rhs(t, q + qd))
    _outcome(lambda: model.jacobian(t, q + qd))

    def linearization() -> Tuple[Any, ...]:
        lin = model.linearize(q, qd, t=t)
        return (lin.M, lin.C, lin.K, lin.A, lin.accelerations, lin.eigenvalues.real,
                lin.eigenvalues.imag)

    _outcome(linearization)
    assert _probe(model) == before


METHODS = lg.methods()


@SETTINGS
@given(models(), st.sampled_from(METHODS), st.lists(VALUES, min_size=4, max_size=4),
       st.sampled_from([0.05, 0.3]), st.sampled_from([None, 0.01, 0.07]),
       st.sampled_from([1e-3, 1e-7]))
def test_simulate_is_finite_or_a_typed_error(built: Any, method: str, values: List[float],
                                             t_end: float, dt: Optional[float],
                                             tol: float) -> None:
    _, model = built
    if model is None:
        return
    before = _probe(model)
    q0, qd0 = values[:2], values[2:]

    def run() -> Tuple[Any, ...]:
        sol = model.simulate(q0, qd0, t_end, method=method, dt=dt, rtol=tol, atol=tol,
                             max_steps=400)
        assert sol.t[0] == 0.0 and sol.t[-1] == t_end
        return (sol.t, sol.q, sol.qd, sol.energy)

    _outcome(run)
    assert _probe(model) == before


@SETTINGS
@given(models(), st.sampled_from(METHODS), st.sampled_from([0.01, 0.05]))
def test_failures_keep_a_finite_partial_solution(built: Any, method: str, dt: float) -> None:
    # From an ordinary state: whatever stops the run, what it computed up to then is finite.
    _, model = built
    if model is None:
        return
    try:
        sol = model.simulate([0.3, -0.2], [0.1, 0.4], 0.5, method=method, dt=dt, max_steps=60)
    except ValueError:
        return
    except lg.LagrangianError as e:
        if e.solution is not None:
            assert np.all(np.isfinite(e.solution.q)) and np.all(np.isfinite(e.solution.qd))
            assert np.all(np.isfinite(e.solution.t))
            assert e.t == e.solution.t[-1] and np.all(np.isfinite(e.q))
        return
    assert np.all(np.isfinite(sol.q)) and np.all(np.isfinite(sol.energy))


@SETTINGS
@given(ANY)
def test_expressions_print_pickle_and_compare(e: lg.Expr) -> None:
    import pickle

    assert isinstance(e, lg.Expr)
    assert pickle.loads(pickle.dumps(e)) == e
    assert isinstance(repr(e), str) and repr(e)
    assert e == e and hash(e) == hash(pickle.loads(pickle.dumps(e)))
