"""Constrained models stated in Python (issue 41): holonomic and velocity constraints on the
energy and particle routes, the multipliers and reactions, consistent initial states, statics
and modes on the constraint manifold, and every feature of a run, each against a closed form."""

import math
import pickle
import re

import numpy as np
import pytest
from numpy.testing import assert_allclose

import lagrangian as lg

G = 9.81


def cartesian_pendulum(m=1.3, l=0.8, route="energy"):
    """A point mass m on a rod of length l from the origin, in Cartesian coordinates (y up)."""
    x, y = lg.coordinates("x y")
    mass, length, g = lg.parameters("m l g")
    values = {"m": m, "l": l, "g": G}
    rod = {"rod": x**2 + y**2 - length**2}
    if route == "energy":
        return lg.Model(
            [x, y],
            kinetic=0.5 * mass * (x.d**2 + y.d**2),
            potential=mass * g * y,
            parameters=values,
            constraints=rod,
        )
    return lg.Model(
        [x, y],
        positions=[(x, y)],
        masses=[mass],
        potential=mass * g * y,
        parameters=values,
        constraints=rod,
    )


def pendulum_state(theta, omega, l):
    """(q, q̇) of the Cartesian pendulum at angle θ from the downward vertical, rate ω."""
    q = [l * math.sin(theta), -l * math.cos(theta)]
    qd = [l * math.cos(theta) * omega, l * math.sin(theta) * omega]
    return q, qd


# -- the pendulum in Cartesian coordinates -----------------------------------------------------
def test_pendulum_period_is_the_elliptic_integral():
    from scipy.special import ellipk

    l, theta0 = 0.8, 2.0
    model = cartesian_pendulum(l=l)
    q0, qd0 = pendulum_state(theta0, 0.0, l)
    x, _ = model.coordinates
    # x crosses zero going left at T/4 and going right at 3T/4.
    crossings = lg.Event(x, direction=1, name="x up")
    period = 4 * math.sqrt(l / G) * ellipk(math.sin(theta0 / 2) ** 2)
    sol = model.simulate(q0, qd0, 1.2 * period, rtol=1e-11, atol=1e-12, events=[crossings],
                         method="dop853")
    assert_allclose(sol.t_events[0], [0.75 * period], rtol=1e-9)
    # On the circle at every output, energy conserved.
    r = np.hypot(sol.q[:, 0], sol.q[:, 1])
    assert np.max(np.abs(r - l)) < 1e-10
    assert np.max(np.abs(sol.energy - sol.energy[0])) < 1e-8 * abs(sol.energy[0])
    assert sol.stats["constraint_residual"] < 1e-9


@pytest.mark.parametrize("route", ["energy", "particles"])
def test_pendulum_rod_tension_from_the_state(route):
    m, l = 1.3, 0.8
    model = cartesian_pendulum(m, l, route)
    sol = model.simulate(*pendulum_state(1.1, 0.7, l), 2.0, rtol=1e-10, atol=1e-12)
    x, y = sol.q.T
    speed2 = np.sum(sol.qd**2, axis=1)
    # θ from the downward vertical: cos θ = −y/l, l θ̇² = v²/l.
    tension = m * (G * (-y / l) + speed2 / l)
    # The reaction +Gᵀλ = 2λ(x, y) pulls towards the pivot: T = −2 l λ.
    assert sol.multipliers.shape == (len(sol.t), 1)
    assert_allclose(-2 * l * sol.multipliers[:, 0], tension, rtol=1e-9, atol=1e-12)
    assert sol.constraint_forces.shape == (len(sol.t), 2)
    assert_allclose(sol.constraint_forces, 2 * sol.multipliers * sol.q, rtol=1e-12, atol=1e-12)
    # The same from the model at the states, one at a time and all at once.
    assert_allclose(model.multipliers(0.0, sol.q, sol.qd), sol.multipliers, rtol=1e-13)
    assert_allclose(model.constraint_forces(sol.t[3], sol.q[3], sol.qd[3]),
                    sol.constraint_forces[3], rtol=1e-13)
    assert model.constraint_names == ("rod",)
    assert model.structure["constraints"] == 1


def test_particle_reactions_are_the_cartesian_rod_force():
    m, l = 2.0, 1.5
    model = cartesian_pendulum(m, l, "particles")
    q, qd = pendulum_state(0.4, -1.2, l)
    reaction = model.particle_reactions(0.0, q, qd)
    assert reaction.shape == (1, 2)
    # Coordinates are the particle's own: the reaction is Gᵀλ, of size T along the rod.
    assert_allclose(reaction[0], model.constraint_forces(0.0, q, qd), rtol=1e-13)
    tension = m * (G * math.cos(0.4) + l * 1.2**2)
    assert_allclose(np.linalg.norm(reaction[0]), tension, rtol=1e-12)
    many = model.particle_reactions(0.0, [q, q], [qd, qd])
    assert many.shape == (2, 1, 2)


