"""Compiled models against the interpreter and against the Rust scenes' closed forms (issue 12,
"Correctness").

A model stated in Python runs its derived equations of motion as machine code
(``backend="native"``) or through the tape interpreter (``backend="interpreter"``, the
reference). A property test (hypothesis, derandomized) builds models from random expressions
over every function of the DSL and checks that both backends give the same numbers — q̈ to
1e-13 relative, the rest bit for bit — and, where the mathematics fails (log or sqrt of a
negative number, division by zero, overflow, a singular mass matrix), the same typed exception,
never a NaN or an infinity. The
scenes of the catalog, stated again here by their energies, agree with the hand-written Rust
scenes to 1e-13 relative.
"""

import math
import operator
import pickle
from typing import Any, Callable, Dict, List, Tuple

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lagrangian as lg
from lagrangian import _expr

BACKENDS = ("native", "interpreter")

# -- the functions of the DSL ----------------------------------------------------------------

# Every function of one and of two arguments the DSL has (`_expr.UNARY`, `_expr.BINARY`: each
# row of the Rust table of functions), so that a function added there is in the property test.
UNARY: Dict[str, Callable[[Any], Any]] = {
    name: operator.neg if name == "neg" else getattr(lg, name) for name in _expr.UNARY
}
BINARY: Dict[str, Callable[[Any, Any], Any]] = {
    "add": operator.add,
    "sub": operator.sub,
    "mul": operator.mul,
    "div": operator.truediv,
    "pow": operator.pow,
    **{name: getattr(lg, name) for name in _expr.BINARY if name not in ("add", "sub", "mul", "div", "pow")},
}
# Literal exponents: integral ones become integer powers, ½ a square root, the rest `pow`.
EXPONENTS = (-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0, 5.0, 0.5, 1.5, -0.5)


def test_the_generator_covers_every_function_of_the_dsl():
    # Each builds its own operation (the generator reads the names from the DSL's tables).
    x, y = lg.coordinates("x y")
    assert set(UNARY) == set(_expr.UNARY) and len(UNARY) >= 11
    assert set(BINARY) == set(_expr.BINARY) and len(BINARY) >= 6
    for name, f in UNARY.items():
        assert f(x) == _expr.Expr(name, (x,)), name
    for name, g in BINARY.items():
        assert g(x, y) == _expr.Expr(name, (x, y)), name


# -- comparing two backends -----------------------------------------------------------------

Outcome = Tuple[str, Any]


def outcome(f: Callable[[], Any]) -> Outcome:
    """``("ok", value)`` or ``("error", (class, message))``; a returned value must be finite."""
    try:
        value = f()
    except (ValueError, lg.LagrangianError) as e:
        return "error", (type(e), str(e))
    arr = np.asarray(value, dtype=np.float64)
    assert np.all(np.isfinite(arr)), f"a non-finite result was returned: {value!r}"
    return "ok", arr


# What the machine code computes differently: q̈ comes from M and f with the LDLᵀ solve
# unrolled into the compiled program, the interpreter factors M apart, so the two round
# differently (measured: at most 2.4e-16 of the largest entry). Everything else runs the same
# program the same way: equal bits.
SOLVED = ("accelerations", "rhs", "rhs (batch)")


def same(a: Outcome, b: Outcome, what: str) -> None:
    assert a[0] == b[0], f"{what}: {a} against {b}"
    if a[0] == "error":
        assert a[1] == b[1], f"{what}: {a[1]} against {b[1]}"
    elif what.split(" at ")[0] in SOLVED:
        scale = float(np.max(np.abs(b[1])))
        assert np.all(np.abs(a[1] - b[1]) <= 1e-13 * scale), f"{what}: {a[1]} against {b[1]}"
    else:
        np.testing.assert_array_equal(a[1], b[1], err_msg=what)


