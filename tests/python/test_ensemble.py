"""Ensembles (``Model.simulate_many``): pendulum periods against the elliptic integral (from
``t_eval`` output and from events), every run bit for bit ``simulate``'s (1 and 2 threads, a
thread pool, a process pool, a Dask LocalCluster; with events and resets), events that read a
swept parameter against closed forms, a forced oscillator's resonance curve against the closed
form, failed runs marked with their typed error and nothing but what they computed, and the
checks."""

import math
import os
import signal
import threading
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
import multiprocessing

import numpy as np
import pytest
from scipy.special import ellipk

import lagrangian as lg
from conftest import double_pendulum_dsl

G = 9.81


def pendulum(l=1.0):
    th, = lg.coordinates("th")
    m, pl, g = lg.parameters("m l g")
    return lg.Model(coordinates=[th], kinetic=0.5 * m * pl**2 * th.d**2,
                    potential=-m * g * pl * lg.cos(th),
                    parameters={"m": 1.0, "l": l, "g": G})


def forced_oscillator():
    """m ẍ + c ẋ + k x = F cos(w t)."""
    x, = lg.coordinates("x")
    m, k, c, f, w = lg.parameters("m k c F w")
    return lg.Model(coordinates=[x], kinetic=0.5 * m * x.d**2, potential=0.5 * k * x**2,
                    dissipation=0.5 * c * x.d**2, forces=[f * lg.cos(w * lg.t)],
                    parameters={"m": 1.0, "k": 4.0, "c": 0.4, "F": 1.0, "w": 1.0})


def crossings(t, q, qd):
    """The times where q changes sign, each the root of the cubic Hermite interpolant of
    (q, q̇) on its sampling interval (Newton from the linear estimate)."""
    i = np.flatnonzero(np.sign(q[:-1]) * np.sign(q[1:]) < 0)
    h = t[i + 1] - t[i]
    s = q[i] / (q[i] - q[i + 1])  # linear estimate, as a fraction of the interval
    for _ in range(8):
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        p = h00 * q[i] + h10 * h * qd[i] + h01 * q[i + 1] + h11 * h * qd[i + 1]
        dp = ((6 * s**2 - 6 * s) * q[i] + (3 * s**2 - 4 * s + 1) * h * qd[i]
              + (-6 * s**2 + 6 * s) * q[i + 1] + (3 * s**2 - 2 * s) * h * qd[i + 1])
        s = s - p / dp
    return t[i] + s * h


def test_pendulum_periods_match_the_elliptic_integral():
    # 1000 pendulums released at rest from amplitudes over (0.1, 3.0): T = 4 √(l/g) K(sin²(θ₀/2)).
    l = 1.3
    model = pendulum(l)
    theta0 = np.linspace(0.1, 3.0, 1002)[1:-1]
    t = np.linspace(0.0, 12.0, 1201)
    ens = model.simulate_many(theta0[:, None], [0.0], 12.0, t_eval=t, method="dop853",
                              rtol=1e-11, atol=1e-12)
    assert ens.ok.all() and ens.q.shape == (1000, 1201, 1)
    exact = 4 * math.sqrt(l / G) * ellipk(np.sin(theta0 / 2) ** 2)
    assert exact.max() / exact.min() > 2.4  # the amplitudes reach far into the nonlinear range
    for i in range(1000):
        z = crossings(t, ens.q[i, :, 0], ens.qd[i, :, 0])
        assert len(z) >= 4, i
        period = 2 * (z[-1] - z[0]) / (len(z) - 1)
        assert abs(period - exact[i]) < 1e-8 * exact[i], (i, period, exact[i])
        assert abs(z[0] - exact[i] / 4) < 1e-8 * exact[i], i


