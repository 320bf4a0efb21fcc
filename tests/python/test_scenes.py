"""The seed's scenes from Python (Rust-native systems) against their closed forms."""

import math

import numpy as np
from numpy.testing import assert_allclose

import lagrangian as lg
from conftest import STATES


def double_pendulum_closed_form(p, q, qd):
    """The textbook double-pendulum accelerations by Cramer's rule."""
    m1, m2, l1, l2, g = p["m1"], p["m2"], p["l1"], p["l2"], p["g"]
    s, c = math.sin(q[0] - q[1]), math.cos(q[0] - q[1])
    a = (m1 + m2) * l1 * l1
    b = m2 * l1 * l2 * c
    d = m2 * l2 * l2
    e = -m2 * l1 * l2 * s * qd[1] ** 2 - (m1 + m2) * g * l1 * math.sin(q[0])
    f = m2 * l1 * l2 * s * qd[0] ** 2 - m2 * g * l2 * math.sin(q[1])
    det = a * d - b * b
    return [(e * d - b * f) / det, (a * f - b * e) / det]


def test_simple_pendulum_accelerations():
    model = lg.scenes.simple_pendulum(m=1.5, l=2.0, g=9.81)
    for th in (0.3, -1.2, 2.9):
        a = model.accelerations(0.0, [th], [0.7])
        assert_allclose(a, [-9.81 / 2.0 * math.sin(th)], rtol=1e-13)


def test_simple_pendulum_small_swing_period():
    # θ ≈ θ₀ cos(√(g/l) t) for a small swing; the anharmonic shift is O(θ₀²).
    model = lg.scenes.simple_pendulum(m=1.0, l=1.0, g=9.81)
    w = math.sqrt(9.81)
    t = np.linspace(0.0, 2.0, 9)
    sol = model.simulate([1e-4], [0.0], 2.0, method="dop853", rtol=1e-12, atol=1e-14, t_eval=t)
    assert_allclose(sol.q[:, 0], 1e-4 * np.cos(w * t), atol=1e-11)


def test_double_pendulum_accelerations(dp_params):
    model = lg.scenes.double_pendulum(**dp_params)
    for q, qd in STATES:
        assert_allclose(
            model.accelerations(0.0, q, qd), double_pendulum_closed_form(dp_params, q, qd),
            rtol=1e-12,
        )


def test_n_pendulum_two_links_is_the_double_pendulum(dp_params):
    p = dp_params
    chain = lg.scenes.n_pendulum([p["m1"], p["m2"]], [p["l1"], p["l2"]], p["g"])
    for q, qd in STATES:
        assert_allclose(
            chain.accelerations(0.0, q, qd), double_pendulum_closed_form(p, q, qd), rtol=1e-12
        )


def test_damped_oscillator_exact_solution():
    # Seed eq. 54–55: m ẍ + c ẋ + k x = 0, under-damped.
    m, k, c = 2.0, 8.0, 0.6
    model = lg.scenes.damped_oscillator(m=m, k=k, c=c)
    gamma, w0 = c / (2 * m), math.sqrt(k / m)
    wd = math.sqrt(w0 * w0 - gamma * gamma)
    t = np.linspace(0.0, 5.0, 11)
    sol = model.simulate([1.0], [0.0], 5.0, rtol=1e-12, atol=1e-14, t_eval=t)
    exact = np.exp(-gamma * t) * (np.cos(wd * t) + gamma / wd * np.sin(wd * t))
    assert_allclose(sol.q[:, 0], exact, atol=1e-10)
    # The energy function decays: Φ dissipates.
    assert np.all(np.diff(sol.energy) < 0)


