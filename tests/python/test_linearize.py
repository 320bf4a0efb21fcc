"""Equilibria of the equations of motion, linearization and modes from Python, against closed
forms: the bead on a spinning hoop on the energy and the particle route (the relative
equilibrium the virtual-work solver used to miss), the seed's two masses (eq. 41–44), the double
pendulum, the ball in a sphere (eq. 53), the damped oscillator, the charged particle, the
inverted pendulum, and the linearization at a moving state against finite differences."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

import lagrangian as lg

M, R, W, G = 0.3, 0.5, 7.0, 9.81


def hoop_energy(omega: float = W) -> lg.Model:
    th, = lg.coordinates("th")
    return lg.Model(
        coordinates=[th],
        kinetic=0.5 * M * R**2 * (th.d**2 + omega**2 * lg.sin(th) ** 2),
        potential=-M * G * R * lg.cos(th),
    )


def hoop_particles(omega: float = W) -> lg.Model:
    th, = lg.coordinates("th")
    phase = omega * lg.t
    position = (R * lg.sin(th) * lg.cos(phase), R * lg.sin(th) * lg.sin(phase), -R * lg.cos(th))
    return lg.Model(
        coordinates=[th],
        positions=[position],
        masses=[M],
        potential=M * G * position[2],
    )


@pytest.mark.parametrize("make", [hoop_energy, hoop_particles])
def test_bead_on_fast_hoop(make):
    # The reported wrong answer: θ = 0 "stable" from every guess. Now cos θ* = g/(RΩ²), stable
    # with ω² = Ω² sin²θ*, and θ = 0 unstable with λ = √(Ω² − g/R).
    model = make()
    theta = math.acos(G / (R * W * W))
    for guess in [0.8, 1.0, 1.2]:
        eq = model.equilibrium([guess])
        assert_allclose(eq.q, [theta], rtol=1e-13)
        assert eq.stable and eq.stability == "stable", eq.reason
        assert abs(model.accelerations(0.0, eq.q, [0.0])[0]) < 1e-12
        modes = model.modes(eq.q)
        assert_allclose(modes.frequencies, [W * math.sin(theta)], rtol=1e-12)
        assert modes.problem == "undamped"
    top = model.equilibrium([0.0])
    assert top.q[0] == 0.0 or abs(top.q[0]) < 1e-30
    assert not top.stable and top.stability == "unstable"
    assert "divergence" in top.reason
    assert top.spectrum is not None
    assert_allclose(top.spectrum.real.max(), math.sqrt(W * W - G / R), rtol=1e-12)


@pytest.mark.parametrize("make", [hoop_energy, hoop_particles])
def test_bead_on_slow_hoop(make):
    omega = 3.0  # Ω² < g/R
    eq = make(omega).equilibrium([0.7])
    assert abs(eq.q[0]) < 1e-14
    assert eq.stable
    modes = make(omega).modes([0.0])
    assert_allclose(modes.frequencies, [math.sqrt(G / R - omega**2)], rtol=1e-12)


def test_two_mass_frequencies_and_resonance():
    # Seed eq. 41–44: m₁m₂ ω⁴ − (m₁k₂ + m₂(k₁ + k₂)) ω² + k₁k₂ = 0, solved by hand.
    m1, m2, k1, k2 = 1.0, 2.0, 30.0, 20.0
    model = lg.scenes.forced_two_mass(m1=m1, m2=m2, k1=k1, k2=k2)
    modes = model.modes([0.0, 0.0])
    a, b, c = m1 * m2, -(m1 * k2 + m2 * (k1 + k2)), k1 * k2
    disc = math.sqrt(b * b - 4 * a * c)
    w2 = [2 * c / (-b + disc), (-b + disc) / (2 * a)]
    assert_allclose(modes.omega_squared, w2, rtol=1e-13)
    assert_allclose(modes.frequencies, np.sqrt(w2), rtol=1e-13)
    assert_allclose(modes.damping_ratios, [0.0, 0.0], atol=0)
    lin = modes.linearization
    phi = modes.shapes
    assert phi.dtype == np.float64
    assert_allclose(phi.T @ lin.M @ phi, np.eye(2), atol=1e-13)
    assert_allclose(lin.K, [[k1 + k2, -k2], [-k2, k2]], rtol=1e-14)
    # The forced response X = (K − Ω² M)⁻¹ F peaks at the natural frequencies.
    amp = lambda w: np.linalg.norm(np.linalg.solve(lin.K - w * w * lin.M, [1.0, 0.0]))
    assert amp(modes.frequencies[0] * (1 + 1e-6)) > 1e4 * amp(0.5 * modes.frequencies[0])


def test_double_pendulum_frequencies():
    l, g = 1.3, 9.81
    modes = lg.scenes.double_pendulum(m1=0.7, m2=0.7, l1=l, l2=l, g=g).modes([0.0, 0.0])
    assert_allclose(modes.omega_squared, [g / l * (2 - math.sqrt(2)), g / l * (2 + math.sqrt(2))],
                    rtol=1e-13)
    assert modes.stable


def test_ball_in_sphere_eq_53():
    m, j, r1, r2, g = 1.0, 0.016, 1.0, 0.2, 9.81
    modes = lg.scenes.ball_in_sphere(m=m, j=j, r1=r1, r2=r2, g=g).modes([0.0])
    w0 = math.sqrt(m * g / ((m + j / r2**2) * (r1 - r2)))
    assert_allclose(modes.frequencies, [w0], rtol=1e-12)


def test_damped_oscillator():
    m, k, c = 2.0, 50.0, 1.5
    modes = lg.scenes.damped_oscillator(m=m, k=k, c=c).modes([0.0])
    w0, zeta = math.sqrt(k / m), c / (2 * math.sqrt(k * m))
    assert modes.problem == "state_space"
    assert_allclose(modes.frequencies, [w0], rtol=1e-12)
    assert_allclose(modes.damping_ratios, [zeta], rtol=1e-12)
    upper = modes.eigenvalues[modes.eigenvalues.imag > 0][0]
    assert_allclose(upper.imag, w0 * math.sqrt(1 - zeta**2), rtol=1e-12)
    assert_allclose(modes.linearization.C, [[c]], rtol=1e-14)
    assert modes.stable and "asymptotically" in modes.reason


def test_charged_particle():
    m, e, b = 0.5, 1.5, 2.0
    lin = lg.scenes.charged_particle(m=m, e=e, b=b).linearize([0.3, -0.2])
    ev = lin.eigenvalues
    assert np.all(np.abs(ev[:2]) < 1e-12)
    assert_allclose(ev[2:].imag, [-e * b / m, e * b / m], rtol=1e-13)
    assert np.all(np.abs(ev[2:].real) < 1e-12)
    modes = lg.scenes.charged_particle(m=m, e=e, b=b).modes([0.3, -0.2])
    assert modes.stability == "neutral" and "zero eigenvalue" in modes.reason


def test_inverted_pendulum():
    l, g = 0.6, 9.81
    modes = lg.scenes.simple_pendulum(m=1.1, l=l, g=g).modes([math.pi])
    positive = modes.eigenvalues[modes.eigenvalues.real > 0]
    assert len(positive) == 1
    assert_allclose(positive.real, [math.sqrt(g / l)], rtol=1e-13)
    assert positive.imag[0] == 0.0
    assert modes.stability == "unstable"


def test_linearization_at_a_moving_state():
    model = lg.scenes.double_pendulum(m1=1.0, m2=0.6, l1=1.2, l2=0.8)
    q, qd = np.array([0.7, -1.1]), np.array([1.3, -0.4])
    lin = model.linearize(q, qd)
    assert lin.A.shape == (4, 4)
    h = 1e-5
    y = np.concatenate([q, qd])
    for j in range(4):
        up, down = y.copy(), y.copy()
        up[j] += h
        down[j] -= h
        diff = (model.accelerations(0.0, up[:2], up[2:]) - model.accelerations(0.0, down[:2], down[2:])) / (2 * h)
        assert_allclose(lin.A[2:, j], diff, rtol=1e-7, atol=1e-7)
    assert_allclose(lin.A[:2, 2:], np.eye(2), atol=0)
    assert np.abs(lin.C).max() > 0.1  # Coriolis terms away from rest
    assert_allclose(lin.A, model.jacobian(0.0, y), rtol=1e-15, atol=0)


def test_time_dependent_forces_need_a_time():
    model = lg.scenes.forced_two_mass(m1=1.0, m2=2.0, k1=30.0, k2=20.0, f1=3.0, omega=2.0)
    with pytest.raises(ValueError, match="no static equilibrium"):
        model.equilibrium([0.0, 0.0])
    t = 0.4
    eq = model.equilibrium([0.0, 0.0], t=t)
    x1 = 3.0 * math.cos(2.0 * t) / 30.0
    assert_allclose(eq.q, [x1, x1], rtol=1e-13)


def test_bad_input():
    model = lg.scenes.simple_pendulum()
    with pytest.raises(ValueError, match="not an equilibrium"):
        model.modes([0.4])
    with pytest.raises(ValueError):
        model.linearize([0.1, 0.2])
    with pytest.raises(ValueError):
        model.linearize([0.1], [math.nan])
    with pytest.raises(lg.SingularMassMatrixError):
        lg.scenes.lever().linearize([0.3])
    # The statics-only lever: K alone classifies it, and says so.
    eq = lg.scenes.lever().equilibrium([0.3])
    assert eq.spectrum is None and "statics only" in eq.reason


def test_driven_pendulum_parametric():
    # Hanging straight stays an equilibrium under the driven pivot, but its linearization
    # changes with t: neutral, with the reason; frozen at t it is that instant's verdict.
    model = lg.scenes.driven_pendulum(a=0.1, omega=20.0)
    eq = model.equilibrium([0.0])
    assert eq.q[0] == 0.0 and eq.stability == "neutral" and "parametric" in eq.reason
    assert model.equilibrium([0.0], t=0.0).stability != "neutral"


@pytest.mark.parametrize("eb, verdict, word", [(3.0, "stable", "gyroscopic"), (1.0, "unstable", "flutter")])
def test_gyroscopic_stabilization(eb, verdict, word):
    # A charge on a potential hill U = −½ k r² in the field B ẑ (m = 1): held when (eB)² ≥ 4k,
    # λ⁴ + ((eB)² − 2k) λ² + k² = 0.
    k = 1.0
    x, y = lg.coordinates("x y")
    model = lg.Model(
        coordinates=[x, y],
        kinetic=0.5 * (x.d**2 + y.d**2) + 0.5 * eb * (x * y.d - y * x.d),
        potential=-0.5 * k * (x**2 + y**2),
    )
    eq = model.equilibrium([0.1, -0.2])
    assert np.abs(eq.q).max() < 1e-14
    assert eq.stability == verdict and word in eq.reason, eq.reason
    assert np.all(eq.eigenvalues < 0)  # K alone would say unstable
    if verdict == "stable":
        modes = model.modes([0.0, 0.0])
        b = eb * eb - 2 * k
        disc = math.sqrt(b * b - 4 * k * k)
        assert_allclose(modes.frequencies, np.sqrt([(b - disc) / 2, (b + disc) / 2]), rtol=1e-12)
        assert modes.problem == "state_space" and np.iscomplexobj(modes.shapes)


# -- the input matrix B = ∂ẋ/∂u for parameters named as inputs -------------------------------


def forced_two_mass_dsl(m1=1.0, m2=2.0, k1=30.0, k2=20.0, f1=3.0, f2=-1.5, om=2.0):
    """The seed's two masses (eq. 41–44) forced by F cos Ωt, with F1, F2 and Ω as parameters."""
    x1, x2 = lg.coordinates("x1 x2")
    F1, F2, Om = lg.parameters("F1 F2 Om")
    drive = lg.cos(Om * lg.t)
    return lg.Model(
        coordinates=[x1, x2],
        kinetic=0.5 * m1 * x1.d**2 + 0.5 * m2 * x2.d**2,
        potential=0.5 * k1 * x1**2 + 0.5 * k2 * (x2 - x1) ** 2,
        forces=[F1 * drive, F2 * drive],
        parameters={F1: f1, F2: f2, Om: om},
    )