def test_pendulum_periods_from_events_with_final_states_only():
    # The same sweep with an event where θ falls through zero and only the final states kept:
    # the crossings are at T/4 + jT.
    l = 0.9
    model = pendulum(l)
    th = model.coordinates[0]
    theta0 = np.linspace(0.1, 3.0, 1002)[1:-1]
    down = lg.Event(th, direction=-1, name="down")
    ens = model.simulate_many(theta0[:, None], [0.0], 12.0, events=[down], final_only=True,
                              method="dop853", rtol=1e-12, atol=1e-12)
    assert ens.ok.all() and ens.event_names == ("down",) and ens.q.shape == (1000, 1)
    exact = 4 * math.sqrt(l / G) * ellipk(np.sin(theta0 / 2) ** 2)
    counts = np.floor((12.0 - exact / 4) / exact).astype(int) + 1
    assert np.array_equal(ens.event_counts[:, 0], counts)
    for i in range(1000):
        t = ens.t_events[0][i]
        expected = exact[i] / 4 + exact[i] * np.arange(counts[i])
        assert np.max(np.abs(t - expected)) < 1e-9 * exact[i], i
        assert np.max(np.abs(ens.q_events[0][i])) < 1e-12 and (ens.qd_events[0][i] < 0).all()


def test_events_that_read_a_swept_parameter():
    # A ball dropped from h = 1 onto a floor that sends it back up at √(2 g h), with g swept:
    # the reset reads g, so each run binds its own value. It lands at √(2h/g) (1 + 2j).
    y, = lg.coordinates("y")
    g, = lg.parameters("g")
    ball = lg.Model(coordinates=[y], kinetic=0.5 * y.d**2, potential=g * y,
                    parameters={"g": G})
    floor = lg.Event(y, direction=-1, reset={y.d: lg.sqrt(2 * g * 1.0)}, name="floor")
    gravity = np.linspace(1.0, 20.0, 7)
    ens = ball.simulate_many([1.0], [0.0], 6.0, parameters={"g": gravity}, events=[floor],
                             final_only=True, rtol=1e-12, atol=1e-12)
    assert ens.ok.all()
    for i, gi in enumerate(gravity):
        t = ens.t_events[0][i]
        j = np.arange(len(t))
        exact = math.sqrt(2.0 / gi) * (1 + 2 * j)
        assert len(t) == np.floor((6.0 / math.sqrt(2.0 / gi) - 1) / 2) + 1
        assert np.max(np.abs(t - exact)) < 1e-9, (gi, t, exact)
        assert np.allclose(ens.qd_events[0][i][:, 0], -math.sqrt(2 * gi), rtol=1e-10)
        alone = ball.with_parameters(g=gi).simulate([1.0], [0.0], 6.0, events=[floor],
                                                     rtol=1e-12, atol=1e-12)
        assert np.array_equal(alone.t_events[0], t)
    # A terminal threshold in a scene's swept length: θ = θ₀ l₀ / l stops each run (status 1).
    scene = lg.scenes.simple_pendulum(m=1.0, l=1.0, g=G)
    th, = scene.coordinates
    length, = lg.parameters("l")
    stop = lg.Event(th - 0.5 / length, direction=-1, terminal=True, name="stop")
    lengths = np.array([1.0, 2.0, 4.0])
    ens = scene.simulate_many([1.0], [0.0], 10.0, parameters={"l": lengths}, events=[stop],
                              t_eval=np.linspace(0.0, 10.0, 11), rtol=1e-12, atol=1e-12)
    assert ens.status.tolist() == [1, 1, 1] and ens.ok.all()
    for i, li in enumerate(lengths):
        assert abs(ens.q_events[0][i][0, 0] - 0.5 / li) < 1e-12
        sol = scene.with_parameters(l=li).simulate([1.0], [0.0], 10.0, events=[stop],
                                                   t_eval=np.linspace(0.0, 10.0, 11),
                                                   rtol=1e-12, atol=1e-12)
        assert sol.status == 1 and ens.solution(i).message == sol.message
        assert np.array_equal(sol.t_events[0], ens.t_events[0][i])
        assert ens.reached[i] == len(sol.t) < 11
        # The rows past the stop are masked, not zeros posing as states.
        assert ens.q.mask[i, ens.reached[i]:].all() and not ens.q.mask[i, :ens.reached[i]].any()
        assert np.array_equal(ens.q[i, :ens.reached[i]], sol.q)


