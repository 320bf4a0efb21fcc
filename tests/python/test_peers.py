"""The SciPy peers of the benchmarks (``benches/peers.py``): the hand-written NumPy right-hand
sides agree with the Rust scenes' accelerations, and ``run_scipy`` (``lagrangian._scipy``, which
the report runs on ``Model.rhs``) integrates them to the exact solution."""

import dataclasses
import doctest
import inspect
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import lagrangian as lg
from lagrangian import _scipy
from lagrangian._scipy import SCIPY_METHODS, run_scipy, scipy_available

# The hand-written comparators live with the benchmarks, not in the package.
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benches"))
import peers as _peers  # noqa: E402
from peers import NUMPY_SCENES, numpy_rhs  # noqa: E402

# One parameter set per case, every parameter away from special values (1, 0) so that a
# misplaced parameter shows; defaulted parameters are left out in some cases so that the
# defaults are compared too.
CASES = {
    "simple_pendulum": dict(m=1.5, l=2.0, g=9.81),
    "double_pendulum": dict(m1=1.3, m2=0.7, l1=1.1, l2=0.8, g=9.81),
    "n_pendulum_1": dict(masses=[1.7], lengths=[0.6], g=9.81),
    "n_pendulum_3": dict(masses=[1.0, 0.5, 0.8], lengths=[1.2, 0.7, 0.9], g=9.81),
    "n_pendulum_6": dict(
        masses=[1.0, 0.5, 0.8, 1.2, 0.3, 0.9], lengths=[1.0, 0.7, 0.9, 0.5, 1.1, 0.6], g=3.7
    ),
    "forced_two_mass": dict(m1=1.3, m2=2.1, k1=3.0, k2=5.5, f1=0.5, f2=-0.3, omega=1.7),
    "forced_two_mass_free": dict(m1=1.3, m2=2.1, k1=3.0, k2=5.5),
    "rolling_cylinder": dict(m=2.0, j=0.3, r=0.4, g=9.81, alpha=0.3),
    "ball_in_sphere": dict(m=1.1, j=0.0044, r1=1.3, r2=0.1, g=9.81),
    "damped_oscillator": dict(m=2.0, k=8.0, c=0.4),
    "kepler": dict(m=1.5, mu=2.3),
    "elastic_pendulum": dict(m=1.2, k=20.0, l0=1.1, g=9.81, c=0.3),
    "elastic_pendulum_undamped": dict(m=1.2, k=20.0, l0=1.1, g=9.81),
    "henon_heiles": dict(),
    "driven_pendulum": dict(m=1.4, l=0.9, g=9.81, a=0.1, omega=30.0),
    "charged_particle": dict(m=1.3, e=2.0, b=1.5, ex=0.3, ey=-0.2),
    "charged_particle_no_e_field": dict(m=1.3, e=-2.0, b=1.5),
    "spatial_chain": dict(masses=[1.0, 0.6, 1.4, 0.8], lengths=[0.9, 1.2, 0.5, 0.7],
                          radius=0.1, g=3.7),
}

STATICS = {"lever", "differential_pulley", "rhombus_link", "spring_rhombus", "two_springs"}


def scene_of(case):
    """The scene a case of CASES is of: its name, or its name and a suffix."""
    return next(s for s in NUMPY_SCENES if case == s or case.startswith(s + "_"))


def random_states(model, scene, seed, count=8):
    """(t, q, q̇) drawn uniformly; radii (Kepler's x, the spring length r) kept away from 0."""
    rng = np.random.default_rng(seed)
    n = model.dof
    for _ in range(count):
        t = rng.uniform(0.0, 5.0)
        q = rng.uniform(-2.5, 2.5, n)
        qd = rng.uniform(-3.0, 3.0, n)
        if scene in ("kepler", "elastic_pendulum"):
            q[0] = rng.uniform(0.5, 2.0) * rng.choice([-1.0, 1.0])
        if scene == "elastic_pendulum":
            q[0] = abs(q[0])
        yield t, q, qd


# -- the right-hand sides ----------------------------------------------------------------------


def test_numpy_scenes_are_the_dynamic_scenes():
    assert set(NUMPY_SCENES) == set(lg.scenes.__all__) - STATICS
    assert {scene_of(case) for case in CASES} == set(NUMPY_SCENES)


