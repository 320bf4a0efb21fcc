"""Loads on rigid bodies (lg.Force, lg.Torque, lg.Spring, lg.Damper), bodies along a solution
(Model.body_motion) and their 3D pictures, and the classics stated with bodies
(lg.scenes.spinning_top, rolling_cylinder_body, ball_in_sphere_body), against closed forms and
hand derivations."""

import math

import numpy as np
import pytest

import lagrangian as lg
from lagrangian._expr import evaluate
from lagrangian._loads import partial_angular_velocity

RNG = np.random.default_rng(50)


def free_body(inertia=(0.3, 0.5, 0.7), mass=2.0):
    """A free body: position (x, y, z), ZYX Euler angles (a, b, c)."""
    x, y, z, a, b, c = lg.coordinates("x y z a b c")
    body = lg.Body(mass, list(inertia), [x, y, z], lg.euler_rotation([a, b, c], "zyx"),
                   name="free")
    return [x, y, z, a, b, c], body


def jacobian_of_omega(body, coords, q, axes="world"):
    """∂ω/∂q̇ at q (3 × dof), from the exact partials."""
    exprs = [e for c in coords for e in partial_angular_velocity(body, c, axes)]
    v = evaluate(exprs, [c.name for c in coords], {}, np.zeros(1), np.asarray(q)[None, :])
    return v[:, 0].reshape(len(coords), 3).T


# -- torques ---------------------------------------------------------------------------------
def test_torque_on_a_rotor_about_a_fixed_axis_gives_tau_over_i():
    a, = lg.coordinates("a")
    rotor = lg.Body(1.0, [0.3, 0.3, 0.5], [0, 0, 0], lg.rotation_about((1, 2, 2), a))
    k = np.array([1.0, 2.0, 2.0]) / 3.0
    tau = np.array([0.4, -1.0, 2.5])
    model = lg.Model([a], bodies=[rotor], loads=[lg.Torque(tau.tolist(), rotor)])
    # Only the component along the axis works: ä = τ·k / (kᵀ I k), the axis k fixed in the body
    # too (R k = k).
    moment = k @ np.diag([0.3, 0.3, 0.5]) @ k
    for _ in range(5):
        q, qd = RNG.normal(size=2)
        assert model.accelerations(0.0, [q], [qd])[0] == pytest.approx(tau @ k / moment,
                                                                       rel=1e-13)


@pytest.mark.parametrize("axes", ["world", "body"])
def test_torque_on_a_free_body_gives_inverse_inertia_times_tau(axes):
    coords, body = free_body()
    tau = np.array([0.7, -0.2, 1.1])
    model = lg.Model(coords, bodies=[body], loads=[lg.Torque(tau.tolist(), body, axes=axes)])
    inertia = np.diag([0.3, 0.5, 0.7])
    for _ in range(4):
        q = np.concatenate([RNG.normal(size=3), RNG.uniform(-1.2, 1.2, size=3)])
        qdd = model.accelerations(0.0, q, np.zeros(6))
        r = evaluate([e for row in body.orientation for e in row], [c.name for c in coords], {},
                     np.zeros(1), q[None, :])[:, 0].reshape(3, 3)
        # At rest ω̇ = J q̈ (world axes): R I⁻¹ Rᵀ τ_world, τ_world = τ or R τ.
        tau_world = tau if axes == "world" else r @ tau
        expected = r @ np.linalg.solve(inertia, r.T @ tau_world)
        assert np.allclose(jacobian_of_omega(body, coords, q) @ qdd, expected, rtol=0,
                           atol=1e-12)
        assert np.allclose(qdd[:3], 0.0, atol=1e-13)


# -- forces at points ------------------------------------------------------------------------
def test_force_at_the_tip_of_a_pendulum_equals_the_hand_written_generalized_force():
    th, = lg.coordinates("th")
    m, length, g = 1.3, 0.8, 9.81
    half = 0.5 * length
    rod = lg.Body(m, [m * length**2 / 12, m * length**2 / 12, 0.0],
                  [half * lg.sin(th), 0.0, -half * lg.cos(th)], lg.rotation_y(-th),
                  gravity=(0.0, 0.0, -g))
    # A force of t, q and q̇ at the tip (0, 0, −l/2 in body axes).
    f = [2.0 * lg.cos(3.0 * lg.t), 0.5, -0.7 * th.d]
    model = lg.Model([th], potential=rod.potential, bodies=[rod],
                     loads=[lg.Force(f, rod, point=[0.0, 0.0, -half])])
    tip_q = length * lg.cos(th) * f[0] + length * lg.sin(th) * f[2]   # F · ∂P/∂θ
    hand = lg.Model([th], kinetic=0.5 * (m * length**2 / 3) * th.d**2,
                    potential=-m * g * half * lg.cos(th), forces=[tip_q])
    for _ in range(6):
        t, q, qd = RNG.normal(size=3)
        assert model.accelerations(t, [q], [qd])[0] == pytest.approx(
            hand.accelerations(t, [q], [qd])[0], rel=1e-12, abs=1e-12)