def evaluations(model: lg.Model, t: float, q: List[float], qd: List[float]) -> Dict[str, Outcome]:
    """Everything the API evaluates at one state."""
    y = np.array(q + qd)
    batch = np.stack([y, y[::-1]], axis=1)
    return {
        "accelerations": outcome(lambda: model.accelerations(t, q, qd)),
        "mass_matrix": outcome(lambda: model.mass_matrix(t, q, qd)),
        "energy": outcome(lambda: model.energy(t, q, qd)),
        "momenta": outcome(lambda: model.momenta(t, q, qd)),
        "lagrangian": outcome(lambda: model.lagrangian(t, q, qd)),
        "rhs": outcome(lambda: model.rhs(t, y)),
        "rhs (batch)": outcome(lambda: model.rhs(t, batch)),
        "jacobian": outcome(lambda: model.jacobian(t, y)),
    }


def build(backend: str, **kwargs: Any) -> Outcome:
    try:
        return "ok", lg.Model(backend=backend, **kwargs)
    except (ValueError, lg.LagrangianError) as e:
        return "error", (type(e), str(e))


def compare_backends(kwargs: Dict[str, Any], states: List[Tuple[float, List[float], List[float]]]) -> int:
    """Build the model with both backends and compare them at every state; returns how many
    evaluations succeeded."""
    native, interp = (build(b, **kwargs) for b in BACKENDS)
    assert native[0] == interp[0], f"build: {native} against {interp}"
    if native[0] == "error":
        assert native[1] == interp[1]
        return 0
    native_model, interp_model = native[1], interp[1]
    assert native_model.structure["backend"] == "native"
    assert interp_model.structure["backend"] == "interpreter"
    finite = 0
    for t, q, qd in states:
        a = evaluations(native_model, t, q, qd)
        b = evaluations(interp_model, t, q, qd)
        for what in a:
            same(a[what], b[what], f"{what} at t={t}, q={q}, qd={qd}")
            finite += a[what][0] == "ok"
    return finite


# -- random models ---------------------------------------------------------------------------

NUMBERS = st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False)
# Values where functions leave their domain or overflow: 0 (log, division, 0**-1), negative
# numbers (log, sqrt, non-integral powers), large ones (exp, sinh, cosh overflow).
SPECIAL = st.sampled_from([0.0, -1.0, 1.0, 0.5 * math.pi, 40.0, 800.0, -800.0])
VALUES = st.one_of(NUMBERS, NUMBERS, NUMBERS, SPECIAL)


@st.composite
def expressions(draw: Any, leaves: List[Any], depth: int = 4) -> Any:
    """A random expression over ``leaves`` and numbers using every function of the DSL."""
    if depth == 0 or draw(st.integers(0, 4)) == 0:
        if draw(st.integers(0, 4)) == 0:
            return lg.Expr.lift(draw(st.floats(-2.0, 2.0, allow_nan=False)))
        return draw(st.sampled_from(leaves))
    kind = draw(st.integers(0, 9))
    if kind < 4:
        f = UNARY[draw(st.sampled_from(sorted(UNARY)))]
        return f(draw(expressions(leaves, depth - 1)))
    if kind == 4:
        return draw(expressions(leaves, depth - 1)) ** draw(st.sampled_from(EXPONENTS))
    f = BINARY[draw(st.sampled_from(sorted(BINARY)))]
    return f(draw(expressions(leaves, depth - 1)), draw(expressions(leaves, depth - 1)))