def test_forced_two_mass_input_matrix_is_m_inverse_dq_du():
    m1, m2, f1, f2, om, t = 1.0, 2.0, 3.0, -1.5, 2.0, 0.7
    model = forced_two_mass_dsl(m1=m1, m2=m2, f1=f1, f2=f2, om=om)
    lin = model.linearize([0.1, -0.2], [0.4, 0.3], t=t, inputs=["F2", "F1", "Om"])
    assert lin.inputs == ("F2", "F1", "Om")
    assert lin.B is not None and lin.B.shape == (4, 3)
    assert np.all(lin.B[:2] == 0.0)
    c, s = math.cos(om * t), math.sin(om * t)
    # ∂q̈/∂F = M⁻¹ ∂Q/∂F, M = diag(m1, m2); ∂Q/∂Ω = −F t sin Ωt.
    expected = [[0.0, c / m1, -f1 * t * s / m1], [c / m2, 0.0, -f2 * t * s / m2]]
    assert_allclose(lin.B[2:], expected, rtol=1e-14, atol=1e-15)
    # The rest of the linearization is the one without inputs.
    plain = model.linearize([0.1, -0.2], [0.4, 0.3], t=t)
    assert plain.B is None and plain.inputs == ()
    assert_allclose(lin.A, plain.A, rtol=0, atol=0)