def test_forced_two_mass_accelerations():
    # Seed eq. 43–44: m₁ẍ₁ = −k₁x₁ + k₂(x₂ − x₁) + F₁ cos Ωt, m₂ẍ₂ = −k₂(x₂ − x₁) + F₂ cos Ωt.
    m1, m2, k1, k2, f1, f2, om = 1.0, 2.0, 30.0, 20.0, 3.0, -1.0, 4.5
    model = lg.scenes.forced_two_mass(m1, m2, k1, k2, f1, f2, om)
    t, x = 0.7, [0.2, -0.1]
    want = [
        (-k1 * x[0] + k2 * (x[1] - x[0]) + f1 * math.cos(om * t)) / m1,
        (-k2 * (x[1] - x[0]) + f2 * math.cos(om * t)) / m2,
    ]
    assert_allclose(model.accelerations(t, x, [0.5, 0.5]), want, rtol=1e-12)
    assert model.structure["forced"]


def test_rolling_cylinder_motion():
    # Seed eq. 48: x(t) = ½ g sin α / (1 + J/(m r²)) t².
    m, r, g, alpha = 2.0, 0.3, 9.81, 0.4
    j = 0.5 * m * r * r
    model = lg.scenes.rolling_cylinder(m=m, j=j, r=r, g=g, alpha=alpha)
    a = g * math.sin(alpha) / (1 + j / (m * r * r))
    sol = model.simulate([0.0], [0.0], 3.0, method="rk4", dt=0.01)
    assert_allclose(sol.q[:, 0], 0.5 * a * sol.t**2, rtol=1e-12, atol=1e-14)


def test_ball_in_sphere_accelerations():
    # Seed eq. 53: (m + J/r₂²)(r₁ − r₂) θ̈ = −m g sin θ.
    m, r1, r2, g = 1.0, 2.0, 0.5, 9.81
    j = 0.4 * m * r2 * r2
    model = lg.scenes.ball_in_sphere(m=m, j=j, r1=r1, r2=r2, g=g)
    th = 0.8
    want = -m * g * math.sin(th) / ((m + j / r2**2) * (r1 - r2))
    assert_allclose(model.accelerations(0.0, [th], [1.0]), [want], rtol=1e-13)


def test_kepler_orbit_closes():
    m, mu, a, e = 1.0, 1.0, 1.0, 0.5
    model = lg.scenes.kepler(m=m, mu=mu)
    rp = a * (1 - e)
    q0, v0 = [rp, 0.0], [0.0, math.sqrt(mu * (1 + e) / rp)]
    period = 2 * math.pi * math.sqrt(a**3 / mu)
    sol = model.simulate(q0, v0, period, rtol=1e-12, atol=1e-12, t_eval=[period])
    assert_allclose(sol.q[-1], q0, atol=1e-8)
    assert_allclose(sol.energy, -mu * m / (2 * a), rtol=1e-10)
    assert model.structure["separable"]


def test_charged_particle_circle():
    # E = 0: a circle of radius |v|/ω_c, ω_c = eB/m, back at the start after one turn.
    m, e, b = 1.0, 2.0, 0.5
    model = lg.scenes.charged_particle(m=m, e=e, b=b)
    wc = e * b / m
    sol = model.simulate([0.0, 0.0], [1.0, 0.0], 2 * math.pi / wc, rtol=1e-12, atol=1e-12)
    assert_allclose(sol.q[-1], [0.0, 0.0], atol=1e-9)
    assert_allclose(sol.energy, 0.5 * m, rtol=1e-10)


def test_driven_pendulum_accelerations():
    m, l, g, a, w = 1.0, 1.0, 9.81, 0.1, 30.0
    model = lg.scenes.driven_pendulum(m=m, l=l, g=g, a=a, omega=w)
    t, th = 0.3, 0.4
    want = -(g - a * w * w * math.cos(w * t)) / l * math.sin(th)
    assert_allclose(model.accelerations(t, [th], [0.2]), [want], rtol=1e-12)
    assert model.structure["time_dependent"]


def test_henon_heiles_accelerations():
    model = lg.scenes.henon_heiles()
    x, y = 0.1, -0.2
    want = [-x - 2 * x * y, -y - x * x + y * y]
    assert_allclose(model.accelerations(0.0, [x, y], [0.3, 0.1]), want, rtol=1e-13)


