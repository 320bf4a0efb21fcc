"""The main job from Python: the seed's systems stated as energies in Python, simulated in Rust.

Each scene is written with the expression DSL (T, U, Φ, Q as in the seed), simulated, and compared
with its exact solution or with the seed's closed form; the last section takes the seed's systems
with their constraints kept as equations (``lg.scenes.CONSTRAINED``) and checks the reactions the
seed eliminates; the last identifies the damped oscillator's k and c from a noisy record
(``Model.fit``). Run with `python3 examples/seed.py` after `pip install .`.
"""

import math

import numpy as np

import lagrangian as lg


def report(name: str, what: str, err: float, sol: "lg.Solution") -> None:
    steps = sol.stats.get("accepted_steps", 0)
    print(f"{name:<34} {what:<34} {err:>9.1e}   {sol.stats['method']:<14} {steps:>7} steps")


def main() -> None:
    print("Seed scenes defined in Python, simulated in Rust\n")
    print(f"{'system':<34} {'checked against':<34} {'error':>9}   method            steps")

    # Double pendulum (§2): energy function h = T + U is conserved.
    th1, th2 = lg.coordinates("th1 th2")
    m, l, g = lg.parameters("m l g")
    T = 0.5 * m * l**2 * (2 * th1.d**2 + th2.d**2 + 2 * th1.d * th2.d * lg.cos(th1 - th2))
    U = -m * g * l * (2 * lg.cos(th1) + lg.cos(th2))
    dp = lg.Model(coordinates=[th1, th2], kinetic=T, potential=U,
                  parameters={"m": 1.0, "l": 1.0, "g": 9.81})
    sol = dp.simulate(q0=[1.0, 0.5], qd0=[0.0, 0.0], t_end=100.0, method="gauss4", dt=1e-3)
    drift = float(np.max(np.abs(sol.energy - sol.energy[0])))
    report("double pendulum", "energy conserved, 100 s", drift, sol)

    # Forced two-mass system (eq. 41-44): x(t) against the modal exact solution.
    x1, x2 = lg.coordinates("x1 x2")
    m1, m2, k1, k2, f1, f2, w = 1.0, 0.5, 40.0, 20.0, 2.0, 1.0, 3.0
    two = lg.Model(
        coordinates=[x1, x2],
        kinetic=0.5 * m1 * x1.d**2 + 0.5 * m2 * x2.d**2,
        potential=0.5 * k1 * x1**2 + 0.5 * k2 * (x2 - x1) ** 2,
        forces=[f1 * lg.cos(w * lg.t), f2 * lg.cos(w * lg.t)],
    )
    sol = two.simulate(q0=[0.0, 0.0], qd0=[0.0, 0.0], t_end=10.0, method="dop853",
                       rtol=1e-10, atol=1e-12)
    # Steady state + free vibration: solve K − Ω²M for the particular amplitude, modes for the rest.
    M = np.diag([m1, m2])
    K = np.array([[k1 + k2, -k2], [-k2, k2]])
    a = np.linalg.solve(K - w**2 * M, [f1, f2])
    lam, vecs = np.linalg.eig(np.linalg.solve(M, K))
    c = np.linalg.solve(vecs, -a)  # x(0) = 0 = a + V c,  ẋ(0) = 0 (cosines only)
    exact = a * math.cos(w * 10.0) + vecs @ (c * np.cos(np.sqrt(lam) * 10.0))
    report("2-DOF forced spring-mass", "exact x(10), eq. 43-44", float(np.max(np.abs(sol.q[-1] - exact))), sol)

    # Cylinder rolling down an incline (eq. 45-48): x(t) = ½ g sin α /(1 + J/(m r²)) t².
    x = lg.coordinates("x")[0]
    mc, J, r, alpha = 2.0, 0.01, 0.1, 0.3
    cyl = lg.Model(coordinates=[x], kinetic=0.5 * (mc + J / r**2) * x.d**2,
                   potential=-mc * 9.81 * x * lg.sin(alpha))
    sol = cyl.simulate(q0=[0.0], qd0=[0.0], t_end=2.0, method="gauss6", dt=0.01)
    exact = 0.5 * 9.81 * math.sin(alpha) / (1 + J / (mc * r**2)) * 4.0
    report("cylinder on an incline", "x(2) = ½ g sinα t²/(1+J/mr²)", abs(sol.q[-1, 0] - exact), sol)

    # Ball rolling inside a sphere (eq. 49-53): small oscillations at ω0.
    th = lg.coordinates("th")[0]
    mb, r1, r2 = 0.1, 0.5, 0.02
    Jb = 0.4 * mb * r2**2
    ball = lg.Model(coordinates=[th], kinetic=0.5 * (mb + Jb / r2**2) * (r1 - r2) ** 2 * th.d**2,
                    potential=-mb * 9.81 * (r1 - r2) * lg.cos(th))
    w0 = math.sqrt(mb * 9.81 / ((mb + Jb / r2**2) * (r1 - r2)))
    period = 2 * math.pi / w0
    sol = ball.simulate(q0=[1e-4], qd0=[0.0], t_end=period, method="gauss6", dt=period / 2000)
    report("ball rolling inside a sphere", "back at θ0 after 2π/ω0 (eq. 53)", abs(sol.q[-1, 0] - 1e-4) / 1e-4, sol)

    # Damped oscillator with Rayleigh dissipation (§4, eq. 54-55).
    xd = lg.coordinates("x")[0]
    mo, k, cdamp = 1.0, 25.0, 0.8
    osc = lg.Model(coordinates=[xd], kinetic=0.5 * mo * xd.d**2, potential=0.5 * k * xd**2,
                   dissipation=0.5 * cdamp * xd.d**2)
    sol = osc.simulate(q0=[1.0], qd0=[0.0], t_end=5.0, method="dop853", rtol=1e-10, atol=1e-12)
    gamma, wd = cdamp / (2 * mo), math.sqrt(k / mo - (cdamp / (2 * mo)) ** 2)
    exact = math.exp(-gamma * 5.0) * (math.cos(wd * 5.0) + gamma / wd * math.sin(wd * 5.0))
    report("damped oscillator (Rayleigh Φ)", "exact x(5), underdamped", abs(sol.q[-1, 0] - exact), sol)

    print("\nStatics by virtual work (§3.2, example 5): two springs under loads f1, f2")
    eq = lg.scenes.two_springs(1.0, 1.0, 200.0, 50.0, 3.0, 2.0).equilibrium([0.0, 0.0])
    print(f"  x = {eq.q}, seed: x1 = (f1+f2)/k1 = {5.0 / 200.0}, x2 = x1 + f2/k2 = {5.0 / 200.0 + 2.0 / 50.0}"
          f", stable = {eq.stable}")

    constrained()
    identified()