@pytest.mark.parametrize("workers", [1, 2])
def test_runs_with_events_are_simulate_bit_for_bit(hundred, workers):
    # A recorded event, a terminal one at its second occurrence and a reset: every run as
    # simulate gives it, with a parameter swept and without.
    model, q0, qd0 = hundred
    th1, th2 = model.coordinates
    l2, = lg.parameters("l2")
    events = [
        lg.Event(th1 - th2, name="cross"),
        lg.Event(th2.d, direction=1, terminal=2, name="turn"),
        lg.Event(th1 - 2.0, direction=1, reset={th1.d: -th1.d}, name="wall"),
    ]
    ens = model.simulate_many(q0, qd0, 5.0, events=events, rtol=1e-9, atol=1e-11,
                              workers=workers)
    lengths = np.linspace(0.5, 1.5, 100)
    swept = model.simulate_many(q0, qd0, 5.0, events=events + [lg.Event(th2 - l2, name="l2")],
                                parameters={"l2": lengths}, rtol=1e-9, atol=1e-11,
                                workers=workers)
    assert (ens.status == 1).sum() > 10 and (ens.status == 0).sum() > 10
    assert ens.event_counts[:, 2].sum() > 0 and swept.event_counts[:, 3].sum() > 0
    for i in range(100):
        assert_same(ens, i, model.simulate(q0[i], qd0[i], 5.0, events=events, rtol=1e-9,
                                           atol=1e-11))
        assert_same(swept, i, model.with_parameters(l2=lengths[i]).simulate(
            q0[i], qd0[i], 5.0, events=events + [lg.Event(th2 - l2, name="l2")], rtol=1e-9,
            atol=1e-11))


def test_failed_runs_have_no_events_and_the_rest_do():
    model = pendulum()
    th = model.coordinates[0]
    m = lg.parameters("m")[0]
    up = lg.Event(th.d * m, direction=1, name="up")  # reads the swept mass
    ens = model.simulate_many([1.0], [0.0], 3.0, parameters={"m": [1.0, 0.0, 2.0]},
                              events=[up], final_only=True, rtol=1e-10, atol=1e-12)
    assert ens.status.tolist() == [0, -1, 0]
    assert ens.failures[1].error == "SingularMassMatrixError"
    assert ens.event_counts[:, 0].tolist() == [1, 0, 1]
    assert ens.t_events[0][1].shape == (0,) and ens.q_events[0][1].shape == (0, 1)
    # θ̇ rises through zero at T/2, whatever the mass.
    half = 2 * math.sqrt(1.0 / G) * ellipk(math.sin(0.5) ** 2)
    assert abs(ens.t_events[0][0][0] - half) < 1e-9 and abs(ens.t_events[0][2][0] - half) < 1e-9
    with pytest.raises(TypeError, match="sequence of lagrangian.Event"):
        model.simulate_many([1.0], [0.0], 1.0, events=up)
    with pytest.raises(ValueError, match="parameter 'L' in the event 'th - L' has no value"):
        model.simulate_many([1.0], [0.0], 1.0, events=[lg.Event(th - lg.parameters("L")[0])])


def assert_same(ens, i, sol):
    """Run i of the ensemble is `sol`, bit for bit."""
    s = ens.solution(i)
    assert np.array_equal(s.t, sol.t) and np.array_equal(s.q, sol.q), i
    assert np.array_equal(s.qd, sol.qd), i
    assert np.array_equal(s.energy, sol.energy), i
    assert s.stats == sol.stats, i
    assert s.event_names == sol.event_names, i
    for mine, theirs in ((s.t_events, sol.t_events), (s.q_events, sol.q_events),
                         (s.qd_events, sol.qd_events)):
        assert len(mine) == len(theirs) and all(map(np.array_equal, mine, theirs)), i
    assert (s.status, s.message) == (sol.status, sol.message), i


@pytest.fixture(scope="module")
def hundred():
    """A double pendulum and 100 initial states, some chaotic."""
    rng = np.random.default_rng(15)
    q0 = rng.uniform(-2.5, 2.5, (100, 2))
    qd0 = rng.uniform(-1.0, 1.0, (100, 2))
    return double_pendulum_dsl(), q0, qd0