def test_elastic_pendulum_accelerations():
    m, k, l0, g = 1.0, 40.0, 1.0, 9.81
    model = lg.scenes.elastic_pendulum(m=m, k=k, l0=l0, g=g)
    r, th, rd, thd = 1.2, 0.5, 0.3, -0.7
    want = [
        r * thd**2 - k / m * (r - l0) + g * math.cos(th),
        (-2 * rd * thd - g * math.sin(th)) / r,
    ]
    assert_allclose(model.accelerations(0.0, [r, th], [rd, thd]), want, rtol=1e-12)


# -- the registry: defaults, signatures, argument checks, exact solutions ---------------------

import inspect
import pickle
from pathlib import Path

import pytest

from lagrangian import _lagrangian
from lagrangian.scenes import SceneModel

CATALOG = {s["name"]: s for s in lg.scenes.catalog()}
EXACT = sorted(name for name, s in CATALOG.items() if s["exact"])

# A state of each scene with an exact solution, away from special cases (a general Kepler orbit:
# not at periapsis, clockwise, the periapsis off the axes).
EXACT_STATES = {
    "forced_two_mass": ([0.1, -0.05], [0.3, 0.0]),
    "rolling_cylinder": ([0.2], [0.5]),
    "damped_oscillator": ([1.0], [-0.3]),
    "kepler": ([0.3, -0.8], [-0.9, -0.4]),
    "charged_particle": ([0.1, 0.2], [1.0, -0.5]),
}


def test_catalog_is_the_scenes():
    assert list(CATALOG) == lg.scenes.__all__
    assert set(EXACT) == set(EXACT_STATES)
    for name, entry in CATALOG.items():
        assert entry["route"] in ("energy", "particle", "body"), name
        assert entry["doc"], name


@pytest.mark.parametrize("name", sorted(CATALOG))
def test_scene_defaults_build(name):
    model = getattr(lg.scenes, name)()
    assert isinstance(model, SceneModel) and isinstance(model, lg.Model)
    assert model.scene == name
    entry = CATALOG[name]
    assert list(model.parameters) == [p[0] for p in entry["parameters"]]
    for pname, kind, default, _ in entry["parameters"]:
        assert model.parameters[pname] == default, pname
    n = model.dof
    q = [0.3] * n
    if name == "elastic_pendulum":
        q = [1.1, 0.3]
    if name not in ("lever", "rhombus_link", "differential_pulley"):  # massless: statics only
        assert np.all(np.isfinite(model.accelerations(0.0, q, [0.1] * n)))
    assert model.has_exact == entry["exact"]


@pytest.mark.parametrize("name", sorted(CATALOG))
def test_scene_signature_and_docstring(name):
    entry = CATALOG[name]
    f = getattr(lg.scenes, name)
    params = inspect.signature(f).parameters
    assert list(params) == [p[0] for p in entry["parameters"]]
    for pname, kind, default, doc in entry["parameters"]:
        want = tuple(default) if kind == "list" else default
        assert params[pname].default == want
        assert f"{pname} :" in f.__doc__
    assert f.__doc__.startswith(entry["doc"])
    assert f.__name__ == name


def test_scene_positional_and_keyword_arguments_agree():
    a = lg.scenes.forced_two_mass(1.0, 2.0, 30.0, 20.0, 3.0, -1.0, 4.5)
    b = lg.scenes.forced_two_mass(m1=1.0, m2=2.0, k1=30.0, k2=20.0, f1=3.0, f2=-1.0, omega=4.5)
    assert a.parameters == b.parameters
    assert lg.scenes.double_pendulum(m2=2.0).parameters == dict(
        m1=1.0, m2=2.0, l1=1.0, l2=1.0, g=9.81
    )