def identified() -> None:
    """Rayleigh's damping coefficient and the spring constant of §4's oscillator identified from
    a noisy free decay (the record made by the model itself, with noise), by ``Model.fit`` with
    the exact Jacobian of the run's sensitivities; needs SciPy."""
    try:
        import scipy  # noqa: F401
    except ImportError:
        print("\nParameters from measurements: needs SciPy (pip install scipy)")
        return
    print("\nParameters from measurements (§4): k and c of the damped oscillator from a noisy record")
    x = lg.coordinates("x")[0]
    k, c = lg.parameters("k c")
    osc = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * k * x**2,
                   dissipation=0.5 * c * x.d**2, parameters={"k": 25.0, "c": 0.8})
    t = np.linspace(0.0, 5.0, 200)
    rng = np.random.default_rng(54)
    record = osc.simulate([1.0], [0.0], 5.0, t_eval=t, rtol=1e-12, atol=1e-12).q
    record = record + 0.01 * rng.standard_normal(record.shape)
    fit = osc.fit(t, record, {"k": 20.0, "c": 0.3}, q0=[1.0], qd0=[0.0],
                  bounds={"c": (0.0, np.inf)})
    for name, truth in (("k", 25.0), ("c", 0.8)):
        value, sigma = fit.parameters[name], fit.uncertainties[name]
        print(f"  {name} = {value:.5f} ± {sigma:.2g}   (true {truth}, {(value - truth) / sigma:+.1f} σ)")
    print(f"  {fit.message} ({fit.nfev} runs with sensitivities)")


