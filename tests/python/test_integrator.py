"""``Model.integrator``: a run kept between calls. A harmonic oscillator propagated piece by
piece against its closed form and against one ``simulate`` over the whole span, forwards and
back, with adaptive and fixed-step methods; a pendulum's zero crossings, stopped by a terminal
event call after call, against the elliptic integral; ``"auto"`` choosing once; and bad input or a
failed call leaving the integrator where it stood."""

import math

import numpy as np
import pytest
from scipy.special import ellipk

import lagrangian as lg

W = 1.7  # ω of the oscillator


def oscillator() -> lg.Model:
    x, = lg.coordinates("x")
    return lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * W**2 * x**2)


def exact(t: float, x0: float = 0.3, v0: float = -0.2) -> np.ndarray:
    return np.array([x0 * math.cos(W * t) + v0 / W * math.sin(W * t),
                     -x0 * W * math.sin(W * t) + v0 * math.cos(W * t)])


@pytest.mark.parametrize("method, options, tol", [
    ("taylor", {"rtol": 1e-13, "atol": 1e-13}, 1e-11),
    ("dop853", {"rtol": 1e-11, "atol": 1e-11}, 1e-9),
    ("rk4", {"dt": 1e-3}, 1e-9),  # error C dt⁴ per unit time, C = ω⁵/120 for RK4's phase
])
def test_pieces_follow_the_closed_form_and_one_whole_run(method, options, tol):
    model = oscillator()
    ig = model.integrator([0.3], [-0.2], method=method, **options)
    assert ig.stats is None and ig.event is None and ig.t == 0.0
    for t in np.linspace(0.25, 10.0, 40):
        assert ig.propagate_until(t) == "finished"
        assert ig.t == t
        state = np.concatenate([ig.q, ig.qd])
        np.testing.assert_allclose(state, exact(t), rtol=0, atol=tol)
    assert ig.method == method and ig.stats["method"] == method
    assert ig.stats["accepted_steps"] >= 1
    whole = model.simulate([0.3], [-0.2], 10.0, method=method, **options)
    np.testing.assert_allclose(ig.q, whole.q[-1], rtol=0, atol=tol)
    # Back to the start, across the whole span in one call.
    assert ig.propagate_until(0.0) == "finished"
    np.testing.assert_allclose(np.concatenate([ig.q, ig.qd]), [0.3, -0.2], rtol=0, atol=2 * tol)


def test_assigned_states_start_the_next_call():
    model = oscillator()
    ig = model.integrator([0.0], [0.0], method="taylor", rtol=1e-13, atol=1e-13)
    ig.t, ig.q, ig.qd = 2.0, np.array([0.3]), [-0.2]  # an array, a list
    assert ig.propagate_until(3.0) == "finished"
    # One time unit after (0.3, −0.2), whatever the clock says (the oscillator is autonomous).
    np.testing.assert_allclose([ig.q[0], ig.qd[0]], exact(1.0), rtol=0, atol=1e-12)
    ig.qd = 0.5  # a scalar for one coordinate, as the constructor takes it
    assert ig.qd[0] == 0.5
    # Reading gives copies: writing into them changes nothing.
    q = ig.q
    q[0] = 99.0
    assert ig.q[0] != 99.0