@st.composite
def models(draw: Any) -> Tuple[Dict[str, Any], List[Tuple[float, List[float], List[float]]]]:
    """Model arguments (T with a random mass matrix, gyroscopic and time-dependent terms; U, Φ
    and Q random) and states to evaluate them at."""
    n = draw(st.integers(1, 3))
    qs = list(lg.coordinates(" ".join(f"q{i}" for i in range(n))))
    a, b = lg.parameters("a b")
    params = {"a": draw(st.floats(0.2, 3.0)), "b": draw(st.floats(-2.0, 2.0))}
    positions = qs + [lg.t, a, b]
    everything = positions + [q.d for q in qs]
    # T = ½ Σ mᵢ(q, t) q̇ᵢ² + c(q, t) q̇₀ q̇ₙ₋₁ + A(q, t) q̇₀ + …: the mass matrix is random too,
    # possibly singular or not finite.
    kinetic = 0
    for q in qs:
        m = draw(st.sampled_from([a, 1.0]))
        if draw(st.booleans()):
            m = m * (1 + draw(expressions(positions, 2)) ** 2)
        kinetic = kinetic + 0.5 * m * q.d**2
    if n > 1 and draw(st.booleans()):
        kinetic = kinetic + 0.3 * lg.cos(draw(expressions(positions, 2))) * qs[0].d * qs[-1].d
    if draw(st.booleans()):
        kinetic = kinetic + draw(expressions(positions, 2)) * qs[0].d
    if draw(st.booleans()):
        kinetic = kinetic + draw(expressions(everything, 2))
    kwargs: Dict[str, Any] = {"coordinates": qs, "kinetic": kinetic}
    if draw(st.booleans()):
        kwargs["potential"] = draw(expressions(positions))
    if draw(st.booleans()):
        kwargs["dissipation"] = draw(expressions(everything, 3))
    if draw(st.booleans()):
        kwargs["forces"] = [draw(expressions(everything, 3)) for _ in qs]
    # Only the parameters the expressions use.
    parts = [kinetic, kwargs.get("potential"), kwargs.get("dissipation")]
    parts += kwargs.get("forces") or []
    used = {s.args[0] for e in parts if e is not None
            for s in lg.Expr.lift(e).free_symbols() if s.op == "param"}
    kwargs["parameters"] = {k: v for k, v in params.items() if k in used}
    states = [
        (draw(VALUES), [draw(VALUES) for _ in qs], [draw(VALUES) for _ in qs])
        for _ in range(draw(st.integers(2, 4)))
    ]
    return kwargs, states