def constrained() -> None:
    """The seed's systems with their constraints kept as equations (lg.scenes.CONSTRAINED): the
    reactions the seed never sees come out as the multipliers."""
    print("\nConstrained: the eliminated coordinates kept, the constraints stated as equations\n")
    print(f"{'system':<34} {'checked against':<34} {'error':>9}   method            steps")
    scenes = lg.scenes

    # Rolling cylinder, x and θ under x = rθ (eq. 45): eq. 48's acceleration, and the friction
    # force rolling needs is the multiplier λ = −(J/r²) ẍ.
    mc, J, r, g, alpha = 2.0, 0.01, 0.1, 9.81, 0.3
    cyl = scenes.rolling_cylinder_constrained(m=mc, j=J, r=r, g=g, alpha=alpha)
    sol = cyl.simulate([0.0, 0.0], [0.0, 0.0], 2.0, method="dop853", rtol=1e-10, atol=1e-12)
    accel = mc * g * math.sin(alpha) / (mc + J / r**2)
    report("cylinder, x = rθ kept (eq. 45)", "x(2) = ½ ẍ t², eq. 48", abs(sol.q[-1, 0] - 2 * accel), sol)
    report("  its friction force = λ", "−(J/r²) ẍ", abs(sol.multipliers[-1, 0] + J / r**2 * accel), sol)

    # Ball in a sphere, θ1 and θ2 under (r1 − r2)θ1 = r2θ2 (eq. 49): the small-oscillation
    # frequency of eq. 53 by modes on the constraint manifold, and a simulated period.
    mb, r1, r2 = 0.1, 0.5, 0.02
    Jb = 0.4 * mb * r2**2
    ball = scenes.ball_in_sphere_constrained(m=mb, j=Jb, r1=r1, r2=r2, g=g)
    w0 = math.sqrt(g / ((r1 - r2) * (1 + Jb / (mb * r2**2))))
    w_modes = math.sqrt(ball.modes([0.0, 0.0]).omega_squared[0])
    print(f"{'ball in a sphere, eq. 49 kept':<34} {'ω0 by modes (eq. 53)':<34} "
          f"{abs(w_modes - w0) / w0:>9.1e}   modes")
    th0 = 1e-4
    period = 2 * math.pi / w0
    sol = ball.simulate([th0, (r1 - r2) * th0 / r2], [0.0, 0.0], period, method="rk4",
                        dt=period / 2000)
    report("  simulated", "back at θ0 after 2π/ω0", abs(sol.q[-1, 0] - th0) / th0, sol)

    # Cartesian pendulum: a rod x² + y² = l², RATTLE keeps it on the rod to round-off; the
    # tension −2lλ = m (g cos θ + l θ̇²).
    l, th = 1.0, 1.0
    pend = scenes.cartesian_pendulum(m=1.0, l=l, g=g)
    q0 = [l * math.sin(th), -l * math.cos(th)]
    sol = pend.simulate(q0, [0.0, 0.0], 10.0, method="stormer_verlet", dt=1e-3)
    report("Cartesian pendulum (RATTLE)", "rod length, 10 s", sol.stats["constraint_residual"], sol)
    rate = (sol.q[:, 0] * sol.qd[:, 1] - sol.q[:, 1] * sol.qd[:, 0]) / l**2
    angle = np.arctan2(sol.q[:, 0], -sol.q[:, 1])
    tension = -2 * l * np.array([pend.multipliers(t, q, qd)[0]
                                 for t, q, qd in zip(sol.t[::500], sol.q[::500], sol.qd[::500])])
    exact = g * np.cos(angle[::500]) + l * rate[::500] ** 2
    report("  its tension = −2lλ", "m (g cos θ + l θ̇²)", float(np.max(np.abs(tension - exact))), sol)

    # Virtual work with the reactions kept (§3.2 examples 3 and 4), closed chains in Cartesian
    # coordinates: the rhombus link balances at Q = P tan θ, the spring rhombus at
    # m g sin θ = 2k(L0 − a sin θ) cos θ.
    P, Q, ll = 3.0, 5.0, 0.8
    eq = scenes.rhombus_link_constrained(l=ll, p=P, q=Q).equilibrium([0.5, 0.2])
    theta = math.atan2(eq.q[1], eq.q[0])
    print(f"{'rhombus link (example 3)':<34} {'Q = P tan θ':<34} "
          f"{abs(Q - P * math.tan(theta)) / Q:>9.1e}   equilibrium, reaction Gᵀλ = "
          f"{np.round(eq.constraint_forces, 12).tolist()} (−2P, −2Q)")
    a, k, L0, M = 0.7, 300.0, 0.5, 3.0
    eq = scenes.spring_rhombus_constrained(a=a, k=k, l0=L0, m=M, g=g).equilibrium([0.35, 0.56])
    theta = math.atan2(eq.q[0], eq.q[1])
    balance = M * g * math.sin(theta) - 2 * k * (L0 - a * math.sin(theta)) * math.cos(theta)
    print(f"{'spring rhombus (example 4)':<34} {'Mg sinθ = 2k(L0 − a sinθ) cosθ':<34} "
          f"{abs(balance) / (M * g):>9.1e}   equilibrium, θ = {math.degrees(theta):.4f}°, "
          f"λ = {eq.multipliers[0]:.6g} = −Mg/(a cos θ) = {-M * g / (a * math.cos(theta)):.6g}, "
          f"{eq.stability}")


if __name__ == "__main__":
    main()
