"""Pictures: Solution.plot, Model.positions against closed forms, Model.animate."""

import math
import sys

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import lagrangian as lg
from conftest import double_pendulum_dsl

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
Image = pytest.importorskip("PIL.Image")

DP = dict(m1=1.3, m2=0.7, l1=1.1, l2=0.8, g=9.81)


def double_pendulum_particles(m1=1.3, m2=0.7, l1=1.1, l2=0.8, g=9.81):
    th1, th2 = lg.coordinates("th1 th2")
    x1, y1 = l1 * lg.sin(th1), -l1 * lg.cos(th1)
    x2, y2 = x1 + l2 * lg.sin(th2), y1 - l2 * lg.cos(th2)
    return lg.Model(coordinates=[th1, th2], positions=[(x1, y1), (x2, y2)], masses=[m1, m2],
                    potential=g * (m1 * y1 + m2 * y2))


def gif_frames(path):
    with Image.open(path) as im:
        return im.n_frames, im.size


# -- Solution.plot -------------------------------------------------------------------------


def curve_at(line, times):
    """The y of a drawn line at the given x (which are among its points)."""
    x, y = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
    index = np.searchsorted(x, times)
    assert_array_equal(x[index], times)
    return y[index]


def test_plot_curves_pass_through_the_solution_and_name_the_coordinates(tmp_path):
    model = lg.scenes.double_pendulum(**DP)
    sol = model.simulate([1.0, 0.5], [0.0, 0.0], 3.0, rtol=1e-8, atol=1e-10)
    assert sol.names == ("th1", "th2")
    path = tmp_path / "dp.png"
    fig = sol.plot(path, title="double pendulum", conserved=model.structure["conservative"])
    ax_q, ax_v, ax_h = fig.axes
    for ax, data in ((ax_q, sol.q), (ax_v, sol.qd)):
        assert len(ax.lines) == 2
        for i, line in enumerate(ax.lines):
            # Smooth: many more points than the solution, through every one of its points.
            assert len(line.get_xdata()) > 5 * len(sol)
            assert_array_equal(curve_at(line, sol.t), data[:, i])
            assert line.get_marker() in ("None", None, "")
    assert [x.get_label() for x in ax_q.lines] == ["th1", "th2"]
    assert [x.get_label() for x in ax_v.lines] == ["dth1/dt", "dth2/dt"]
    assert "th1" in ax_q.get_ylabel() and "th2" in ax_q.get_ylabel()
    assert "dth1/dt" in ax_v.get_ylabel()
    assert ax_h.get_xlabel() == "t"
    # A conserved h: its relative error on a log axis, zeros left out of the log scale.
    (d,) = ax_h.lines
    want = np.abs(sol.energy - sol.energy[0]) / abs(sol.energy[0])
    got = d.get_ydata()
    assert np.isnan(got[0]) and want[0] == 0.0
    assert_allclose(got[want > 0], want[want > 0], rtol=1e-15)
    assert ax_h.get_yscale() == "log"
    assert "relative energy error" in ax_h.get_ylabel()
    assert f"{want.max():.2g}" in ax_h.get_title(loc="left")
    assert "conserved by the system" in ax_h.get_title(loc="left")
    # Recorded by the run (stats["conserved"]): the same figure.
    assert sol.stats["conserved"] is True
    assert "relative energy error" in sol.plot().axes[2].get_ylabel()
    # Not told, and not recorded by the run: judged from h, and said so.
    del sol.stats["conserved"]
    judged = sol.plot().axes[2]
    assert judged.get_yscale() == "log" and "relative energy change" in judged.get_ylabel()
    assert "less than 1e-3" in judged.get_title(loc="left")
    for ax in (ax_q, ax_v):
        assert ax.yaxis.get_major_formatter().get_useOffset() is False
    assert fig._suptitle.get_text() == "double pendulum"
    with open(path, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
    with Image.open(path) as im:
        assert im.size[0] > 100 and im.size[1] > 100


def test_plot_curves_between_adaptive_steps_follow_the_motion():
    # Few, long steps of DOP853 on x'' = -4x (about 11 per period): the drawn curves follow
    # cos 2t between them to 5e-3 and 3e-2, where straight segments are off by 0.14.
    osc = lg.scenes.damped_oscillator(m=1.0, k=4.0, c=0.0)
    sol = osc.simulate([1.0], [0.0], 20.0, rtol=1e-6, atol=1e-6)
    assert np.max(np.diff(sol.t)) > 0.5
    fig = sol.plot()
    (q_line,), (v_line,) = fig.axes[0].lines, fig.axes[1].lines
    t = np.asarray(q_line.get_xdata())
    assert_allclose(q_line.get_ydata(), np.cos(2 * t), atol=5e-3)
    assert_allclose(v_line.get_ydata(), -2 * np.sin(2 * t), atol=3e-2)
    straight = np.interp(t, sol.t, sol.q[:, 0])
    assert np.max(np.abs(straight - np.cos(2 * t))) > 0.1


def test_plot_energy_itself_when_not_conserved():
    damped = lg.scenes.damped_oscillator(m=1.0, k=4.0, c=0.3)
    assert not damped.structure["conservative"]
    sol = damped.simulate([1.0], [0.0], 10.0)
    fig = sol.plot()
    ax_h = fig.axes[2]
    assert ax_h.get_yscale() == "linear"
    (h,) = ax_h.lines
    assert_allclose(curve_at(h, sol.t), sol.energy, rtol=1e-15)
    assert "not conserved" in ax_h.get_title(loc="left")
    assert ax_h.yaxis.get_major_formatter().get_useOffset() is False
    # Asked for explicitly, either way.
    assert sol.plot(conserved=True).axes[2].get_yscale() == "log"
    x, = lg.coordinates("x")
    osc = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2)
    still = osc.simulate([1.0], [0.0], 1.0, rtol=1e-12, atol=1e-12)
    assert still.plot(conserved=False).axes[2].get_yscale() == "linear"
    # No offset notation on an energy that moves in its 9th digit.
    big = lg.Solution(still.t, still.q, still.qd, 1e6 + 1e-3 * still.t,
                      {"method": "none", "accepted_steps": 0})
    ax = big.plot(conserved=False).axes[2]
    ax.figure.draw_without_rendering()
    assert ax.yaxis.get_offset_text().get_text() == ""