@pytest.mark.parametrize("workers", [1, 2])
def test_every_run_is_simulate_bit_for_bit(hundred, workers):
    model, q0, qd0 = hundred
    t = np.linspace(0.0, 5.0, 51)
    steps = model.simulate_many(q0, qd0, 5.0, method="dop853", rtol=1e-8, atol=1e-10,
                                workers=workers)
    dense = model.simulate_many(q0, qd0, 5.0, t_eval=t, rtol=1e-8, atol=1e-10,
                                workers=workers)
    final = model.simulate_many(q0, qd0, 5.0, method="gauss4", dt=0.01, final_only=True,
                                workers=workers)
    assert steps.output == "steps" and dense.output == "t_eval" and final.output == "final"
    for i in range(100):
        assert_same(steps, i, model.simulate(q0[i], qd0[i], 5.0, method="dop853", rtol=1e-8,
                                             atol=1e-10))
        assert_same(dense, i, model.simulate(q0[i], qd0[i], 5.0, t_eval=t, rtol=1e-8,
                                             atol=1e-10))
        sol = model.simulate(q0[i], qd0[i], 5.0, method="gauss4", dt=0.01)
        assert final.t[i] == sol.t[-1] == 5.0
        assert np.array_equal(final.q[i], sol.q[-1]) and np.array_equal(final.qd[i], sol.qd[-1])
        assert final.run_stats(i) == sol.stats
    assert dense.stats["method"].tolist() == ["dop853"] * 100  # auto chose it for each
    assert dense.stats["choice"][0] is not None


@pytest.mark.parametrize("workers", [1, 2])
def test_taylor_runs_in_lanes_are_simulate_bit_for_bit(hundred, workers):
    # Taylor runs to their final states or to states at times go several at a time through
    # the lanes of the machine's vectors: each run is still `simulate`'s, bit for bit, with the
    # same counters — in a parameter sweep too (lanes of different g side by side), and a run
    # stopped by max_steps fails as it fails alone.
    model, q0, qd0 = hundred
    g = np.linspace(1.0, 20.0, 100)
    plain = model.simulate_many(q0, qd0, 4.0, method="taylor", rtol=1e-10, atol=1e-10,
                                final_only=True, workers=workers)
    sweep = model.simulate_many(q0, qd0, 4.0, method="taylor", rtol=1e-10, atol=1e-10,
                                parameters={"g": g}, final_only=True, workers=workers)
    t_eval = np.linspace(0.0, 4.0, 17)
    timed = model.simulate_many(q0, qd0, 4.0, method="taylor", rtol=1e-10, atol=1e-10,
                                t_eval=t_eval, parameters={"g": g}, workers=workers)
    steps = np.sort(plain.stats["accepted_steps"])
    limit = int(steps[50])
    limited = model.simulate_many(q0, qd0, 4.0, method="taylor", rtol=1e-10, atol=1e-10,
                                  max_steps=limit, final_only=True, workers=workers)
    for i in range(100):
        for ens, m in ((plain, model), (sweep, model.with_parameters(g=g[i]))):
            sol = m.simulate(q0[i], qd0[i], 4.0, method="taylor", rtol=1e-10, atol=1e-10)
            assert ens.t[i] == sol.t[-1] == 4.0
            assert np.array_equal(ens.q[i], sol.q[-1]), i
            assert np.array_equal(ens.qd[i], sol.qd[-1]), i
            assert ens.run_stats(i) == sol.stats, i
        sol = model.with_parameters(g=g[i]).simulate(q0[i], qd0[i], 4.0, method="taylor",
                                                     rtol=1e-10, atol=1e-10, t_eval=t_eval)
        assert np.array_equal(timed.q[i], sol.q) and np.array_equal(timed.qd[i], sol.qd), i
        assert timed.run_stats(i) == sol.stats, i
        assert limited.ok[i] == (plain.stats["accepted_steps"][i] <= limit), i
    assert 30 <= (~limited.ok).sum() <= 60
    failed = int(np.flatnonzero(~limited.ok)[0])
    with pytest.raises(lg.TooManyStepsError) as alone:
        model.simulate(q0[failed], qd0[failed], 4.0, method="taylor", rtol=1e-10, atol=1e-10,
                       max_steps=limit)
    assert str(limited.error(failed)) == str(alone.value)


