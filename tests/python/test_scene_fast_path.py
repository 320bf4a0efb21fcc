"""A ready-made scene's run moves from its Rust energies to the traced, compiled eq. 55 program
once it has spent on the Rust route what compiling costs (``stats["scene_path"]`` says which): a
long run switches and keeps to the Rust route's orbit to round-off and to the closed form; a short
run does not switch and is the Rust route's bit for bit. ``LAGRANGIAN_SCENE_PATH`` holds a run on
one route (for benchmarks)."""

import math

import numpy as np
from numpy.testing import assert_allclose, assert_array_equal

import lagrangian as lg

# Kepler's orbit of a = 1, e = 0.5 (μ = 1) from periapsis: period 2π.
Q0, V0 = [0.5, 0.0], [0.0, math.sqrt(3.0)]
LONG = 20 * 2 * math.pi


def run(t_end, monkeypatch=None, path=None, **kw):
    if monkeypatch is not None:
        monkeypatch.setenv("LAGRANGIAN_SCENE_PATH", path)
    return lg.scenes.kepler().simulate(Q0, V0, t_end, method="dop853", rtol=1e-11, atol=1e-11, **kw)


def test_a_long_run_switches_and_keeps_to_the_rust_route(monkeypatch):
    sol = run(LONG)
    assert sol.stats["scene_path"].startswith("compiled"), sol.stats["scene_path"]
    rust = run(LONG, monkeypatch, "rust")
    assert rust.stats["scene_path"].startswith("rust")
    assert rust.stats["rhs_evaluations"] > 3_000
    # Round-off from the switch on, over twenty orbits.
    assert_allclose(sol.q[-1], rust.q[-1], rtol=0, atol=1e-9)
    assert_allclose(sol.qd[-1], rust.qd[-1], rtol=0, atol=1e-9)
    # On the closed form within the method's own global error over twenty orbits (a phase
    # lag of about 1e-7, the Rust route's too).
    q, qd = lg.scenes.kepler().exact(LONG, Q0, V0)
    assert_allclose(sol.q[-1], q, rtol=0, atol=1e-6)
    assert_allclose(sol.qd[-1], qd, rtol=0, atol=1e-6)
    assert np.max(np.abs(rust.q[-1] - q)) > 1e-8  # the error is the method's, not the switch's
    # The same run again: the switch counts evaluations, not time, so the numbers repeat.
    assert_array_equal(run(LONG, monkeypatch, "").q, sol.q)


def test_a_short_run_stays_on_the_rust_route(monkeypatch):
    sol = run(3.0)
    assert sol.stats["scene_path"].startswith("rust"), sol.stats["scene_path"]
    held = run(3.0, monkeypatch, "rust")
    assert_array_equal(sol.t, held.t)
    assert_array_equal(sol.q, held.q)
    assert_array_equal(sol.qd, held.qd)


def test_held_compiled_from_the_start(monkeypatch):
    sol = run(3.0, monkeypatch, "compiled")
    assert sol.stats["scene_path"].startswith("compiled")
    q, qd = lg.scenes.kepler().exact(3.0, Q0, V0)
    assert_allclose(sol.q[-1], q, rtol=0, atol=1e-9)
    assert_allclose(sol.qd[-1], qd, rtol=0, atol=1e-9)


def test_events_on_a_run_that_switches():
    model = lg.scenes.kepler()
    periapsis = lg.Event(model.coordinates[1], direction=1, name="periapsis")
    sol = model.simulate(Q0, V0, LONG + 1.0, method="dop853", rtol=1e-11, atol=1e-11,
                         events=[periapsis])
    assert sol.stats["scene_path"].startswith("compiled")
    assert_allclose(sol.t_events[0], 2 * math.pi * np.arange(1, 21), rtol=0, atol=1e-6)


def test_a_stated_model_has_no_scene_path():
    x, y = lg.coordinates("x y")
    model = lg.Model(coordinates=[x, y], kinetic=0.5 * (x.d**2 + y.d**2),
                     potential=-1 / lg.sqrt(x**2 + y**2))
    sol = model.simulate(Q0, V0, 1.0, method="dop853")
    assert "scene_path" not in sol.stats


def test_an_ensemble_run_is_the_run_alone():
    # Each run of an ensemble on its own switch: the same numbers and route as `simulate`, for a
    # sweep over states and for a scene built per run.
    model = lg.scenes.kepler()
    q0 = [Q0, [0.6, 0.0]]
    ens = model.simulate_many(q0, [V0, V0], LONG, method="dop853", rtol=1e-11, atol=1e-11,
                              final_only=True)
    for i in range(2):
        alone = model.simulate(q0[i], V0, LONG, method="dop853", rtol=1e-11, atol=1e-11)
        assert alone.stats["scene_path"].startswith("compiled")
        assert_array_equal(ens.q[i], alone.q[-1])
        assert ens.run_stats(i) == alone.stats
    swept = model.simulate_many([Q0, Q0], [V0, V0], 3.0, parameters={"mu": [1.0, 1.1]},
                                method="dop853", rtol=1e-11, atol=1e-11, final_only=True)
    for i, mu in enumerate((1.0, 1.1)):
        alone = lg.scenes.kepler(mu=mu).simulate(Q0, V0, 3.0, method="dop853", rtol=1e-11,
                                                 atol=1e-11)
        assert alone.stats["scene_path"].startswith("rust")
        assert_array_equal(swept.q[i], alone.q[-1])
        assert swept.run_stats(i) == alone.stats