@settings(max_examples=120, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(models())
def test_native_and_interpreter_agree_on_random_models(case):
    kwargs, states = case
    compare_backends(kwargs, states)


def test_every_function_in_every_part_agrees_at_ordinary_and_failing_states():
    # Not left to the generator's luck: each function in T, U, Φ and Q, at states where it is
    # finite and where it is not.
    x, y = lg.coordinates("x y")
    a, = lg.parameters("a")
    args = {"u": [x, x - y, 2 * x + lg.t], "b": [(x, y), (y, x + 1), (a * x, lg.t)]}
    grid = [-2.0, -0.5, 0.0, 0.3, 1.0, 40.0, 800.0]
    states = [(t, [q0, q1], [v, -v]) for q0 in grid
              for t, q1, v in ((0.0, 0.0, 0.0), (1.3, -0.7, 1.5), (-0.4, 2.0, -0.3))]
    ok = 0
    for name, f in list(UNARY.items()) + [(f"**{e}", lambda u, e=e: u**e) for e in EXPONENTS]:
        for u in args["u"]:
            e = f(u)
            for kwargs in (
                {"kinetic": 0.5 * (1 + e**2) * x.d**2 + 0.5 * a * y.d**2, "potential": e},
                {"kinetic": 0.5 * x.d**2 + 0.5 * y.d**2 + e * x.d * y.d,
                 "dissipation": e * x.d**2, "forces": [e, e * y.d]},
            ):
                ok += compare_backends(
                    dict(coordinates=[x, y], parameters={"a": 1.7}, **kwargs), states
                )
    for name, g in BINARY.items():
        for u, v in args["b"]:
            e = g(u, v)
            kwargs = {"kinetic": 0.5 * (2 + lg.sin(e)) * x.d**2 + 0.5 * y.d**2 + e * y.d,
                      "potential": e * x, "dissipation": g(x.d, y.d + 2) ** 2,
                      "forces": [g(x.d, y), e]}
            ok += compare_backends(
                dict(coordinates=[x, y], parameters={"a": 1.7}, **kwargs), states
            )
    assert ok > 5000, ok


def test_failures_are_the_same_typed_errors():
    x, = lg.coordinates("x")
    for backend in BACKENDS:
        # log of a negative number in the force −∂U/∂x = −log x − 1: not finite.
        m = lg.Model([x], kinetic=0.5 * x.d**2, potential=x * lg.log(x), backend=backend)
        with pytest.raises(lg.NonFiniteError):
            m.accelerations(0.0, [-1.0], [0.0])
        with pytest.raises(lg.NonFiniteError):
            m.rhs(0.0, [-1.0, 0.0])
        # A mass matrix that vanishes at x = 0 and is not finite for x < 0.
        m = lg.Model([x], kinetic=0.5 * lg.sqrt(x) * x.d**2, backend=backend)
        with pytest.raises(lg.SingularMassMatrixError):
            m.accelerations(0.0, [0.0], [1.0])
        with pytest.raises(lg.SingularMassMatrixError):
            m.accelerations(0.0, [-1.0], [1.0])
        with pytest.raises(lg.NonFiniteError):
            m.mass_matrix(0.0, [-1.0], [1.0])
        # exp overflows.
        m = lg.Model([x], kinetic=0.5 * x.d**2, potential=lg.exp(lg.exp(x)), backend=backend)
        with pytest.raises(lg.NonFiniteError):
            m.accelerations(0.0, [7.0], [0.0])
        with pytest.raises(lg.NonFiniteError):
            m.energy(0.0, [7.0], [0.0])


def test_energy_is_never_returned_infinite():
    # p and L finite, but q̇·p = 2T overflows: h = q̇·p − L must not be returned as inf.
    x, = lg.coordinates("x")
    for backend in BACKENDS:
        m = lg.Model([x], kinetic=0.5 * lg.exp(x) * x.d**2, backend=backend)
        q, qd = [math.log(1e308)], [1.5]
        assert np.isfinite(m.momenta(0.0, q, qd)).all() and np.isfinite(m.lagrangian(0.0, q, qd))
        with pytest.raises(lg.NonFiniteError):
            m.energy(0.0, q, qd)


# -- the backend option ----------------------------------------------------------------------

def _pendulum(**kw: Any) -> lg.Model:
    th, = lg.coordinates("th")
    m, l, g = lg.parameters("m l g")
    return lg.Model(coordinates=[th], kinetic=0.5 * m * l**2 * th.d**2,
                    potential=-m * g * l * lg.cos(th),
                    parameters={"m": 1.0, "l": 2.0, "g": 9.81}, **kw)


def test_backend_is_native_by_default_and_survives_rebinding_and_pickling():
    assert _pendulum().structure["backend"] == "native"
    for backend in BACKENDS:
        model = _pendulum(backend=backend)
        assert model.structure["backend"] == backend
        moon = model.with_parameters(g=1.62)
        assert moon.structure["backend"] == backend
        again = pickle.loads(pickle.dumps(moon))
        assert again.structure["backend"] == backend
        assert repr(again) == repr(moon)
        assert again.parameters["g"] == 1.62
        want = -1.62 / 2.0 * math.sin(0.3)
        assert abs(again.accelerations(0.0, [0.3], [0.0])[0] - want) <= 1e-15
    assert "backend" not in repr(_pendulum())
    assert "backend='interpreter'" in repr(_pendulum(backend="interpreter"))


def test_unknown_backend_is_a_clear_error():
    with pytest.raises(ValueError, match='unknown backend "llvm".*"native".*"interpreter"'):
        _pendulum(backend="llvm")
    with pytest.raises(TypeError, match="backend must be a string"):
        _pendulum(backend=1)


def test_particle_route_takes_the_backend_too():
    th, = lg.coordinates("th")
    for backend in BACKENDS:
        model = lg.Model([th], positions=[(lg.sin(th), -lg.cos(th))], masses=[1.0],
                         potential=-9.81 * lg.cos(th), backend=backend)
        assert model.structure["backend"] == backend
        again = pickle.loads(pickle.dumps(model.with_parameters()))
        assert again.structure["backend"] == backend
        assert abs(again.accelerations(0.0, [0.3], [0.0])[0] + 9.81 * math.sin(0.3)) <= 1e-15
    assert lg.scenes.simple_pendulum().structure["backend"] == "rust"


# -- the scenes' closed forms ----------------------------------------------------------------

def _close(got: Any, want: Any, what: str, rtol: float = 1e-13) -> None:
    """Entry by entry to ``rtol`` of the entry, with an absolute floor of ``rtol`` times the
    largest entry (an entry that cancels to nearly zero carries the rounding of its terms)."""
    got, want = np.asarray(got, dtype=np.float64), np.asarray(want, dtype=np.float64)
    scale = max(float(np.max(np.abs(want), initial=0.0)), 1e-300)
    err = np.abs(got - want)
    bound = rtol * np.maximum(np.abs(want), scale)
    assert np.all(err <= bound), (
        f"{what}: worst relative error {float(np.max(err / scale)):.3g}\n{got}\n{want}"
    )


def _simple_pendulum(m: float, l: float, g: float) -> Dict[str, Any]:
    th, = lg.coordinates("theta")
    return dict(coordinates=[th], kinetic=0.5 * m * l**2 * th.d**2,
                potential=-m * g * l * lg.cos(th))


def _double_pendulum(m1: float, m2: float, l1: float, l2: float, g: float) -> Dict[str, Any]:
    th1, th2 = lg.coordinates("th1 th2")
    return dict(
        coordinates=[th1, th2],
        kinetic=0.5 * (m1 + m2) * l1**2 * th1.d**2 + 0.5 * m2 * l2**2 * th2.d**2
        + m2 * l1 * l2 * th1.d * th2.d * lg.cos(th1 - th2),
        potential=-(m1 + m2) * g * l1 * lg.cos(th1) - m2 * g * l2 * lg.cos(th2),
    )


def _n_pendulum(masses: List[float], lengths: List[float], g: float) -> Dict[str, Any]:
    ths = list(lg.coordinates(" ".join(f"th{k + 1}" for k in range(len(masses)))))
    vx = vy = y = 0
    kinetic = potential = 0
    for th, m, l in zip(ths, masses, lengths):
        vx = vx + l * lg.cos(th) * th.d
        vy = vy + l * lg.sin(th) * th.d
        y = y - l * lg.cos(th)
        kinetic = kinetic + 0.5 * m * (vx**2 + vy**2)
        potential = potential + m * g * y
    return dict(coordinates=ths, kinetic=kinetic, potential=potential)


def _forced_two_mass(m1: float, m2: float, k1: float, k2: float, f1: float, f2: float,
                     omega: float) -> Dict[str, Any]:
    x1, x2 = lg.coordinates("x1 x2")
    drive = lg.cos(omega * lg.t)
    return dict(coordinates=[x1, x2], kinetic=0.5 * m1 * x1.d**2 + 0.5 * m2 * x2.d**2,
                potential=0.5 * k1 * x1**2 + 0.5 * k2 * (x2 - x1)**2,
                forces=[f1 * drive, f2 * drive])


def _rolling_cylinder(m: float, j: float, r: float, g: float, alpha: float) -> Dict[str, Any]:
    # Seed eq. 45–48: T = ½ m ẋ² + ½ J ω², ω = ẋ / r; U = −m g x sin α.
    x, = lg.coordinates("x")
    return dict(coordinates=[x], kinetic=0.5 * m * x.d**2 + 0.5 * j * (x.d / r)**2,
                potential=-m * g * math.sin(alpha) * x)


def _ball_in_sphere(m: float, j: float, r1: float, r2: float, g: float) -> Dict[str, Any]:
    # Seed eq. 49–53: the centre moves on a circle of radius r₁ − r₂, the ball turns at
    # ω = (r₁ − r₂) θ̇ / r₂; U = −m g (r₁ − r₂) cos θ.
    th, = lg.coordinates("theta")
    arm = r1 - r2
    return dict(coordinates=[th],
                kinetic=0.5 * m * (arm * th.d)**2 + 0.5 * j * (arm * th.d / r2)**2,
                potential=-m * g * arm * lg.cos(th))


def _damped_oscillator(m: float, k: float, c: float) -> Dict[str, Any]:
    x, = lg.coordinates("x")
    return dict(coordinates=[x], kinetic=0.5 * m * x.d**2, potential=0.5 * k * x**2,
                dissipation=0.5 * c * x.d**2)


def _kepler(m: float, mu: float) -> Dict[str, Any]:
    x, y = lg.coordinates("x y")
    return dict(coordinates=[x, y], kinetic=0.5 * m * (x.d**2 + y.d**2),
                potential=-mu * m / lg.sqrt(x**2 + y**2))


def _elastic_pendulum(m: float, k: float, l0: float, g: float, c: float) -> Dict[str, Any]:
    r, th = lg.coordinates("r theta")
    return dict(coordinates=[r, th], kinetic=0.5 * m * (r.d**2 + r**2 * th.d**2),
                potential=0.5 * k * (r - l0)**2 - m * g * r * lg.cos(th),
                dissipation=0.5 * c * r.d**2)


def _henon_heiles() -> Dict[str, Any]:
    x, y = lg.coordinates("x y")
    return dict(coordinates=[x, y], kinetic=0.5 * (x.d**2 + y.d**2),
                potential=0.5 * (x**2 + y**2) + x**2 * y - y**3 / 3)


def _driven_pendulum(m: float, l: float, g: float, a: float, omega: float) -> Dict[str, Any]:
    # The pivot at height a cos ωt: the bob at (l sin θ, a cos ωt − l cos θ).
    th, = lg.coordinates("theta")
    vx = l * lg.cos(th) * th.d
    vy = -a * omega * lg.sin(omega * lg.t) + l * lg.sin(th) * th.d
    return dict(coordinates=[th], kinetic=0.5 * m * (vx**2 + vy**2),
                potential=m * g * (a * lg.cos(omega * lg.t) - l * lg.cos(th)))


def _charged_particle(m: float, e: float, b: float, ex: float, ey: float) -> Dict[str, Any]:
    # L = ½ m |v|² + e v·A − e φ with A = ½ b (−y, x), φ = −(ex x + ey y).
    x, y = lg.coordinates("x y")
    return dict(coordinates=[x, y],
                kinetic=0.5 * m * (x.d**2 + y.d**2) + 0.5 * e * b * (x * y.d - y * x.d),
                potential=-e * (ex * x + ey * y))


def _spring_rhombus(a: float, k: float, l0: float, m: float, g: float) -> Dict[str, Any]:
    # Seed §3.2 example 4: the mass hangs at (0, −2a cos θ); the spring's length is 2a sin θ.
    th, = lg.coordinates("theta")
    return dict(coordinates=[th], kinetic=0.5 * m * (2 * a * lg.sin(th) * th.d)**2,
                potential=0.5 * k * (2 * l0 - 2 * a * lg.sin(th))**2
                - m * g * 2 * a * lg.cos(th))


def _two_springs(m1: float, m2: float, k1: float, k2: float, f1: float, f2: float
                 ) -> Dict[str, Any]:
    x1, x2 = lg.coordinates("x1 x2")
    return dict(coordinates=[x1, x2], kinetic=0.5 * m1 * x1.d**2 + 0.5 * m2 * x2.d**2,
                potential=0.5 * k1 * x1**2 + 0.5 * k2 * (x2 - x1)**2, forces=[f1, f2])


def _spatial_chain(masses: List[float], lengths: List[float], radius: float, g: float
                   ) -> Dict[str, Any]:
    # lg.Body per link: R_k = R_{k−1} R_x|y(q_k), the centre l/2 down the link's z axis.
    qs = list(lg.coordinates(" ".join(f"q{k + 1}" for k in range(len(masses)))))
    rot: Any = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    joint: Any = (0.0, 0.0, 0.0)
    bodies = []
    for k, (q, m, l) in enumerate(zip(qs, masses, lengths)):
        turn = lg.rotation_x(q) if k % 2 == 0 else lg.rotation_y(q)
        rot = tuple(tuple(sum(rot[i][j] * turn[j][c] for j in range(3)) for c in range(3))
                    for i in range(3))
        centre = tuple(joint[i] - 0.5 * l * rot[i][2] for i in range(3))
        joint = tuple(joint[i] - l * rot[i][2] for i in range(3))
        side = m * (3 * radius**2 + l**2) / 12.0
        bodies.append(lg.Body(m, (side, side, 0.5 * m * radius**2), centre, rot,
                              gravity=(0.0, 0.0, -g)))
    return dict(coordinates=qs, bodies=bodies, potential=sum(b.potential for b in bodies))


SCENES: List[Tuple[str, Dict[str, Any], Callable[..., Dict[str, Any]], float]] = [
    # (scene, arguments, the same energies in Python, scale of q and q̇)
    ("simple_pendulum", dict(m=1.3, l=0.7, g=9.81), _simple_pendulum, 2.0),
    ("double_pendulum", dict(m1=1.3, m2=0.7, l1=1.1, l2=0.8, g=9.81), _double_pendulum, 2.0),
    ("n_pendulum", dict(masses=[1.0, 0.6, 1.4, 0.8], lengths=[0.9, 1.2, 0.5, 0.7], g=9.81),
     _n_pendulum, 1.5),
    ("n_pendulum", dict(masses=[1.2], lengths=[0.8], g=9.81), _n_pendulum, 2.0),
    ("forced_two_mass", dict(m1=1.0, m2=0.5, k1=10.0, k2=5.0, f1=0.7, f2=-0.3, omega=1.9),
     _forced_two_mass, 2.0),
    ("rolling_cylinder", dict(m=1.0, j=0.005, r=0.1, g=9.81, alpha=0.3), _rolling_cylinder, 2.0),
    ("ball_in_sphere", dict(m=1.0, j=0.016, r1=1.0, r2=0.2, g=9.81), _ball_in_sphere, 2.0),
    ("damped_oscillator", dict(m=1.7, k=4.0, c=0.4), _damped_oscillator, 2.0),
    ("kepler", dict(m=1.3, mu=2.0), _kepler, 2.0),
    ("elastic_pendulum", dict(m=1.1, k=40.0, l0=1.0, g=9.81, c=0.3), _elastic_pendulum, 2.0),
    ("henon_heiles", dict(), _henon_heiles, 0.8),
    ("driven_pendulum", dict(m=1.0, l=1.0, g=9.81, a=0.1, omega=20.0), _driven_pendulum, 2.0),
    ("charged_particle", dict(m=1.2, e=0.8, b=1.5, ex=0.3, ey=-0.2), _charged_particle, 2.0),
    ("spring_rhombus", dict(a=0.7, k=300.0, l0=0.5, m=3.0, g=9.81), _spring_rhombus, 1.0),
    ("two_springs", dict(m1=1.5, m2=0.5, k1=40.0, k2=25.0, f1=2.0, f2=-3.0), _two_springs, 2.0),
    ("spatial_chain", dict(masses=[1.0, 0.6, 1.4, 0.8], lengths=[0.9, 1.2, 0.5, 0.7],
                           radius=0.1, g=9.81), _spatial_chain, 1.5),
]


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name, args, energies, scale", SCENES,
                         ids=[f"{s[0]}-{len(s[1].get('masses', [0]))}" for s in SCENES])