def test_plot_formats_by_suffix(tmp_path):
    x, = lg.coordinates("x")
    osc = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2)
    sol = osc.simulate([1.0], [0.0], 1.0, t_eval=np.linspace(0.0, 1.0, 11))
    assert sol.names == ("x",)
    sol.plot(tmp_path / "a.svg")
    sol.plot(tmp_path / "a.PDF")
    assert (tmp_path / "a.svg").read_text().lstrip().startswith("<?xml")
    assert (tmp_path / "a.PDF").read_bytes().startswith(b"%PDF")
    with pytest.raises(ValueError, match=r"\.png, \.svg, \.pdf"):
        sol.plot(tmp_path / "a.jpg")
    assert not (tmp_path / "a.jpg").exists()


def test_plot_without_names_and_empty_errors():
    t = np.linspace(0.0, 1.0, 4)
    q = np.stack([np.cos(t), np.sin(t)], axis=1)
    sol = lg.Solution(t, q, -q, np.ones(4), {"method": "none", "accepted_steps": 0})
    fig = sol.plot()
    assert [x.get_label() for x in fig.axes[0].lines] == ["q0", "q1"]
    # A perfectly conserved energy has no error to put on a log scale.
    assert fig.axes[2].get_yscale() == "linear"
    assert "h − h₀ = 0" in fig.axes[2].get_title(loc="left")
    empty = lg.Solution(np.zeros(0), np.zeros((0, 1)), np.zeros((0, 1)), np.zeros(0),
                        {"method": "none", "accepted_steps": 0})
    with pytest.raises(ValueError, match="empty"):
        empty.plot()


def test_plot_without_matplotlib_says_how_to_install(monkeypatch):
    sol = lg.scenes.simple_pendulum(m=1.0, l=1.0, g=9.81).simulate([0.3], [0.0], 0.5)
    for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
        monkeypatch.setitem(sys.modules, name, None)
    with pytest.raises(ImportError, match=r"pip install lagrangian\[plot\]"):
        sol.plot()


# -- Model.positions -----------------------------------------------------------------------

STATES = [[0.3, -0.4], [1.0, 0.5], [-2.0, 2.5], [3.1, -3.0]]


def dp_closed_form(q, l1=DP["l1"], l2=DP["l2"]):
    x1, y1 = l1 * math.sin(q[0]), -l1 * math.cos(q[0])
    return [[x1, y1], [x1 + l2 * math.sin(q[1]), y1 - l2 * math.cos(q[1])]]


@pytest.mark.parametrize("make", [lambda: lg.scenes.double_pendulum(**DP),
                                  lambda: double_pendulum_particles(**DP)],
                         ids=["scene", "particle_route"])