def test_follower_thrust_in_body_axes_against_a_hand_derivation():
    x, y, th = lg.coordinates("x y th")
    m, inertia, thrust, d = 2.0, 0.3, 5.0, 0.4
    plate = lg.PlanarBody(m, inertia, [x, y], th)
    # Thrust T along the body's x axis, applied at (0, d) in body axes: the force turns with
    # the body, F = T (cos θ, sin θ), and its moment about the centre is −d T.
    model = lg.Model([x, y, th], bodies=[plate],
                     loads=[lg.Force([thrust, 0, 0], plate, point=[0, d, 0], axes="body")])
    for _ in range(5):
        q, qd = RNG.normal(size=3), RNG.normal(size=3)
        qdd = model.accelerations(0.0, q, qd)
        expected = [thrust / m * math.cos(q[2]), thrust / m * math.sin(q[2]),
                    -d * thrust / inertia]
        assert np.allclose(qdd, expected, rtol=0, atol=1e-12)


def test_virtual_power_equals_finite_differences_of_the_work():
    coords, body = free_body()
    names = [c.name for c in coords]
    force = np.array([0.3, -1.2, 0.8])
    tau = np.array([-0.5, 0.9, 0.4])
    point = [0.2, -0.1, 0.35]
    loads = [lg.Force(force.tolist(), body, point=point), lg.Torque(tau.tolist(), body)]
    model = lg.Model(coords, bodies=[body], loads=loads)
    q0 = np.concatenate([RNG.normal(size=3), RNG.uniform(-1.0, 1.0, size=3)])
    got = evaluate(list(model.forces), names, {}, np.zeros(1), q0[None, :])[:, 0]
    flat_r = [e for row in body.orientation for e in row]
    h = 1e-5

    def pose(q):
        v = evaluate(list(body.point(point)) + flat_r, names, {}, np.zeros(1), q[None, :])[:, 0]
        return v[:3], v[3:].reshape(3, 3)

    for i in range(6):
        e = np.zeros(6)
        e[i] = h
        (p_plus, r_plus), (p_minus, r_minus) = pose(q0 + e), pose(q0 - e)
        # F·δP for the force; for the torque the small rotation δθ = vee(R₊R₋ᵀ) (its
        # antisymmetric part: sin of the angle, exact to O(h³)).
        turn = r_plus @ r_minus.T
        skew = 0.5 * (turn - turn.T)
        dtheta = np.array([skew[2, 1], skew[0, 2], skew[1, 0]])
        work = force @ (p_plus - p_minus) + tau @ dtheta
        assert got[i] == pytest.approx(work / (2 * h), rel=1e-8, abs=1e-9)


# -- springs and dampers ---------------------------------------------------------------------
def test_spring_between_two_bodies_oscillates_with_the_reduced_mass():
    x1, x2 = lg.coordinates("x1 x2")
    m1, m2, k, rest = 1.5, 0.5, 12.0, 0.8
    r = lg.rotation_z(0.0)
    b1 = lg.Body(m1, [0.1, 0.1, 0.1], [x1, 0, 0], r, name="b1")
    b2 = lg.Body(m2, [0.1, 0.1, 0.1], [x2, 0, 0], r, name="b2")
    # Attached 0.1 off each centre, facing each other: the spring's length is x2 − x1 − 0.2.
    spring = lg.Spring(k, b1.point([0.1, 0, 0]), b2.point([-0.1, 0, 0]), rest_length=rest)
    model = lg.Model([x1, x2], bodies=[b1, b2], loads=[spring])
    mu = m1 * m2 / (m1 + m2)
    period = 2 * math.pi * math.sqrt(mu / k)
    s0 = rest + 0.2 + 0.15       # stretched 0.15 beyond rest
    sol = model.simulate([0.0, s0], [0.0, 0.0], period, t_eval=[0.5 * period, period],
                         rtol=1e-12, atol=1e-12)
    s = sol.q[:, 1] - sol.q[:, 0] - 0.2
    assert s[0] == pytest.approx(rest - 0.15, abs=1e-9)     # half a period: compressed
    assert s[1] == pytest.approx(rest + 0.15, abs=1e-9)     # a whole period: back
    # The centre of mass stays put; the energy is constant.
    centre = (m1 * sol.q[:, 0] + m2 * sol.q[:, 1]) / (m1 + m2)
    assert np.allclose(centre, m2 * s0 / (m1 + m2), atol=1e-10)
    assert np.ptp(sol.energy) < 1e-10
    assert float(model.energy(0.0, [0.0, s0], [0.0, 0.0])) == pytest.approx(0.5 * k * 0.15**2)