def test_parameter_sweeps_bind_each_run(hundred):
    # A compiled model rebound per run and a scene built per run: each run as with_parameters
    # would make it, bit for bit.
    model, q0, qd0 = hundred
    g = np.linspace(1.0, 20.0, 100)
    ens = model.simulate_many(q0, qd0, 3.0, parameters={"g": g, "m2": 0.5}, rtol=1e-9,
                              workers=2)
    scene = lg.scenes.double_pendulum(1.3, 0.7, 1.1, 0.8, 9.81)
    by_scene = scene.simulate_many(q0, qd0, 3.0, parameters={"g": g, "m2": 0.5}, rtol=1e-9,
                                   final_only=True)
    for i in range(0, 100, 9):
        assert_same(ens, i, model.with_parameters(g=g[i], m2=0.5).simulate(q0[i], qd0[i], 3.0,
                                                                              rtol=1e-9))
        sol = scene.with_parameters(g=g[i], m2=0.5).simulate(q0[i], qd0[i], 3.0, rtol=1e-9)
        assert np.array_equal(by_scene.q[i], sol.q[-1])
        # The two models of the same pendulum agree to the tolerance.
        assert np.allclose(by_scene.q[i], ens.q[i][-1], rtol=0, atol=1e-5)


def test_forced_oscillator_resonance_curve():
    # m ẍ + c ẋ + k x = F cos ωt from rest: after the transient (decay rate c/2m = 0.2, e^{-16}
    # by t = 80) x = a cos ωt + b sin ωt with √(a² + b²) = F / √((k − mω²)² + (cω)²).
    model = forced_oscillator()
    w = np.linspace(0.5, 4.0, 351)
    t = np.linspace(80.0, 100.0, 401)
    ens = model.simulate_many([0.0], [0.0], 100.0, parameters={"w": w}, t_eval=t,
                              method="dop853", rtol=1e-11, atol=1e-13)
    assert ens.ok.all()
    amplitude = np.empty(len(w))
    for i, wi in enumerate(w):
        basis = np.column_stack([np.cos(wi * t), np.sin(wi * t)])
        (a, b), *_ = np.linalg.lstsq(basis, ens.q[i, :, 0], rcond=None)
        amplitude[i] = math.hypot(a, b)
    exact = 1.0 / np.sqrt((4.0 - w**2) ** 2 + (0.4 * w) ** 2)
    assert np.allclose(amplitude, exact, rtol=1e-6, atol=0)
    # The peak sits at √(ω₀² − c²/2m²), not at ω₀ = 2.
    assert abs(w[np.argmax(amplitude)] - math.sqrt(4.0 - 0.08)) <= 0.5 * (w[1] - w[0])


def test_singular_runs_are_marked_and_the_rest_are_right():
    # Zero masses make M singular: those runs fail as simulate fails for them, at their first
    # evaluation with SingularMassMatrixError, keeping the initial state and nothing else; the
    # others follow the closed form. A compiled model rebound per run, and a scene built per run.
    osc = lg.scenes.damped_oscillator(m=1.0, k=4.0, c=0.4)
    x, = lg.coordinates("x")
    m, k, c = lg.parameters("m k c")
    model = lg.Model(coordinates=[x], kinetic=0.5 * m * x.d**2, potential=0.5 * k * x**2,
                     dissipation=0.5 * c * x.d**2, parameters={"m": 1.0, "k": 4.0, "c": 0.4})
    masses = np.array([0.5, 0.0, 1.0, 2.0, 0.0, 3.0])
    t = np.linspace(0.0, 3.0, 7)
    for subject in (model, osc):
        ens = subject.simulate_many([1.0], [0.5], 3.0, parameters={"m": masses}, t_eval=t,
                                    rtol=1e-11, atol=1e-12)
        assert ens.status.tolist() == [0, -1, 0, 0, -1, 0]
        assert sorted(ens.failures) == [1, 4]
        for i in (1, 4):
            failure = ens.failures[i]
            expected = lg.SingularMassMatrixError
            assert type(ens.error(i)) is expected and failure.error == expected.__name__
            with pytest.raises(expected) as raised:
                subject.with_parameters(m=0.0).simulate([1.0], [0.5], 3.0, t_eval=t)
            err = raised.value
            assert str(err) == failure.message == str(ens.error(i))
            assert failure.t == err.t == 0.0 and ens.reached[i] == 1
            assert_same(ens, i, err.solution)
        assert isinstance(ens.q, np.ma.MaskedArray) and ens.q.mask[1, 1:].all()
        assert np.isfinite(np.ma.getdata(ens.q)).all() and np.isfinite(np.ma.getdata(ens.qd)).all()
        for i in (0, 2, 3, 5):
            assert not ens.q.mask[i].any() and ens.reached[i] == len(t)
            exact = lg.scenes.damped_oscillator(m=masses[i], k=4.0, c=0.4)
            for j, tj in enumerate(t):
                xq, xqd = exact.exact(tj, [1.0], [0.5])
                assert abs(ens.q[i, j, 0] - xq[0]) < 1e-9 and abs(ens.qd[i, j, 0] - xqd[0]) < 1e-9


