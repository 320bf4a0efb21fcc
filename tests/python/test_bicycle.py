"""The Whipple bicycle (``lg.scenes.whipple_bicycle``) against the benchmark of Meijaard,
Papadopoulos, Ruina & Schwab (2007, Proc. R. Soc. A 463, 1955–1982): the linearized equations
M q̈ + v C₁ q̇ + (g K₀ + v² K₂) q = 0 in (lean φ, steer δ) of eq. 5.4, the eigenvalues of
Table 2, the weave and capsize speeds, and a nonlinear run's decay at the least-damped rate.

The published values are those of the paper, checked against second sources: the same
matrices in the NLEVP collection's ``bicycle`` problem (Betcke, Higham, Mehrmann, Schröder &
Tisseur), and SymPy's independent Kane's-method derivation of the bicycle, whose state matrix
the last test compares."""

import math

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq

import lagrangian as lg

G = 9.81
M_PUB = [[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]]
C1_PUB = [[0.0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]]
K0_PUB = [[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]]
K2_PUB = [[0.0, 76.59734589573222], [0.0, 2.65431523794604]]
WEAVE, CAPSIZE = 4.29238253634111, 6.02426201538837


@pytest.fixture(scope="module")
def bike():
    return lg.scenes.whipple_bicycle()


def upright(v, r_r=0.3, r_f=0.35):
    qd = np.zeros(8)
    qd[0], qd[6], qd[7] = v, -v / r_r, -v / r_f
    return np.zeros(8), qd


def reduced(model, v):
    q, qd = upright(v)
    return model.linearize_steady(q, qd, independent=["phi", "delta"], steady=["theta_r"])


@pytest.fixture(scope="module")
def matrices(bike):
    still, one = reduced(bike, 0.0), reduced(bike, 1.0)
    return {"M": still.M, "C1": one.C, "K0": still.K / G, "K2": one.K - still.K}


def test_matrices_match_the_benchmark(matrices):
    for name, pub in (("M", M_PUB), ("C1", C1_PUB), ("K0", K0_PUB), ("K2", K2_PUB)):
        err = np.abs(matrices[name] - np.array(pub)) / np.maximum(np.abs(pub), 1.0)
        assert err.max() < 1e-10, (name, matrices[name], err.max())


def test_speed_enters_as_the_benchmark_says(bike, matrices):
    # C = v C₁ and K = g K₀ + v² K₂ exactly: the linearization at 3.7 m/s from the matrices.
    lin = reduced(bike, 3.7)
    np.testing.assert_allclose(lin.C, 3.7 * matrices["C1"], rtol=0, atol=1e-11)
    np.testing.assert_allclose(lin.K, G * matrices["K0"] + 3.7**2 * matrices["K2"], rtol=0,
                               atol=1e-10)
    np.testing.assert_allclose(lin.M, matrices["M"], rtol=0, atol=1e-12)
    # The reduction: pitch from the front contact's height, five speeds from the five rows.
    assert lin.dependent == ("theta",)
    assert lin.dependent_speeds == ("x", "y", "psi", "theta", "theta_f")
    assert lin.cyclic == ("x", "y", "psi", "theta_r", "theta_f")
    np.testing.assert_allclose(lin.accelerations, [0.0, 0.0], atol=1e-12)


def test_eigenvalues_of_table_2(bike):
    # Meijaard et al. (2007), Table 2: standing still, the two inverted-pendulum pairs; at
    # 5 m/s castering, the weave pair and the (stable) capsize mode.
    still = np.sort(reduced(bike, 0.0).eigenvalues.real)
    np.testing.assert_allclose(still, [-5.53094371765393, -3.13164324790656, 3.13164324790656,
                                       5.53094371765393], rtol=0, atol=1e-10)
    five = reduced(bike, 5.0).eigenvalues
    want = [-14.07838969279822, -0.77534188219585 - 4.46486771378823j,
            -0.77534188219585 + 4.46486771378823j, -0.32286642900409]
    for w in want:
        assert np.min(np.abs(five - w)) < 1e-10, (w, five)


def test_weave_and_capsize_speeds(bike, matrices):
    m, c1, k0, k2 = (matrices[k] for k in ("M", "C1", "K0", "K2"))
    minv = np.linalg.inv(m)

    def growth(v):  # the largest real part of the eigenvalues at speed v
        a = np.block([[np.zeros((2, 2)), np.eye(2)],
                      [-minv @ (G * k0 + v * v * k2), -minv @ (v * c1)]])
        return float(np.max(np.linalg.eigvals(a).real))

    weave = brentq(growth, 4.0, 5.0, xtol=1e-13)
    capsize = brentq(growth, 5.5, 6.5, xtol=1e-13)
    assert abs(weave / WEAVE - 1) < 1e-10 and abs(capsize / CAPSIZE - 1) < 1e-10
    # The model's own linearization at those speeds: the weave pair, then the capsize root,
    # on the imaginary axis.
    for v in (weave, capsize):
        assert abs(np.max(reduced(bike, v).eigenvalues.real)) < 1e-9
    assert growth(4.0) > 0 > growth(5.0) and growth(6.5) > 0