def test_terminal_event_stops_each_call_at_the_next_crossing():
    # A pendulum from rest at θ₀ crosses θ = 0 at T/4, 3T/4, 5T/4, … with T = 4√(l/g) K(sin²(θ₀/2)).
    # Each call stops at the next one, not again at the crossing it stands on.
    th, = lg.coordinates("th")
    g, l, theta0 = 9.81, 1.3, 2.0
    model = lg.Model(coordinates=[th], kinetic=0.5 * l**2 * th.d**2, potential=-g * l * lg.cos(th))
    period = 4 * math.sqrt(l / g) * ellipk(math.sin(theta0 / 2) ** 2)
    ig = model.integrator([theta0], [0.0], method="taylor", rtol=1e-13, atol=1e-13,
                          events=[lg.Event(th, terminal=True, name="bottom")])
    for k in range(5):
        assert ig.propagate_until(10 * period) == "terminated"
        assert ig.event == "bottom"
        assert ig.t == pytest.approx((2 * k + 1) * period / 4, abs=1e-10)
        assert abs(ig.q[0]) < 1e-10
        assert abs(ig.qd[0]) == pytest.approx(2 * math.sqrt(g / l) * math.sin(theta0 / 2), abs=1e-9)
    # A call to where it stands changes nothing; backwards, the crossing before comes next.
    t_last = ig.t
    assert ig.propagate_until(t_last) == "finished" and ig.event is None
    assert ig.propagate_until(0.0) == "terminated"
    assert ig.t == pytest.approx(t_last - period / 2, abs=1e-10)
    # A state assigned elsewhere: a call that reaches t before any crossing finishes.
    ig.t, ig.q, ig.qd = 0.0, [theta0], [0.0]
    assert ig.propagate_until(period / 8) == "finished" and ig.event is None
    assert ig.propagate_until(period) == "terminated"
    assert ig.t == pytest.approx(period / 4, abs=1e-10)


def test_impacts_of_ones_own_at_a_terminal_event():
    # A ball dropped from h onto a floor, the impact law applied by hand at each terminal event
    # (either direction): q̇ → −e q̇. Impact k at t₁ + Σ_{j=1..k−1} 2 eʲ v₁/g, v₁ = √(2gh), t₁ = v₁/g.
    y, = lg.coordinates("y")
    g, h, e = 9.81, 2.0, 0.8
    ball = lg.Model(coordinates=[y], kinetic=0.5 * y.d**2, potential=g * y)
    ig = ball.integrator([h], [0.0], method="taylor", rtol=1e-13, atol=1e-13,
                         events=[lg.Event(y, terminal=True, name="floor")])
    v1 = math.sqrt(2 * g * h)
    t_impact = v1 / g
    for k in range(1, 7):
        assert ig.propagate_until(100.0) == "terminated" and ig.event == "floor"
        assert ig.t == pytest.approx(t_impact, abs=1e-10), k
        assert ig.qd[0] == pytest.approx(-v1 * e ** (k - 1), rel=1e-10)
        # Going up from just below the floor (as rounding may leave it): the next call does not
        # stop here again, the event settling on its root while t stays.
        ig.q, ig.qd = [-1e-13], -e * ig.qd
        ig.t = ig.t  # not a move
        t_impact += 2 * e**k * v1 / g
    # Moving t drops the settling: from below the floor going up, y = 0 is crossed at once.
    ig.t, ig.q, ig.qd = ig.t + 1.0, [-1e-13], [1.0]
    t_moved = ig.t
    assert ig.propagate_until(t_moved + 1.0) == "terminated"
    assert ig.t == pytest.approx(t_moved, abs=1e-12)


def test_terminal_counts_start_afresh_at_each_call():
    # terminal=2 stops at the second crossing of the call: every other zero of the pendulum.
    th, = lg.coordinates("th")
    model = lg.Model(coordinates=[th], kinetic=0.5 * th.d**2, potential=0.5 * th**2)  # ω = 1
    ig = model.integrator([1.0], [0.0], method="dop853", rtol=1e-12, atol=1e-12,
                          events=[lg.Event(th, terminal=2)])
    for k in range(1, 4):
        assert ig.propagate_until(50.0) == "terminated"
        assert ig.t == pytest.approx(math.pi / 2 + (2 * k - 1) * math.pi, abs=1e-9)


def test_auto_chooses_once_and_keeps_its_reason():
    model = oscillator()
    ig = model.integrator([0.3], [-0.2], rtol=1e-12, atol=1e-12)
    assert ig.method == "auto"
    ig.propagate_until(1.0)
    chosen, why = ig.method, ig.stats["choice"]
    assert chosen != "auto" and why
    assert chosen == model.simulate([0.3], [-0.2], 1.0, rtol=1e-12, atol=1e-12).stats["method"]
    for t in (2.0, 3.0):
        ig.propagate_until(t)
        assert ig.method == chosen and ig.stats["choice"] == why and ig.stats["method"] == chosen