def test_scenes_stated_in_python_match_the_rust_scenes(name, args, energies, scale, backend):
    scene = getattr(lg.scenes, name)(**args)
    model = lg.Model(backend=backend, **energies(**args))
    assert model.structure["backend"] == backend
    for key in ("time_dependent", "separable", "dissipative", "forced", "conservative"):
        assert model.structure[key] == scene.structure[key], key
    # A constant M found on the graph is constant in the scene; the converse need not hold
    # (the driven pendulum's M = m l² (cos² θ + sin² θ) is not simplified).
    assert scene.structure["constant_mass"] or not model.structure["constant_mass"]
    n = scene.dof
    rng = np.random.default_rng(12)
    for _ in range(25):
        t = float(rng.uniform(-3.0, 3.0))
        q = list(rng.uniform(-scale, scale, n))
        qd = list(rng.uniform(-scale, scale, n))
        if name == "elastic_pendulum":
            q[0] = 1.0 + 0.3 * q[0] / scale  # a stretched spring, r > 0
        if name == "spring_rhombus":
            q[0] = 0.8 + 0.5 * q[0]  # away from θ = 0, where M = 4 m a² sin² θ vanishes
        if name == "kepler":
            q[0] += 2.5 * scale  # away from the centre
        y = np.array(q + qd)
        at = f"{name} at t={t}, q={q}, qd={qd}"
        _close(model.accelerations(t, q, qd), scene.accelerations(t, q, qd), f"q̈ of {at}")
        _close(model.rhs(t, y), scene.rhs(t, y), f"rhs of {at}")
        _close(model.mass_matrix(t, q, qd), scene.mass_matrix(t, q, qd), f"M of {at}")
        _close(model.energy(t, q, qd), scene.energy(t, q, qd), f"h of {at}")
        _close(model.momenta(t, q, qd), scene.momenta(t, q, qd), f"p of {at}")
        _close(model.lagrangian(t, q, qd), scene.lagrangian(t, q, qd), f"L of {at}")
        _close(model.jacobian(t, y), scene.jacobian(t, y), f"jacobian of {at}")


