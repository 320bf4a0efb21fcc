"""``Model.fit``: parameters recovered from noisy synthetic data within the uncertainty the fit
reports, the covariance against its definition, weights, bounds, several trials, the initial
state, and every bad input refused with a clear error (never NaN)."""

import math

import numpy as np
import pytest

import lagrangian as lg

pytest.importorskip("scipy")


def damped(k=4.0, c=0.3, m=1.0):
    x, = lg.coordinates("x")
    pm, pk, pc = lg.parameters("m k c")
    return lg.Model([x], kinetic=0.5 * pm * x.d**2, potential=0.5 * pk * x**2,
                    dissipation=0.5 * pc * x.d**2, parameters={"m": m, "k": k, "c": c})


def two_mass():
    x1, x2 = lg.coordinates("x1 x2")
    m1, m2, k1, k2, f1, w = lg.parameters("m1 m2 k1 k2 F1 Omega")
    return lg.Model([x1, x2], kinetic=0.5 * m1 * x1.d**2 + 0.5 * m2 * x2.d**2,
                    potential=0.5 * k1 * x1**2 + 0.5 * k2 * (x2 - x1) ** 2,
                    forces=[f1 * lg.cos(w * lg.t), 0.0],
                    parameters=dict(m1=1.0, m2=0.5, k1=10.0, k2=5.0, F1=1.0, Omega=2.0))


T = np.linspace(0.0, 15.0, 200)


def record(model, q0=(1.0,), qd0=(0.0,), t=T):
    return model.simulate(list(q0), list(qd0), float(t[-1]), t0=float(t[0]), t_eval=t,
                          rtol=1e-12, atol=1e-12).q


def test_exact_data_are_recovered_to_the_tolerance():
    data = record(damped())
    fit = damped(k=3.0, c=0.1).fit(T, data, {"k": 3.0, "c": 0.1}, q0=[1.0], qd0=[0.0])
    assert fit.success
    assert abs(fit.parameters["k"] - 4.0) < 1e-7 and abs(fit.parameters["c"] - 0.3) < 1e-7
    assert fit.cost < 1e-14
    assert list(fit.parameters) == ["k", "c"]
    assert fit.model.parameters["k"] == fit.parameters["k"]


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_noisy_data_within_the_reported_uncertainty(seed):
    rng = np.random.default_rng(seed)
    sigma = 0.01
    data = record(damped()) + sigma * rng.standard_normal((len(T), 1))
    fit = damped().fit(T, data, {"k": 3.0, "c": 0.1}, q0=[1.0], qd0=[0.0],
                       bounds={"c": (0.0, np.inf)})
    assert fit.success
    for name, truth in (("k", 4.0), ("c", 0.3)):
        assert abs(fit.parameters[name] - truth) < 4.0 * fit.uncertainties[name]
    # The residual variance estimates the noise's: s² = 2 cost / (m − p) ≈ σ².
    s2 = 2.0 * fit.cost / (len(T) - 2)
    assert 0.6 * sigma**2 < s2 < 1.6 * sigma**2
    # Every number finite.
    assert np.isfinite(fit.covariance).all() and np.isfinite(fit.residuals).all()


def test_covariance_is_s2_times_the_inverse_of_jtj():
    rng = np.random.default_rng(5)
    model = damped()
    data = record(model) + 0.01 * rng.standard_normal((len(T), 1))
    fit = model.fit(T, data, {"k": 3.5, "c": 0.2}, q0=[1.0], qd0=[0.0])
    # J from the sensitivities at the solution, as the fit's own definition says.
    sol = fit.model.simulate([1.0], [0.0], float(T[-1]), t_eval=T, rtol=1e-10, atol=1e-10,
                             sensitivities=["k", "c"])
    jac = np.column_stack([sol.sensitivities["k"][:, 0], sol.sensitivities["c"][:, 0]])
    r = (sol.q - data).ravel()
    s2 = r @ r / (len(T) - 2)
    expected = s2 * np.linalg.inv(jac.T @ jac)
    np.testing.assert_allclose(fit.covariance, expected, rtol=1e-6)
    assert math.isclose(fit.uncertainties["k"], math.sqrt(expected[0, 0]), rel_tol=1e-6)


def test_forced_two_mass_springs_from_both_coordinates():
    rng = np.random.default_rng(11)
    t = np.linspace(0.0, 10.0, 300)
    model = two_mass()
    data = record(model, (0.0, 0.0), (0.0, 0.0), t) + 0.002 * rng.standard_normal((300, 2))
    fit = model.fit(t, data, {"k1": 8.0, "k2": 6.0}, q0=[0.0, 0.0], qd0=[0.0, 0.0],
                    bounds={"k1": (0.0, np.inf), "k2": (0.0, np.inf)})
    assert fit.success
    assert abs(fit.parameters["k1"] - 10.0) < 4 * fit.uncertainties["k1"]
    assert abs(fit.parameters["k2"] - 5.0) < 4 * fit.uncertainties["k2"]
    assert fit.residuals.shape == (300, 2)