def test_scene_arguments_checked_by_name():
    with pytest.raises(TypeError, match="mass"):
        lg.scenes.kepler(mass=1.0)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="multiple values for argument 'm'"):
        lg.scenes.kepler(1.0, m=2.0)  # type: ignore[misc]
    with pytest.raises(TypeError, match="too many"):
        lg.scenes.kepler(1.0, 1.0, 1.0)  # type: ignore[call-arg]
    with pytest.raises(ValueError, match="kepler: invalid argument mu: the value NaN is not finite"):
        lg.scenes.kepler(mu=math.nan)
    with pytest.raises(ValueError, match="invalid argument masses.*not finite"):
        lg.scenes.n_pendulum(masses=[1.0, math.inf], lengths=[1.0, 1.0])
    with pytest.raises(ValueError, match=r"invalid argument g: must be a real number, got the "
                       r"list \[9\.81\]"):
        lg.scenes.n_pendulum(g=[9.81])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="invalid argument masses: must be a list of numbers, "
                       "got 1.0"):
        lg.scenes.n_pendulum(masses=1.0)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="argument m must be a real number"):
        lg.scenes.simple_pendulum(m="1")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="argument m must be a real number"):
        lg.scenes.simple_pendulum(m=True)
    # The binding checks names too, for callers that skip the Python signature.
    with pytest.raises(ValueError, match="invalid argument mass: unknown parameter; the "
                       "parameters are m, mu"):
        _lagrangian.scene_model("kepler", {"mass": 1.0})
    with pytest.raises(ValueError, match='unknown scene "nope"; the scenes are simple_pendulum, '):
        _lagrangian.scene_model("nope", {})


def test_scene_argument_messages_say_what_was_given_and_what_is_needed():
    # Every kind of mistake, each message naming the argument, what it got and what it needs.
    cases = [
        (lambda: lg.scenes.n_pendulum(5),  # type: ignore[arg-type]
         "n_pendulum: invalid argument masses: must be a list of numbers, got 5.0"),
        (lambda: lg.scenes.n_pendulum(g=[1.0, 2.0]),  # type: ignore[arg-type]
         "n_pendulum: invalid argument g: must be a real number, got the list [1.0, 2.0]"),
        (lambda: lg.scenes.n_pendulum([1.0, math.nan], [1.0, 1.0]),
         "n_pendulum: invalid argument masses: entry 1 of [1.0, NaN] is NaN, not finite: give "
         "finite numbers"),
        (lambda: lg.scenes.kepler(mu=math.inf),
         "kepler: invalid argument mu: the value inf is not finite: give a finite number"),
        (lambda: _lagrangian.scene_model("kepler", {"mass": 1.0}),
         "kepler: invalid argument mass: unknown parameter; the parameters are m, mu"),
    ]
    for call, message in cases:
        with pytest.raises(ValueError) as err:
            call()
        assert str(err.value) == message
    with pytest.raises(TypeError, match="double_pendulum: argument m1 must be a real number, "
                       "got 'a'"):
        lg.scenes.double_pendulum(m1="a")  # type: ignore[arg-type]


def test_scenes_namespace_shows_only_public_names():
    names = set(dir(lg.scenes))
    assert not names & {"Any", "Callable", "Dict", "List", "Tuple", "annotations", "inspect",
                        "scene_model"}
    public = {n for n in names if not n.startswith("_")}
    assert public == (set(lg.scenes.__all__) | set(lg.scenes.CONSTRAINED)
                      | set(lg.scenes.VEHICLES) | set(lg.scenes.BODIES)
                      | {"SceneModel", "catalog", "CONSTRAINED", "VEHICLES", "BODIES"})
    for name in public:
        assert getattr(lg.scenes, name) is not None


def test_n_pendulum_lists_from_numpy_and_tuples():
    a = lg.scenes.n_pendulum(np.array([1.0, 2.0]), (1.0, 0.5))
    assert a.parameters == {"masses": [1.0, 2.0], "lengths": [1.0, 0.5], "g": 9.81}
    assert [c.name for c in a.coordinates] == ["th1", "th2"]