def test_runs_that_fail_midway_keep_what_they_computed():
    # A step budget that the wide swings exhaust: those runs stop with TooManyStepsError and
    # keep exactly what simulate's err.solution keeps.
    model = pendulum()
    theta0 = np.array([0.2, 2.0, 0.15, 1.0])
    t = np.linspace(0.0, 20.0, 201)
    kwargs = dict(t_eval=t, method="dop853", rtol=1e-12, atol=1e-12, max_steps=350)
    ens = model.simulate_many(theta0[:, None], [0.0], 20.0, **kwargs)
    assert ens.status.tolist() == [0, -1, 0, -1]
    for i in (1, 3):
        assert ens.failures[i].error == "TooManyStepsError"
        with pytest.raises(lg.TooManyStepsError) as err:
            model.simulate([theta0[i]], [0.0], 20.0, **kwargs)
        partial = err.value.solution
        assert ens.failures[i].t == err.value.t
        assert 0 < ens.reached[i] == len(partial) < len(t)
        assert_same(ens, i, partial)
        assert ens.q.mask[i, ens.reached[i]:].all() and not ens.q.mask[i, :ens.reached[i]].any()
    final = model.simulate_many(theta0[:, None], [0.0], 20.0, method="dop853", rtol=1e-12,
                                atol=1e-12, max_steps=350, final_only=True)
    steps = model.simulate_many(theta0[:, None], [0.0], 20.0, method="dop853", rtol=1e-12,
                                atol=1e-12, max_steps=350)
    for i in range(4):
        # The last accepted state, at its own time: never filled, never NaN.
        assert final.t[i] == steps.t[i][-1] and np.array_equal(final.q[i], steps.q[i][-1])
    assert final.t[1] < 20.0 and final.failures[1].t == final.t[1]


def thirty():
    rng = np.random.default_rng(7)
    return rng.uniform(-2.0, 2.0, (30, 2)), rng.uniform(-1.0, 1.0, (30, 2))


def test_executors_give_the_local_result():
    model = double_pendulum_dsl()
    q0, qd0 = thirty()
    t = np.linspace(0.0, 4.0, 41)
    m2 = np.linspace(0.0, 1.0, 30)  # m2 = 0 makes M singular for the first run
    local = model.simulate_many(q0, qd0, 4.0, parameters={"m2": m2}, t_eval=t, rtol=1e-9)
    assert local.status[0] == -1 and local.ok[1:].all()
    with ThreadPoolExecutor(2) as pool:
        threaded = model.simulate_many(q0, qd0, 4.0, parameters={"m2": m2}, t_eval=t,
                                       rtol=1e-9, executor=pool, chunks=7, timeout=120)
    spawn = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(2, mp_context=spawn) as pool:
        processes = model.simulate_many(q0, qd0, 4.0, parameters={"m2": m2}, t_eval=t,
                                        rtol=1e-9, executor=pool, timeout=300)
    for other in (threaded, processes):
        assert_ensembles_equal(local, other)