def test_weights_leave_samples_out_and_scale_residuals():
    data = record(damped())
    corrupt = data.copy()
    corrupt[50:60] += 5.0  # outliers, weighted out
    w = np.ones_like(data)
    w[50:60] = 0.0
    fit = damped().fit(T, corrupt, {"k": 3.0, "c": 0.1}, q0=[1.0], qd0=[0.0], weights=w)
    assert abs(fit.parameters["k"] - 4.0) < 1e-6
    assert np.all(fit.residuals[50:60] == 0.0)
    # A scalar weight scales the residuals and the cost, not the solution.
    fit2 = damped().fit(T, data, {"k": 3.0, "c": 0.1}, q0=[1.0], qd0=[0.0], weights=3.0)
    assert abs(fit2.parameters["k"] - 4.0) < 1e-7


def test_bounds_hold_the_parameters():
    rng = np.random.default_rng(3)
    data = record(damped(c=0.0)) + 0.02 * rng.standard_normal((len(T), 1))
    fit = damped().fit(T, data, {"k": 3.0, "c": 0.1}, q0=[1.0], qd0=[0.0],
                       bounds={"c": (0.0, 1.0)})
    assert 0.0 <= fit.parameters["c"] <= 1.0


def test_several_trials_at_once():
    model = damped()
    t2 = np.linspace(0.0, 8.0, 120)
    a = record(model, (1.0,), (0.0,))
    b = record(model, (0.0,), (2.0,), t2)
    fit = damped(k=3.0, c=0.1).fit([T, t2], [a, b], {"k": 3.0, "c": 0.1},
                                   q0=[[1.0], [0.0]], qd0=[[0.0], [2.0]])
    assert fit.success
    assert abs(fit.parameters["k"] - 4.0) < 1e-7 and abs(fit.parameters["c"] - 0.3) < 1e-7
    assert [r.shape for r in fit.residuals] == [(200, 1), (120, 1)]
    assert len(fit.initial_states) == 2


def test_initial_state_fitted_too():
    data = record(damped(), (1.2,), (-0.4,))
    fit = damped().fit(T, data, {"k": 3.5, "c": 0.2}, q0=[1.0], qd0=[0.0],
                       fit_initial_state=True)
    (q0, qd0), = fit.initial_states
    assert abs(q0[0] - 1.2) < 1e-7 and abs(qd0[0] + 0.4) < 1e-7
    assert abs(fit.parameters["k"] - 4.0) < 1e-7
    assert fit.covariance.shape == (4, 4)


def test_no_convergence_says_so():
    data = record(damped())
    fit = damped().fit(T, data, {"k": 1.0, "c": 2.0}, q0=[1.0], qd0=[0.0], max_nfev=1)
    assert not fit.success
    assert "did not converge" in fit.message
    assert math.isfinite(fit.cost)


def test_plot_draws_data_fit_and_residuals(tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    fit = damped().fit(T, record(damped()), {"k": 3.0, "c": 0.1}, q0=[1.0], qd0=[0.0])
    fig = fit.plot(tmp_path / "fit.png")
    assert len(fig.axes) == 2
    assert (tmp_path / "fit.png").read_bytes().startswith(b"\x89PNG")


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(parameters={"mass": 1.0}), "not a parameter"),
        (dict(parameters={}), "parameters"),
        (dict(bounds={"k": (5.0, 6.0)}), "outside its bounds"),
        (dict(bounds={"k": (6.0, 5.0)}), "below high"),
        (dict(bounds={"m": (0.0, 2.0)}), "not among"),
        (dict(q0=None), "q0 and qd0"),
        (dict(q0=[1.0, 2.0]), "entries"),
        (dict(weights=-1.0), "≥ 0"),
        (dict(weights=np.ones(3)), "broadcast"),
    ],
)
def test_bad_input(kwargs, match):
    args = dict(parameters={"k": 3.0, "c": 0.1}, q0=[1.0], qd0=[0.0])
    args.update(kwargs)
    params = args.pop("parameters")
    with pytest.raises(ValueError, match=match):
        damped().fit(T, record(damped()), params, **args)


def test_bad_data():
    data = record(damped())
    bad = data.copy()
    bad[3, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        damped().fit(T, bad, {"k": 3.0}, q0=[1.0], qd0=[0.0])
    with pytest.raises(ValueError, match="shape"):
        damped().fit(T, data[:-1], {"k": 3.0}, q0=[1.0], qd0=[0.0])
    with pytest.raises(ValueError, match="increasing"):
        damped().fit(T[::-1], data, {"k": 3.0}, q0=[1.0], qd0=[0.0])
    with pytest.raises(ValueError, match="more samples"):
        damped().fit(T[:2], data[:2], {"k": 3.0, "c": 0.1}, q0=[1.0], qd0=[0.0])
    with pytest.raises(ValueError, match="trials"):
        damped().fit([T, T], [data], {"k": 3.0}, q0=[[1.0], [1.0]], qd0=[[0.0], [0.0]])


def test_undetermined_parameter_refused():
    # m and k enter only as k/m in a free oscillation from rest: JᵀJ is singular.
    data = record(damped(c=0.0))
    with pytest.raises(ValueError, match="do not determine"):
        damped(c=0.0).fit(T, data, {"k": 4.0, "m": 1.0}, q0=[1.0], qd0=[0.0])


def test_scene_parameters_cannot_be_fitted():
    scene = lg.scenes.damped_oscillator(m=1.0, k=4.0, c=0.3)
    data = record(scene)
    with pytest.raises(ValueError):
        scene.fit(T, data, {"k": 3.0}, q0=[1.0], qd0=[0.0])
