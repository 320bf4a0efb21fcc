"""Rigid bodies (``lg.Body``): T = ½ m|ṙ|² + ½ ΩᵀIΩ derived on the expression graph, checked
against closed forms — the compound pendulum in two formulations, the torque-free asymmetric
body against Euler's equations (scipy), the heavy symmetric top between the roots of its cubic,
the quaternion body on its constraint — and bad input refused with the body named."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import lagrangian as lg
from lagrangian._expr import BINARY, UNARY

TIGHT = dict(rtol=1e-12, atol=1e-12)


def test_every_operation_has_a_derivative_rule():
    # The rule is a required part of each operation's entry: one of each arity answers.
    x, = lg.coordinates("x")
    for op, entry in UNARY.items():
        assert isinstance(entry.derivative(x, lg._expr.Expr(op, (x,))), lg.Expr), op
    for op, entry in BINARY.items():
        y = lg._expr.Expr(op, (x, x))
        assert isinstance(entry.derivative(x, x, y, lg.Expr.lift(1.0), lg.Expr.lift(0.0)), lg.Expr), op


def test_derivative_is_exact_against_finite_differences():
    x, y = lg.coordinates("x y")
    e = (lg.sin(x) * lg.exp(y) / (1 + x**2) + lg.atan2(y, x) + lg.sqrt(2 + lg.cosh(x * y))
         + lg.log(3 + lg.tanh(x)) + lg.tan(0.3 * y) + x**y + lg.abs(x - 2) + lg.sinh(y) - (-x))
    from lagrangian._bodies import evaluate

    dx = lg.derivative(e, x)
    at = {"x": 0.7, "y": 1.3}
    h = 1e-6
    fd = (evaluate(e, {"x": 0.7 + h, "y": 1.3}, {}) - evaluate(e, {"x": 0.7 - h, "y": 1.3}, {})) \
        / (2 * h)
    assert abs(evaluate(dx, at, {}) - fd) < 1e-8
    assert lg.derivative(e, lg.t) == lg.Expr.lift(0.0)


# -- compound pendulum -------------------------------------------------------------------------
def _pendulums(axis):
    th, = lg.coordinates("th")
    m, L, g = lg.parameters("m L g")
    values = {"m": 1.3, "L": 0.7, "g": 9.81}
    if axis == "y":  # swings in the x–z plane, z up
        pos, rot, height = (L / 2 * lg.sin(th), 0.0, -L / 2 * lg.cos(th)), lg.rotation_y(th), \
            -L / 2 * lg.cos(th)
        inertia = [m * L**2 / 12, m * L**2 / 12, 0.0]  # the rod along body z
    else:  # swings in the x–y plane, y up
        pos, rot, height = (L / 2 * lg.sin(th), -L / 2 * lg.cos(th), 0.0), lg.rotation_z(th), \
            -L / 2 * lg.cos(th)
        inertia = [0.0, m * L**2 / 12, m * L**2 / 12]  # the rod along body y
    body = lg.Body(mass=m, inertia=inertia, position=pos, orientation=rot, name="rod")
    as_body = lg.Model([th], potential=m * g * height, bodies=[body], parameters=values)
    by_hand = lg.Model([th], kinetic=0.5 * (m * L**2 / 3) * th.d**2, potential=m * g * height,
                       parameters=values)
    return as_body, by_hand, values


@pytest.mark.parametrize("axis", ["y", "z"])
def test_compound_pendulum_two_formulations_agree(axis):
    as_body, by_hand, v = _pendulums(axis)
    rng = np.random.default_rng(1)
    for q, qd in zip(rng.uniform(-3, 3, 5), rng.uniform(-5, 5, 5)):
        a, b = as_body.accelerations(0.0, [q], [qd]), by_hand.accelerations(0.0, [q], [qd])
        assert abs(a[0] - b[0]) <= 1e-13 * (1 + abs(b[0]))
    omega2 = v["m"] * v["g"] * (v["L"] / 2) / (v["m"] * v["L"] ** 2 / 3)
    modes = as_body.modes([0.0])
    assert abs(modes.omega_squared[0] - omega2) <= 1e-12 * omega2
    lin = as_body.linearize([0.0], qd=[0.0])
    assert abs(lin.K[0, 0] / lin.M[0, 0] - omega2) <= 1e-12 * omega2


def test_a_rod_on_a_turntable_takes_the_time_derivative():
    # R = R_z(Ωt) R_y(θ): a rod hanging from a pivot on a platform turning at Ω; by hand
    # T = ½ (mL²/3)(θ̇² + Ω² sin²θ) (the rod has no inertia about its own axis).
    th, = lg.coordinates("th")
    m, L, g, W = 1.3, 0.7, 9.81, 2.3
    R = [list(r) for r in np.array(lg.rotation_z(W * lg.t), dtype=object)
         @ np.array(lg.rotation_y(th), dtype=object)]
    pos = [-L / 2 * R[i][2] for i in range(3)]
    rod = lg.Body(m, [m * L**2 / 12, m * L**2 / 12, 0.0], pos, R, name="rod")
    as_body = lg.Model([th], potential=-m * g * L / 2 * lg.cos(th), bodies=[rod])
    by_hand = lg.Model([th], kinetic=0.5 * (m * L**2 / 3) * (th.d**2 + W**2 * lg.sin(th)**2),
                       potential=-m * g * L / 2 * lg.cos(th))
    rng = np.random.default_rng(3)
    for t, q, qd in rng.uniform(-3, 3, (5, 3)):
        a, b = as_body.accelerations(t, [q], [qd])[0], by_hand.accelerations(t, [q], [qd])[0]
        assert abs(a - b) <= 1e-13 * (1 + abs(b))


def test_planar_body_is_the_body_in_the_plane():
    x, y, th = lg.coordinates("x y th")
    b = lg.PlanarBody(2.0, 0.5, (x, y), th)
    model = lg.Model([x, y, th], bodies=[b], potential=2.0 * 9.81 * y)
    M = model.linearize([0.1, 0.2, 0.3], qd=[0.0, 0.0, 0.0]).M
    assert np.allclose(M, np.diag([2.0, 2.0, 0.5]), rtol=0, atol=1e-14)


# -- torque-free asymmetric body with ZXZ Euler angles ------------------------------------------
I123 = np.array([1.0, 2.0, 3.0])


def _euler_body(inertia=I123):
    phi, th, psi = lg.coordinates("phi th psi")
    body = lg.Body(mass=1.0, inertia=list(inertia), position=(0.0, 0.0, 0.0),
                   orientation=lg.euler_rotation([phi, th, psi], "zxz"), name="spinner")
    return lg.Model([phi, th, psi], bodies=[body])


def _rot(a, axis):
    c, s = np.cos(a), np.sin(a)
    return {"x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
            "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


def _R_zxz(phi, th, psi):
    return _rot(phi, "z") @ _rot(th, "x") @ _rot(psi, "z")


def _B(th, psi):
    """ω_body = B(θ, ψ) (φ̇, θ̇, ψ̇) for ZXZ angles."""
    return np.array([[np.sin(th) * np.sin(psi), np.cos(psi), 0.0],
                     [np.sin(th) * np.cos(psi), -np.sin(psi), 0.0],
                     [np.cos(th), 0.0, 1.0]])


def _omega(q, qd):
    return np.array([_B(a[1], a[2]) @ b for a, b in zip(q, qd)])


def _euler_equations(t_end, w0, inertia=I123, t_eval=None):
    i1, i2, i3 = inertia

    def f(_, w):
        return [(i2 - i3) / i1 * w[1] * w[2], (i3 - i1) / i2 * w[2] * w[0],
                (i1 - i2) / i3 * w[0] * w[1]]

    return solve_ivp(f, (0.0, t_end), w0, method="DOP853", rtol=1e-13, atol=1e-13,
                     t_eval=t_eval, dense_output=True)


def test_torque_free_body_follows_eulers_equations():
    model = _euler_body()
    q0 = np.array([0.3, 1.1, -0.4])
    w0 = np.array([0.7, -0.5, 0.9])
    qd0 = np.linalg.solve(_B(q0[1], q0[2]), w0)
    sol = model.simulate(q0, qd0, 10.0, **TIGHT)
    w = _omega(sol.q, sol.qd)
    ref = _euler_equations(10.0, w0).sol(sol.t).T
    assert np.max(np.abs(w - ref)) < 1e-10
    assert np.max(np.abs(sol.energy - 0.5 * np.sum(I123 * w0**2))) < 1e-10
    L = np.array([_R_zxz(*q) @ (I123 * wi) for q, wi in zip(sol.q, w)])
    assert np.max(np.abs(L - L[0])) < 1e-9
    assert abs(np.linalg.norm(L[0]) - np.linalg.norm(I123 * w0)) < 1e-12


def test_intermediate_axis_flips():
    model = _euler_body()
    # body axis 2 along world z (φ = ψ = 0, θ = π/2): L stays near world z, θ far from 0 and π
    q0 = np.array([0.0, np.pi / 2, 0.0])
    w0 = np.array([1e-2, 1.0, 1e-2])
    qd0 = np.linalg.solve(_B(q0[1], q0[2]), w0)
    sol = model.simulate(q0, qd0, 25.0, **TIGHT)
    w = _omega(sol.q, sol.qd)
    assert w[0, 1] > 0.99 and np.min(w[:, 1]) < -0.99  # ω₂ turned over
    ref = _euler_equations(25.0, w0).sol(sol.t).T
    assert np.max(np.abs(w - ref)) < 1e-8


# -- the heavy symmetric top ---------------------------------------------------------------------
def test_heavy_top_nutates_between_the_roots_of_the_cubic():
    phi, th, psi = lg.coordinates("phi th psi")
    m, g, l, A0, C = 1.0, 9.81, 0.3, 0.02, 0.03  # A0 about the centre of mass
    R = lg.euler_rotation([phi, th, psi], "zxz")
    pos = tuple(R[i][2] * l for i in range(3))  # the centre of mass on body z, l from the tip
    top = lg.Body(mass=m, inertia=[A0, A0, C], position=pos, orientation=R, name="top",
                  gravity=(0.0, 0.0, -g))
    model = lg.Model([phi, th, psi], potential=top.potential, bodies=[top])
    A = A0 + m * l**2
    q0, qd0 = np.array([0.0, 0.6, 0.0]), np.array([0.5, 0.0, 40.0])
    sol = model.simulate(q0, qd0, 3.0, **TIGHT, t_eval=np.linspace(0, 3.0, 6001))
    u0, s0 = np.cos(q0[1]), np.sin(q0[1])
    a = C * (qd0[2] + qd0[0] * u0)  # p_ψ
    b = A * qd0[0] * s0**2 + a * u0  # p_φ
    E = 0.5 * A * (qd0[1] ** 2 + qd0[0] ** 2 * s0**2) + a**2 / (2 * C) + m * g * l * u0
    assert np.max(np.abs(sol.energy - E)) < 1e-11 * E
    cos_th, w3 = np.cos(sol.q[:, 1]), sol.qd[:, 2] + sol.qd[:, 0] * np.cos(sol.q[:, 1])
    assert np.max(np.abs(C * w3 - a)) < 1e-10 * abs(a)
    assert np.max(np.abs(A * sol.qd[:, 0] * (1 - cos_th**2) + C * w3 * cos_th - b)) < 1e-10
    # u̇² = (1 − u²)(2/A)(E − a²/2C − mglu) − (b − au)²/A²
    P = np.polynomial.Polynomial
    f = P([1, 0, -1]) * P([E - a**2 / (2 * C), -m * g * l]) * (2 / A) - P([b, -a]) ** 2 / A**2
    roots = np.sort(np.real(np.roots(f.coef[::-1])))
    inside = roots[(roots >= -1) & (roots <= 1)]
    u1, u2 = inside[0], inside[-1]
    assert u1 < u2 - 1e-3
    u = np.cos(sol.q[:, 1])
    assert np.min(u) >= u1 - 1e-6 and np.max(u) <= u2 + 1e-6
    assert np.min(u) < u1 + 1e-3 * (u2 - u1) and np.max(u) > u2 - 1e-3 * (u2 - u1)


# -- the quaternion body ------------------------------------------------------------------------
def _qmul(p, q):
    w1, v1 = p[0], np.asarray(p[1:])
    w2, v2 = q[0], np.asarray(q[1:])
    return np.concatenate([[w1 * w2 - v1 @ v2], w1 * v2 + w2 * v1 + np.cross(v1, v2)])


def test_quaternion_body_keeps_its_norm_and_matches_euler_angles():
    q0_, q1_, q2_, q3_ = qs = lg.coordinates("q0 q1 q2 q3")
    body = lg.Body(mass=1.0, inertia=list(I123), position=(0.0, 0.0, 0.0),
                   orientation=lg.quaternion_rotation(*qs), name="quat")
    model = lg.Model(list(qs), bodies=[body],
                     constraints=[q0_**2 + q1_**2 + q2_**2 + q3_**2 - 1])
    angles = np.array([0.3, 1.1, -0.4])
    quat = np.array([1.0, 0, 0, 0])
    for a, axis in zip(angles, (2, 0, 2)):
        h = np.zeros(4)
        h[0], h[1 + axis] = np.cos(a / 2), np.sin(a / 2)
        quat = _qmul(quat, h)
    w0 = np.array([0.7, -0.5, 0.9])
    qd0 = 0.5 * _qmul(quat, np.concatenate([[0.0], w0]))
    t_end = 200.0
    t_eval = np.linspace(0, t_end, 401)
    sol = model.simulate(quat, qd0, t_end, **TIGHT, t_eval=t_eval)
    norm = np.linalg.norm(sol.q, axis=1)
    assert np.max(np.abs(norm - 1.0)) < 1e-10
    w = np.array([2 * _qmul(q * [1, -1, -1, -1], qd)[1:] for q, qd in zip(sol.q, sol.qd)])
    euler = _euler_body().simulate(angles, np.linalg.solve(_B(angles[1], angles[2]), w0), t_end,
                                   **TIGHT, t_eval=t_eval)
    assert np.max(np.abs(w - _omega(euler.q, euler.qd))) < 1e-7
    assert np.max(np.abs(w - _euler_equations(t_end, w0).sol(t_eval).T)) < 1e-7
    for qq, angles_t in zip(sol.q, euler.q):  # the same orientation, R(q) = R_zxz(φ, θ, ψ)
        w_, x, y, z = qq
        Rq = np.array([[w_*w_ + x*x - y*y - z*z, 2*(x*y - w_*z), 2*(x*z + w_*y)],
                       [2*(x*y + w_*z), w_*w_ - x*x + y*y - z*z, 2*(y*z - w_*x)],
                       [2*(x*z - w_*y), 2*(y*z + w_*x), w_*w_ - x*x - y*y + z*z]])
        assert np.max(np.abs(Rq - _R_zxz(*angles_t))) < 1e-7


# -- bad input -----------------------------------------------------------------------------------
def test_bad_bodies_are_refused_naming_the_body():
    th, = lg.coordinates("th")
    rot = lg.rotation_z(th)
    pos = (0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="'b'.*3×3"):
        lg.Body(1.0, [1, 1, 1], pos, [[1, 0], [0, 1]], name="b")
    with pytest.raises(ValueError, match="'b'.*not symmetric"):
        lg.Body(1.0, [[1, 0.1, 0], [0, 1, 0], [0, 0, 1]], pos, rot, name="b")
    with pytest.raises(ValueError, match="'b'.*not positive semidefinite"):
        lg.Body(1.0, [[1, 2, 0], [2, 1, 0], [0, 0, 1]], pos, rot, name="b")
    with pytest.raises(ValueError, match="'b'.*triangle"):
        lg.Body(1.0, [1.0, 1.0, 2.5], pos, rot, name="b")
    with pytest.raises(ValueError, match="'b'.*mass is -1"):
        lg.Body(-1.0, [1, 1, 1], pos, rot, name="b")
    with pytest.raises(ValueError, match="'b'.*position must be three"):
        lg.Body(1.0, [1, 1, 1], (0.0, 0.0), rot, name="b")
    lg.Body(1.0, [1.0, 2.0, 3.0], pos, rot, name="plate")  # a flat plate: I₁ + I₂ = I₃
    m, = lg.parameters("m")
    neg = lg.Body(m, [m, m, m], pos, rot, name="p")
    with pytest.raises(ValueError, match="'p'.*mass is -2"):
        lg.Model([th], bodies=[neg], parameters={"m": -2.0})
    stretched = [[2 * lg.cos(th), -lg.sin(th), 0], [lg.sin(th), lg.cos(th), 0], [0, 0, 1]]
    with pytest.raises(ValueError, match="'s'.*not a rotation.*RᵀR"):
        lg.Model([th], bodies=[lg.Body(1.0, [1, 1, 1], pos, stretched, name="s")])
    mirror = [[lg.cos(th), lg.sin(th), 0], [lg.sin(th), -lg.cos(th), 0], [0, 0, 1]]
    with pytest.raises(ValueError, match="'r'.*not a rotation.*det R = -1"):
        lg.Model([th], bodies=[lg.Body(1.0, [1, 1, 1], pos, mirror, name="r")])
    with pytest.raises(ValueError, match="sequence 'zzx'"):
        lg.euler_rotation([th, th, th], "zzx")
    x, = lg.coordinates("x")
    with pytest.raises(ValueError, match="'c'.*position reads x.*not a coordinate"):
        lg.Model([th], bodies=[lg.Body(1.0, [1, 1, 1], (x, 0, 0), rot, name="c")])
    with pytest.raises(ValueError, match="'v'.*orientation reads the velocity"):
        lg.Model([th], bodies=[lg.Body(1.0, [1, 1, 1], pos, lg.rotation_z(th.d), name="v")])
    with pytest.raises(TypeError, match="bodies"):
        lg.Model([th], bodies=["not a body"])


def test_bodies_combine_with_kinetic_and_particles():
    x, th = lg.coordinates("x th")
    rod = lg.PlanarBody(1.0, 0.25, (x, 0.0), th)
    both = lg.Model([x, th], kinetic=0.5 * 3.0 * x.d**2, bodies=[rod],
                    positions=[(x, 1.0)], masses=[2.0])
    M = both.linearize([0.2, 0.1], qd=[0.0, 0.0]).M
    assert np.allclose(M, np.diag([1.0 + 3.0 + 2.0, 0.25]), rtol=0, atol=1e-14)


def test_a_model_with_bodies_pickles_and_takes_new_parameters():
    import pickle

    as_body, by_hand, v = _pendulums("y")
    again = pickle.loads(pickle.dumps(as_body))
    assert again.accelerations(0.0, [0.4], [1.1])[0] == as_body.accelerations(0.0, [0.4], [1.1])[0]
    longer = as_body.with_parameters(L=1.4)
    ref = by_hand.with_parameters(L=1.4)
    a, b = longer.accelerations(0.0, [0.4], [1.1])[0], ref.accelerations(0.0, [0.4], [1.1])[0]
    assert abs(a - b) <= 1e-13 * abs(b)


def test_angular_velocity_carried_by_rotations_equals_vee_of_rt_rdot():
    # Ω built with R (about an axis k: k ȧ; of AB: Bᵀ Ω_A + Ω_B; a quaternion: 2 G(q) q̇/‖q‖²)
    # against Ω = vee(RᵀṘ) by differentiating R itself, at random states, the quaternion off the
    # unit sphere too.
    from lagrangian._bodies import Body
    from lagrangian._expr import evaluate

    a, b, c, d = lg.coordinates("a b c d")
    names = ["a", "b", "c", "d"]
    frame = lg.Frame().revolute(a, axis=(0, 1, 0)).revolute(b * c, axis=(1, -2, 0.5),
                                                           offset=(0.1, 0.2, 0.3))
    rotations = [
        lg.euler_rotation((a, b, c), "zxz"),
        lg.euler_rotation((a, b, c), "zyx"),
        lg.quaternion_rotation(a, b, c, d),
        lg.rotation_about((1.0, 2.0, 3.0), a * lg.t + b),
        frame.orientation,
    ]
    rng = np.random.default_rng(7)
    states = rng.normal(size=(5, 8))
    times = rng.uniform(0.0, 2.0, size=5)
    for r in rotations:
        assert r.omega is not None
        carried = Body(1.0, [1.0, 2.0, 2.5], (0.0, 0.0, 0.0), r)
        derived = Body(1.0, [1.0, 2.0, 2.5], (0.0, 0.0, 0.0), [list(row) for row in r])
        assert derived.omega is None
        for axes in ("body", "world"):
            fast = evaluate(list(carried.angular_velocity(axes)), names, {}, times,
                            states[:, :4], qd=states[:, 4:])
            slow = evaluate(list(derived.angular_velocity(axes)), names, {}, times,
                            states[:, :4], qd=states[:, 4:])
            assert np.max(np.abs(fast - slow)) < 1e-13 * max(1.0, np.max(np.abs(slow)))