def assert_ensembles_equal(a, b):
    assert a.output == b.output and len(a) == len(b)
    assert a.failures == b.failures
    assert np.array_equal(a.reached, b.reached) and np.array_equal(a.status, b.status)
    for key in a.stats:
        assert a.stats[key].tolist() == b.stats[key].tolist(), key
    assert a.event_names == b.event_names
    assert np.array_equal(a.event_counts, b.event_counts)
    for x, y in ((a.t_events, b.t_events), (a.q_events, b.q_events),
                 (a.qd_events, b.qd_events)):
        assert all(np.array_equal(u, v) for xs, ys in zip(x, y) for u, v in zip(xs, ys))
    if a.output == "steps":
        for x, y in ((a.t, b.t), (a.q, b.q), (a.qd, b.qd)):
            assert all(np.array_equal(u, v) for u, v in zip(x, y))
    else:
        for x, y in ((a.t, b.t), (a.q, b.q), (a.qd, b.qd)):
            assert np.array_equal(np.ma.getdata(x), np.ma.getdata(y))
            assert np.array_equal(np.ma.getmaskarray(x), np.ma.getmaskarray(y))


def test_dask_local_cluster_gives_the_local_result(hundred):
    distributed = pytest.importorskip("distributed", reason="pip install '.[dask]'")
    model, q0, qd0 = hundred
    t = np.linspace(0.0, 5.0, 51)
    scene = lg.scenes.double_pendulum(1.3, 0.7, 1.1, 0.8, 9.81)
    g = np.linspace(1.0, 20.0, 100)
    th1 = model.coordinates[0]
    m2, = lg.parameters("m2")
    terminal = lg.Event(th1 - m2, direction=1, terminal=True, name="over")  # a swept threshold
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=None, timeout=120)
    try:
        client = distributed.Client(cluster, timeout=120)
        try:
            for run in (
                lambda **kw: model.simulate_many(q0, qd0, 5.0, t_eval=t, rtol=1e-8, **kw),
                lambda **kw: model.simulate_many(q0, qd0, 5.0, method="dop853", rtol=1e-8, **kw),
                lambda **kw: scene.simulate_many(q0, qd0, 2.0, parameters={"g": g},
                                                 final_only=True, **kw),
                lambda **kw: model.simulate_many(q0, qd0, 5.0, parameters={"m2": g / 10},
                                                 events=[terminal], final_only=True, **kw),
            ):
                local = run()
                assert_ensembles_equal(local, run(executor=client, timeout=300))
            # Every run equals simulate through Dask too.
            ens = model.simulate_many(q0, qd0, 5.0, t_eval=t, rtol=1e-8, executor=client,
                                      chunks=3, timeout=300)
            for i in range(100):
                assert_same(ens, i, model.simulate(q0[i], qd0[i], 5.0, t_eval=t, rtol=1e-8))
        finally:
            client.close(timeout=60)
    finally:
        cluster.close(timeout=60)


def test_broadcast_and_input_checks():
    model = pendulum()
    ens = model.simulate_many([0.5], [[0.0], [0.1], [0.2]], 1.0, final_only=True)
    assert len(ens) == 3 and ens.q.shape == (3, 1)
    ens = model.simulate_many([0.5], [0.0], 1.0, parameters={"l": [1.0, 2.0]}, final_only=True)
    assert len(ens) == 2 and ens.q[0, 0] != ens.q[1, 0]
    with pytest.raises(ValueError, match="do not agree in number"):
        model.simulate_many([[0.5], [0.6]], [0.0], 1.0, parameters={"l": [1.0, 2.0, 3.0]})
    with pytest.raises(ValueError, match="unknown parameter 'L'"):
        model.simulate_many([0.5], [0.0], 1.0, parameters={"L": [1.0]})
    with pytest.raises(ValueError, match=r"parameter 'l'\[1\] = nan is not finite"):
        model.simulate_many([0.5], [0.0], 1.0, parameters={"l": [1.0, float("nan")]})
    with pytest.raises(ValueError, match=r"q0\[1, 0\] = inf is not finite"):
        model.simulate_many([[0.5], [math.inf]], [0.0], 1.0)
    with pytest.raises(ValueError, match="t_eval or final_only"):
        model.simulate_many([0.5], [0.0], 1.0, t_eval=[0.5], final_only=True)
    with pytest.raises(ValueError, match="workers = 0"):
        model.simulate_many([0.5], [0.0], 1.0, workers=0)
    with pytest.raises(TypeError, match="executor must be"):
        model.simulate_many([0.5], [0.0], 1.0, executor=object())
    # The options are simulate's, with its messages.
    for bad in (dict(rtol=-1.0), dict(method="rk4"), dict(method="nope"), dict(dt=-0.1)):
        with pytest.raises(ValueError) as many:
            model.simulate_many([0.5], [0.0], 1.0, **bad)
        with pytest.raises(ValueError) as one:
            model.simulate([0.5], [0.0], 1.0, **bad)
        assert str(many.value) == str(one.value)


