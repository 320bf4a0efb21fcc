"""Rolling contact and knife edges (``lg.rolling_contact``, ``lg.knife_edge``) against
independent kinematics and closed forms, and the steady linearization of a rolling disc
(``Model.linearize_steady``) against its closed form."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import lagrangian as lg
from lagrangian._expr import derivative, evaluate


DISC = lg.scenes.rolling_disc()


def free_disc():
    """A disc free in space (z up): centre (x, y, z), R = R_z(ψ) R_x(φ) R_y(θ), radius 0.4."""
    x, y, z, psi, phi, th = lg.coordinates("x y z psi phi th")
    rot = lg.euler_rotation([psi, phi, th], "zxy")
    body = lg.Body(2.0, (0.08, 0.16, 0.08), (x, y, z), rot)
    return [x, y, z, psi, phi, th], body


def at(exprs, coords, q, t=0.0):
    return evaluate(list(exprs), [c.name for c in coords], {}, np.array([t]),
                    np.array([q], dtype=float), "test")[:, 0]


def rot_z(a):
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def rot_x(a):
    return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])


def test_contact_point_and_height_of_a_tilted_disc():
    coords, body = free_disc()
    contact = lg.rolling_contact(body, 0.4, name="disc")
    q = [0.3, -0.2, 0.9, 0.7, 0.25, 1.1]
    p = at(contact.point, coords, q)
    # The lowest point of the rim: r down the lean frame's z axis from the centre, whatever
    # the spin θ.
    up_in_plane = rot_z(q[3]) @ rot_x(q[4]) @ np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(p, np.array(q[:3]) - 0.4 * up_in_plane, rtol=0, atol=1e-15)
    # Its height above z = 0: z − r cos φ.
    h = at([contact.height], coords, q)[0]
    assert abs(h - (0.9 - 0.4 * math.cos(0.25))) < 1e-15
    assert abs(p[2] - h) < 1e-15
    assert list(contact.constraints) == ["disc height"]


def test_slip_is_the_material_velocity_of_the_contact_point():
    # Independent check: follow the body-fixed point that touches at t0 along the motion
    # q(t) = q0 + q̇ t by central differences of its world position.
    coords, body = free_disc()
    contact = lg.rolling_contact(body, 0.4)
    q0 = np.array([0.3, -0.2, 0.9, 0.7, 0.25, 1.1])
    qd = np.array([0.5, -0.3, 0.2, 0.9, -0.4, 2.0])
    rot = np.array([at(row, coords, q0) for row in body.orientation])
    p_body = rot.T @ (at(contact.point, coords, q0) - at(body.position, coords, q0))
    h = 1e-5
    ends = [at(body.point(tuple(p_body)), coords, q0 + s * h * qd) for s in (1.0, -1.0)]
    fd = (ends[0] - ends[1]) / (2 * h)
    # The rows are linear in q̇: a(q)·q̇ with a = ∂(slip)/∂q̇.
    got = [sum(v * at([derivative(e, c.d)], coords, q0)[0] for c, v in zip(coords, qd))
           for e in contact.slip]
    np.testing.assert_allclose(got, fd, rtol=0, atol=1e-9)
    assert np.max(np.abs(fd)) > 0.5  # a motion that slips: the check is not of zeros
    # The two rows are the slip along t₁ = x and t₂ = z × x = y on the ground z = 0.
    assert contact.tangents == ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def test_knife_edge_gives_the_chaplygin_sleigh():
    # Blade a behind the centre of mass: u̇ = a ω², ω̇ = −m a u ω / (I + m a²) (Bloch,
    # Nonholonomic Mechanics and Control, §1.7), u the speed along the blade, ω = ψ̇.
    m, inertia, a = 1.5, 0.3, 0.4
    x, y, psi = lg.coordinates("x y psi")
    sled = lg.Body(m, (0.1, 0.2, inertia), (x, y, 0.0), lg.rotation_z(psi))
    rows = lg.knife_edge(sled, point=(-a, 0.0, 0.0), name="blade")
    assert list(rows) == ["blade"]
    model = lg.Model([x, y, psi], bodies=[sled], velocity_constraints=rows)
    heading, u, w = 0.7, 1.3, -0.8
    c, s = math.cos(heading), math.sin(heading)
    v_lat = a * w  # the centre of mass's sideways speed that the blade allows
    qd = [u * c - v_lat * s, u * s + v_lat * c, w]
    acc = model.accelerations(0.0, [0.2, -0.1, heading], qd)
    wdot = -m * a * u * w / (inertia + m * a * a)
    ax_body, ay_body = a * w * w - v_lat * w, a * wdot + u * w
    expect = [ax_body * c - ay_body * s, ax_body * s + ay_body * c, wdot]
    np.testing.assert_allclose(acc, expect, rtol=0, atol=1e-13)


def test_rolling_disc_lean_oscillation_along_a_run():
    # Released leaning φ₀ with ψ̇ = 0 at v above the critical speed: ψ̇ = (I_a ω/I_d)(φ − φ₀)
    # and the lean oscillates about φ* = k φ₀ / (k − m g r), k = B I_a ω²/I_d, reaching
    # 2φ* − φ₀ (linearized; φ₀ = 0.01 leaves O(φ₀²) of nonlinearity).
    m, r, g, v, phi0 = 1.0, 0.3, 9.81, 2.0, 0.01
    disc = lg.scenes.rolling_disc(m=m, r=r, g=g)
    sol = disc.simulate([0, 0, 0, phi0, 0], [v, 0, 0, 0, v / r], 1.5, rtol=1e-10, atol=1e-12,
                        t_eval=np.linspace(0.0, 1.5, 3001))
    assert sol.status == 0, sol.message
    i_d, i_a, w = m * r * r / 4, m * r * r / 2, v / r
    k = (i_a + m * r * r) * i_a * w * w / i_d
    peak = 2 * k * phi0 / (k - m * g * r) - phi0
    assert abs(np.max(sol.q[:, 3]) / peak - 1) < 1e-3
    e = disc.energy(0.0, sol.q, sol.qd)
    assert np.ptp(e) < 1e-8 * abs(e[0])


def disc_lean(v, m=1.0, r=0.3, g=9.81):
    disc = DISC.with_parameters(m=m, r=r, g=g)
    return disc.linearize_steady(np.zeros(5), [v, 0, 0, 0, v / r], independent=["phi", "psi"],
                                 steady=["theta"])


def test_rolling_disc_linearization_against_the_closed_form():
    # Upright rolling at ω = v/r (O'Reilly 1996, Nonlinear Dynamics 10, §5; derived on the
    # bicycle page): A φ̈ + B ω ψ̇ − m g r φ = 0, I_d ψ̈ − I_a ω φ̇ = 0 (signs of the model's
    # axes), A = I_d + m r², B = I_a + m r².
    m, r, g, v = 1.3, 0.25, 9.81, 1.7
    lin = disc_lean(v, m, r, g)
    i_d, i_a = m * r * r / 4, m * r * r / 2
    big_a, big_b, w = i_d + m * r * r, i_a + m * r * r, v / r
    np.testing.assert_allclose(lin.M, np.diag([big_a, i_d]), rtol=1e-14, atol=1e-16)
    np.testing.assert_allclose(lin.K, [[-m * g * r, 0.0], [0.0, 0.0]], rtol=1e-14, atol=1e-14)
    assert abs(lin.C[0, 0]) < 1e-14 and abs(lin.C[1, 1]) < 1e-14
    assert abs(lin.C[0, 1] * lin.C[1, 0] + big_b * i_a * w * w) < 1e-13
    lam2 = -(big_b * i_a * w * w / i_d - m * g * r) / big_a
    np.testing.assert_allclose(sorted(np.abs(lin.eigenvalues)), [0, 0, math.sqrt(abs(lam2)),
                                                                 math.sqrt(abs(lam2))],
                               rtol=1e-12, atol=1e-12)
    assert lin.cyclic == ("x", "y", "theta")
    assert lin.dependent == () and lin.dependent_speeds == ("x", "y")
    np.testing.assert_allclose(lin.accelerations, [0.0, 0.0], atol=1e-14)


def test_rolling_disc_critical_speed_is_sqrt_g_r_over_3():
    r, g = 0.3, 9.81

    def lam_squared(v):  # λ² of the lean pair: > 0 falls over, < 0 wobbles
        e = disc_lean(v, r=r, g=g).eigenvalues
        return float(np.real(e[np.argmax(np.abs(e))] ** 2))

    assert lam_squared(0.5) > 0 > lam_squared(1.5)
    vc = brentq(lam_squared, 0.5, 1.5, xtol=1e-14)
    assert abs(vc / math.sqrt(g * r / 3) - 1) < 1e-10


def test_contact_bad_input():
    _, body = free_disc()
    with pytest.raises(TypeError, match="lg.Body"):
        lg.rolling_contact("disc", 0.3)
    with pytest.raises(ValueError, match="radius"):
        lg.rolling_contact(body, -0.3)
    with pytest.raises(ValueError, match="axle"):
        lg.rolling_contact(body, 0.3, axle=(0, 0, 0))
    with pytest.raises(ValueError, match="up"):
        lg.rolling_contact(body, 0.3, up=(0, 0, 0))
    with pytest.raises(ValueError, match="name"):
        lg.rolling_contact(body, 0.3, name="")
    with pytest.raises(TypeError, match="lg.Body"):
        lg.knife_edge(None)
    with pytest.raises(ValueError, match="blade"):
        lg.knife_edge(body, blade=(1, 0))



def test_linearize_steady_bad_input():
    disc = lg.scenes.rolling_disc()
    q, qd = np.zeros(5), [1.0, 0, 0, 0, 1 / 0.3]
    with pytest.raises(ValueError, match="not a coordinate"):
        disc.linearize_steady(q, qd, independent=["lean"], steady=["theta"])
    with pytest.raises(ValueError, match="steady coordinate"):
        disc.linearize_steady(q, qd, independent=["phi", "psi"])
    with pytest.raises(ValueError, match="independent too"):
        disc.linearize_steady(q, qd, independent=["phi", "theta"], steady=["theta"])
    with pytest.raises(ValueError, match="twice"):
        disc.linearize_steady(q, qd, independent=["phi", "phi"], steady=["theta"])
    with pytest.raises(ValueError, match="at least one"):
        disc.linearize_steady(q, qd, independent=[], steady=["theta"])
    with pytest.raises(ValueError, match="cannot be solved"):
        # x and y held: the rows would be solved for ψ̇ and θ̇, but upright the contact lies
        # on the vertical through the centre, so ψ̇ enters neither row: singular.
        disc.linearize_steady(q, qd, independent=["phi"], steady=["x", "y"])
    free = lg.scenes.double_pendulum()
    with pytest.raises(ValueError, match="constrained model"):
        lg.Model.linearize_steady(free, [0, 0], [0, 0], independent=["th1"])


def test_linearize_steady_solves_the_holonomic_rows_for_the_dependent_positions():
    # The Cartesian pendulum at rest at θ₀ from the bottom, reduced to x = l sin θ (y follows
    # from the rod): T = ½ m ẋ² / cos²θ, ẍ = −g sin θ cos θ at rest, so M = m / cos²θ₀ and
    # K = −M ∂ẍ/∂x = m g cos 2θ₀ / (l cos³θ₀).
    m, l, g, th0 = 1.5, 0.8, 9.81, 0.6
    pendulum = lg.scenes.cartesian_pendulum(m=m, l=l, g=g)
    q = [l * math.sin(th0), -l * math.cos(th0)]
    lin = pendulum.linearize_steady(q, [0.0, 0.0], independent=["x"])
    c = math.cos(th0)
    assert lin.dependent == ("y",) and lin.cyclic == () and lin.steady == ()
    assert abs(lin.M[0, 0] / (m / c**2) - 1) < 1e-13
    assert abs(lin.K[0, 0] / (m * g * math.cos(2 * th0) / (l * c**3)) - 1) < 1e-12
    assert abs(lin.C[0, 0]) < 1e-13
    assert abs(lin.accelerations[0] + g * math.sin(th0) * c) < 1e-13
    np.testing.assert_allclose(lin.P[:, 0], [1.0, math.tan(th0)], rtol=1e-14)
    # Solving for x instead names it, and refuses a coordinate the rod does not read.
    with pytest.raises(ValueError, match="independent"):
        pendulum.linearize_steady(q, [0.0, 0.0], independent=["x"], dependent=["x"])


def test_disc_rolls_down_an_incline_given_by_its_normal():
    # A free disc (six coordinates) on the plane of normal u = (sin α, 0, cos α) through the
    # origin, upright in the fall line s = (cos α, 0, −sin α) and at rest: the height row and
    # the two slip rows leave the rolling of eq. 48, a = g sin α / (1 + I_a/(m r²)) = ⅔ g sin α
    # along s, θ̈ = a/r, and no lean.
    alpha, r, g, m = 0.4, 0.4, 9.81, 2.0
    coords, body = free_disc()
    contact = lg.rolling_contact(body, r, up=(math.sin(alpha), 0.0, math.cos(alpha)),
                                 name="disc")
    model = lg.Model(coords, bodies=[body], potential=m * g * coords[2],
                     constraints=contact.constraints,
                     velocity_constraints=contact.velocity_constraints)
    u = np.array([math.sin(alpha), 0.0, math.cos(alpha)])
    q = np.concatenate([r * u, [0.0, 0.0, alpha]])
    assert abs(at([contact.height], coords, q)[0]) < 1e-15
    acc = model.accelerations(0.0, q, np.zeros(6))
    a = 2.0 / 3.0 * g * math.sin(alpha)
    expect = [a * math.cos(alpha), 0.0, -a * math.sin(alpha), 0.0, 0.0, a / r]
    np.testing.assert_allclose(acc, expect, rtol=0, atol=1e-12)
    t1, t2 = contact.tangents
    np.testing.assert_allclose(t1, [math.cos(alpha), 0.0, -math.sin(alpha)], atol=1e-15)
    np.testing.assert_allclose(t2, [0.0, 1.0, 0.0], atol=1e-15)


def test_steady_linearization_of_a_flat_wheel_is_refused():
    # Lying flat (φ = π/2) the contact point is undefined: the rows' Jacobians divide by
    # √(1 − (u·a)²) = 0. A ValueError saying where, never NaN matrices.
    disc = lg.scenes.rolling_disc()
    q = np.zeros(5)
    q[3] = np.pi / 2
    with pytest.raises(ValueError, match=r"not finite at t = 0.0, q = \[0.0, 0.0, 0.0, 1.57"):
        disc.linearize_steady(q, np.zeros(5), independent=["phi", "psi"], steady=["theta"])