def test_nonlinear_run_decays_at_the_least_damped_rate(bike):
    # 5 m/s is self-stable: after a small lean the motion dies out at the capsize mode's rate
    # −0.32286642900409 (Table 2). By t = 12 s the weave (−0.775) has fallen e^{−0.45·12} ≈
    # 1/230 further behind, and a lean of 10⁻³ leaves O(10⁻⁶) of nonlinearity: the fitted
    # rate holds to 1e-5 (the run gives about 2e-7).
    q, qd = upright(5.0)
    q[3] = 1e-3
    q, qd = bike.project(q, qd)
    sol = bike.simulate(q, qd, 20.0, rtol=1e-10, atol=1e-12, t_eval=np.linspace(0, 20, 801))
    assert sol.status == 0, sol.message
    tail = sol.t >= 12.0
    rate = np.polyfit(sol.t[tail], np.log(np.abs(sol.q[tail, 3])), 1)[0]
    assert abs(rate / -0.32286642900409 - 1) < 1e-5, rate
    # The rear contact's speed is kept to second order in the lean (the heading drifts).
    assert abs(math.hypot(sol.qd[-1, 0], sol.qd[-1, 1]) - 5.0) < 1e-5


def test_upright_at_rest_is_consistent(bike):
    q, qd = upright(5.0)
    pq, pqd = bike.project(q, qd)
    np.testing.assert_allclose(pq, q, atol=1e-15)
    np.testing.assert_allclose(pqd, qd, atol=1e-12)
    assert bike.constraint_names == ("front height", "rear slip 1", "rear slip 2",
                                     "front slip 1", "front slip 2")


def test_bicycle_bad_parameters():
    with pytest.raises(ValueError, match="'m_b'"):
        lg.scenes.whipple_bicycle(m_b=-1.0)
    with pytest.raises(ValueError, match="'r_f'"):
        lg.scenes.whipple_bicycle(r_f=0.0)
    with pytest.raises(TypeError, match="'w'"):
        lg.scenes.whipple_bicycle(w="long")
    with pytest.raises(ValueError, match="'lam'"):
        lg.scenes.whipple_bicycle(lam=math.inf)
    with pytest.raises(ValueError, match="'r'"):
        lg.scenes.rolling_disc(r=-0.3)
    assert lg.scenes.VEHICLES == ("rolling_disc", "whipple_bicycle")


def test_dependent_positions_named_or_refused(bike):
    q, qd = upright(2.0)
    named = bike.linearize_steady(q, qd, independent=["phi", "delta"], steady=["theta_r"],
                                  dependent=["theta"])
    np.testing.assert_allclose(named.K, reduced(bike, 2.0).K, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="cannot be solved"):  # the front height ignores x
        bike.linearize_steady(q, qd, independent=["phi", "delta"], steady=["theta_r"],
                              dependent=["x"])


def test_state_matrix_matches_sympys_kane_derivation(bike):
    # SymPy's own Whipple bicycle (sympy/physics/mechanics/tests/test_kane3.py: Kane's method,
    # linearized with the speed symbolic) checks its state matrix of (φ, δ, φ̇, δ̇) against
    # these numbers at v = 0 … 5 m/s to 1e-12: an independent derivation.
    for v in range(6):
        want = np.array([
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [9.48977444677355, -0.891197738059089 * v**2 - 0.571523173729245,
             -0.105522449805691 * v, -0.330515398992311 * v],
            [11.7194768719633, -1.97171508499972 * v**2 + 30.9087533932407,
             3.67680523332152 * v, -3.08486552743311 * v]])
        np.testing.assert_allclose(reduced(bike, float(v)).A, want, rtol=0, atol=1e-12)


def test_nonlinear_run_follows_the_linearization_to_third_order(bike):
    # From a lean φ₀ at 5 m/s the run's (φ, δ) follow exp(A t) y₀ of the reduced linearization
    # for 10 s (weave, castering and capsize modes at once); the lean dynamics are odd in
    # (φ, δ), so what is left is cubic: 10 times φ₀, 1000 times the deviation.
    lin = reduced(bike, 5.0)
    ts = np.linspace(0.0, 10.0, 201)
    errs = []
    for amp in (1e-4, 1e-3):
        q, qd = upright(5.0)
        q[3] = amp
        q, qd = bike.project(q, qd)
        sol = bike.simulate(q, qd, 10.0, rtol=1e-11, atol=1e-14, t_eval=ts)
        y0 = np.array([q[3], q[5], qd[3], qd[5]])
        linear = np.array([expm(lin.A * t) @ y0 for t in ts])[:, :2]
        errs.append(np.max(np.abs(sol.q[:, [3, 5]] - linear)))
    assert errs[0] < 1e-6 * 1e-4  # measured 1.0e-11
    assert abs(errs[1] / errs[0] / 1000 - 1) < 0.05, errs


def test_bodies_example_prints_the_benchmark_speeds(tmp_path):
    # examples/bodies.py, as a user runs it: the weave and capsize speeds it finds are the
    # paper's, the nonlinear lean decays at the linear rate, the top keeps its energy.
    import re
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[2] / "examples" / "bodies.py"
    done = subprocess.run([sys.executable, str(script), "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    out = done.stdout
    weave, capsize = map(float, re.search(r"weave speed ([\d.]+) m/s to the capsize speed "
                                          r"([\d.]+) m/s", out).groups())
    assert abs(weave - 4.292383) < 1e-6 and abs(capsize - 6.024262) < 1e-6, out
    rate, linear = map(float, re.search(r"decays at (-[\d.]+) 1/s from t = 8 to 15 \(linear "
                                        r"(-[\d.]+)\)", out).groups())
    assert abs(rate - linear) < 1e-3, out
    assert float(re.search(r"energy kept to ([\de.+-]+)", out).group(1)) < 1e-9, out
    assert "elbow at t = 1" in out