def test_particle_reactions_in_other_coordinates():
    # A bead on a circle, the particle placed by polar coordinates (r, φ) with r = l held by
    # a constraint: J = ∂x/∂q is not the identity, yet the reaction is the rod's pull.
    r, phi = lg.coordinates("r phi")
    m, l = 0.7, 1.1
    model = lg.Model(
        [r, phi],
        positions=[(r * lg.sin(phi), -r * lg.cos(phi))],
        masses=[m],
        potential=m * G * (-r * lg.cos(phi)),
        constraints=[r - l],
    )
    phi0, w = 0.6, 1.7
    reaction = model.particle_reactions(0.0, [l, phi0], [0.0, w])[0]
    tension = m * (G * math.cos(phi0) + l * w**2)
    inward = -np.array([math.sin(phi0), -math.cos(phi0)])
    assert_allclose(reaction, tension * inward, rtol=1e-12, atol=1e-13)
    # The generalized reaction: along r only, −T.
    assert_allclose(model.constraint_forces(0.0, [l, phi0], [0.0, w]), [-tension, 0.0],
                    rtol=1e-12, atol=1e-13)


# -- the rolling cylinder (seed eq. 45–48) ----------------------------------------------------
def test_rolling_cylinder_acceleration_and_friction():
    x, th = lg.coordinates("x theta")
    m, r, J, alpha = 2.0, 0.3, 0.5 * 2.0 * 0.3**2, 0.4
    model = lg.Model(
        [x, th],
        kinetic=0.5 * m * x.d**2 + 0.5 * J * th.d**2,
        potential=-m * G * lg.sin(alpha) * x,
        constraints={"rolling": x - r * th},
    )
    a = G * math.sin(alpha) / (1 + J / (m * r * r))
    qdd = model.accelerations(0.0, [0.0, 0.0], [0.5, 0.5 / r])
    assert_allclose(qdd, [a, a / r], rtol=1e-13)
    # G = (1, −r): the friction force on x is λ, its torque −r λ; rolling needs
    # F = m g sin α − m a (up the slope): λ = −F.
    friction = m * G * math.sin(alpha) - m * a
    assert_allclose(model.multipliers(0.0, [0.0, 0.0], [0.5, 0.5 / r]), [-friction], rtol=1e-13)
    assert_allclose(friction, m * G * math.sin(alpha) / 3, rtol=1e-13)  # a solid cylinder
    sol = model.simulate([0.0, 0.0], [0.0, 0.0], 1.5, t_eval=[0.5, 1.0, 1.5], rtol=1e-10,
                         atol=1e-12)
    assert_allclose(sol.q[:, 0], 0.5 * a * sol.t**2, rtol=1e-10)
    assert_allclose(sol.q[:, 1], sol.q[:, 0] / r, rtol=1e-12)
    assert_allclose(sol.multipliers[:, 0], -friction, rtol=1e-10)


# -- the knife edge (a velocity constraint) ----------------------------------------------------
def knife_edge(m=1.5, J=0.2):
    x, y, phi = lg.coordinates("x y phi")
    return lg.Model(
        [x, y, phi],
        kinetic=0.5 * m * (x.d**2 + y.d**2) + 0.5 * J * phi.d**2,
        velocity_constraints={"no side slip": -lg.sin(phi) * x.d + lg.cos(phi) * y.d},
    )


def test_knife_edge_circle_and_side_force():
    m, v, w = 1.5, 2.0, 0.8
    model = knife_edge(m)
    t = np.linspace(0.0, 6.0, 13)
    sol = model.simulate([0.0, 0.0, 0.0], [v, 0.0, w], 6.0, t_eval=t, rtol=1e-11, atol=1e-12)
    # φ = ωt, speed v along the blade: a circle of radius v/ω about (0, v/ω).
    assert_allclose(sol.q[:, 2], w * t, rtol=1e-11, atol=1e-12)
    assert_allclose(sol.q[:, 0], v / w * np.sin(w * t), rtol=1e-8, atol=1e-9)
    assert_allclose(sol.q[:, 1], v / w * (1 - np.cos(w * t)), rtol=1e-8, atol=1e-9)
    # The side force, λ (−sin φ, cos φ, 0), is the centripetal m v ω.
    assert_allclose(sol.multipliers[:, 0], m * v * w, rtol=1e-9)
    assert_allclose(sol.constraint_forces[:, :2],
                    m * v * w * np.column_stack([-np.sin(w * t), np.cos(w * t)]),
                    rtol=1e-8, atol=1e-9)
    assert model.constraint_names == ("no side slip",)
    assert model.velocity_constraints.keys() == {"no side slip"}


# -- the double pendulum in Cartesian coordinates ------------------------------------------
def cartesian_double_pendulum(m=1.0, l=1.0):
    x1, y1, x2, y2 = lg.coordinates("x1 y1 x2 y2")
    return lg.Model(
        [x1, y1, x2, y2],
        positions=[(x1, y1), (x2, y2)],
        masses=[m, m],
        potential=m * G * (y1 + y2),
        constraints={"upper rod": x1**2 + y1**2 - l**2,
                     "lower rod": (x2 - x1) ** 2 + (y2 - y1) ** 2 - l**2},
    )