@pytest.mark.parametrize("scene", NUMPY_SCENES)
def test_numpy_rhs_parameters_match_scene_signature(scene):
    ours = inspect.signature(_peers._BUILDERS[scene]).parameters
    theirs = inspect.signature(getattr(lg.scenes, scene)).parameters
    assert list(ours) == list(theirs)
    # The scenes have defaults (the comparators, benchmark code, take every value explicitly):
    # the comparator built from the scene's defaults is the scene built with no arguments.
    defaults = {k: p.default for k, p in theirs.items()}
    assert inspect.Parameter.empty not in defaults.values()
    model = getattr(lg.scenes, scene)()
    f = numpy_rhs(scene, **defaults)
    for t, q, qd in random_states(model, scene, seed=7, count=3):
        a = model.accelerations(t, q, qd)
        dy = f(t, np.concatenate([q, qd]))
        assert_allclose(dy[model.dof :], a, rtol=1e-12, atol=1e-12 * np.max(np.abs(a)))


@pytest.mark.parametrize("case", sorted(CASES))
def test_numpy_rhs_matches_scene_accelerations(case):
    # f(t, y) = (q̇, q̈) with q̈ = model.accelerations: the q̇ half is copied, so exactly equal;
    # q̈ to 1e-12 of the largest component (a componentwise 1e-12 would fail on components that
    # nearly cancel, where two correct solvers of M q̈ = rhs differ by the rounding of M's
    # solve relative to ‖q̈‖).
    scene, params = scene_of(case), CASES[case]
    model = getattr(lg.scenes, scene)(**params)
    f = numpy_rhs(scene, **params)
    n = model.dof
    for t, q, qd in random_states(model, scene, seed=20240611):
        dy = f(t, np.concatenate([q, qd]))
        assert dy.shape == (2 * n,) and dy.dtype == np.float64
        assert_array_equal(dy[:n], qd)
        a = model.accelerations(t, q, qd)
        assert_allclose(dy[n:], a, rtol=1e-12, atol=1e-12 * np.max(np.abs(a)))


def test_numpy_rhs_time_dependence_is_real():
    # The forced and driven scenes depend on t: a rhs that ignored t would pass the comparison
    # above only if t did not matter, so check it does.
    for case, y in (("forced_two_mass", [0.4, -0.3, 0.2, 0.1]), ("driven_pendulum", [0.4, 0.2])):
        f = numpy_rhs(case, **CASES[case])
        assert not np.allclose(f(0.0, np.array(y)), f(0.37, np.array(y)))