def test_positions_double_pendulum_closed_form(make):
    model = make()
    assert model.has_positions
    for q in STATES:
        r = model.positions(0.7, q)
        assert r.shape == (2, 2)
        assert_allclose(r, dp_closed_form(q), rtol=1e-15, atol=1e-15)
    many = model.positions(np.linspace(0.0, 1.0, len(STATES)), np.array(STATES))
    assert many.shape == (len(STATES), 2, 2)
    assert_allclose(many, [dp_closed_form(q) for q in STATES], rtol=1e-15, atol=1e-15)


def test_positions_scenes_closed_form():
    th = 0.7
    assert_allclose(lg.scenes.simple_pendulum(m=1.0, l=2.0, g=9.81).positions(0.0, [th]),
                    [[2.0 * math.sin(th), -2.0 * math.cos(th)]], rtol=1e-15)
    lengths = [1.0, 0.5, 0.25]
    chain = lg.scenes.n_pendulum([1.0, 2.0, 3.0], lengths, g=9.81)
    q = [0.2, -0.9, 2.0]
    x = np.cumsum([l * math.sin(a) for l, a in zip(lengths, q)])
    y = np.cumsum([-l * math.cos(a) for l, a in zip(lengths, q)])
    assert_allclose(chain.positions(0.0, q), np.stack([x, y], axis=1), rtol=1e-15)
    elastic = lg.scenes.elastic_pendulum(m=1.0, k=20.0, l0=1.0, g=9.81)
    assert_allclose(elastic.positions(0.0, [1.3, th]),
                    [[1.3 * math.sin(th), -1.3 * math.cos(th)]], rtol=1e-15)
    # The driven pivot moves: the bob at (l sin θ, a cos ω t − l cos θ).
    driven = lg.scenes.driven_pendulum(m=1.0, l=1.5, g=9.81, a=0.2, omega=30.0)
    t = 0.37
    assert_allclose(driven.positions(t, [th]),
                    [[1.5 * math.sin(th), 0.2 * math.cos(30.0 * t) - 1.5 * math.cos(th)]],
                    rtol=1e-15)
    for scene in (lg.scenes.kepler(m=1.0, mu=1.0), lg.scenes.henon_heiles(),
                  lg.scenes.charged_particle(m=1.0, e=1.0, b=2.0)):
        assert_allclose(scene.positions(0.0, [0.4, -1.2]), [[0.4, -1.2]], rtol=1e-15)
    lever = lg.scenes.lever(l1=2.0, l2=3.0, p=1.0, q=1.0)
    assert_allclose(lever.positions(0.0, [th]),
                    [[2.0 * math.cos(th), -2.0 * math.sin(th)],
                     [-3.0 * math.cos(th), 3.0 * math.sin(th)]], rtol=1e-15)


def test_positions_particle_route_3d():
    th, ph = lg.coordinates("th ph")
    l = 1.5
    pos = (l * lg.sin(th) * lg.cos(ph), l * lg.sin(th) * lg.sin(ph), -l * lg.cos(th))
    model = lg.Model(coordinates=[th, ph], positions=[pos], masses=[1.0])
    q = [0.7, 0.3]
    want = [l * math.sin(q[0]) * math.cos(q[1]), l * math.sin(q[0]) * math.sin(q[1]),
            -l * math.cos(q[0])]
    assert_allclose(model.positions(0.0, q), [want], rtol=1e-15)


CYLINDER = dict(m=2.0, j=0.09, r=0.3, g=9.81, alpha=0.4)
BALL = dict(m=1.0, j=0.4, r1=5.0, r2=1.0, g=9.81)