def test_double_pendulum_modes_and_rod_forces():
    m, l = 1.2, 0.9
    model = cartesian_double_pendulum(m, l)
    eq = model.equilibrium([0.1, -0.8, 0.15, -1.9])
    assert_allclose(eq.q, [0.0, -l, 0.0, -2 * l], atol=1e-13)
    assert eq.stable and eq.stability == "stable"
    # The upper rod carries both weights, the lower one: T = −2 l λ.
    assert_allclose(-2 * l * eq.multipliers, [2 * m * G, m * G], rtol=1e-12)
    # They hold the weights up: Gᵀλ = ∂U/∂q at rest.
    assert_allclose(eq.constraint_forces, [0.0, m * G, 0.0, m * G], atol=1e-12)
    modes = model.modes(eq.q)
    assert len(modes.frequencies) == 2  # n − k = 4 − 2
    assert_allclose(modes.omega_squared, (G / l) * np.array([2 - math.sqrt(2), 2 + math.sqrt(2)]),
                    rtol=1e-12)
    # The shapes move along the manifold: sideways only, the lower bob √2 times the upper
    # (in phase) for the slow mode.
    shape = modes.shapes[:, 0].real
    assert_allclose(shape[[1, 3]], [0.0, 0.0], atol=1e-12)
    assert_allclose(shape[2] / shape[0], 1 + math.sqrt(2), rtol=1e-10)


def test_double_pendulum_small_oscillation_frequency_in_a_run():
    m, l = 1.0, 1.0
    model = cartesian_double_pendulum(m, l)
    # The slow mode, small: x₂ = (1 + √2) x₁.
    eps = 1e-4
    x1 = eps
    x2 = x1 + (1 + math.sqrt(2)) * eps - eps
    q0 = [x1, -math.sqrt(l**2 - x1**2), x2, 0.0]
    q0[3] = q0[1] - math.sqrt(l**2 - (x2 - x1) ** 2)
    q, qd = model.project(q0, [0.0] * 4)
    w = math.sqrt((G / l) * (2 - math.sqrt(2)))
    x = model.coordinates[0]
    sol = model.simulate(q, qd, 1.6 * 2 * math.pi / w, rtol=1e-11, atol=1e-14,
                         events=[lg.Event(x, direction=-1)])
    assert_allclose(sol.t_events[0][0], 0.25 * 2 * math.pi / w, rtol=1e-6)


# -- statics: the rhombus link of example 3 -------------------------------------------------
def test_rhombus_link_equilibrium_and_reaction():
    # OA = x, OB = y on a rod x² + y² = l²; the loads do δW = 2(P δx + Q δy): Q = P tan θ.
    x, y = lg.coordinates("x y")
    l, p = 0.7, 3.0
    model = lg.Model([x, y], kinetic=0.5 * (x.d**2 + y.d**2), constraints=[x**2 + y**2 - l**2])
    for q_load in (0.4, 3.0, 11.0):
        eq = model.equilibrium([0.5, 0.2], loads=[2 * p, 2 * q_load])
        theta = math.atan2(eq.q[1], eq.q[0])
        assert_allclose(p * math.tan(theta), q_load, rtol=1e-12)
        assert_allclose(math.hypot(*eq.q), l, rtol=1e-14)
        # The reactions balance the loads: Gᵀλ = −(2P, 2Q), λ = −√(P² + Q²)/l.
        assert_allclose(eq.constraint_forces, [-2 * p, -2 * q_load], rtol=1e-12)
        assert_allclose(eq.multipliers, [-math.hypot(p, q_load) / l], rtol=1e-12)