@pytest.mark.parametrize("name", EXACT)
def test_exact_solves_the_equations_of_motion(name):
    # The exact q at t agrees with a tight run of the model's own equations to 1e-9.
    model = getattr(lg.scenes, name)()
    q0, qd0 = EXACT_STATES[name]
    q, qd = model.exact(0.0, q0, qd0)
    assert_allclose(q, q0, atol=1e-14)
    assert_allclose(qd, qd0, atol=1e-14)
    t = np.linspace(0.0, 3.0, 7)
    sol = model.simulate(q0, qd0, 3.0, method="dop853", rtol=1e-13, atol=1e-15, t_eval=t)
    for i, ti in enumerate(t):
        q, qd = model.exact(float(ti), q0, qd0)
        assert_allclose(q, sol.q[i], rtol=0, atol=1e-9)
        assert_allclose(qd, sol.qd[i], rtol=0, atol=1e-9)


def test_exact_matches_closed_forms():
    # Rolling cylinder, seed eq. 48: x = x0 + v0 t + ½ a t².
    m, j, r, g, alpha = 2.0, 0.09, 0.3, 9.81, 0.4
    a = g * math.sin(alpha) / (1 + j / (m * r * r))
    q, qd = lg.scenes.rolling_cylinder(m=m, j=j, r=r, g=g, alpha=alpha).exact(1.5, [0.2], [0.5])
    assert_allclose(q, [0.2 + 0.5 * 1.5 + 0.5 * a * 1.5**2], rtol=1e-15)
    assert_allclose(qd, [0.5 + a * 1.5], rtol=1e-15)
    # Damped oscillator, seed §4, under-damped from rest.
    m, k, c = 2.0, 8.0, 0.6
    gamma, w0 = c / (2 * m), math.sqrt(k / m)
    wd = math.sqrt(w0 * w0 - gamma * gamma)
    t = 1.3
    q, _ = lg.scenes.damped_oscillator(m=m, k=k, c=c).exact(t, [1.0], [0.0])
    want = math.exp(-gamma * t) * (math.cos(wd * t) + gamma / wd * math.sin(wd * t))
    assert_allclose(q, [want], rtol=1e-13)
    # Kepler from periapsis: after one period the body is back; after half, at apoapsis.
    mu, a_, e = 1.0, 1.0, 0.6
    rp = a_ * (1 - e)
    q0, v0 = [rp, 0.0], [0.0, math.sqrt(mu * (1 + e) / rp)]
    period = 2 * math.pi * math.sqrt(a_**3 / mu)
    kepler = lg.scenes.kepler(mu=mu)
    assert_allclose(kepler.exact(period, q0, v0)[0], q0, atol=1e-13)
    assert_allclose(kepler.exact(0.5 * period, q0, v0)[0], [-a_ * (1 + e), 0.0], atol=1e-13)
    # Charged particle without E: a circle about q0 + (v_y, −v_x)/ω_c.
    cp = lg.scenes.charged_particle(m=1.0, e=2.0, b=0.5)
    q, _ = cp.exact(0.5 * math.pi, [0.0, 0.0], [1.0, 0.0])
    assert_allclose(q, [1.0, -1.0], atol=1e-15)


def test_exact_refused_where_unknown():
    with pytest.raises(ValueError, match="double_pendulum has no exact solution"):
        lg.scenes.double_pendulum().exact(1.0, [0.1, 0.2], [0.0, 0.0])
    kepler = lg.scenes.kepler()
    with pytest.raises(ValueError, match="bound"):
        kepler.exact(1.0, [1.0, 0.0], [0.0, 2.0])  # escape speed exceeded
    with pytest.raises(ValueError, match=r"q0 has shape \(1,\) but the model has 2 coordinates"):
        kepler.exact(1.0, [1.0], [0.0, 1.0])
    with pytest.raises(ValueError, match="q0 has length 1, expected 2"):
        _lagrangian.scene_exact("kepler", {}, [1.0], [0.0, 1.0], 1.0)
    with pytest.raises(ValueError, match="resonance"):
        # m = k = 1: ω² = (3 ± √5)/2, the lower ω = (√5 − 1)/2.
        w = (math.sqrt(5.0) - 1.0) / 2.0
        lg.scenes.forced_two_mass(m1=1.0, m2=1.0, k1=1.0, k2=1.0, f1=1.0, omega=w).exact(
            1.0, [0.0, 0.0], [0.0, 0.0]
        )