def test_positions_rolling_cylinder_rolls_without_slipping():
    cyl = lg.scenes.rolling_cylinder(**CYLINDER)
    r, alpha = CYLINDER["r"], CYLINDER["alpha"]
    down = np.array([math.cos(alpha), -math.sin(alpha)])
    normal = np.array([math.sin(alpha), math.cos(alpha)])
    for x in [-0.4, 0.0, 0.25, 1.7, 6.0]:
        centre, rim, opposite = cyl.positions(0.0, [x])
        assert_allclose(centre, x * down, atol=1e-15)
        assert_allclose(rim - centre, centre - opposite, atol=1e-14)
        assert_allclose(np.linalg.norm(rim - centre), r, rtol=1e-14)
        # The marker starts along the normal and turns clockwise by the distance rolled / r.
        turned = math.atan2(rim[0] - centre[0], rim[1] - centre[1]) - alpha
        assert_allclose(math.remainder(turned - x / r, 2 * math.pi), 0.0, atol=1e-14)
    # The rim point touching the slope (marker along −n, at x = π r) is at rest: its central
    # difference vanishes to O(h²) while the centre moves at unit speed along the slope.
    x, h = math.pi * r, 1e-5
    contact = cyl.positions(0.0, [x])[1]
    assert_allclose((contact + r * normal) @ normal, 0.0, atol=1e-15)
    ahead, behind = cyl.positions(0.0, [x + h]), cyl.positions(0.0, [x - h])
    assert_allclose((ahead[1] - behind[1]) / (2 * h), [0.0, 0.0], atol=1e-9)
    assert_allclose((ahead[0] - behind[0]) / (2 * h), down, rtol=1e-9)
    assert_allclose((ahead[2] - behind[2]) / (2 * h), 2 * down, rtol=1e-9)


def test_positions_ball_in_sphere_rolls_without_slipping():
    ball = lg.scenes.ball_in_sphere(**BALL)
    r1, r2 = BALL["r1"], BALL["r2"]
    for th in [-1.2, 0.0, 0.3, 2.0]:
        centre, rim, opposite = ball.positions(0.0, [th])
        assert_allclose(centre, (r1 - r2) * np.array([math.sin(th), -math.cos(th)]), atol=1e-15)
        assert_allclose(rim - centre, centre - opposite, atol=1e-14)
        assert_allclose(np.linalg.norm(rim - centre), r2, rtol=1e-14)
        # The ball turns by θ₂ = (r₁ − r₂) θ₁ / r₂ (seed eq. 49), clockwise.
        turned = math.atan2(rim[0] - centre[0], rim[1] - centre[1])
        assert_allclose(math.remainder(turned - (r1 - r2) * th / r2, 2 * math.pi), 0.0,
                        atol=1e-14)
    # At θ₁ = π r₂ / r₁ the marker touches the sphere, and that point is at rest.
    th, h = math.pi * r2 / r1, 1e-5
    contact = ball.positions(0.0, [th])[1]
    assert_allclose(np.linalg.norm(contact), r1, rtol=1e-15)
    ahead, behind = ball.positions(0.0, [th + h]), ball.positions(0.0, [th - h])
    assert_allclose((ahead[1] - behind[1]) / (2 * h), [0.0, 0.0], atol=1e-8)
    assert_allclose(np.linalg.norm((ahead[0] - behind[0]) / (2 * h)), r1 - r2, rtol=1e-9)


def test_positions_errors():
    energy = double_pendulum_dsl()
    assert not energy.has_positions
    with pytest.raises(ValueError, match="no positions"):
        energy.positions(0.0, [0.1, 0.2])
    for scene in (lg.scenes.forced_two_mass(m1=1.0, m2=1.0, k1=1.0, k2=1.0),
                  lg.scenes.damped_oscillator(m=1.0, k=1.0, c=0.1)):
        assert not scene.has_positions
        with pytest.raises(ValueError, match="no particle positions"):
            scene.positions(0.0, np.zeros(scene.dof))
    dp = lg.scenes.double_pendulum(**DP)
    with pytest.raises(ValueError, match="coordinates"):
        dp.positions(0.0, [0.1])
    with pytest.raises(ValueError, match="not finite"):
        dp.positions(0.0, [0.1, math.nan])
    with pytest.raises(ValueError, match="not finite"):
        dp.positions(np.array([0.0, math.inf]), np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"shape \(3, 2\)"):
        dp.positions(np.zeros(2), np.zeros((3, 2)))


def test_position_expressions_kept():
    model = double_pendulum_particles()
    assert len(model.position_expressions) == 2
    assert lg.scenes.double_pendulum(**DP).position_expressions is None


# -- Model.animate -------------------------------------------------------------------------


def test_animate_gif_frame_count(tmp_path):
    model = lg.scenes.double_pendulum(**DP)
    sol = model.simulate([1.0, 0.5], [0.0, 0.0], 2.0, rtol=1e-8, atol=1e-10)
    assert len(sol) > 12
    out = model.animate(sol, tmp_path / "dp.gif", fps=10, max_frames=12)
    assert out == tmp_path / "dp.gif"
    frames, size = gif_frames(out)
    assert frames == 12 and size[0] > 100
    # Fewer points than max_frames: one frame per point.
    short = model.simulate([1.0, 0.5], [0.0, 0.0], 1.0, t_eval=np.linspace(0.0, 1.0, 7))
    assert gif_frames(model.animate(short, tmp_path / "short.gif", trail=False))[0] == 7


