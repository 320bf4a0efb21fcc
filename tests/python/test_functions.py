"""One elementary function, one place: every row of the Rust table (src/expr/functions.rs) has its
Python symbol, NumPy function and SymPy mapping, each agreeing with the compiled value, and a
function is named in at most three source files."""

import math
import pathlib
import re

import numpy as np
import pytest

import lagrangian as lg
from lagrangian import _expr

ROOT = pathlib.Path(__file__).resolve().parents[2]
TABLE = ROOT / "src" / "expr" / "functions.rs"


def rust_names():
    """The `name` of every row of the Rust table that has one."""
    rows = re.findall(r'^\s+name: (?:"(\w+)")?,$', TABLE.read_text(encoding="utf-8"), re.M)
    assert len(rows) >= 12, rows
    return [name for name in rows if name]


def test_every_rust_function_has_its_python_numpy_and_sympy_entries():
    names = rust_names()
    assert set(names) == set(_expr.UNARY), (names, list(_expr.UNARY))
    assert set(_expr.NUMPY_UNARY) == set(names)
    for name in names:
        if name == "neg":
            continue  # unary minus: the operator, -x
        f = getattr(lg, name)
        assert callable(f) and f.__doc__ and f.__doc__.strip(), name
        assert f(lg.t).op == name
    # SymPy's function of each name exists (sqrt and unary minus are a power and a product there).
    sp = pytest.importorskip("sympy")
    for name, e in {**_expr.UNARY, **_expr.BINARY}.items():
        if e.sympy is not None:
            assert isinstance(getattr(sp, e.sympy), type), (name, e.sympy)
    assert {n for n, e in _expr.UNARY.items() if e.sympy is None} == {"neg", "sqrt"}


@pytest.mark.parametrize("name", [n for n in _expr.UNARY if n != "neg"])
def test_each_function_compiles_to_numpys_value_and_through_sympy(name):
    """U = f(q) + 0·q̇² through the compiled model: its energy at q̇ = 0 is NumPy's f(q), from the
    Python symbol and from SymPy's function alike (one libm call apart at most)."""
    q, = lg.coordinates("q")
    f = getattr(lg, name)
    ours = lg.Model(coordinates=[q], kinetic=0.5 * q.d**2, potential=f(q))
    sp = pytest.importorskip("sympy")
    x = sp.Symbol("x")
    e = _expr.UNARY[name]
    sym = sp.sqrt(x) if name == "sqrt" else getattr(sp, e.sympy)(x)
    theirs = lg.from_sympy(sp.Rational(1, 2) * sp.Symbol("v") ** 2, sym, coordinates=[x],
                           velocities=[sp.Symbol("v")])
    for x0 in (0.37, 1.9):
        want = float(_expr.NUMPY_UNARY[name](x0))
        for model in (ours, theirs):
            got = model.energy(0.0, [x0], [0.0])
            assert math.isclose(got, want, rel_tol=4e-16, abs_tol=0.0), (name, x0, got, want)
    # np.<ufunc> on an expression is the function itself.
    assert _expr.NUMPY_UNARY[name](q) == f(q)


def test_numpy_binary_table_matches_the_operators():
    a, b = 0.7, -1.3  # xʸ of a positive x
    x, y = lg.coordinates("x y")
    for op, np_f in _expr.NUMPY_BINARY.items():
        e = _expr.Expr(op, (x, y))
        model = lg.Model(coordinates=[x, y], kinetic=0.5 * (x.d**2 + y.d**2), potential=e)
        want = float(np_f(a, b))
        assert math.isclose(model.energy(0.0, [a, b], [0.0, 0.0]), want, rel_tol=4e-16), op


def test_an_elementary_function_is_named_in_at_most_three_source_files():
    """`tanh` (any case, in any identifier, but not inside another function's name such as
    atanh): the Rust table's row, its Python symbol and — until the drawing code reads
    `_expr.NUMPY_UNARY` — the drawing's NumPy map."""
    pattern = re.compile(r"(?<![a-z])tanh", re.I)
    found = sorted(
        str(p.relative_to(ROOT))
        for top in ("src", "python")
        for p in (ROOT / top).rglob("*")
        if p.suffix in (".rs", ".py", ".pyi")
        and pattern.search(p.read_text(encoding="utf-8", errors="replace"))
    )
    assert "src/expr/functions.rs" in found and "python/lagrangian/_expr.py" in found, found
    assert len(found) <= 3, found