def test_numpy_rhs_double_pendulum_equals_two_link_chain():
    p = CASES["double_pendulum"]
    dp = numpy_rhs("double_pendulum", **p)
    chain = numpy_rhs(
        "n_pendulum", masses=[p["m1"], p["m2"]], lengths=[p["l1"], p["l2"]], g=p["g"]
    )
    for y in ([0.3, -0.4, 0.0, 0.0], [1.0, 0.5, 0.3, -0.2], [-2.0, 2.5, 3.0, -4.0]):
        assert_allclose(chain(0.0, np.array(y)), dp(0.0, np.array(y)), rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("scene", ["nope", "lever", "two_springs", "Simple_Pendulum"])
def test_numpy_rhs_unknown_scene_rejected(scene):
    with pytest.raises(ValueError, match="no scene"):
        numpy_rhs(scene, m=1.0)


def test_numpy_rhs_missing_parameter_rejected():
    with pytest.raises(ValueError, match="missing g"):
        numpy_rhs("simple_pendulum", m=1.0, l=1.0)
    with pytest.raises(ValueError, match="missing masses, lengths"):
        numpy_rhs("n_pendulum", g=9.81)


def test_numpy_rhs_extra_parameter_rejected():
    with pytest.raises(ValueError, match="does not take x"):
        numpy_rhs("henon_heiles", x=1.0)
    with pytest.raises(ValueError, match="missing g and does not take gravity"):
        numpy_rhs("simple_pendulum", m=1.0, l=1.0, gravity=9.81)


@pytest.mark.parametrize(
    "scene, params, match",
    [
        ("simple_pendulum", dict(m=1.0, l=0.0, g=9.81), "l = 0.0 must be positive"),
        ("damped_oscillator", dict(m=-2.0, k=1.0, c=0.0), "m = -2.0 must be positive"),
        ("kepler", dict(m=1.0, mu=math.nan), "not finite"),
        ("ball_in_sphere", dict(m=1.0, j=0.1, r1=0.1, r2=0.1, g=9.81), "r1 = 0.1 must exceed"),
        ("rolling_cylinder", dict(m=1.0, j=-0.1, r=0.1, g=9.81, alpha=0.2), "j = -0.1"),
        ("n_pendulum", dict(masses=[1.0, 2.0], lengths=[1.0], g=9.81), "one length per mass"),
        ("n_pendulum", dict(masses=[], lengths=[], g=9.81), "one length per mass"),
        ("n_pendulum", dict(masses=[1.0, 0.0], lengths=[1.0, 1.0], g=9.81), "masses = 0.0"),
    ],
)
def test_numpy_rhs_bad_values_rejected(scene, params, match):
    with pytest.raises(ValueError, match=match):
        numpy_rhs(scene, **params)


def test_numpy_rhs_non_number_rejected():
    with pytest.raises(TypeError, match="g must be a real number"):
        numpy_rhs("simple_pendulum", m=1.0, l=1.0, g="9.81")


# -- SciPy -------------------------------------------------------------------------------------


def damped_exact(m, k, c, x0, v0, t):
    """The under-damped solution of m ẍ + c ẋ + k x = 0 (seed eq. 55)."""
    gamma = c / (2.0 * m)
    w0 = math.sqrt(k / m)
    wd = math.sqrt(w0 * w0 - gamma * gamma)
    decay = math.exp(-gamma * t)
    f, g = math.cos(wd * t), math.sin(wd * t) / wd
    return (
        decay * (x0 * f + (v0 + gamma * x0) * g),
        decay * (v0 * f - (w0 * w0 * x0 + gamma * v0) * g),
    )


def test_scipy_available_reports_installed_scipy():
    try:
        import scipy.integrate  # noqa: F401
    except ImportError:
        assert not scipy_available()
    else:
        assert scipy_available()


@pytest.mark.parametrize("method", SCIPY_METHODS)
def test_run_scipy_damped_oscillator_converges_to_exact(method):
    # Over 10 time units (≈ 3 periods) the global error of every method stays within 100×rtol
    # (measured: 0.5–20×); the tight run proves the error follows the tolerance down.
    pytest.importorskip("scipy")
    m, k, c = 2.0, 8.0, 0.4
    f = numpy_rhs("damped_oscillator", m=m, k=k, c=c)
    x, v = damped_exact(m, k, c, 1.0, 0.5, 10.0)
    for rtol in (1e-6, 1e-10):
        run = run_scipy(f, [1.0], [0.5], 10.0, method, rtol=rtol, atol=1e-2 * rtol)
        assert run.success and run.message
        assert (run.method, run.rtol, run.atol, run.t) == (method, rtol, 1e-2 * rtol, 10.0)
        assert run.q.shape == (1,) and run.qd.shape == (1,)
        err = max(abs(run.q[0] - x), abs(run.qd[0] - v))
        assert err < 100.0 * rtol, (method, rtol, err)
        assert run.steps >= 1 and run.nfev > run.steps
        if method in ("RK45", "DOP853"):
            # FSAL pairs: 2 evaluations to start, 6 (RK45) or 12 (DOP853) per attempted step,
            # so `steps` counts accepted steps, not evaluations.
            per_step = 6 if method == "RK45" else 12
            assert run.nfev >= 2 + per_step * run.steps and run.njev == 0
        if method == "Radau":
            assert run.njev >= 1


def test_run_scipy_starts_at_t0():
    # The oscillator is autonomous: from t0 = 3 to 13 it moves as from 0 to 10.
    pytest.importorskip("scipy")
    f = numpy_rhs("damped_oscillator", m=2.0, k=8.0, c=0.4)
    run = run_scipy(f, [1.0], [0.5], 13.0, "DOP853", rtol=1e-11, atol=1e-13, t0=3.0)
    x, v = damped_exact(2.0, 8.0, 0.4, 1.0, 0.5, 10.0)
    assert run.t == 13.0
    assert_allclose([run.q[0], run.qd[0]], [x, v], rtol=0, atol=1e-9)


def test_run_scipy_charged_particle_circle():
    # Two coordinates and a gyroscopic force: with E = 0 the orbit is a circle of radius
    # |v0|/|ω_c| about q0 + (v0y, −v0x)/ω_c, and after one period 2π/ω_c the state returns.
    pytest.importorskip("scipy")
    m, e, b = 1.3, 2.0, 1.5
    wc = e * b / m
    f = numpy_rhs("charged_particle", m=m, e=e, b=b)
    run = run_scipy(f, [0.2, -0.1], [0.7, 0.4], 2.0 * math.pi / wc, "DOP853", 1e-11, 1e-13)
    assert_allclose(run.q, [0.2, -0.1], atol=1e-9)
    assert_allclose(run.qd, [0.7, 0.4], atol=1e-9)


def test_run_scipy_repeats_give_one_median_time():
    pytest.importorskip("scipy")
    f = numpy_rhs("henon_heiles")
    one = run_scipy(f, [0.1, 0.0], [0.0, 0.3], 5.0, "RK45", 1e-8, 1e-10)
    three = run_scipy(f, [0.1, 0.0], [0.0, 0.3], 5.0, "RK45", 1e-8, 1e-10, repeats=3)
    # solve_ivp is deterministic: repeating changes the timing only.
    assert_array_equal(three.q, one.q)
    assert (three.nfev, three.steps) == (one.nfev, one.steps)
    assert math.isfinite(three.seconds) and three.seconds >= 0.0


def test_run_scipy_failed_solve_is_returned():
    # q̈ = 2 q³ from q = q̇ = 1 is q = 1/(1 − t), which blows up at t = 1: the step size
    # underflows and solve_ivp gives up. (LSODA is left out: on this problem SciPy 1.17's LSODA
    # keeps evaluating at a fixed t and never returns.)
    pytest.importorskip("scipy")

    def blow_up(t, y):
        q, v = y.tolist()
        return np.array([v, 2.0 * q**3])

    run = run_scipy(blow_up, [1.0], [1.0], 2.0, "RK45", 1e-8, 1e-10)
    assert not run.success
    assert "step size" in run.message
    assert 0.99 < run.t < 1.0 + 1e-6
    assert run.q[0] > 1e6


def test_run_scipy_result_is_frozen():
    pytest.importorskip("scipy")
    run = run_scipy(numpy_rhs("henon_heiles"), [0.1, 0.0], [0.0, 0.3], 1.0, "RK45", 1e-6, 1e-9)
    with pytest.raises(dataclasses.FrozenInstanceError):
        run.seconds = 0.0


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(method="BDF"), "not one of RK45, DOP853, Radau, LSODA"),
        (dict(method="rk45"), "not one of"),
        (dict(qd0=[0.0, 1.0]), "same, non-zero length"),
        (dict(q0=[], qd0=[]), "same, non-zero length"),
        (dict(q0=[math.inf]), r"q0\[0\] = inf is not finite"),
        (dict(rtol=0.0), "must be positive"),
        (dict(atol=-1e-9), "must be positive"),
        (dict(repeats=0), "repeats = 0"),
        (dict(repeats=1.5), "repeats = 1.5"),
        (dict(t_end=math.nan), "t_end = nan is not finite"),
    ],
)
def test_run_scipy_bad_input_rejected(kwargs, match):
    pytest.importorskip("scipy")
    args = dict(
        rhs=numpy_rhs("damped_oscillator", m=1.0, k=1.0, c=0.0),
        q0=[1.0], qd0=[0.0], t_end=1.0, method="RK45", rtol=1e-6, atol=1e-9,
    )
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        run_scipy(**args)


def test_run_scipy_without_scipy_names_the_install(monkeypatch):
    # A None entry in sys.modules makes the import fail as if SciPy were not installed.
    monkeypatch.setitem(sys.modules, "scipy", None)
    monkeypatch.setitem(sys.modules, "scipy.integrate", None)
    assert not scipy_available()
    f = numpy_rhs("damped_oscillator", m=1.0, k=1.0, c=0.0)
    with pytest.raises(ImportError, match="pip install scipy"):
        run_scipy(f, [1.0], [0.0], 1.0, "RK45", 1e-6, 1e-9)


@pytest.mark.parametrize("module", [_peers, _scipy], ids=["benches.peers", "lagrangian._scipy"])
def test_peers_docstring_examples_run(module):
    pytest.importorskip("scipy")
    result = doctest.testmod(module)
    assert result.attempted > 0 and result.failed == 0