@pytest.mark.parametrize("make,q0,qd0", [
    (lambda: lg.scenes.rolling_cylinder(**CYLINDER), [0.0], [0.5]),
    (lambda: lg.scenes.ball_in_sphere(**BALL), [1.0], [0.0]),
    (lambda: lg.scenes.driven_pendulum(m=1.0, l=1.0, g=9.81, a=0.1, omega=20.0), [0.5], [0.0]),
    (lambda: lg.scenes.kepler(m=1.0, mu=1.0), [1.0, 0.0], [0.0, 1.2]),
    (lambda: lg.scenes.n_pendulum([1.0] * 4, [0.5] * 4, g=9.81), [0.5] * 4, [0.0] * 4),
], ids=["rolling_cylinder", "ball_in_sphere", "driven_pendulum", "kepler", "n_pendulum"])
def test_animate_scenes(tmp_path, make, q0, qd0):
    model = make()
    sol = model.simulate(q0, qd0, 1.5, t_eval=np.linspace(0.0, 1.5, 9))
    assert gif_frames(model.animate(sol, str(tmp_path / "m.gif"), max_frames=30))[0] == 9


def test_animate_particle_route_chain_and_backwards(tmp_path):
    model = double_pendulum_particles()
    sol = model.simulate([1.0, 0.5], [0.0, 0.0], -1.0, t_eval=np.linspace(0.0, -1.0, 5))
    assert gif_frames(model.animate(sol, tmp_path / "c.gif", chain=True))[0] == 5


def test_animate_3d_points(tmp_path):
    th, ph = lg.coordinates("th ph")
    pos = (lg.sin(th) * lg.cos(ph), lg.sin(th) * lg.sin(ph), -lg.cos(th))
    model = lg.Model(coordinates=[th, ph], positions=[pos], masses=[1.0],
                     potential=9.81 * pos[2])
    sol = model.simulate([1.0, 0.0], [0.0, 2.0], 1.0, t_eval=np.linspace(0.0, 1.0, 6))
    assert gif_frames(model.animate(sol, tmp_path / "s.gif", chain=True))[0] == 6


def test_animate_errors(tmp_path):
    dp = lg.scenes.double_pendulum(**DP)
    sol = dp.simulate([1.0, 0.5], [0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match=r"\.gif, \.mp4"):
        dp.animate(sol, tmp_path / "dp.avi")
    with pytest.raises(ValueError, match="no positions"):
        double_pendulum_dsl().animate(sol, tmp_path / "dp.gif")
    pend = lg.scenes.simple_pendulum(m=1.0, l=1.0, g=9.81)
    with pytest.raises(ValueError, match="2 coordinates but the model has 1"):
        pend.animate(sol, tmp_path / "dp.gif")
    bad = lg.Solution(sol.t, np.where(sol.t[:, None] > 0.5, np.nan, sol.q), sol.qd, sol.energy,
                      sol.stats)
    with pytest.raises(ValueError, match="not finite"):
        dp.animate(bad, tmp_path / "dp.gif")
    empty = lg.Solution(np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), sol.stats)
    with pytest.raises(ValueError, match="empty"):
        dp.animate(empty, tmp_path / "dp.gif")
    with pytest.raises(ValueError, match="fps"):
        dp.animate(sol, tmp_path / "dp.gif", fps=0)
    with pytest.raises(ValueError, match="max_frames"):
        dp.animate(sol, tmp_path / "dp.gif", max_frames=0)
    assert not (tmp_path / "dp.gif").exists()


def test_animate_mp4_needs_ffmpeg(tmp_path):
    from matplotlib import animation

    pend = lg.scenes.simple_pendulum(m=1.0, l=1.0, g=9.81)
    sol = pend.simulate([0.5], [0.0], 1.0, t_eval=np.linspace(0.0, 1.0, 5))
    if animation.FFMpegWriter.isAvailable():
        assert pend.animate(sol, tmp_path / "p.mp4").stat().st_size > 0
    else:
        with pytest.raises(RuntimeError, match="ffmpeg"):
            pend.animate(sol, tmp_path / "p.mp4")


# -- Model(drawing=...) and the movie's frames ---------------------------------------------