def test_bad_input_and_failures_leave_the_integrator_where_it_stood():
    model = oscillator()
    with pytest.raises(ValueError, match="dt = -0.1"):
        model.integrator([0.3], [-0.2], method="rk4", dt=-0.1)
    with pytest.raises(ValueError, match="dt"):
        model.integrator([0.3], [-0.2], method="rk4")  # a fixed-step method needs dt
    with pytest.raises(ValueError, match="rtol"):
        model.integrator([0.3], [-0.2], rtol=-1.0)
    with pytest.raises(ValueError, match="unknown method|not a method|nonesuch"):
        model.integrator([0.3], [-0.2], method="nonesuch")
    with pytest.raises(ValueError, match="q0"):
        model.integrator([0.3, 1.0], [-0.2])
    # A method that cannot serve the model is refused when the integrator is made.
    x, = lg.coordinates("x")
    kinked = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=lg.abs(x))
    with pytest.raises(ValueError, match="taylor cannot integrate this system"):
        kinked.integrator([0.1], [0.0], method="taylor")
    # A Rust scene takes taylor (its energies traced into the expression graph).
    lg.scenes.simple_pendulum().integrator([0.1], [0.0], method="taylor")
    th, = lg.coordinates("th")
    nonseparable = lg.Model(coordinates=[th], kinetic=0.5 * (2 + lg.cos(th)) * th.d**2)
    with pytest.raises(ValueError, match="yoshida4 cannot integrate this system"):
        nonseparable.integrator([0.1], [0.0], method="yoshida4", dt=0.01)
    ig = model.integrator([0.3], [-0.2], method="dop853", rtol=1e-10, atol=1e-10, max_steps=5)
    ig.propagate_until(0.01)
    before = (ig.t, ig.q.copy(), ig.qd.copy(), ig.stats)
    for bad, error in [(math.nan, ValueError), (math.inf, ValueError), ("1", TypeError)]:
        with pytest.raises(error):
            ig.propagate_until(bad)
    with pytest.raises(ValueError, match="not finite"):
        ig.q = [math.nan]
    with pytest.raises(ValueError, match=r"shape \(2,\)"):
        ig.qd = [1.0, 2.0]
    with pytest.raises(ValueError, match="string"):
        ig.q = "x"
    with pytest.raises(ValueError, match="not finite"):
        ig.t = math.inf
    with pytest.raises(lg.TooManyStepsError) as failed:
        ig.propagate_until(100.0)  # five steps do not get there
    err = failed.value
    assert err.solution is None and 0.01 < err.t < 100.0
    np.testing.assert_allclose([err.q[0], err.qd[0]], exact(err.t), rtol=0, atol=1e-8)
    after = (ig.t, ig.q, ig.qd, ig.stats)
    assert after[0] == before[0] and after[3] == before[3]
    np.testing.assert_array_equal(after[1], before[1])
    np.testing.assert_array_equal(after[2], before[2])
    assert ig.propagate_until(ig.t) == "finished"  # an empty span: nothing to do
    assert "dop853" in repr(ig)


def test_site_example_is_the_standard_map():
    # Between kicks the rotor moves freely: θₙ = θₙ₋₁ + pₙ, pₙ = pₙ₋₁ + K sin θₙ₋₁ exactly.
    import doctest
    from pathlib import Path

    page = (Path(__file__).parents[2] / "docs" / "site" / "events.rst").read_text()
    section = page[page.index("Runs taken piece by piece"):]
    examples = doctest.DocTestParser().get_examples(section)
    code = "import numpy as np\nimport lagrangian as lg\n" + "".join(e.source for e in examples)
    scope: dict = {}
    exec(compile(code, "events.rst", "exec"), scope)
    ig = scope["ig"]
    theta, p = 0.5, 0.2
    for _ in range(20):
        p += 0.5 * math.sin(theta)
        theta += p
    assert ig.t == 20.0
    assert ig.q[0] == pytest.approx(theta, abs=1e-10) and ig.qd[0] == pytest.approx(p, abs=1e-10)