@pytest.mark.parametrize("name", sorted(CATALOG))
def test_scene_pickles_and_rebinds(name):
    model = getattr(lg.scenes, name)()
    again = pickle.loads(pickle.dumps(model))
    assert type(again) is SceneModel
    assert repr(again) == repr(model) and again.parameters == model.parameters
    if model.parameters:
        key = next(iter(model.parameters))
        value = model.parameters[key]
        moved = model.with_parameters(**{key: value})
        assert type(moved) is SceneModel and moved.parameters == model.parameters


@pytest.mark.parametrize("name", sorted(CATALOG))
def test_scene_drawing_refers_to_its_particles(name):
    model = getattr(lg.scenes, name)()
    drawing = model._drawing()
    if not model.has_positions:
        with pytest.raises(ValueError, match=f"the scene {name} has no particle positions"):
            model.positions(0.0, [0.1] * model.dof)
        return
    count = model.positions(0.0, [0.2] * model.dof).shape[0]
    if drawing is None:
        return
    used = [i for rod in drawing.rods for i in rod] + [i for b in drawing.bodies for i in b]
    used += list(drawing.trail or ())
    assert all(-1 <= i < count for i in used), (name, used, count)
    if drawing.pivot is not None:
        t = np.array([0.0, 0.1])
        assert drawing.pivot(t).shape == (2, 2)


def test_driven_pendulum_pivot_moves_as_the_rust_scene():
    model = lg.scenes.driven_pendulum(a=0.2, omega=3.0)
    drawing = model._drawing()
    assert drawing is not None and drawing.pivot is not None
    t = np.array([0.0, 0.4, 1.1])
    assert_allclose(drawing.pivot(t), np.stack([0 * t, 0.2 * np.cos(3.0 * t)], axis=1),
                    rtol=1e-15)
    # The bob hangs l below the pivot.
    assert_allclose(model.positions(0.4, [0.0]), [[0.0, 0.2 * math.cos(1.2) - 1.0]], atol=1e-15)


def test_stub_matches_catalog():
    # python/lagrangian/scenes.pyi is generated from the registry (see its docstring).
    stub = Path(lg.scenes.__file__).with_name("scenes.pyi")
    assert stub.read_text(encoding="utf-8") == lg.scenes._stub()


def test_elastic_pendulum_dashpot_absent_at_zero():
    # One system type for both: at c = 0 the dashpot is absent, not a zero term.
    assert not lg.scenes.elastic_pendulum().structure["dissipative"]
    assert lg.scenes.elastic_pendulum().structure["conservative"]
    damped = lg.scenes.elastic_pendulum(c=0.3)
    assert damped.structure["dissipative"]
    r, th, rd, thd = 1.2, 0.5, 0.3, -0.7
    free = lg.scenes.elastic_pendulum().accelerations(0.0, [r, th], [rd, thd])
    assert_allclose(damped.accelerations(0.0, [r, th], [rd, thd]), free - [0.3 * rd, 0.0],
                    rtol=1e-13)