def test_keyboard_interrupt_stops_the_ensemble():
    # As for simulate (test_errors.py): a helper thread sends SIGINT; the bounded ensemble
    # (seconds of work) must end with KeyboardInterrupt instead of finishing.
    model = lg.scenes.double_pendulum(1.0, 1.0, 1.0, 1.0, 9.81)
    sent = threading.Event()

    def interrupt():
        time.sleep(0.3)
        sent.set()
        os.kill(os.getpid(), signal.SIGINT)

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        threading.Thread(target=interrupt, daemon=True).start()
        with pytest.raises(KeyboardInterrupt):
            model.simulate_many([1.0, 0.5], [0.0, 0.0], 4e3, method="rk4", dt=1e-3,
                                parameters={"g": np.linspace(9.0, 10.0, 20)}, final_only=True,
                                max_steps=10**8, workers=2)
        assert sent.is_set()
    finally:
        signal.signal(signal.SIGINT, previous)


def test_counters_come_from_one_list_in_rust():
    # `Statistics::COUNTERS` names the counters once: a run's stats, an ensemble's columns and
    # its per-run stats all follow it, in its order.
    from lagrangian import _lagrangian
    from lagrangian._ensemble import COUNTERS

    assert COUNTERS == tuple(_lagrangian.COUNTERS) and len(set(COUNTERS)) == len(COUNTERS)
    model = lg.scenes.double_pendulum()
    sol = model.simulate([1.0, 0.5], [0.0, 0.0], 0.5, method="radau5")
    # A scene's run says its route last (`scene_path`).
    assert list(sol.stats) == ["method", "choice", *COUNTERS, "conserved", "scene_path"]
    ens = model.simulate_many([[1.0, 0.5], [0.5, 0.2]], [0.0, 0.0], 0.5, method="radau5")
    assert [k for k in ens.stats if k in COUNTERS] == list(COUNTERS)
    for i, q0 in enumerate(([1.0, 0.5], [0.5, 0.2])):
        one = model.simulate(q0, [0.0, 0.0], 0.5, method="radau5")
        assert ens.run_stats(i) == one.stats


def test_batch_integrator_is_the_integrator_run_by_run(hundred):
    # Runs advanced together piece by piece (SIMD lanes for Taylor): after each call every run
    # stands where Model.integrator stands after the same calls, bit for bit — in a g sweep
    # too; a run that fails (max_steps) is marked with the integrator's error and kept out of
    # the later calls, at the state it stood at; bad times are refused.
    model, q0, qd0 = hundred
    q0, qd0, g = q0[:24], qd0[:24], np.linspace(5.0, 15.0, 24)
    kw = dict(method="taylor", rtol=1e-10, atol=1e-10)
    bi = model.batch_integrator(q0, qd0, parameters={"g": g}, max_steps=60, **kw)
    assert len(bi) == 24 and bi.t == 0.0 and bi.ok.all()
    stops = (0.5, 1.5, 3.0)
    for t in stops:
        bi.propagate_until(t)
        assert bi.t == t
    assert 0 < (~bi.ok).sum() < 24
    for i in range(24):
        ig = model.with_parameters(g=g[i]).integrator(q0[i], qd0[i], max_steps=60, **kw)
        failed_at = None
        for t in stops:
            try:
                ig.propagate_until(t)
            except lg.TooManyStepsError as e:
                failed_at = e
                break
        assert bi.ok[i] == (failed_at is None), i
        if failed_at is None:
            assert np.array_equal(bi.q[i], ig.q) and np.array_equal(bi.qd[i], ig.qd), i
        else:
            assert str(bi.error(i)) == str(failed_at) and bi.t_failed[i] == ig.t, i
            assert np.array_equal(bi.q[i], ig.q) and np.array_equal(bi.qd[i], ig.qd), i
    with pytest.raises(ValueError, match="finite time"):
        bi.propagate_until(float("nan"))