# -- initial states and bad input -------------------------------------------------------------
def test_inconsistent_initial_state_is_refused_and_projected():
    l = 0.8
    model = cartesian_pendulum(l=l)
    # g = 0.81 − 0.64 = 0.17.
    with pytest.raises(ValueError, match=r"rod.*position.*residual 1\.(7|69999)"):
        model.simulate([0.0, -0.9], [0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match=r"rod.*velocity"):
        model.simulate([0.0, -l], [0.0, 1.0], 1.0)
    with pytest.raises(ValueError, match="rod"):
        model.integrator([0.0, -0.9], [0.0, 0.0])
    with pytest.raises(ValueError, match="run 1"):
        model.simulate_many([[0.0, -l], [0.1, -l]], [0.0, 0.0], 1.0)
    q, qd = model.project([0.3, -0.9], [0.5, 0.2])
    assert_allclose(np.hypot(*q), l, rtol=1e-14)
    assert abs(np.dot(q, qd)) < 1e-13
    # The positions move along the radius (the M metric, equal masses).
    assert_allclose(q / np.linalg.norm(q), np.array([0.3, -0.9]) / np.hypot(0.3, 0.9),
                    rtol=1e-14)
    sol = model.simulate(q, qd, 0.5)
    assert sol.status == 0
    # A consistent state comes back unchanged.
    q2, qd2 = model.project(q, qd)
    assert np.array_equal(q2, q) and np.array_equal(qd2, qd)


def test_nonlinear_velocity_constraint_is_refused():
    x, y = lg.coordinates("x y")
    with pytest.raises(ValueError, match=r'"speed" is not linear in the velocities'):
        lg.Model([x, y], kinetic=0.5 * (x.d**2 + y.d**2),
                 velocity_constraints={"speed": x.d**2 + y.d**2 - 1})


def test_holonomic_constraint_reading_a_velocity_is_refused():
    x, y = lg.coordinates("x y")
    with pytest.raises(ValueError, match=r"'constraint 0' reads the velocity"):
        lg.Model([x, y], kinetic=0.5 * (x.d**2 + y.d**2), constraints=[x * y.d])


def test_bad_constraint_arguments():
    x, y = lg.coordinates("x y")
    kinetic = 0.5 * (x.d**2 + y.d**2)
    with pytest.raises(TypeError, match="list of expressions"):
        lg.Model([x, y], kinetic=kinetic, constraints=x - 1)
    with pytest.raises(ValueError, match="two constraints are named 'a'"):
        lg.Model([x, y], kinetic=kinetic, constraints={"a": x}, velocity_constraints={"a": y.d})
    z, = lg.coordinates("z")
    with pytest.raises(ValueError, match="not a coordinate"):
        lg.Model([x, y], kinetic=kinetic, constraints=[z])
    with pytest.raises(ValueError, match="has no value"):
        lg.Model([x, y], kinetic=kinetic, constraints=[x - lg.parameters("a")[0]])
    free = lg.Model([x, y], kinetic=kinetic)
    for method in ("multipliers", "constraint_forces", "particle_reactions"):
        with pytest.raises(ValueError, match="needs a constrained model"):
            getattr(free, method)(0.0, [0.0, 0.0], [0.0, 0.0])
    with pytest.raises(ValueError, match="needs a constrained model"):
        free.project([0.0, 0.0], [0.0, 0.0])
    sol = free.simulate([0.0, 0.0], [1.0, 0.0], 1.0)
    assert sol.multipliers is None and sol.constraint_forces is None
    with pytest.raises(ValueError, match="particle route"):
        cartesian_pendulum().particle_reactions(0.0, [0.0, -0.8], [0.0, 0.0])


def test_redundant_constraint_is_refused_naming_the_rows():
    x, y = lg.coordinates("x y")
    model = lg.Model(
        [x, y],
        kinetic=0.5 * (x.d**2 + y.d**2),
        potential=G * y,
        constraints={"rod": x**2 + y**2 - 1, "rod again": 2 * (x**2 + y**2 - 1)},
    )
    with pytest.raises(ValueError, match=r"rod again.*rod") as e:
        model.multipliers(0.0, [0.0, -1.0], [0.0, 0.0])
    assert "t = 0" in str(e.value)
    with pytest.raises(ValueError, match="rod again"):
        model.project([0.1, -1.0], [0.0, 0.0])


# -- every feature of a run ---------------------------------------------------------------
def test_pickling_round_trip():
    model = cartesian_double_pendulum(1.0, 1.0)
    again = pickle.loads(pickle.dumps(model))
    assert again.constraint_names == ("upper rod", "lower rod")
    q, qd = [0.6, -0.8, 1.2, -1.6], [0.8, 0.6, 0.0, 0.0]
    q, qd = model.project(q, qd)
    assert_allclose(again.multipliers(0.0, q, qd), model.multipliers(0.0, q, qd), rtol=0)
    sol = again.simulate(q, qd, 0.5, rtol=1e-9, atol=1e-12)
    back = pickle.loads(pickle.dumps(sol))
    assert_allclose(back.multipliers, sol.multipliers, rtol=0)
    assert_allclose(back.constraint_forces, sol.constraint_forces, rtol=0)
    assert repr(again) == repr(model)
    velocity = pickle.loads(pickle.dumps(knife_edge()))
    assert velocity.velocity_constraints.keys() == {"no side slip"}


def test_with_parameters_rebinds_the_constraints():
    model = cartesian_pendulum(l=0.8)
    longer = model.with_parameters(l=1.2)
    q, qd = longer.project([0.0, -1.0], [0.0, 0.0])
    assert_allclose(q, [0.0, -1.2], rtol=1e-14)


def test_dense_output_stays_near_the_circle():
    l = 0.8
    model = cartesian_pendulum(l=l)
    sol = model.simulate(*pendulum_state(1.0, 0.0, l), 2.0, dense=True, rtol=1e-10, atol=1e-12)
    q, _ = sol(np.linspace(0.0, 2.0, 101))
    assert np.max(np.abs(np.hypot(q[:, 0], q[:, 1]) - l)) < 1e-8


def test_integrator_goes_on_consistently():
    l = 0.8
    model = cartesian_pendulum(l=l)
    q0, qd0 = pendulum_state(0.5, 0.0, l)
    ig = model.integrator(q0, qd0, rtol=1e-10, atol=1e-12)
    for t in (0.5, 1.0, 1.5):
        assert ig.propagate_until(t) == "finished"
    sol = model.simulate(q0, qd0, 1.5, rtol=1e-10, atol=1e-12)
    assert_allclose(ig.q, sol.q[-1], atol=1e-8)
    assert abs(np.hypot(*ig.q) - l) < 1e-10


def test_simulate_many_matches_simulate():
    l = 0.8
    model = cartesian_pendulum(l=l)
    states = [pendulum_state(th, 0.0, l) for th in (0.3, 1.0, 2.0)]
    q0 = np.array([s[0] for s in states])
    qd0 = np.array([s[1] for s in states])
    ens = model.simulate_many(q0, qd0, 1.0, t_eval=[0.5, 1.0], rtol=1e-10, atol=1e-12)
    for i in range(3):
        one = model.simulate(q0[i], qd0[i], 1.0, t_eval=[0.5, 1.0], rtol=1e-10, atol=1e-12)
        assert_allclose(ens.q[i], one.q, rtol=0, atol=0)
        assert ens.run_stats(i) == one.stats
    assert ens.stats["constraint_residual"].shape == (3,)
    assert np.all(ens.stats["constraint_residual"] < 1e-9)


def test_simulate_many_on_dask():
    pytest.importorskip("dask")
    from dask.distributed import Client, LocalCluster

    l = 0.8
    model = cartesian_pendulum(l=l)
    q0 = np.array([pendulum_state(th, 0.0, l)[0] for th in (0.3, 1.0)])
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False) as cluster, \
            Client(cluster) as client:
        ens = model.simulate_many(q0, [0.0, 0.0], 0.5, t_eval=[0.5], executor=client,
                                  rtol=1e-10, atol=1e-12)
    local = model.simulate_many(q0, [0.0, 0.0], 0.5, t_eval=[0.5], rtol=1e-10, atol=1e-12)
    assert_allclose(ens.q, local.q, rtol=0, atol=0)
    assert_allclose(ens.stats["constraint_residual"], local.stats["constraint_residual"], rtol=0)