def test_zero_rest_length_spring_in_3d_is_isotropic():
    coords, body = free_body(mass=3.0)
    k = 7.0
    model = lg.Model(coords, bodies=[body], loads=[lg.Spring(k, body, [0.0, 0.0, 0.0])])
    q = np.concatenate([RNG.normal(size=3), RNG.uniform(-1, 1, size=3)])
    qdd = model.accelerations(0.0, q, np.zeros(6))
    assert np.allclose(qdd[:3], -k / 3.0 * q[:3], rtol=0, atol=1e-13)
    assert np.allclose(qdd[3:], 0.0, atol=1e-13)


def test_spring_between_frames_of_a_pendulum_chain():
    # A spring from the world point (d, 0, 0) to the origin of a frame at the end of a rod of
    # length l turned by θ about y: U = ½ k |P − A|², its generalized force −k (P − A)·∂P/∂θ.
    th, = lg.coordinates("th")
    tip = lg.Frame().revolute(th, axis=(0, 1, 0)).fixed(offset=(0, 0, -0.7))
    bob = tip.body(0.4, [0.01, 0.01, 0.01])
    k, d = 5.0, 0.3
    model = lg.Model([th], bodies=[bob], loads=[lg.Spring(k, tip, [d, 0.0, 0.0])])
    for _ in range(4):
        q, qd = RNG.normal(size=2)
        p = np.array([-0.7 * math.sin(q), 0.0, -0.7 * math.cos(q)])
        dp = np.array([-0.7 * math.cos(q), 0.0, 0.7 * math.sin(q)])
        force = -k * (p - np.array([d, 0.0, 0.0])) @ dp
        inertia = 0.4 * 0.49 + 0.01
        assert model.accelerations(0.0, [q], [qd])[0] == pytest.approx(force / inertia,
                                                                       rel=1e-12, abs=1e-12)


def test_damper_decays_at_the_closed_form_rate():
    x, = lg.coordinates("x")
    m, k, c = 2.0, 18.0, 1.2
    block = lg.Body(m, [0.1, 0.1, 0.1], [x + 2.0, 0, 0], lg.rotation_z(0.0), name="block")
    anchor = [0.0, 0.0, 0.0]
    model = lg.Model([x], bodies=[block],
                     loads=[lg.Spring(k, block, anchor, rest_length=2.0),
                            lg.Damper(c, block, anchor)])
    gamma = c / (2 * m)
    wd = math.sqrt(k / m - gamma**2)
    x0, v0 = 0.3, -0.4
    times = np.linspace(0.5, 6.0, 12)
    sol = model.simulate([x0], [v0], 6.0, t_eval=times, rtol=1e-12, atol=1e-12)
    exact = np.exp(-gamma * times) * (x0 * np.cos(wd * times)
                                      + (v0 + gamma * x0) / wd * np.sin(wd * times))
    assert np.allclose(sol.q[:, 0], exact, rtol=0, atol=1e-9)
    assert model.structure["dissipative"]


def test_damper_across_a_moving_line_resists_only_the_stretching():
    # Two free bodies, a damper between off-centre points: Φ = ½ c ℓ̇², the power −2Φ.
    x1, y1, t1, x2, y2, t2 = lg.coordinates("x1 y1 t1 x2 y2 t2")
    b1 = lg.PlanarBody(1.0, 0.2, [x1, y1], t1)
    b2 = lg.PlanarBody(2.0, 0.4, [x2, y2], t2)
    c = 0.9
    damper = lg.Damper(c, b1.point([0.2, 0.1, 0]), b2.point([-0.1, 0.3, 0]))
    model = lg.Model([x1, y1, t1, x2, y2, t2], bodies=[b1, b2], loads=[damper])
    q = RNG.normal(size=6)
    qd = RNG.normal(size=6)
    q[3] += 3.0
    names = [s.name for s in model.coordinates]
    ends = evaluate(list(b1.point([0.2, 0.1, 0])) + list(b2.point([-0.1, 0.3, 0])), names, {},
                    np.zeros(3), np.stack([q - 1e-6 * qd, q, q + 1e-6 * qd]))
    a, b = ends[:3], ends[3:]
    lengths = np.linalg.norm(a - b, axis=0)
    rate = (lengths[2] - lengths[0]) / 2e-6
    m = model.mass_matrix(0.0, q, qd)
    qdd = model.accelerations(0.0, q, qd)
    # The damper's power Q·q̇ = q̇ᵀ M q̈ (no other force) is −c ℓ̇².
    assert float(qd @ m @ qdd) == pytest.approx(-c * rate**2, rel=1e-7)