def double_pendulum_drawn(l1=1.1, l2=0.8):
    """The seed's double pendulum stated by T and U (energy route), with its bobs to draw."""
    model = double_pendulum_dsl(l1=l1, l2=l2)
    th1, th2 = model.coordinates
    pl1, pl2 = lg.parameters("l1 l2")
    x1, y1 = pl1 * lg.sin(th1), -pl1 * lg.cos(th1)
    points = [(x1, y1), (x1 + pl2 * lg.sin(th2), y1 - pl2 * lg.cos(th2))]
    return lg.Model(coordinates=model.coordinates, kinetic=model.kinetic,
                    potential=model.potential, parameters=model.parameters, drawing=points)


def test_drawing_points_evaluate_to_the_closed_form():
    from lagrangian._plot import expression_positions

    model = double_pendulum_drawn()
    assert not model.has_positions and len(model.drawing) == 2
    f = expression_positions(model.drawing, ["th1", "th2"], model.parameters)
    states = np.array(STATES)
    assert_allclose(f(np.zeros(len(STATES)), states), [dp_closed_form(q) for q in STATES],
                    rtol=1e-15, atol=1e-15)
    # New parameter values reach the drawing; pickling keeps it.
    longer = model.with_parameters(l1=2.0)
    g = expression_positions(longer.drawing, ["th1", "th2"], longer.parameters)
    assert_allclose(g(np.zeros(1), states[:1]), [dp_closed_form(STATES[0], l1=2.0)],
                    rtol=1e-15)
    import pickle

    back = pickle.loads(pickle.dumps(model))
    assert back.drawing == model.drawing
    assert "drawing=[" in repr(model)
    assert_array_equal(back.accelerations(0.0, [0.3, 0.1], [0.0, 0.0]),
                       model.accelerations(0.0, [0.3, 0.1], [0.0, 0.0]))


def test_drawing_points_may_use_time():
    from lagrangian._plot import expression_positions

    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2,
                     drawing=[(x + lg.t, lg.cos(x))])
    f = expression_positions(model.drawing, ["x"], {})
    assert_allclose(f(np.array([0.5, 2.0]), np.array([[0.1], [0.3]])),
                    [[[0.6, math.cos(0.1)]], [[2.3, math.cos(0.3)]]], rtol=1e-15)


def test_drawing_errors():
    th, = lg.coordinates("th")
    T, U = 0.5 * th.d**2, -lg.cos(th)
    with pytest.raises(ValueError, match="velocity"):
        lg.Model(coordinates=[th], kinetic=T, potential=U, drawing=[(th.d, th)])
    with pytest.raises(ValueError, match="2 or 3 components"):
        lg.Model(coordinates=[th], kinetic=T, potential=U, drawing=[(th,)])
    with pytest.raises(ValueError, match="empty"):
        lg.Model(coordinates=[th], kinetic=T, potential=U, drawing=[])
    with pytest.raises(TypeError, match="sequence of points"):
        lg.Model(coordinates=[th], kinetic=T, potential=U, drawing=th)
    other, = lg.coordinates("phi")
    with pytest.raises(ValueError, match="not a coordinate"):
        lg.Model(coordinates=[th], kinetic=T, potential=U, drawing=[(other, th)])
    k, = lg.parameters("k")
    with pytest.raises(ValueError, match="no value"):
        lg.Model(coordinates=[th], kinetic=T, potential=U, drawing=[(k * th, th)])
    model = lg.Model(coordinates=[th], kinetic=T, potential=U)
    sol = model.simulate([0.5], [0.0], 1.0, t_eval=np.linspace(0.0, 1.0, 4))
    with pytest.raises(ValueError, match="velocity"):
        model.animate(sol, "never.gif", drawing=[(th.d, th)])
    with pytest.raises(ValueError, match="not a coordinate"):
        model.animate(sol, "never.gif", drawing=[(other, th)])


def test_animate_energy_route_with_drawing(tmp_path):
    model = double_pendulum_drawn()
    sol = model.simulate([1.0, 0.5], [0.0, 0.0], 2.0)
    frames, size = gif_frames(model.animate(sol, tmp_path / "dp.gif", max_frames=20))
    assert frames == 20 and size[0] > 100
    # Or points given to animate, for a model that has none.
    plain = double_pendulum_dsl()
    th1, _ = plain.coordinates
    out = plain.animate(sol, tmp_path / "one.gif", max_frames=5,
                        drawing=[(lg.sin(th1), -lg.cos(th1))])
    assert gif_frames(out)[0] == 5