# Every scene traced into the expression graph: the traced eq. 55 program (what the Taylor method
# expands) gives the Rust scene's accelerations, q̈ = 2 cq[2] of the Taylor series through the
# state, at random states; where the Rust scene refuses (the massless statics scenes), so does
# the trace.
@pytest.mark.parametrize("name", sorted(CATALOG))
def test_traced_scene_has_the_rust_accelerations(name):
    model = getattr(lg.scenes, name)()
    n = len(model.coordinates)
    rng = np.random.default_rng(len(name))
    for _ in range(10):
        t = float(rng.uniform(-2.0, 2.0))
        q = 0.4 + 0.5 * rng.uniform(-1.0, 1.0, n)
        qd = rng.uniform(-1.0, 1.0, n)
        try:
            want = model.accelerations(t, q, qd)
        except lg.SingularMassMatrixError:
            with pytest.raises(lg.SingularMassMatrixError):
                model.taylor_series(q, qd, t=t, order=2)
            continue
        cq, cqd = model.taylor_series(q, qd, t=t, order=2)
        assert_allclose(cq[0], q, rtol=0, atol=0)
        assert_allclose(cq[1], qd, rtol=1e-15, atol=1e-15)
        assert_allclose(2.0 * cq[2], want, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(want).max()))
        assert_allclose(cqd[1], want, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(want).max()))


@pytest.mark.parametrize("name", EXACT)
def test_taylor_on_a_scene_meets_its_exact_solution(name):
    model = getattr(lg.scenes, name)()
    q0, qd0 = EXACT_STATES[name]
    t = np.linspace(0.0, 3.0, 7)
    for tol in (1e-8, 1e-12):
        sol = model.simulate(q0, qd0, 3.0, method="taylor", rtol=tol, atol=tol, t_eval=t)
        assert sol.stats["method"] == "taylor"
        for i, ti in enumerate(t):
            q, qd = model.exact(float(ti), q0, qd0)
            assert_allclose(sol.q[i], q, rtol=0, atol=20 * tol * max(1.0, np.abs(q).max()))
            assert_allclose(sol.qd[i], qd, rtol=0, atol=20 * tol * max(1.0, np.abs(qd).max()))


def test_taylor_on_the_pendulum_scene_keeps_the_elliptic_period():
    # From rest at θ₀, back at θ₀ after T = 4 K(sin(θ₀/2)) √(l/g) (K by the AGM).
    l, g, theta0 = 1.5, 9.81, 2.0
    k = math.sin(theta0 / 2.0)
    a, b = 1.0, math.sqrt(1.0 - k * k)
    while abs(a - b) > 1e-16 * a:
        a, b = (a + b) / 2.0, math.sqrt(a * b)
    period = 4.0 * (math.pi / (2.0 * a)) * math.sqrt(l / g)
    model = lg.scenes.simple_pendulum(m=1.0, l=l, g=g)
    sol = model.simulate([theta0], [0.0], period, method="taylor", rtol=1e-13, atol=1e-13)
    assert abs(sol.q[-1, 0] - theta0) < 1e-10
    assert abs(sol.qd[-1, 0]) < 1e-10


@pytest.mark.parametrize("name", ["double_pendulum", "damped_oscillator", "henon_heiles"])
def test_every_method_runs_on_a_scene(name):
    # Each registered method runs and agrees with a tight DOP853 run, or refuses with its reason
    # (the explicit splittings on a system that is not separable, the symplectic methods on a
    # dissipative one).
    model = getattr(lg.scenes, name)()
    n = len(model.coordinates)
    q0, qd0 = [0.5, -0.3][:n], [0.0, 0.2][:n]
    ref = model.simulate(q0, qd0, 1.0, method="dop853", rtol=1e-12, atol=1e-12)
    ran = []
    for method in lg.methods():
        _, adaptive, _ = _lagrangian.method_info(method)
        step = {"dt": 1e-3} if adaptive is False else {"rtol": 1e-9, "atol": 1e-9}
        try:
            sol = model.simulate(q0, qd0, 1.0, method=method, **step)
        except ValueError as e:
            assert "cannot integrate this system" in str(e), (method, e)
            assert method not in ("taylor", "auto", "dop853", "radau5", "gauss6"), (method, e)
            continue
        assert_allclose(sol.q[-1], ref.q[-1], atol=1e-3)
        ran.append(method)
    assert "taylor" in ran
    if name == "henon_heiles":
        assert ran == lg.methods()