@pytest.mark.parametrize("name, args, energies, scale", SCENES,
                         ids=[f"{s[0]}-{len(s[1].get('masses', [0]))}" for s in SCENES])
def test_implicit_methods_on_compiled_models_follow_the_rust_scenes(name, args, energies, scale):
    """Gauss–Legendre runs on the (q, p) form and its Jacobian, Radau IIA on the Jacobian of
    the accelerations: for small models both are derived on the graph and compiled, for the
    scenes written in Rust they come from dual numbers. Gauss iterates to round-off, so a fixed-
    step run agrees to round-off; Radau's steps follow its error estimates, which the two
    Jacobians' rounding moves by as little."""
    scene = getattr(lg.scenes, name)(**args)
    model = lg.Model(**energies(**args))
    n = scene.dof
    rng = np.random.default_rng(5)
    q0 = list(rng.uniform(-0.5 * scale, 0.5 * scale, n))
    qd0 = list(rng.uniform(-0.5 * scale, 0.5 * scale, n))
    if name == "elastic_pendulum":
        q0[0] = 1.1
    if name == "spring_rhombus":
        q0[0] = 0.9
    if name == "kepler":
        q0[0] += 2.5 * scale
    for method, options, rtol in (("gauss4", dict(dt=0.01), 1e-11),
                                  ("radau5", dict(rtol=1e-10, atol=1e-12), 1e-9)):
        got = model.simulate(q0, qd0, 1.0, method=method, **options)
        want = scene.simulate(q0, qd0, 1.0, method=method, **options)
        for a, b, what in ((got.q[-1], want.q[-1], "q"), (got.qd[-1], want.qd[-1], "q̇")):
            _close(a, b, f"{method} {what} of {name} at t = 1", rtol=rtol)
        # A wrong Jacobian still converges, slower: the Newton iterations would tell.
        work = [s.stats["rhs_evaluations"] for s in (got, want)]
        assert abs(work[0] - work[1]) <= 0.02 * work[1], f"{method} on {name}: {work}"