# -- errors ----------------------------------------------------------------------------------
def test_loads_refuse_bad_input_naming_the_load():
    x, = lg.coordinates("x")
    y, = lg.coordinates("y")
    k, = lg.parameters("k")
    block = lg.Body(1.0, [0.1, 0.1, 0.1], [x, 0, 0], lg.rotation_z(0.0))
    with pytest.raises(ValueError, match="force 'push': the force reads 'y', which is not a "
                                         "coordinate"):
        lg.Model([x], bodies=[block], loads=[lg.Force([y, 0, 0], block, name="push")])
    with pytest.raises(ValueError, match=r"loads\[0\] \(spring\): the stiffness reads the "
                                         "parameter 'k', which has no value"):
        lg.Model([x], bodies=[block], loads=[lg.Spring(k, block, [0, 0, 0])])
    with pytest.raises(ValueError, match="spring 's': the end a reads the velocity x.d"):
        lg.Model([x], bodies=[block], loads=[lg.Spring(1.0, [x.d, 0, 0], block, name="s")])
    with pytest.raises(TypeError, match=r"loads\[1\]: expected lg.Force, lg.Torque"):
        lg.Model([x], bodies=[block], loads=[lg.Torque([0, 0, 1], block), 3.0])
    with pytest.raises(ValueError, match="axes='local'; give 'world' or 'body'"):
        lg.Torque([0, 0, 1], block, axes="local")
    with pytest.raises(TypeError, match="expected an lg.Body"):
        lg.Force([1, 0, 0], [x, 0, 0])
    with pytest.raises(ValueError, match="the force must be three expressions"):
        lg.Force([1, 0], block)
    with pytest.raises(ValueError, match="forces: 2 expressions for 1 coordinates"):
        lg.Model([x], bodies=[block], forces=[1.0, 2.0], loads=[lg.Torque([0, 0, 1], block)])
    other = lg.Body(1.0, [0.1, 0.1, 0.1], [y, 0, 0], lg.rotation_z(0.0), name="other")
    with pytest.raises(ValueError, match="its body 'other' moves with 'y'"):
        lg.Model([x], bodies=[block], loads=[lg.Torque([0, 0, 1], other)])
    fast = lg.Body(1.0, [0.1, 0.1, 0.1], [x.d, 0, 0], lg.rotation_z(0.0), name="fast")
    with pytest.raises(ValueError, match="its body 'fast' is placed by the velocity x.d"):
        lg.Model([x], bodies=[block], loads=[lg.Force([1, 0, 0], fast)])


def test_loads_add_to_the_given_parts_and_survive_with_parameters():
    x, = lg.coordinates("x")
    k, = lg.parameters("k")
    block = lg.Body(1.0, [0.1, 0.1, 0.1], [x, 0, 0], lg.rotation_z(0.0))
    model = lg.Model([x], potential=0.5 * x**2, dissipation=0.1 * x.d**2, forces=[1.0],
                     parameters={"k": 4.0}, bodies=[block],
                     loads=[lg.Spring(k, block, [0, 0, 0]), lg.Force([2.0, 0, 0], block),
                            lg.Damper(0.6, [x + 1.0, 0, 0], [0, 0, 0])])
    # ẍ = 1 + 2 − x − 4x − 0.2ẋ − 0.6ẋ
    assert model.accelerations(0.0, [0.5], [1.0])[0] == pytest.approx(3 - 2.5 - 0.8, abs=1e-14)
    stiffer = model.with_parameters(k=10.0)
    assert stiffer.accelerations(0.0, [0.5], [1.0])[0] == pytest.approx(3 - 5.5 - 0.8, abs=1e-14)
    assert stiffer.bodies == (block,)