def test_rods_where_the_motion_keeps_a_distance():
    from lagrangian._plot import auto_drawing, expression_positions

    model = double_pendulum_drawn()
    sol = model.simulate([1.0, 0.5], [0.0, 0.0], 3.0)
    f = expression_positions(model.drawing, ["th1", "th2"], model.parameters)
    dense = f(sol.t, sol.q)
    chain = auto_drawing(dense)
    assert chain.rods == ((-1, 0), (0, 1)) and chain.trail == (1,)
    assert chain.marks == ((0.0, 0.0),)
    # A spring (elastic pendulum): no rod; a dumbbell flying free: one rod, not to the origin.
    elastic = lg.scenes.elastic_pendulum(m=1.0, k=20.0, l0=1.0, g=9.81)
    esol = elastic.simulate([1.2, 0.5], [0.0, 0.0], 3.0)
    assert auto_drawing(elastic.positions(esol.t, esol.q)).rods == ()
    x, y, a = lg.coordinates("x y a")
    dumbbell = [(x + lg.cos(a), y + lg.sin(a)), (x - lg.cos(a), y - lg.sin(a))]
    f = expression_positions(dumbbell, ["x", "y", "a"], {})
    q = np.stack([np.linspace(1, 3, 50), np.linspace(0, 1, 50), np.linspace(0, 6, 50)], axis=1)
    assert auto_drawing(f(np.zeros(50), q)).rods == ((0, 1),)


def movie_of(model, sol, frames=12):
    from lagrangian import _plot

    times = _plot._frame_times(sol.t, frames)
    frame_pos = model.positions(times, _plot.trajectory(sol, times)[0])
    dense_t = np.linspace(sol.t[0], sol.t[-1], 10 * len(times))
    dense = model.positions(dense_t, _plot.trajectory(sol, dense_t)[0])
    return _plot._Movie(model._drawing(), times, frame_pos, dense_t, dense, [1])


@pytest.mark.parametrize("make,q0", [
    (lambda: lg.scenes.double_pendulum(**DP), [1.0, 0.5]),
    (lambda: lg.scenes.ball_in_sphere(**BALL), [1.0]),
], ids=["double_pendulum", "ball_in_sphere"])
def test_blitted_frames_equal_full_redraws(make, q0):
    model = make()
    sol = model.simulate(q0, [0.0] * len(q0), 1.0)
    movie = movie_of(model, sol)
    blitted = [frame.copy() for frame in movie.frames()]
    for artist in movie.moving:
        artist.set_animated(False)
    for i in (0, 5, len(blitted) - 1):
        movie.update(i)
        movie.canvas.draw()
        full = np.asarray(movie.canvas.buffer_rgba())
        differs = np.any(np.abs(full.astype(int) - blitted[i].astype(int)) > 2, axis=2)
        assert np.mean(differs) < 2e-3, (i, np.mean(differs))


def test_gif_frames_keep_the_rendered_colours(tmp_path):
    model = lg.scenes.double_pendulum(**DP)
    sol = model.simulate([1.0, 0.5], [0.0, 0.0], 1.0)
    path = model.animate(sol, tmp_path / "dp.gif", max_frames=12)
    movie = movie_of(model, sol)
    rendered = [frame[:, :, :3].astype(int) for frame in movie.frames()]
    with Image.open(path) as im:
        for i in (0, 6, 11):
            im.seek(i)
            got = np.asarray(im.convert("RGB")).astype(int)
            error = np.abs(got - rendered[i])
            # One palette for every frame, no dithering: white stays white, colours stay close.
            assert np.mean(error) < 1.0 and np.percentile(error, 99.9) < 24
            assert np.all(got[rendered[i].sum(axis=2) == 3 * 255] == 255)


# -- WorkPrecision.plot --------------------------------------------------------------------


def hand_made_work_precision(agreement, lowest=1e-9):
    from lagrangian._measure import Reference
    from lagrangian._workprec import Row

    rows = []
    for k, method in enumerate(m for m in lg.methods() if m != "auto"):
        for j, tol in enumerate([1e-4, 1e-7, 1e-10]):
            fixed = method in ("rk4", "stormer_verlet", "yoshida4", "yoshida6", "yoshida8",
                               "blanes_moan4", "midpoint", "gauss4", "gauss6")
            error = 10.0 ** (-2 - 3 * j - 0.1 * k) if j < 2 else lowest * (1 + k)
            rows.append(Row(method, None if fixed else tol, 0.01 / 2**j if fixed else None,
                            error, None, 1e-4 * (k + 1) * 4**j, 10, 100))
    rows.append(Row("gauss6", None, 1.0, None, None, None, 0, 0, "ConvergenceError: …"))
    ref = Reference(np.zeros(1), np.zeros(1), "computed", "two runs", agreement)
    wp = lg.WorkPrecision(rows, ref, "hand-made")
    peers = lg.WorkPrecision(
        [Row(f"scipy {m}", tol, None, 10 * tol, None, 1e-2 * tol**-0.1, 10, 100)
         for m in ("RK45", "DOP853", "Radau", "LSODA") for tol in (1e-4, 1e-8)], ref)
    return wp, peers