def test_plots_of_a_constrained_run(tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    model = cartesian_pendulum(route="particles")
    sol = model.simulate(*pendulum_state(1.0, 0.0, 0.8), 1.0)
    fig = sol.plot()
    assert fig is not None
    path = tmp_path / "pendulum.png"
    fig.savefig(path)
    assert path.read_bytes().startswith(b"\x89PNG")
    pytest.importorskip("PIL")
    movie = tmp_path / "pendulum.gif"
    model.animate(sol, str(movie))
    assert movie.read_bytes().startswith(b"GIF89a")


def test_every_method_runs_or_says_which_can():
    # Each method either holds the constraints (projected Runge–Kutta and radau5 steps,
    # RATTLE, the constrained variational step) and agrees with a tight reference, or refuses
    # with a ValueError that lists the methods that fit.
    l = 0.8
    model = cartesian_pendulum(l=l)
    q0, qd0 = pendulum_state(1.0, 0.0, l)
    fixed = {"rk4", "stormer_verlet", "yoshida4", "yoshida6", "yoshida8", "blanes_moan4",
             "midpoint", "gauss4", "gauss6"}
    exact = model.simulate(q0, qd0, 1.0, method="dop853", rtol=1e-12, atol=1e-14).q[-1]
    assert set(lg.methods()) >= fixed | {"auto", "dopri5", "dop853", "radau5", "taylor"}
    ran, refused = set(), set()
    for method in lg.methods():
        dt = 1e-3 if method in fixed else None
        try:
            sol = model.simulate(q0, qd0, 1.0, method=method, dt=dt, rtol=1e-10, atol=1e-12)
        except ValueError as e:
            refused.add(method)
            fitting = re.search(r"methods that fit: \[(.*)\]", str(e))
            assert "constrained" in str(e) and fitting, (method, str(e))
            fit = {m.strip().strip('"') for m in fitting.group(1).split(",")}
            assert method not in fit and fit >= {"rk4", "dopri5", "dop853", "radau5"}, method
            continue
        ran.add(method)
        assert np.max(np.abs(np.hypot(sol.q[:, 0], sol.q[:, 1]) - l)) < 1e-9, method
        assert sol.stats["constraint_residual"] < 1e-9, method
        # Second order at dt = 10⁻³ is the loosest: 10⁻⁵.
        assert_allclose(sol.q[-1], exact, atol=1e-5 if dt else 1e-7, err_msg=method)
    assert ran >= {"auto", "rk4", "dopri5", "dop853", "radau5"}
    assert {"taylor", "gauss4", "gauss6"} <= refused
    assert "constrained" in model.simulate(q0, qd0, 0.1).stats["choice"]
    with pytest.raises(ValueError, match="constrained model has no single program"):
        model.taylor_series(q0, qd0)


def test_evaluations_and_linearization_of_a_constrained_model():
    l = 0.8
    model = cartesian_pendulum(m=1.3, l=l)
    q, qd = pendulum_state(0.7, 1.1, l)
    qdd = model.accelerations(0.0, q, qd)
    # On the circle to second order: x ẍ + y ÿ + |q̇|² = 0, and θ̈ = −(g/l) sin θ.
    assert abs(np.dot(q, qdd) + np.dot(qd, qd)) < 1e-13
    theta_dd = (q[0] * qdd[1] - q[1] * qdd[0]) / l**2
    assert_allclose(theta_dd, -G / l * math.sin(0.7), rtol=1e-13)
    assert_allclose(model.rhs(0.0, np.array(q + qd))[2:], qdd, rtol=1e-14)
    assert model.jacobian(0.0, np.array(q + qd)).shape == (4, 4)
    # Linearized about the bottom: ±i√(g/l), and a double zero (a Jordan block: off the
    # circle the linearized flow drifts, which rounding splits into ±√ε) from the direction
    # the rod holds.
    lin = model.linearize([0.0, -l])
    eig = np.sort_complex(lin.eigenvalues)
    assert_allclose(np.abs(eig.imag).max(), math.sqrt(G / l), rtol=1e-12)
    assert np.sum(np.abs(eig) < 1e-6) == 2
    # The n − k = 1 mode.
    modes = model.modes([0.0, -l])
    assert_allclose(modes.frequencies, [math.sqrt(G / l)], rtol=1e-12)


def test_moving_constraint_bead_on_a_spinning_wire():
    # A bead on a straight wire spinning at ω in the horizontal plane: −sin ωt x + cos ωt y = 0.
    # Radially r̈ = ω² r, so r = r₀ cosh ωt; the wire pushes it on with the Coriolis force
    # 2 m ω ṙ = 2 m ω² r₀ sinh ωt (λ along ∂g/∂q, the direction of rotation).
    x, y = lg.coordinates("x y")
    m, w, r0 = 0.5, 1.3, 0.4
    bead = lg.Model([x, y], kinetic=0.5 * m * (x.d**2 + y.d**2),
                    constraints={"wire": -lg.sin(w * lg.t) * x + lg.cos(w * lg.t) * y})
    assert bead.structure["driven"] and not bead.structure["conservative"]
    assert lg.Model([x, y], kinetic=0.5 * (x.d**2 + y.d**2)).structure["constraints"] == 0
    t = np.linspace(0.0, 2.0, 9)
    sol = bead.simulate([r0, 0.0], [0.0, w * r0], 2.0, t_eval=t, rtol=1e-11, atol=1e-13)
    r = r0 * np.cosh(w * t)
    assert_allclose(sol.q, np.column_stack([r * np.cos(w * t), r * np.sin(w * t)]),
                    rtol=1e-10, atol=1e-11)
    assert_allclose(sol.multipliers[:, 0], 2 * m * w**2 * r0 * np.sinh(w * t),
                    rtol=1e-9, atol=1e-11)
    # The wire does work: h = ½ m (ṙ² + ω² r²) = ½ m r₀² ω² cosh 2ωt, and the reactions' power
    # Gᵀλ·q̇ is its rate, m r₀² ω³ sinh 2ωt, at every output and from the model pointwise.
    assert_allclose(sol.energy, 0.5 * m * r0**2 * w**2 * np.cosh(2 * w * t), rtol=1e-9)
    power = m * r0**2 * w**3 * np.sinh(2 * w * t)
    assert_allclose(sol.constraint_power, power, rtol=1e-9, atol=1e-12)
    assert_allclose(bead.constraint_power(t[4], sol.q[4], sol.qd[4]), power[4], rtol=1e-9)
    assert_allclose(bead.constraint_power(0.0, sol.q, sol.qd), np.sum(
        bead.constraint_forces(0.0, sol.q, sol.qd) * sol.qd, axis=1), rtol=1e-14, atol=1e-15)
    # A constraint that holds still does no work, and a model without one has no power.
    pendulum = cartesian_pendulum()
    psol = pendulum.simulate(*pendulum_state(1.0, 0.0, 0.8), 1.0, rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(psol.constraint_power)) < 1e-9
    free = lg.Model([x, y], kinetic=0.5 * (x.d**2 + y.d**2))
    assert free.simulate([0.0, 0.0], [1.0, 0.0], 1.0).constraint_power is None
    # At rest on the wire at t = 0 is not consistent: the wire moves.
    with pytest.raises(ValueError, match="wire.*velocity"):
        bead.simulate([r0, 0.0], [0.0, 0.0], 1.0)


def test_events_with_resets_stay_on_the_circle():
    # A wall at x = 0.3 that reverses the bob: the reset velocity is consistent again.
    l = 1.0
    model = cartesian_pendulum(l=l)
    x, y = model.coordinates
    wall = lg.Event(x - 0.3, direction=1, reset={x.d: -x.d, y.d: -y.d}, name="wall")
    sol = model.simulate(*pendulum_state(-0.5, 0.0, l), 5.0, events=[wall], rtol=1e-10,
                         atol=1e-12)
    assert len(sol.t_events[0]) >= 3
    assert_allclose(sol.q_events[0][:, 0], 0.3, atol=1e-10)
    assert np.max(np.abs(np.hypot(sol.q[:, 0], sol.q[:, 1]) - l)) < 1e-9
    # Elastic bounces: the energy is kept.
    assert np.max(np.abs(sol.energy - sol.energy[0])) < 1e-7


def test_integrator_refuses_an_assigned_state_off_the_constraints():
    model = cartesian_pendulum(l=1.0)
    ig = model.integrator(*pendulum_state(1.0, 0.0, 1.0))
    ig.q = [0.5, -0.5]
    with pytest.raises(ValueError, match="rod.*position"):
        ig.propagate_until(1.0)
    ig.q = pendulum_state(0.7, 0.0, 1.0)[0]
    assert ig.propagate_until(1.0) == "finished"
    assert "constraint_residual" in ig.stats


@pytest.mark.parametrize("kind", ["holonomic", "velocity"])
def test_compiled_rows_agree_with_the_interpreter(kind):
    # G and γ derived on the graph and compiled (backend="native") against the dual-number
    # passes over the row tapes (backend="interpreter"): the same multipliers and the same run,
    # to rounding.
    x1, y1, x2, y2 = lg.coordinates("x1 y1 x2 y2")
    w, = lg.parameters("w")
    rows = {"upper": x1**2 + y1**2 - 1, "lower": (x2 - x1) ** 2 + (y2 - y1) ** 2 - 1}
    moving = None
    if kind == "velocity":
        rows = {"upper": x1**2 + y1**2 - 1}
        moving = {"drive": x2.d - lg.cos(w * lg.t) * x1.d + 0.1 * y2.d}

    def build(backend):
        return lg.Model([x1, y1, x2, y2], positions=[(x1, y1), (x2, y2)], masses=[1.0, 2.0],
                        potential=G * (y1 + 2 * y2) + 0.1 * w * x2**2, parameters={"w": 0.7},
                        constraints=rows, velocity_constraints=moving, backend=backend)

    native, interpreted = build("native"), build("interpreter")
    q, qd = native.project([0.6, -0.8, 1.2, -1.7], [0.3, 0.2, -0.1, 0.4], t=0.3)
    assert_allclose(native.multipliers(0.3, q, qd), interpreted.multipliers(0.3, q, qd),
                    rtol=1e-13)
    a = native.simulate(q, qd, 1.3, t0=0.3, t_eval=[0.8, 1.3], rtol=1e-10, atol=1e-12)
    b = interpreted.simulate(q, qd, 1.3, t0=0.3, t_eval=[0.8, 1.3], rtol=1e-10, atol=1e-12)
    assert_allclose(a.q, b.q, rtol=1e-12, atol=1e-13)
    assert_allclose(a.multipliers, b.multipliers, rtol=1e-10)


def test_dead_point_is_refused_naming_the_rows_and_the_time():
    # A point on the unit circle and on the line y = −1 touch at (0, −1), where the two rows'
    # gradients are parallel: G loses rank.
    x, y = lg.coordinates("x y")
    model = lg.Model([x, y], kinetic=0.5 * (x.d**2 + y.d**2),
                     constraints={"circle": x**2 + y**2 - 1, "floor": y + 1})
    with pytest.raises(ValueError, match=r"floor.*circle.*t = 0\.25|t = 0\.25.*floor"):
        model.multipliers(0.25, [0.0, -1.0], [0.0, 0.0])
    with pytest.raises(ValueError, match="floor"):
        model.simulate([0.0, -1.0], [0.0, 0.0], 1.0)


def test_spring_rhombus_of_example_4():
    # Half-diagonals x = a sin θ (the spring BD = 2x) and y = a cos θ on x² + y² = a²;
    # U = 2k(L₀ − x)² − 2Mg y. Balance: Mg sin θ = 2k(L₀ − a sin θ) cos θ, λ = −Mg / (a cos θ).
    x, y = lg.coordinates("x y")
    a, l0, k, mass = 1.0, 0.8, 50.0, 2.0
    model = lg.Model([x, y], kinetic=0.5 * (x.d**2 + y.d**2),
                     potential=2 * k * (l0 - x) ** 2 - 2 * mass * G * y,
                     constraints={"rhombus": x**2 + y**2 - a**2})
    eq = model.equilibrium([0.5, 0.8])
    theta = math.atan2(eq.q[0], eq.q[1])
    assert_allclose(mass * G * math.sin(theta),
                    2 * k * (l0 - a * math.sin(theta)) * math.cos(theta), rtol=1e-12)
    assert_allclose(eq.multipliers, [-mass * G / (a * math.cos(theta))], rtol=1e-12)
    assert eq.stable


def test_a_solution_from_before_constraints_has_no_reactions():
    # A pickle of an earlier version keeps only the fields it knew.
    free = cartesian_pendulum().simulate(*pendulum_state(0.3, 0.0, 0.8), 0.2)
    state = free.__getstate__()
    del state["multipliers"], state["constraint_forces"]
    old = lg.Solution.__new__(lg.Solution)
    old.__setstate__(state)
    assert old.multipliers is None and old.constraint_forces is None
    assert_allclose(old.q, free.q, rtol=0)


# -- how closely a run holds the constraints, and change points (issue 49) ---------------------
def rod_beside_a_free_coordinate():
    """A pendulum rod x² + y² = 1 (U = g y) beside a free coordinate z."""
    x, y, z = lg.coordinates("x y z")
    return lg.Model([x, y, z], kinetic=0.5 * (x.d**2 + y.d**2 + z.d**2), potential=G * y,
                    constraints={"rod": x**2 + y**2 - 1})


@pytest.mark.parametrize("zd", [0.0, 1000.0])
def test_a_free_coordinate_does_not_loosen_the_rod(zd):
    # The rod's tolerance is its own: z running to 10⁵ (z = ż t exactly) leaves it at
    # atol + rtol as a distance, |g| ≤ 2 · 2e-8 (it was judged against the largest |q|:
    # 2.7e-5 at ż = 1000).
    model = rod_beside_a_free_coordinate()
    th, tol = 0.7, 1e-8
    sol = model.simulate([math.sin(th), -math.cos(th), 0.0], [0.0, 0.0, zd], 100.0, rtol=tol,
                         atol=tol)
    residual = np.max(np.abs(sol.q[:, 0] ** 2 + sol.q[:, 1] ** 2 - 1))
    assert residual <= 4 * tol
    assert residual <= sol.stats["constraint_residual"] <= 4 * tol
    assert_allclose(sol.q[:, 2], zd * sol.t, rtol=1e-9, atol=1e-9)
    energy = 0.5 * (sol.qd[:, 0] ** 2 + sol.qd[:, 1] ** 2) + G * sol.q[:, 1]
    assert np.max(np.abs(energy - energy[0])) < 1e-5


def four_bar(a, b, c, d, g):
    """A planar four-bar in its link angles: crank a from the origin, coupler b, rocker c from
    the ground pivot (d, 0); uniform rods of unit mass, gravity g along −y; the loop closed by
    its x and y rows."""
    t1, t2, t3 = lg.coordinates("t1 t2 t3")
    vx = -a * lg.sin(t1) * t1.d - b / 2 * lg.sin(t2) * t2.d
    vy = a * lg.cos(t1) * t1.d + b / 2 * lg.cos(t2) * t2.d
    kinetic = (a**2 / 6 * t1.d**2 + c**2 / 6 * t3.d**2 + 0.5 * (vx**2 + vy**2)
               + b**2 / 24 * t2.d**2)
    potential = g * (1.5 * a * lg.sin(t1) + b / 2 * lg.sin(t2) + c / 2 * lg.sin(t3))
    return lg.Model([t1, t2, t3], kinetic=kinetic, potential=potential,
                    constraints={"loop x": a * lg.cos(t1) + b * lg.cos(t2) - c * lg.cos(t3) - d,
                                 "loop y": a * lg.sin(t1) + b * lg.sin(t2) - c * lg.sin(t3)})


def loop_residual(q, a, b, c, d):
    t1, t2, t3 = q.T
    gx = a * np.cos(t1) + b * np.cos(t2) - c * np.cos(t3) - d
    gy = a * np.sin(t1) + b * np.sin(t2) - c * np.sin(t3)
    return np.maximum(np.abs(gx), np.abs(gy))


def test_a_winding_crank_does_not_drift():
    # A Grashof crank-rocker (a = 1, b = 3, c = 2, d = 3): the crank winds to θ₁ ≈ 700 by
    # t = 200, and the loop stays closed to the tolerance, no worse in the second half (judged
    # against |θ₁| it drifted to 3.6e-4).
    a, b, c, d = 1.0, 3.0, 2.0, 3.0
    model = four_bar(a, b, c, d, 0.0)
    # The far joint of the coupler at θ₁ = π/2: |B − A| = b, |B − (d, 0)| = c.
    A, D = np.array([0.0, a]), np.array([d, 0.0])
    e = D - A
    along = (b * b - c * c + e @ e) / (2 * np.linalg.norm(e))
    u = e / np.linalg.norm(e)
    B = A + along * u + math.sqrt(b * b - along * along) * np.array([-u[1], u[0]])
    q0 = [math.pi / 2, math.atan2(*(B - A)[::-1]), math.atan2(*(B - D)[::-1])]
    jac = np.array([[-a * math.sin(q0[0]), -b * math.sin(q0[1]), c * math.sin(q0[2])],
                    [a * math.cos(q0[0]), b * math.cos(q0[1]), -c * math.cos(q0[2])]])
    qd0 = [3.0, *np.linalg.solve(jac[:, 1:], -3.0 * jac[:, 0])]
    tol = 1e-6
    sol = model.simulate(q0, qd0, 200.0, rtol=tol, atol=tol)
    assert sol.q[-1, 0] > 600
    r = loop_residual(sol.q, a, b, c, d)
    half = len(r) // 2
    assert r[:half].max() <= 6 * tol and r[half:].max() <= 6 * tol
    assert r.max() <= sol.stats["constraint_residual"]
    assert np.max(np.abs(sol.energy - sol.energy[0])) < 1e-2 * sol.energy[0]


def parallelogram_change_points():
    """When the parallelogram four-bar (a = c = 1, b = d = 2, g = 9.81) from θ₁ = π/2 at
    θ̇₁ = 3 on its parallelogram branch (θ₂ = 0, θ₃ = θ₁) has its links collinear, θ₁ = π and
    2π: on the branch J θ̇²/2 + 2 g sin θ is conserved (J = 5/3), t(θ) = ∫ dθ/θ̇."""
    from scipy.integrate import quad

    rate = lambda th: math.sqrt(9.0 + 4.0 * G * (1.0 - math.sin(th)) / (5.0 / 3.0))
    first = quad(lambda th: 1.0 / rate(th), math.pi / 2, math.pi, epsabs=1e-13)[0]
    return [first, first + quad(lambda th: 1.0 / rate(th), math.pi, 2 * math.pi,
                                epsabs=1e-13)[0]]


@pytest.mark.parametrize("tolerances", [dict(rtol=1e-6, atol=1e-6), dict(),
                                        dict(rtol=1e-8, atol=1e-8)])
def test_a_change_point_is_never_crossed_onto_the_other_branch(tolerances):
    # All links collinear (G of rank 1) at t ≈ 0.40 and 0.86: the run goes on along the
    # parallelogram with bounded multipliers and its energy, or stops with the typed error at
    # a change point — never onto the antiparallelogram with multipliers of 10¹³ (which the
    # defaults did).
    model = four_bar(1.0, 2.0, 1.0, 2.0, G)
    q0, qd0 = [math.pi / 2, 0.0, math.pi / 2], [3.0, 0.0, 3.0]
    typical = np.max(np.abs(model.multipliers(0.0, q0, qd0)))
    stops = parallelogram_change_points()
    try:
        sol = model.simulate(q0, qd0, 1.0, **tolerances)
    except ValueError as e:
        message = str(e)
        assert "constraints are dependent" in message and "loop" in message
        t = float(re.search(r"at t = ([-+0-9.e]+)", message).group(1))
        assert min(abs(t - s) for s in stops) < 1e-4, (t, stops)
        return
    assert np.max(np.abs(sol.q[:, 1])) < 1e-5
    assert np.max(np.abs(sol.q[:, 2] - sol.q[:, 0])) < 1e-5
    assert np.max(np.abs(sol.multipliers)) < 1e3 * typical
    rtol = tolerances.get("rtol", 1e-6)
    assert np.max(np.abs(sol.energy - sol.energy[0])) < 1e3 * rtol * abs(sol.energy[0])