# -- bodies along a solution -------------------------------------------------------------------
def test_body_motion_of_a_body_spun_about_a_moving_axis():
    # R = R_z(Ω t) R_x(θ): ω = Ω e_z + θ̇ R_z(Ω t) e_x in world axes.
    th, = lg.coordinates("th")
    spin = 1.7
    body = lg.Body(1.0, [0.2, 0.3, 0.4], [lg.cos(spin * lg.t), lg.sin(spin * lg.t), th],
                   _matmul(lg.rotation_z(spin * lg.t), lg.rotation_x(th)),
                   name="spun")
    model = lg.Model([th], kinetic=0.5 * th.d**2, bodies=[body])
    sol = model.simulate([0.3], [0.8], 2.0, rtol=1e-11, atol=1e-11)
    motion = model.body_motion(sol)
    one = motion["spun"]
    assert one is motion[0] and len(motion) == 1
    t, q, qd = sol.t, sol.q[:, 0], sol.qd[:, 0]
    expected = np.stack([qd * np.cos(spin * t), qd * np.sin(spin * t), np.full_like(t, spin)], 1)
    assert np.allclose(one.angular_velocity, expected, rtol=0, atol=1e-13)
    # In body axes: Ω = Rᵀω = (θ̇, Ω sin θ, Ω cos θ).
    body_axes = np.stack([qd, spin * np.sin(q), spin * np.cos(q)], 1)
    assert np.allclose(one.angular_velocity_body, body_axes, rtol=0, atol=1e-13)
    velocity = np.stack([-spin * np.sin(spin * t), spin * np.cos(spin * t), qd], 1)
    assert np.allclose(one.velocity, velocity, rtol=0, atol=1e-13)
    assert np.allclose(one.position[:, 2], q, rtol=0, atol=0)
    kinetic = 0.5 * np.sum(velocity**2, 1) + 0.5 * (0.2 * qd**2 + 0.3 * (spin * np.sin(q))**2
                                                    + 0.4 * (spin * np.cos(q))**2)
    assert np.allclose(one.kinetic, kinetic, rtol=1e-14, atol=1e-14)
    assert one.orientation.shape == (len(t), 3, 3) and np.all(one.potential == 0.0)


def _matmul(a, b):
    return tuple(tuple(sum((a[i][k] * b[k][j] for k in range(3)), lg.Expr.lift(0.0))
                       for j in range(3)) for i in range(3))


def test_body_motion_of_the_top_orthonormal_and_its_energy_constant():
    model = lg.scenes.spinning_top()
    sol = model.simulate([0.0, 0.6, 0.0], [0.5, 0.0, 40.0], 2.0, rtol=1e-11, atol=1e-11)
    top = model.body_motion(sol)["top"]
    r = top.orientation
    gram = np.einsum("nki,nkj->nij", r, r)
    assert np.max(np.abs(gram - np.eye(3))) < 1e-14
    assert np.allclose(np.linalg.det(r), 1.0, rtol=0, atol=1e-14)
    # The whole model is this one body: its energy is the run's, and constant.
    assert np.allclose(top.energy, sol.energy, rtol=0, atol=1e-12)
    assert np.ptp(top.energy) < 1e-9
    # The symmetry axis is R's third column and the centre of mass is l up it.
    assert np.allclose(top.position, 0.3 * r[:, :, 2], rtol=0, atol=1e-15)
    # Ω₃ = ψ̇ + φ̇ cos θ is conserved (torque-free about the symmetry axis).
    assert np.ptp(top.angular_velocity_body[:, 2]) < 1e-8


def test_body_motion_errors():
    x, = lg.coordinates("x")
    plain = lg.Model([x], kinetic=0.5 * x.d**2)
    sol = plain.simulate([0.0], [1.0], 0.1)
    with pytest.raises(ValueError, match="this model has no bodies"):
        plain.body_motion(sol)
    with pytest.raises(TypeError, match=r"bodies\[0\]: expected lg.Body"):
        plain.body_motion(sol, [3])
    two = lg.Model(list(lg.coordinates("a b")), kinetic=0.5 * lg.Coordinate("a").d**2
                   + 0.5 * lg.Coordinate("b").d**2)
    block = lg.Body(1.0, [0.1, 0.1, 0.1], [x, 0, 0], lg.rotation_z(0.0), name="b")
    with pytest.raises(ValueError, match="give a solution of this model"):
        lg.Model([x], bodies=[block]).body_motion(two.simulate([0, 0], [1, 1], 0.1))
    with pytest.raises(KeyError, match="no body named 'c'"):
        lg.Model([x], bodies=[block]).body_motion(sol)["c"]


# -- pictures ----------------------------------------------------------------------------------
@pytest.fixture
def top_motion():
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    model = lg.scenes.spinning_top()
    sol = model.simulate([0.0, 0.6, 0.0], [0.5, 0.0, 40.0], 1.0, rtol=1e-9, atol=1e-9)
    return model.body_motion(sol)