def test_work_precision_every_method_its_own_colour_and_marker(tmp_path):
    wp, peers = hand_made_work_precision(agreement=1e-12)
    fig = wp.plot(tmp_path / "wp.png", peers=peers)
    ax = fig.axes[0]
    lines = [line for line in ax.get_lines() if not line.get_label().startswith("_")]
    count = len(lg.methods()) - 1 + 4  # every method but auto, and SciPy's four
    assert len(lines) == count
    looks = {(line.get_color(), line.get_marker()) for line in lines}
    assert len({c for c, _ in looks}) == count and len({m for _, m in looks}) == count
    assert {line.get_linestyle() for line in lines if "scipy" in line.get_label()} == {"--"}
    # The same method looks the same in every figure.
    again = lg.WorkPrecision(wp.by_method("gauss6"), wp.reference).plot()
    (g6,) = [x for x in again.axes[0].get_lines() if x.get_label() == "gauss6"]
    (first,) = [x for x in lines if x.get_label() == "gauss6"]
    assert (g6.get_color(), g6.get_marker()) == (first.get_color(), first.get_marker())
    # Each point labelled with its tolerance or step.
    texts = [t.get_text() for t in ax.texts]
    # The adaptive ones (dopri5, dop853, radau5, taylor) and SciPy's four at 1e-4.
    assert texts.count("1e-4") == 4 + 4 and "0.0025" in texts
    drawn = sum(len(line.get_xdata()) for line in lines)
    assert len([t for t in ax.texts if t.get_fontsize() < 6]) == drawn
    # The legend sits outside the data.
    fig.draw_without_rendering()
    legend = ax.get_legend().get_window_extent()
    assert legend.x0 >= ax.get_window_extent().x1
    with Image.open(tmp_path / "wp.png") as im:
        assert im.size[0] > 500


def test_work_precision_floor_and_round_off_caveat():
    from lagrangian._plot import method_styles

    wp, _ = hand_made_work_precision(agreement=1e-12, lowest=1e-9)
    ax = wp.plot().axes[0]
    texts = " ".join(t.get_text() for t in ax.texts)
    assert "reference floor 1.0e-12" in texts and "grey: at round-off" not in texts
    floor = [x for x in ax.get_lines() if list(x.get_ydata()) == [1e-12, 1e-12]]
    assert len(floor) == 1
    # Errors down at the floor: shaded, with the caveat.
    wp, _ = hand_made_work_precision(agreement=1e-12, lowest=5e-13)
    ax = wp.plot().axes[0]
    assert "grey: at round-off" in " ".join(t.get_text() for t in ax.texts)
    assert len(ax.patches) == 1 and ax.get_ylim()[0] < 5e-13
    # An exact reference: the floor is round-off.
    wp, _ = hand_made_work_precision(agreement=None, lowest=1e-15)
    ax = wp.plot().axes[0]
    assert "round-off floor" in " ".join(t.get_text() for t in ax.texts)
    # Names not known get looks no other name in the figure has.
    styles = method_styles(["rk4", "mine", "theirs"])
    assert len(set(styles.values())) == 3
    assert len({c for c, _ in styles.values()}) == 3


def test_movie_frames_are_blitted_not_redrawn(tmp_path, monkeypatch):
    # What makes a 300-frame GIF take seconds: the figure is drawn in full twice (the palette's
    # last frame, the still background), every frame only blits the moving artists.
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    draws = []
    full = FigureCanvasAgg.draw
    monkeypatch.setattr(FigureCanvasAgg, "draw", lambda self: draws.append(1) or full(self))
    model = lg.scenes.double_pendulum(**DP)
    sol = model.simulate([1.0, 0.5], [0.0, 0.0], 2.0, t_eval=np.linspace(0.0, 2.0, 200))
    assert gif_frames(model.animate(sol, tmp_path / "dp.gif", max_frames=60))[0] == 60
    assert len(draws) == 2