def pendulum_with_torque(m=1.4, l=0.6, g=9.81, tau=0.8, c=0.3):
    """A damped pendulum driven by a torque τ: q̈ = (τ − c θ̇)/(m l²) − (g/l) sin θ; the mass m
    enters M, the input τ the force."""
    th, = lg.coordinates("th")
    pm, pl, pg, ptau, pc = lg.parameters("m l g tau c")
    return lg.Model(
        coordinates=[th],
        kinetic=0.5 * pm * pl**2 * th.d**2,
        potential=-pm * pg * pl * lg.cos(th),
        dissipation=0.5 * pc * th.d**2,
        forces=[ptau],
        parameters={pm: m, pl: l, pg: g, ptau: tau, pc: c},
    )


@pytest.mark.parametrize("theta, omega", [(0.0, 0.0), (0.4, 0.0), (2.5, -1.7)])
def test_pendulum_input_matrix_closed_forms(theta, omega):
    m, l, g, tau, c = 1.4, 0.6, 9.81, 0.8, 0.3
    lin = pendulum_with_torque(m, l, g, tau, c).linearize([theta], [omega], inputs=["g", "tau", "m"])
    assert lin.B is not None
    assert_allclose(lin.B[0], [0.0, 0.0, 0.0], atol=0)
    dg = -math.sin(theta) / l
    dtau = 1.0 / (m * l**2)
    # m is inside M: M⁻¹ (∂f/∂m − (∂M/∂m) q̈) = −(τ − c θ̇)/(m² l²).
    dm = -(tau - c * omega) / (m**2 * l**2)
    assert_allclose(lin.B[1], [dg, dtau, dm], rtol=1e-14, atol=1e-15)