def test_plot_bodies_draws_boxes_axes_and_trails(top_motion, tmp_path):
    fig = top_motion.plot(tmp_path / "top.png", snapshots=4)
    ax = fig.axes[0]
    # A trail, then per snapshot the box and its three principal axes.
    assert len(ax.lines) == 1 + 4 * (1 + 3)
    assert (tmp_path / "top.png").read_bytes().startswith(b"\x89PNG")
    box = ax.lines[1].get_data_3d()
    assert np.count_nonzero(np.isnan(box[0])) == 11          # twelve edges, eleven gaps
    positions = top_motion[0].position
    for i, (lo, hi) in enumerate((ax.get_xlim(), ax.get_ylim(), ax.get_zlim())):
        assert lo < positions[:, i].min() and positions[:, i].max() < hi
    # Cube limits: equal spans on the three axes.
    spans = [np.ptp(lim) for lim in (ax.get_xlim(), ax.get_ylim(), ax.get_zlim())]
    assert np.allclose(spans, spans[0], rtol=1e-12)
    # The box of the top: a² = 3(I_j + I_k − I_i)/(2m) for I = (0.02, 0.02, 0.03), m = 1.
    from lagrangian._plot_bodies import box_of

    half, _ = box_of(1.0, np.diag([0.02, 0.02, 0.03]))
    assert np.allclose(half, np.sqrt([0.045, 0.045, 0.015]), rtol=1e-14)
    assert len(top_motion.plot(snapshots=2, trail=False).axes[0].lines) == 2 * 4


def test_animate_bodies_writes_the_frames(top_motion, tmp_path):
    from PIL import Image

    out = top_motion.animate(tmp_path / "top.gif", fps=10, max_frames=8)
    with Image.open(out) as im:
        assert im.n_frames == 8
    with pytest.raises(ValueError, match="must end in .gif, .mp4"):
        top_motion.animate(tmp_path / "top.avi")


# -- the classics with bodies --------------------------------------------------------------------
def steady_precession(theta, spin, m=1.0, a=0.02, c=0.03, l=0.3, g=9.81):
    """The slow and fast roots Ω of A Ω² cos θ − C ω₃ Ω + m g l = 0."""
    big_a = a + m * l**2
    roots = np.sort(np.roots([big_a * math.cos(theta), -c * spin, m * g * l]).real)
    return roots[0], roots[1]


@pytest.mark.parametrize("spin", [40.0, 400.0])
def test_spinning_top_precesses_steadily_at_the_exact_rate(spin):
    model = lg.scenes.spinning_top()
    theta = 0.6
    slow, fast = steady_precession(theta, spin)
    for rate in (slow, fast):
        qd0 = [rate, 0.0, spin - rate * math.cos(theta)]
        assert np.allclose(model.accelerations(0.0, [0.0, theta, 0.0], qd0), 0.0, atol=1e-11)
    qd0 = [slow, 0.0, spin - slow * math.cos(theta)]
    t_end = 2.0
    sol = model.simulate([0.0, theta, 0.0], qd0, t_end, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(sol.q[:, 1] - theta)) < 1e-9
    assert sol.q[-1, 0] == pytest.approx(slow * t_end, rel=1e-9)
    # The fast-top limit Ω → m g l / (C ω₃): the slow root is m g l / (C ω₃) · c(x),
    # c(x) = (1 − √(1 − 4x)) / (2x) = 1 + x + 2x² + …, x = A cos θ m g l / (C ω₃)² (0.19 at
    # ω₃ = 40, 0.0019 at 400): the measured precession approaches the fast-top formula so.
    gyro = 1.0 * 9.81 * 0.3 / (0.03 * spin)
    x = (0.02 + 0.09) * math.cos(theta) * gyro / (0.03 * spin)
    measured = sol.q[-1, 0] / t_end
    assert measured / gyro == pytest.approx((1 - math.sqrt(1 - 4 * x)) / (2 * x), rel=1e-9)
    if spin > 100:
        assert abs(measured / gyro - 1.0 - x) < 2.5 * x**2


def test_spinning_top_from_frames_equals_the_euler_angle_body():
    model = lg.scenes.spinning_top(m=1.2, a=0.025, c=0.04, l=0.25, g=9.81)
    phi, th, psi = lg.coordinates("phi th psi")
    r = lg.euler_rotation([phi, th, psi], "zxz")
    top = lg.Body(1.2, [0.025, 0.025, 0.04], [0.25 * r[i][2] for i in range(3)], r,
                  gravity=(0.0, 0.0, -9.81))
    direct = lg.Model([phi, th, psi], potential=top.potential, bodies=[top])
    for _ in range(5):
        q = RNG.uniform(-1.0, 1.0, 3) + np.array([0.0, 1.5, 0.0])
        qd = RNG.normal(size=3) * 5
        assert np.allclose(model.accelerations(0.0, q, qd), direct.accelerations(0.0, q, qd),
                           rtol=1e-12, atol=1e-12)


