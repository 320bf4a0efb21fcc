"""Joints on ``lg.Frame`` (revolute, prismatic, spherical, universal, planar, free), loop
closures (``lg.coincide``) and joint reactions (``lg.joint_reaction``, ``lg.loop_reaction``),
checked against hand-written Lagrangians, closed forms (a pendulum's rod tension, a compound
pendulum's pivot force, a four-bar's 1-DOF energy equation, Euler's equations) and conservation
laws; bad input refused with the joint named."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import lagrangian as lg

TIGHT = dict(rtol=1e-12, atol=1e-12)
G = 9.81


def _close(a, b, tol):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert np.max(np.abs(a - b)) <= tol * (1 + np.max(np.abs(b))), np.max(np.abs(a - b))


def _agree(model_a, model_b, n, seed, tol=1e-12, spread=2.0):
    rng = np.random.default_rng(seed)
    for _ in range(5):
        q, qd = rng.uniform(-spread, spread, n), rng.uniform(-spread, spread, n)
        _close(model_a.accelerations(0.0, q, qd), model_b.accelerations(0.0, q, qd), tol)


# -- revolute ------------------------------------------------------------------------------------
def _compound(m=1.3, L=0.7):
    th, = lg.coordinates("th")
    link = lg.Frame().revolute(th, axis=(0, 1, 0), name="pivot")
    rod = link.body(m, [m * L**2 / 12, m * L**2 / 12, 0.0], center=(0, 0, -L / 2),
                    gravity=(0, 0, -G), name="rod")
    return th, link, rod, lg.Model([th], potential=rod.potential, bodies=[rod])


def test_compound_pendulum_by_revolute_joint_is_the_hand_written_one():
    m, L = 1.3, 0.7
    th, _, _, model = _compound(m, L)
    by_hand = lg.Model([th], kinetic=0.5 * (m * L**2 / 3) * th.d**2,
                       potential=-m * G * L / 2 * lg.cos(th))
    _agree(model, by_hand, 1, 0, 1e-13)


def test_compound_pendulum_pivot_force_is_the_closed_form():
    # uniform rod about its end: radial m(L/2 θ̇² + g cos θ) towards the pivot, tangential
    # m g sin θ · I_c/(I_c + m L²/4) = m g sin θ / 4; no torque about the hinge
    m, L = 1.3, 0.7
    th, link, _, model = _compound(m, L)
    sol = model.simulate([2.0], [0.5], 4.0, **TIGHT, t_eval=np.linspace(0, 4, 81))
    r = lg.joint_reaction(model, sol, link)
    a, w = sol.q[:, 0], sol.qd[:, 0]
    # the centre at (−sin θ, 0, −cos θ) L/2
    up = np.stack([np.sin(a), np.zeros_like(a), np.cos(a)], 1)  # from the centre to the pivot
    tangent = np.stack([-np.cos(a), np.zeros_like(a), np.sin(a)], 1)  # increasing θ
    _close(np.sum(r.force * up, 1), m * (L / 2 * w**2 + G * np.cos(a)), 1e-10)
    _close(np.sum(r.force * tangent, 1), m * G * np.sin(a) / 4, 1e-10)
    _close(r.force[:, 1], 0.0, 1e-12)
    _close(r.torque[:, 1], 0.0, 1e-10)
    _close(r.point, 0.0, 0.0)
    # the same in the joint's own axes: the rod is along −z there
    rf = lg.joint_reaction(model, sol, link, axes="frame")
    _close(rf.force[:, 2], m * (L / 2 * w**2 + G * np.cos(a)), 1e-10)


def test_pendulum_rod_tension_is_m_g_cos_plus_l_thetadot_squared():
    # a ball of radius ρ on a rod of length l: the tension m(g cos θ + l θ̇²) whatever ρ
    th, = lg.coordinates("th")
    m, l, rho = 0.8, 1.2, 0.1
    arm = lg.Frame().revolute(th, axis=(0, 0, 1))
    ball = arm.body(m, [0.4 * m * rho**2] * 3, center=(0, -l, 0), gravity=(0, -G, 0))
    model = lg.Model([th], potential=ball.potential, bodies=[ball])
    sol = model.simulate([1.0], [3.0], 5.0, **TIGHT, t_eval=np.linspace(0, 5, 101))
    r = lg.joint_reaction(model, sol, arm, axes="frame")  # arm axes: the rod along −y
    a, w = sol.q[:, 0], sol.qd[:, 0]
    _close(r.force[:, 1], m * (G * np.cos(a) + l * w**2), 1e-10)
    i_c = 0.4 * m * rho**2
    _close(r.force[:, 0], m * G * np.sin(a) * i_c / (i_c + m * l**2), 1e-10)
    _close(r.torque, 0.0, 1e-10)


def test_applied_forces_enter_the_reaction():
    # a constant horizontal push F at the bob, stated to the model as Q = F l cos θ: the hinge
    # carries no torque about its axis once the push is counted, and F l cos θ without it
    th, = lg.coordinates("th")
    m, l, F = 0.8, 1.2, 2.5
    arm = lg.Frame().revolute(th, axis=(0, 0, 1))
    bob = arm.body(m, [0.01] * 3, center=(0, -l, 0), gravity=(0, -G, 0))
    model = lg.Model([th], potential=bob.potential, bodies=[bob], forces=[F * l * lg.cos(th)])
    sol = model.simulate([0.3], [0.0], 3.0, **TIGHT, t_eval=np.linspace(0, 3, 31))
    push = (arm.point((0, -l, 0)), (F, 0.0, 0.0))
    r = lg.joint_reaction(model, sol, arm, applied=[push])
    _close(r.torque[:, 2], 0.0, 1e-11)
    without = lg.joint_reaction(model, sol, arm)
    _close(without.torque[:, 2], F * l * np.cos(sol.q[:, 0]), 1e-11)
    with pytest.raises(ValueError, match=r"applied\[0\]"):
        lg.joint_reaction(model, sol, arm, applied=[(F, 0.0)])


def test_applied_torques_enter_the_reaction():
    # a motor torque τ(t) about the hinge, stated to the model as Q = τ: counted, the hinge
    # carries no torque about its axis; left out, the reaction's axial torque is τ itself
    th, = lg.coordinates("th")
    m, l = 0.8, 1.2
    tau = 0.7 * lg.cos(2.0 * lg.t)
    arm = lg.Frame().revolute(th, axis=(0, 0, 1))
    bob = arm.body(m, [0.01] * 3, center=(0, -l, 0), gravity=(0, -G, 0))
    model = lg.Model([th], potential=bob.potential, bodies=[bob], forces=[tau])
    sol = model.simulate([0.3], [0.0], 3.0, **TIGHT, t_eval=np.linspace(0, 3, 31))
    r = lg.joint_reaction(model, sol, arm, applied_torques=[(0.0, 0.0, tau)])
    _close(r.torque[:, 2], 0.0, 1e-11)
    without = lg.joint_reaction(model, sol, arm)
    _close(without.torque[:, 2], 0.7 * np.cos(2.0 * sol.t), 1e-11)
    with pytest.raises(ValueError, match=r"applied_torques\[0\]"):
        lg.joint_reaction(model, sol, arm, applied_torques=[(1.0, 2.0)])


def _double(m1=1.0, m2=0.7, L1=1.1, L2=0.8):
    t1, t2 = lg.coordinates("t1 t2")
    upper = lg.Frame().revolute(t1, axis=(0, 0, 1), name="shoulder")
    lower = upper.revolute(t2, axis=(0, 0, 1), offset=(0, -L1, 0), name="elbow")
    b1 = upper.body(m1, [m1 * L1**2 / 12, 0.0, m1 * L1**2 / 12], (0, -L1 / 2, 0),
                    gravity=(0, -G, 0))
    b2 = lower.body(m2, [m2 * L2**2 / 12, 0.0, m2 * L2**2 / 12], (0, -L2 / 2, 0),
                    gravity=(0, -G, 0))
    model = lg.Model([t1, t2], potential=b1.potential + b2.potential, bodies=[b1, b2])
    return (t1, t2), upper, lower, model


def test_double_pendulum_by_two_revolute_joints_is_the_hand_written_one():
    m1, m2, L1, L2 = 1.0, 0.7, 1.1, 0.8
    (t1, t2), upper, lower, model = _double(m1, m2, L1, L2)
    p2 = t1 + t2  # the lower rod's absolute angle
    v1 = (L1 / 2 * lg.cos(t1) * t1.d, L1 / 2 * lg.sin(t1) * t1.d)
    v2 = (L1 * lg.cos(t1) * t1.d + L2 / 2 * lg.cos(p2) * (t1.d + t2.d),
          L1 * lg.sin(t1) * t1.d + L2 / 2 * lg.sin(p2) * (t1.d + t2.d))
    T = (0.5 * m1 * (v1[0]**2 + v1[1]**2) + 0.5 * (m1 * L1**2 / 12) * t1.d**2
         + 0.5 * m2 * (v2[0]**2 + v2[1]**2) + 0.5 * (m2 * L2**2 / 12) * (t1.d + t2.d)**2)
    U = -G * (m1 * L1 / 2 * lg.cos(t1) + m2 * (L1 * lg.cos(t1) + L2 / 2 * lg.cos(p2)))
    by_hand = lg.Model([t1, t2], kinetic=T, potential=U)
    _agree(model, by_hand, 2, 1, 1e-12, spread=3.0)
    # frictionless hinges: no torque about either axis; the shoulder carries both rods
    sol = model.simulate([1.5, -0.5], [0.0, 2.0], 3.0, **TIGHT, t_eval=np.linspace(0, 3, 61))
    for frame in (upper, lower):
        r = lg.joint_reaction(model, sol, frame)
        _close(r.torque[:, 2], 0.0, 1e-11)
    r_top = lg.joint_reaction(model, sol, upper)
    r_el = lg.joint_reaction(model, sol, lower)
    qdd = model.accelerations(0.0, sol.q, sol.qd)
    a1 = L1 / 2 * (qdd[:, 0] * np.cos(sol.q[:, 0]) - sol.qd[:, 0]**2 * np.sin(sol.q[:, 0]))
    _close(r_top.force[:, 0] - r_el.force[:, 0], m1 * a1, 1e-10)  # the upper rod's Newton in x


# -- prismatic + revolute: a pendulum on a cart -------------------------------------------------
def test_pendulum_on_a_cart_is_its_hand_written_lagrangian():
    x, th = lg.coordinates("x th")
    M, m, l = 2.0, 0.5, 0.9
    cart = lg.Frame().prismatic(x, axis=(1, 0, 0), name="rail")
    arm = cart.revolute(th, axis=(0, 0, 1), name="hinge")
    box = cart.body(M, [0.1, 0.1, 0.1], gravity=(0, -G, 0))
    bob = arm.body(m, [0.0, 0.0, 0.0], center=(0, -l, 0), gravity=(0, -G, 0))
    model = lg.Model([x, th], potential=box.potential + bob.potential, bodies=[box, bob])
    T = 0.5 * (M + m) * x.d**2 + m * l * lg.cos(th) * x.d * th.d + 0.5 * m * l**2 * th.d**2
    by_hand = lg.Model([x, th], kinetic=T, potential=-m * G * l * lg.cos(th))
    _agree(model, by_hand, 2, 2, 1e-12, spread=3.0)
    sol = model.simulate([0.0, 1.0], [0.3, 0.0], 3.0, **TIGHT, t_eval=np.linspace(0, 3, 61))
    rail = lg.joint_reaction(model, sol, cart)
    _close(rail.force[:, 0], 0.0, 1e-11)  # nothing pushes the cart along its rail
    hinge = lg.joint_reaction(model, sol, arm, axes="frame")
    qdd = model.accelerations(0.0, sol.q, sol.qd)
    a, w = sol.q[:, 1], sol.qd[:, 1]
    # the rod's tension: m (g cos θ + l θ̇² − ẍ sin θ)
    _close(hinge.force[:, 1], m * (G * np.cos(a) + l * w**2 - qdd[:, 0] * np.sin(a)), 1e-10)


# -- spherical ------------------------------------------------------------------------------------
def _ball_on_rod(frame, m, l, rho):
    return frame.body(m, [0.4 * m * rho**2] * 3, center=(0, 0, -l), gravity=(0, 0, -G))


def _lz(R, w, m, l, rho):
    """Angular momentum about the vertical through the pivot, in NumPy: the ball at R(0,0,−l)."""
    r = R @ np.array([0.0, 0.0, -l])
    v = np.cross(w, r)
    return (m * np.cross(r, v) + 0.4 * m * rho**2 * w)[2]


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def test_spherical_pendulum_conserves_energy_and_vertical_momentum():
    m, l, rho = 1.1, 0.9, 0.15
    a, b, c = lg.coordinates("a b c")
    ball_frame = lg.Frame().spherical([a, b, c], "zyx")
    ball = _ball_on_rod(ball_frame, m, l, rho)
    model = lg.Model([a, b, c], potential=ball.potential, bodies=[ball])
    sol = model.simulate([0.2, 0.7, 0.1], [1.5, 0.0, 0.3], 10.0, **TIGHT,
                         t_eval=np.linspace(0, 10, 201))
    _close(sol.energy, sol.energy[0], 1e-10)
    lz = []
    for (z, y, x), (zd, yd, xd) in zip(sol.q, sol.qd):
        R = _rz(z) @ _ry(y) @ _rx(x)
        w = zd * np.array([0, 0, 1.0]) + yd * (_rz(z) @ [0, 1.0, 0]) + xd * (R @ [1.0, 0, 0])
        lz.append(_lz(R, w, m, l, rho))
    assert np.max(np.abs(np.array(lz) - lz[0])) < 1e-10
    assert abs(lz[0]) > 0.1  # a real swirl, not a plane swing
    r = lg.joint_reaction(model, sol, ball_frame)
    _close(r.torque, 0.0, 1e-11)  # a ball joint transmits no torque


def test_spherical_pendulum_by_quaternion_keeps_its_norm_and_matches_the_angles():
    m, l, rho = 1.1, 0.9, 0.15
    qs = lg.coordinates("q0 q1 q2 q3")
    frame = lg.Frame().spherical(quaternion=qs, name="ball")
    assert list(frame.constraints) == ["ball.unit"]
    ball = _ball_on_rod(frame, m, l, rho)
    model = lg.Model(list(qs), potential=ball.potential, bodies=[ball],
                     constraints=frame.constraints)
    # the same start as the Euler-angle run: R = R_z(0.2) R_y(0.7) R_x(0.1)
    ang = np.array([0.2, 0.7, 0.1])
    half = [np.array([np.cos(v / 2), *(np.sin(v / 2) * e)])
            for v, e in zip(ang, np.eye(3)[[2, 1, 0]])]
    quat = _qmul(_qmul(half[0], half[1]), half[2])
    R0 = _rz(ang[0]) @ _ry(ang[1]) @ _rx(ang[2])
    w0 = 1.5 * np.array([0, 0, 1.0]) + 0.3 * (R0 @ [1.0, 0, 0])  # ż = 1.5, ẋ = 0.3
    qd0 = 0.5 * _qmul(np.array([0.0, *w0]), quat)  # q̇ = ½ ω ⊗ q (ω in world axes)
    sol = model.simulate(quat, qd0, 10.0, **TIGHT, t_eval=np.linspace(0, 10, 201))
    assert np.max(np.abs(np.linalg.norm(sol.q, axis=1) - 1)) < 1e-10
    _close(sol.energy, sol.energy[0], 1e-10)
    a, b, c = lg.coordinates("a b c")
    euler_frame = lg.Frame().spherical([a, b, c], "zyx")
    eb = _ball_on_rod(euler_frame, m, l, rho)
    euler = lg.Model([a, b, c], potential=eb.potential, bodies=[eb])
    ref = euler.simulate(ang, [1.5, 0.0, 0.3], 10.0, **TIGHT, t_eval=np.linspace(0, 10, 201))
    for qq, (z, y, x) in zip(sol.q, ref.q):  # the same ball position
        assert np.max(np.abs(_qrot(qq) @ [0, 0, -l] - _rz(z) @ _ry(y) @ _rx(x) @ [0, 0, -l])) \
            < 1e-8


def _qmul(p, q):
    w1, v1 = p[0], np.asarray(p[1:])
    w2, v2 = q[0], np.asarray(q[1:])
    return np.concatenate([[w1 * w2 - v1 @ v2], w1 * v2 + w2 * v1 + np.cross(v1, v2)])


def _qrot(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[w*w + x*x - y*y - z*z, 2*(x*y - w*z), 2*(x*z + w*y)],
                     [2*(x*y + w*z), w*w - x*x + y*y - z*z, 2*(y*z - w*x)],
                     [2*(x*z - w*y), 2*(y*z + w*x), w*w - x*x - y*y + z*z]])


# -- universal ----------------------------------------------------------------------------------
def test_universal_joint_pendulum_is_its_hand_written_lagrangian():
    a, b = lg.coordinates("a b")
    m, l, I1, I2, I3 = 0.9, 1.3, 0.05, 0.07, 0.03
    cross = lg.Frame().universal([a, b], axes=((1, 0, 0), (0, 1, 0)), name="hooke")
    body = cross.body(m, [I1, I2, I3], center=(0, 0, -l), gravity=(0, 0, -G))
    model = lg.Model([a, b], potential=body.potential, bodies=[body])
    # p = R_x(a) R_y(b) (0, 0, −l) = (−l sin b, l cos b sin a, −l cos b cos a);
    # Ω = (ȧ cos b, ḃ, ȧ sin b) in body axes
    ca, sa, cb, sb = lg.cos(a), lg.sin(a), lg.cos(b), lg.sin(b)
    v = (-l * cb * b.d, l * (-sb * sa * b.d + cb * ca * a.d), l * (sb * ca * b.d + cb * sa * a.d))
    T = 0.5 * m * (v[0]**2 + v[1]**2 + v[2]**2) + 0.5 * (I1 * (a.d * cb)**2 + I2 * b.d**2
                                                         + I3 * (a.d * sb)**2)
    by_hand = lg.Model([a, b], kinetic=T, potential=-m * G * l * cb * ca)
    _agree(model, by_hand, 2, 3, 1e-12, spread=1.2)
    sol = model.simulate([0.5, -0.4], [1.0, 2.0], 3.0, **TIGHT, t_eval=np.linspace(0, 3, 61))
    r = lg.joint_reaction(model, sol, cross, axes="frame")  # about the second axis: body y
    _close(r.torque[:, 1], 0.0, 1e-11)
    rw = lg.joint_reaction(model, sol, cross)  # about the first axis: world x
    _close(rw.torque[:, 0], 0.0, 1e-11)
    assert np.max(np.abs(r.torque[:, 2])) > 1e-3  # the cross does carry a torque about its normal


# -- planar ----------------------------------------------------------------------------------------
def test_planar_joint_body_is_the_planar_body():
    x, y, th = lg.coordinates("x y th")
    frame = lg.Frame().planar(x, y, th)
    body = frame.body(2.0, [0.25, 0.25, 0.5], center=(0.3, 0.0, 0.0))
    model = lg.Model([x, y, th], bodies=[body], potential=2.0 * G * y)
    ref_body = lg.PlanarBody(2.0, 0.5, (x + 0.3 * lg.cos(th), y + 0.3 * lg.sin(th)), th)
    ref = lg.Model([x, y, th], bodies=[ref_body], potential=2.0 * G * y)
    _agree(model, ref, 3, 4, 1e-12)
    # a plane tilted by axes (x, z): y ↦ world z, the normal −y
    tilted = lg.Frame().planar(x, y, th, axes=((1, 0, 0), (0, 0, 1)))
    tb = tilted.body(2.0, [0.25, 0.5, 0.25])  # the moment 0.5 about the normal, body y
    tm = lg.Model([x, y, th], bodies=[tb], potential=2.0 * G * y)
    centred = lg.Model([x, y, th], bodies=[lg.PlanarBody(2.0, 0.5, (x, y), th)],
                       potential=2.0 * G * y)
    _agree(tm, centred, 3, 5, 1e-12)


# -- free ------------------------------------------------------------------------------------------
def test_free_body_by_quaternion_follows_eulers_equations():
    x, y, z, *qs = lg.coordinates("x y z q0 q1 q2 q3")
    inertia = np.array([1.0, 2.0, 3.0])
    frame = lg.Frame().free([x, y, z], quaternion=qs, name="flyer")
    body = frame.body(1.5, list(inertia))
    model = lg.Model([x, y, z, *qs], bodies=[body], constraints=frame.constraints)
    w0 = np.array([0.7, -0.5, 0.9])
    quat = np.array([np.cos(0.3), np.sin(0.3), 0.0, 0.0])
    qd0 = 0.5 * _qmul(quat, np.array([0.0, *w0]))  # q̇ = ½ q ⊗ Ω (Ω in body axes)
    t_end = 50.0
    t_eval = np.linspace(0, t_end, 201)
    sol = model.simulate([0.1, 0.2, 0.3, *quat], [1.0, -2.0, 0.5, *qd0], t_end, **TIGHT,
                         t_eval=t_eval)
    assert np.max(np.abs(np.linalg.norm(sol.q[:, 3:], axis=1) - 1)) < 1e-10
    _close(sol.q[:, :3], np.array([0.1, 0.2, 0.3]) + np.outer(t_eval, [1.0, -2.0, 0.5]), 1e-10)
    w = np.array([2 * _qmul(q * [1, -1, -1, -1], qd)[1:] for q, qd in zip(sol.q[:, 3:],
                                                                        sol.qd[:, 3:])])

    def euler(_, om):
        i1, i2, i3 = inertia
        return [(i2 - i3) / i1 * om[1] * om[2], (i3 - i1) / i2 * om[2] * om[0],
                (i1 - i2) / i3 * om[0] * om[1]]

    ref = solve_ivp(euler, (0, t_end), w0, method="DOP853", rtol=1e-13, atol=1e-13,
                    t_eval=t_eval).y.T
    assert np.max(np.abs(w - ref)) < 1e-9


def test_a_body_below_a_quaternion_joint_keeps_m_regular():
    # the body hangs on a fixed child of the quaternion frame: it still adds ½ c (q·q̇)²
    qs = lg.coordinates("q0 q1 q2 q3")
    frame = lg.Frame().spherical(quaternion=qs).fixed(offset=(0, 0, -1.0))
    body = frame.body(1.0, [0.1, 0.1, 0.1])
    assert list(frame.constraints) == ["spherical(q0, q1, q2, q3).unit"]
    model = lg.Model(list(qs), bodies=[body], constraints=frame.constraints)
    M = model.mass_matrix(0.0, [0.6, 0.8, 0.0, 0.0], [0.0] * 4)
    assert np.min(np.linalg.eigvalsh(M)) > 1e-3


def test_free_joint_with_angles_and_offset():
    # a free joint placed at an offset and turned: the body's centre at offset + R p
    x, y, z, a, b, c = lg.coordinates("x y z a b c")
    base = lg.Frame().fixed(offset=(1.0, 0.0, 0.0), rotation=lg.rotation_z(np.pi / 2))
    frame = base.free([x, y, z], angles=[a, b, c], sequence="zyx")
    body = frame.body(2.0, [0.3, 0.4, 0.5])
    model = lg.Model([x, y, z, a, b, c], bodies=[body])
    M = model.mass_matrix(0.0, [0.1, 0.2, 0.3, 0.0, 0.0, 0.0], [0.0] * 6)
    _close(M[:3, :3], 2.0 * np.eye(3), 1e-14)
    _close(M[3:, 3:], np.diag([0.5, 0.4, 0.3]), 1e-14)  # zyx at zero: ż about z, ẏ y, ẋ x


# -- closed loops: the four-bar -----------------------------------------------------------------
A, B, C, D = 1.0, 3.0, 2.5, 3.5  # crank, coupler, rocker, ground: Grashof crank–rocker
MASS = (0.5, 1.5, 1.2)


def _four_bar():
    t1, t2, t3 = lg.coordinates("t1 t2 t3")
    world = lg.Frame()
    crank = world.revolute(t1, name="O_A")
    coupler = crank.revolute(t2, offset=(A, 0, 0), name="A")
    rocker = world.revolute(t3, offset=(D, 0, 0), name="O_B")
    bodies = [f.body(m, [0.0, m * L**2 / 12, m * L**2 / 12], center=(L / 2, 0, 0),
                     gravity=(0, -G, 0))
              for f, m, L in zip((crank, coupler, rocker), MASS, (A, B, C))]
    loop = lg.coincide(coupler, (B, 0, 0), rocker, (C, 0, 0), components="xy", name="pin B")
    model = lg.Model([t1, t2, t3], potential=sum(b.potential for b in bodies), bodies=bodies,
                     constraints=loop)
    return model, loop, crank, coupler, rocker


def _closed_form(t1):
    """The open branch: the coupler's absolute angle φ₂ and the rocker's θ₃ at crank angle θ₁,
    and their rates per unit θ̇₁ from the velocity loop."""
    pa = A * np.array([np.cos(t1), np.sin(t1)])
    ob = np.array([D, 0.0])
    d = ob - pa
    dist = np.linalg.norm(d)
    along = (B**2 - C**2 + dist**2) / (2 * dist)
    h = np.sqrt(B**2 - along**2)
    pb = pa + along * d / dist + h * np.array([-d[1], d[0]]) / dist  # the upper intersection
    phi2 = np.arctan2(*(pb - pa)[::-1])
    t3 = np.arctan2(*(pb - ob)[::-1])
    perp = lambda a: np.array([-np.sin(a), np.cos(a)])  # noqa: E731
    # A perp(θ₁) + B perp(φ₂) ω₂ = C perp(θ₃) ω₃ per unit θ̇₁
    w2, w3 = np.linalg.solve(np.column_stack([B * perp(phi2), -C * perp(t3)]), -A * perp(t1))
    return phi2, t3, w2, w3


def _energy_rate(t1, E):
    """θ̇₁ from the energy equation ½ M(θ₁) θ̇₁² + U(θ₁) = E (minimal coordinate)."""
    m1, m2, m3 = MASS
    phi2, t3, w2, w3 = _closed_form(t1)
    perp = lambda a: np.array([-np.sin(a), np.cos(a)])  # noqa: E731
    v2 = A * perp(t1) + B / 2 * perp(phi2) * w2
    M = m1 * A**2 / 3 + m2 * v2 @ v2 + m2 * B**2 / 12 * w2**2 + m3 * C**2 / 3 * w3**2
    U = G * (m1 * A / 2 * np.sin(t1) + m2 * (A * np.sin(t1) + B / 2 * np.sin(phi2))
             + m3 * C / 2 * np.sin(t3))
    return np.sqrt(2 * (E - U) / M)


def test_four_bar_follows_its_one_degree_of_freedom_energy_equation():
    model, loop, crank, coupler, rocker = _four_bar()
    assert list(loop) == ["pin B.x", "pin B.y"]
    t1 = 0.3
    phi2, t3, w2, w3 = _closed_form(t1)
    q0 = [t1, phi2 - t1, t3]
    qd0 = np.array([1.0, w2 - 1.0, w3]) * 6.0
    sol = model.simulate(q0, qd0, 4.0, **TIGHT, t_eval=np.linspace(0, 4, 161))
    assert sol.q[-1, 0] > 2 * np.pi + t1  # the crank went round
    E = sol.energy[0]
    _close(sol.energy, E, 1e-10)
    for q, qd in zip(sol.q, sol.qd):
        phi2, t3, w2, w3 = _closed_form(q[0])
        assert abs(np.angle(np.exp(1j * (q[0] + q[1] - phi2)))) < 1e-10
        assert abs(np.angle(np.exp(1j * (q[2] - t3)))) < 1e-10
        assert abs(qd[0] - _energy_rate(q[0], E)) < 1e-10 * qd[0]
        _close(qd[1:], qd[0] * np.array([w2 - 1.0, w3]), 1e-8)
    lam = model.multipliers(0.0, sol.q, sol.qd)
    assert np.all(np.isfinite(lam)) and np.max(np.abs(lam)) > 1.0
    # the pin's force from the multipliers: the rocker (−λ on it) and the crank + coupler side
    # (+λ) turn freely on their hinges, which holds only with the sign of Gᵀλ
    for frame in (rocker, crank, coupler):
        r = lg.joint_reaction(model, sol, frame, loops=[loop])
        scale = np.max(np.abs(r.torque)) + 1.0
        assert np.max(np.abs(r.torque[:, 2])) < 1e-8 * scale, frame.joint.name
        # the loop's rows are the model's: left out, they must be named as acting elsewhere ...
        with pytest.raises(ValueError, match="not accounted for"):
            lg.joint_reaction(model, sol, frame)
        # ... and then the reaction lacks the loop's force: the hinge torque is not zero
        wrong = lg.joint_reaction(model, sol, frame, elsewhere=list(loop))
        assert np.max(np.abs(wrong.torque[:, 2])) > 1e-2
    pin = lg.loop_reaction(model, sol, loop)
    _close(pin.force[:, :2], sol.multipliers, 1e-12)
    _close(pin.force[:, 2], 0.0, 0.0)
    _close(pin.point[:, :2], np.column_stack([D + C * np.cos(sol.q[:, 2]),
                                              C * np.sin(sol.q[:, 2])]), 1e-9)


def test_a_ball_joint_stated_as_a_loop_is_the_spherical_joint():
    # a free body whose pivot point is pinned to the origin by coincide(..., "xyz"): the same
    # motion as the spherical joint, and the loop's force (on the body) is the joint's reaction
    m, l, rho = 1.1, 0.9, 0.15
    x, y, z, a, b, c = lg.coordinates("x y z a b c")
    world = lg.Frame()
    body_frame = world.free([x, y, z], angles=[a, b, c], sequence="zyx")
    ball = body_frame.body(m, [0.4 * m * rho**2] * 3, gravity=(0, 0, -G))
    pin = lg.coincide(body_frame, (0, 0, l), world, (0, 0, 0), name="pivot")
    model = lg.Model([x, y, z, a, b, c], potential=ball.potential, bodies=[ball],
                     constraints=pin)
    a_, b_, c_ = lg.coordinates("a b c")
    joint = lg.Frame().spherical([a_, b_, c_], "zyx")
    ref_ball = _ball_on_rod(joint, m, l, rho)
    ref = lg.Model([a_, b_, c_], potential=ref_ball.potential, bodies=[ref_ball])
    ang, rates = np.array([0.2, 0.7, 0.1]), np.array([1.5, 0.0, 0.3])
    R = _rz(ang[0]) @ _ry(ang[1]) @ _rx(ang[2])
    w = rates[0] * np.array([0, 0, 1.0]) + rates[1] * (_rz(ang[0]) @ [0, 1.0, 0]) \
        + rates[2] * (R @ [1.0, 0, 0])
    centre = R @ [0, 0, -l]
    t_eval = np.linspace(0, 5, 101)
    sol = model.simulate([*centre, *ang], [*np.cross(w, centre), *rates], 5.0, **TIGHT,
                         t_eval=t_eval)
    want = ref.simulate(ang, rates, 5.0, **TIGHT, t_eval=t_eval)
    _close(sol.q[:, 3:], want.q, 1e-10)
    force = lg.loop_reaction(model, sol, pin).force
    _close(force, lg.joint_reaction(ref, want, joint).force, 1e-10)
    assert np.max(np.abs(force)) > m * G


# -- the frames' records ---------------------------------------------------------------------------
def test_frames_record_their_joints_and_bodies():
    t1, t2 = lg.coordinates("t1 t2")
    world = lg.Frame()
    a = world.revolute(t1, axis=(0, 0, 2))
    b = a.prismatic(t2, name="slide")
    assert a.parent is world and b.parent is a and world.children == [a]
    assert a.joint.kind == "revolute" and a.joint.name == "revolute(t1)"
    assert a.joint.axes == ((0.0, 0.0, 1.0),) and b.joint.name == "slide"
    body = b.body(1.0, [1.0, 1.0, 1.0])
    assert b.bodies == [body] and world.subtree() == [world, a, b]
    assert b.constraints == {}


# -- bad input ------------------------------------------------------------------------------------
def test_bad_joints_are_refused_naming_the_joint():
    a, b, c, d = lg.coordinates("a b c d")
    f = lg.Frame()
    with pytest.raises(ValueError, match="revolute joint 'hip'.*axis"):
        f.revolute(a, axis=(0, 0, 0), name="hip")
    with pytest.raises(ValueError, match="prismatic joint 'rail'.*axis"):
        f.prismatic(a, axis=(1, 2), name="rail")
    with pytest.raises(ValueError, match="revolute joint 'hip'.*one expression"):
        f.revolute([a, b], name="hip")
    with pytest.raises(ValueError, match="spherical joint 'ball'.*angles must be 3"):
        f.spherical([a, b], name="ball")
    with pytest.raises(ValueError, match=r"spherical joint 'spherical\(a\)'.*angles must be 3"):
        f.spherical(a)
    with pytest.raises(ValueError, match="universal joint.*axes must be two"):
        f.universal([a, b], axes=(1, 0, 0))
    with pytest.raises(ValueError, match="revolute joint 'hip': offset or rotation"):
        f.revolute(a, offset=(1, 0), name="hip")
    with pytest.raises(ValueError, match="fixed joint 'base': offset or rotation"):
        f.fixed(rotation=[[1, 0], [0, 1]], name="base")
    with pytest.raises(TypeError, match="revolute joint: name"):
        f.revolute(a, name="")
    with pytest.raises(ValueError, match="spherical joint 'ball'.*quaternion must be 4"):
        f.spherical(quaternion=[a, b, c], name="ball")
    with pytest.raises(ValueError, match="spherical joint 'ball'.*either"):
        f.spherical([a, b, c], quaternion=[a, b, c, d], name="ball")
    with pytest.raises(ValueError, match="spherical joint 'ball'.*sequence"):
        f.spherical([a, b, c], "zzx", name="ball")
    with pytest.raises(ValueError, match="universal joint 'cross'.*not perpendicular"):
        f.universal([a, b], axes=((1, 0, 0), (1, 1, 0)), name="cross")
    with pytest.raises(ValueError, match="universal joint 'cross'.*angles must be 2"):
        f.universal([a], name="cross")
    with pytest.raises(ValueError, match="planar joint 'floor'.*not perpendicular"):
        f.planar(a, b, c, axes=((1, 0, 0), (1, 0, 0)), name="floor")
    with pytest.raises(ValueError, match="free joint 'fly'.*position must be 3"):
        f.free([a, b], angles=[a, b, c], name="fly")
    with pytest.raises(ValueError, match="free joint 'fly'.*either"):
        f.free([a, b, c], name="fly")
    with pytest.raises(ValueError, match="coincide 'loop'.*components"):
        lg.coincide(f, (0, 0, 0), f, (1, 0, 0), components="xw")
    with pytest.raises(TypeError, match="coincide"):
        lg.coincide(f, (0, 0, 0), "world", (1, 0, 0))
    th, link, rod, model = _compound()
    with pytest.raises(ValueError, match="axes"):
        lg.joint_reaction(model, ([0.0], [[0.1]], [[0.0]]), link, axes="body")
    with pytest.raises(ValueError, match="no bodies"):
        lg.joint_reaction(model, ([0.0], [[0.1]], [[0.0]]), lg.Frame())
    loop = lg.coincide(link, (0, 0, -0.7), f, (0, 0, -0.7), components="x", name="tip")
    with pytest.raises(ValueError, match="no constraint row 'tip.x'"):
        lg.joint_reaction(model, ([0.0], [[0.1]], [[0.0]]), link, loops=[loop])