def central_differences(model, names, t, q, qd, h=1e-5):
    """∂q̈/∂u by central differences of the accelerations of the rebound model."""
    columns = []
    for k in names:
        u = model.parameters[k]
        up = model.with_parameters(**{k: u + h}).accelerations(t, q, qd)
        down = model.with_parameters(**{k: u - h}).accelerations(t, q, qd)
        columns.append((up - down) / (2 * h))
    return np.array(columns).T


@pytest.mark.parametrize("backend", ["native", "interpreter"])
def test_double_pendulum_input_matrix_against_finite_differences(backend):
    from conftest import double_pendulum_dsl

    model = double_pendulum_dsl()
    if backend == "interpreter":
        model = lg.Model(
            coordinates=list(model.coordinates),
            kinetic=model.kinetic,
            potential=model.potential,
            parameters=model.parameters,
            backend="interpreter",
        )
    names = ["m1", "m2", "l1", "l2", "g"]
    q, qd = [0.7, -1.1], [1.3, -0.4]
    lin = model.linearize(q, qd, inputs=names)
    assert lin.B is not None and lin.B.shape == (4, 5)
    assert np.all(lin.B[:2] == 0.0)
    fd = central_differences(model, names, 0.0, q, qd)
    assert_allclose(lin.B[2:], fd, rtol=1e-7, atol=1e-7)
    assert np.abs(lin.B[2:, :4]).min() > 1e-3  # every parameter moves the accelerations