def test_rolling_cylinder_with_a_body_equals_the_scene():
    scene = lg.scenes.rolling_cylinder(m=1.3, j=0.007, r=0.12, g=9.81, alpha=0.4)
    one = lg.scenes.rolling_cylinder_body(m=1.3, j=0.007, r=0.12, g=9.81, alpha=0.4)
    kept = lg.scenes.rolling_cylinder_body(m=1.3, j=0.007, r=0.12, g=9.81, alpha=0.4,
                                           constrained=True)
    assert [c.name for c in one.coordinates] == ["x"]
    exact = 1.3 * 9.81 * math.sin(0.4) / (1.3 + 0.007 / 0.12**2)      # eq. 48
    for _ in range(5):
        x, v = RNG.normal(size=2)
        a = scene.accelerations(0.0, [x], [v])[0]
        assert a == pytest.approx(exact, rel=1e-12)
        assert one.accelerations(0.0, [x], [v])[0] == pytest.approx(a, rel=1e-12, abs=1e-12)
        both = kept.accelerations(0.0, [x, -x / 0.12], [v, -v / 0.12])
        assert both[0] == pytest.approx(a, rel=1e-12, abs=1e-12)
        assert both[1] == pytest.approx(-a / 0.12, rel=1e-12)
        assert float(one.energy(0.0, [x], [v])) == pytest.approx(
            float(scene.energy(0.0, [x], [v])), rel=1e-12, abs=1e-12)


def test_ball_in_sphere_with_a_body_equals_the_scene():
    values = dict(m=0.8, j=0.02, r1=1.1, r2=0.25, g=9.81)
    scene = lg.scenes.ball_in_sphere(**values)
    one = lg.scenes.ball_in_sphere_body(**values)
    kept = lg.scenes.ball_in_sphere_body(**values, constrained=True)
    ratio = (1.1 - 0.25) / 0.25
    for _ in range(5):
        th, v = RNG.normal(size=2)
        a = scene.accelerations(0.0, [th], [v])[0]
        assert one.accelerations(0.0, [th], [v])[0] == pytest.approx(a, rel=1e-12, abs=1e-12)
        both = kept.accelerations(0.0, [th, -ratio * th], [v, -ratio * v])
        assert both[0] == pytest.approx(a, rel=1e-12, abs=1e-12)
    # Small oscillations: ω² = g / ((r₁ − r₂)(1 + J/(m r₂²))) (eq. 53 linearized).
    w2 = 9.81 / ((1.1 - 0.25) * (1 + 0.02 / (0.8 * 0.25**2)))
    assert one.modes([0.0]).frequencies[0] ** 2 == pytest.approx(w2, rel=1e-10)


def test_body_scenes_are_listed_and_check_their_parameters():
    assert lg.scenes.BODIES == ("spinning_top", "gyroscope", "rolling_cylinder_body",
                                "ball_in_sphere_body")
    for name in lg.scenes.BODIES:
        model = getattr(lg.scenes, name)()
        assert isinstance(model, lg.Model) and len(model.bodies) == (3 if name == "gyroscope"
                                                                      else 1)
    with pytest.raises(ValueError, match="spinning_top: parameter 'l' = 0.0 must be > 0"):
        lg.scenes.spinning_top(l=0.0)
    with pytest.raises(ValueError, match="ball_in_sphere_body: the ball's radius"):
        lg.scenes.ball_in_sphere_body(r2=2.0)
    with pytest.raises(ValueError, match="triangle inequality"):
        lg.scenes.spinning_top(a=0.01, c=0.05)
    with pytest.raises(ValueError, match="gyroscope: the rotor's moments c = 0.05 > 2a"):
        lg.scenes.gyroscope(a=0.01, c=0.05)
    with pytest.raises(ValueError, match="gyroscope: parameter 'outer' = -1.0 must be ≥ 0"):
        lg.scenes.gyroscope(outer=-1.0)


def test_a_torque_about_the_node_line_replaces_gravity_on_the_top():
    # Gravity's moment about the tip is m g l sin θ along the node line (cos φ, sin φ, 0): the
    # top without gravity under that torque (world axes, a function of q) moves as the heavy top;
    # the same torque stated in body axes, Rᵀ of it, too.
    heavy = lg.scenes.spinning_top()
    light = lg.scenes.spinning_top(g=0.0)
    top, = light.bodies
    phi, th, psi = light.coordinates
    size = 1.0 * 9.81 * 0.3 * lg.sin(th)
    world = [size * lg.cos(phi), size * lg.sin(phi), 0.0]
    r = top.orientation
    body = [sum((r[k][i] * world[k] for k in range(3)), lg.Expr.lift(0.0)) for i in range(3)]
    values = {k: v for k, v in light.parameters.items() if k != "g"}
    for axes, tau in (("world", world), ("body", body)):
        driven = lg.Model(list(light.coordinates), kinetic=light.kinetic, parameters=values,
                          loads=[lg.Torque(tau, top, axes=axes, name="node")])
        for _ in range(4):
            q = RNG.uniform(-1.0, 1.0, 3) + np.array([0.0, 1.5, 0.0])
            qd = RNG.normal(size=3) * 5
            assert np.allclose(driven.accelerations(0.0, q, qd), heavy.accelerations(0.0, q, qd),
                               rtol=1e-12, atol=1e-12)


def test_gyroscope_nutates_at_c_omega_over_the_gimbals_moments():
    # Linearized about θ = 0 at spin ω: A_out ψ̈ = −C ω θ̇, A_in θ̈ = C ω ψ̇ — the gimbals nutate
    # at ω_n = C ω / √(A_in A_out), the only non-zero eigenvalues ±i ω_n.
    a, c, inner, inner_z, outer = 0.012, 0.02, 0.004, 0.003, 0.006
    gyro = lg.scenes.gyroscope(a=a, c=c, inner=inner, inner_z=inner_z, outer=outer)
    for omega in (50.0, 300.0):
        lin = gyro.linearize([0.0, 0.0, 0.0], [0.0, 0.0, omega])
        expected = c * omega / math.sqrt((a + inner) * (a + inner_z + outer))
        eig = np.sort_complex(lin.eigenvalues)
        assert np.max(np.abs(eig.real)) < 1e-12 * expected
        assert abs(np.max(eig.imag) - expected) < 1e-12 * expected
        assert np.sum(np.abs(eig) > 1e-9 * expected) == 2


def test_gyroscope_under_a_torque_precesses_at_tau_over_c_omega():
    # From rest in the gimbals, a torque τ about the inner axis on a rotor spinning at ω about y:
    # H = C ω ŷ turns towards the torque, x̂, so the outer gimbal turns about z backwards,
    # ψ̇ = −(τ / C ω)(1 − cos ω_n t), θ = (A_out τ / (C ω)²)(1 − cos ω_n t). θ stays below 1e-6:
    # the nonlinear run follows the linear solution to O(θ²).
    a, c, inner, inner_z, outer, tau, omega = 0.012, 0.02, 0.004, 0.003, 0.006, 1e-4, 200.0
    gyro = lg.scenes.gyroscope(a=a, c=c, inner=inner, inner_z=inner_z, outer=outer, tau=tau)
    a_out = a + inner_z + outer
    wn = c * omega / math.sqrt((a + inner) * a_out)
    t = np.linspace(0.0, 2.0, 201)
    sol = gyro.simulate([0.0, 0.0, 0.0], [0.0, 0.0, omega], t_end=2.0, t_eval=t, rtol=1e-12,
                        atol=1e-14, method="dop853")
    rate = tau / (c * omega)
    psi = -rate * (t - np.sin(wn * t) / wn)
    theta = a_out * tau / (c * omega) ** 2 * (1.0 - np.cos(wn * t))
    assert np.max(np.abs(sol.q[:, 0] - psi)) < 1e-6 * np.max(np.abs(psi))
    assert np.max(np.abs(sol.q[:, 1] - theta)) < 1e-4 * np.max(theta)
    assert abs(sol.qd[-1, 2] - omega) < 1e-6 * omega      # the spin is kept


def test_partial_angular_velocity_read_off_the_carried_omega_equals_vee_of_dr():
    # A rotation that carries Ω gives ∂ω/∂ṡ as the coefficient of ṡ in Ω; a matrix given entry
    # by entry, vee(∂R/∂s Rᵀ): the same at random states, world and body axes.
    coords, body = free_body()
    plain = lg.Body(2.0, [0.3, 0.5, 0.7], body.position, [list(row) for row in body.orientation])
    assert body.omega is not None and plain.omega is None
    rng = np.random.default_rng(3)
    for axes in ("world", "body"):
        for q in rng.uniform(-1.5, 1.5, size=(3, 6)):
            a = jacobian_of_omega(body, coords, q, axes)
            b = jacobian_of_omega(plain, coords, q, axes)
            assert np.max(np.abs(a - b)) < 1e-13