def test_particle_route_masses_as_inputs_against_finite_differences():
    # Two masses on a rotating rod (the particle route, T derived from positions): the masses
    # enter M through the derived T, the drive amplitude a force.
    r, th = lg.coordinates("r th")
    m1, m2, k, a = lg.parameters("m1 m2 k a")
    p1 = (r * lg.cos(th), r * lg.sin(th))
    p2 = (2 * r * lg.cos(th), 2 * r * lg.sin(th))
    model = lg.Model(
        coordinates=[r, th],
        positions=[p1, p2],
        masses=[m1, m2],
        potential=0.5 * k * (r - 1.0) ** 2,
        forces=[0.0, a * lg.sin(3.0 * lg.t)],
        parameters={m1: 0.8, m2: 1.3, k: 12.0, a: 0.9},
    )
    names = ["m1", "m2", "k", "a"]
    t, q, qd = 0.4, [1.2, 0.3], [0.5, -0.9]
    lin = model.linearize(q, qd, t=t, inputs=names)
    fd = central_differences(model, names, t, q, qd)
    assert_allclose(lin.B[2:], fd, rtol=1e-7, atol=1e-7)
    # ∂θ̈/∂a = sin 3t / (m1 r² + 4 m2 r²), exactly.
    assert_allclose(lin.B[3, 3], math.sin(3.0 * t) / ((0.8 + 4 * 1.3) * 1.2**2), rtol=1e-14)


def test_bad_inputs():
    model = pendulum_with_torque()
    with pytest.raises(ValueError, match="unknown input 'F'.*m, l, g, tau, c"):
        model.linearize([0.1], inputs=["F"])
    with pytest.raises(TypeError, match="sequence of parameter names"):
        model.linearize([0.1], inputs="tau")
    th, = lg.coordinates("th")
    bare = lg.Model(coordinates=[th], kinetic=0.5 * th.d**2, potential=0.5 * th**2)
    with pytest.raises(ValueError, match="no parameters"):
        bare.linearize([0.1], inputs=["k"])
    with pytest.raises(ValueError, match="ready-made scene"):
        lg.scenes.simple_pendulum().linearize([0.1], inputs=["g"])
    # A Parameter stands for its name; no inputs at all give an empty B.
    tau, = lg.parameters("tau")
    assert model.linearize([0.1], inputs=[tau]).inputs == ("tau",)
    empty = model.linearize([0.1], inputs=[])
    assert empty.B is not None and empty.B.shape == (2, 0)
