"""Bad input gets a clear exception before any work; failures of the mathematics raise
subclasses of LagrangianError whose messages say where (t) and what to try."""

import math
import os
import re
import signal
import threading
import time

import numpy as np
import pytest

import lagrangian as lg


@pytest.fixture
def osc():
    x, = lg.coordinates("x")
    k, = lg.parameters("k")
    return lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * k * x**2,
                    parameters={"k": 4.0})


# -- bad input -------------------------------------------------------------------------------

@pytest.mark.parametrize("q0, qd0, what", [
    ([1.0, 2.0], [0.0], "q0"),
    ([1.0], [], "qd0"),
    ([[1.0]], [0.0], "q0"),
    ("1", [0.0], "q0"),
])
def test_simulate_rejects_wrong_lengths(osc, q0, qd0, what):
    with pytest.raises(ValueError, match=what):
        osc.simulate(q0, qd0, 1.0)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_simulate_rejects_non_finite_initial_values(osc, bad):
    with pytest.raises(ValueError, match="not finite"):
        osc.simulate([bad], [0.0], 1.0)
    with pytest.raises(ValueError, match="not finite"):
        osc.simulate([0.0], [bad], 1.0)
    with pytest.raises(ValueError, match="not finite"):
        osc.simulate([0.0], [0.0], bad)
    with pytest.raises(ValueError, match="not finite"):
        osc.accelerations(0.0, [bad], [0.0])


def test_simulate_rejects_unknown_method_and_option(osc):
    with pytest.raises(ValueError, match="unknown method \"rk45\""):
        osc.simulate([1.0], [0.0], 1.0, method="rk45")
    with pytest.raises(TypeError):
        osc.simulate([1.0], [0.0], 1.0, tolerance=1e-6)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="method must be a string"):
        osc.simulate([1.0], [0.0], 1.0, method=4)  # type: ignore[arg-type]


@pytest.mark.parametrize("rtol, atol", [(0.0, 1e-9), (1e-6, 0.0), (-1e-6, 1e-9), (1e-6, math.nan)])
def test_simulate_rejects_tolerances_not_positive(osc, rtol, atol):
    with pytest.raises(ValueError):
        osc.simulate([1.0], [0.0], 1.0, rtol=rtol, atol=atol)


def test_simulate_rejects_dt_pointing_away(osc):
    with pytest.raises(ValueError, match="before t0"):
        osc.simulate([1.0], [0.0], -1.0, dt=0.01, method="rk4")
    with pytest.raises(ValueError, match="after t0"):
        osc.simulate([1.0], [0.0], 1.0, dt=-0.01, method="rk4")
    with pytest.raises(ValueError, match="dt = 0"):
        osc.simulate([1.0], [0.0], 1.0, dt=0.0, method="rk4")
    with pytest.raises(ValueError, match="empty"):
        osc.simulate([1.0], [0.0], 0.0)
    # A negative dt integrates backwards: x(−1) = cos 2.
    sol = osc.simulate([1.0], [0.0], -1.0, dt=-1e-3, method="rk4")
    assert sol.t[-1] == -1.0
    assert abs(sol.q[-1, 0] - math.cos(2.0)) < 1e-10


def test_simulate_rejects_fixed_step_method_without_dt(osc):
    with pytest.raises(ValueError, match="takes fixed steps: pass dt"):
        osc.simulate([1.0], [0.0], 1.0, method="yoshida4")


def test_simulate_rejects_bad_t_eval_and_max_steps(osc):
    with pytest.raises(ValueError, match="outside the span"):
        osc.simulate([1.0], [0.0], 1.0, t_eval=[0.5, 2.0])
    with pytest.raises(ValueError, match="direction"):
        osc.simulate([1.0], [0.0], 1.0, t_eval=[0.5, 0.2])
    with pytest.raises(ValueError, match="max_steps"):
        osc.simulate([1.0], [0.0], 1.0, max_steps=0)


def test_simulate_rejects_method_that_cannot_serve_the_system():
    model = lg.scenes.double_pendulum(1.0, 1.0, 1.0, 1.0, 9.81)
    with pytest.raises(ValueError, match="not separable"):
        model.simulate([1.0, 0.5], [0.0, 0.0], 1.0, method="verlet", dt=0.01)


def test_model_rejects_unknown_parameter_names(osc):
    x, = lg.coordinates("x")
    with pytest.raises(ValueError, match="unknown parameter 'kk'"):
        lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, parameters={"kk": 1.0})
    with pytest.raises(ValueError, match="unknown parameter 'g'"):
        osc.with_parameters(g=1.0)
    with pytest.raises(ValueError, match="unknown parameter 'z'"):
        lg.scenes.simple_pendulum(1.0, 1.0, 9.81).with_parameters(z=1.0)
    k, = lg.parameters("k")
    with pytest.raises(ValueError, match="parameter 'k' in the potential has no value"):
        lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=k * x)
    with pytest.raises(ValueError, match="not finite"):
        osc.with_parameters(k=math.nan)
    with pytest.raises(TypeError):
        osc.with_parameters(k="4")  # type: ignore[arg-type]


def test_model_rejects_free_symbols_that_are_not_coordinates():
    x, y = lg.coordinates("x y")
    with pytest.raises(ValueError, match="y in the potential is not a coordinate"):
        lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=y)
    with pytest.raises(ValueError, match="y.d in the kinetic energy is not a coordinate"):
        lg.Model(coordinates=[x], kinetic=0.5 * y.d**2)
    with pytest.raises(ValueError, match="the potential depends on the velocity x.d"):
        lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=x.d * x)
    with pytest.raises(TypeError, match="not a coordinate"):
        lg.Model(coordinates=[x.d], kinetic=0.5 * x.d**2)  # type: ignore[list-item]
    with pytest.raises(ValueError, match="forces has 2 entries"):
        lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, forces=[1.0, 2.0])
    with pytest.raises(ValueError, match="needs kinetic"):
        lg.Model(coordinates=[x], potential=x)
    with pytest.raises(TypeError, match="expected an expression or a real number"):
        x + "1"  # type: ignore[operator]
    with pytest.raises(ValueError, match="not finite"):
        x + math.inf


def test_scenes_reject_bad_arguments():
    with pytest.raises(ValueError, match="one length per mass"):
        lg.scenes.n_pendulum([1.0, 1.0], [1.0], 9.81)
    with pytest.raises(ValueError, match="not finite"):
        lg.scenes.kepler(1.0, math.nan)


def test_equilibrium_rejects_bad_loads(osc):
    x, y = lg.coordinates("x y")
    with pytest.raises(ValueError, match="loads has 2 entries"):
        osc.equilibrium([0.0], loads=[1.0, 2.0])
    with pytest.raises(ValueError, match="not a coordinate"):
        osc.equilibrium([0.0], loads=[y])
    with pytest.raises(ValueError, match="q_guess"):
        osc.equilibrium([0.0, 1.0])


# -- failures of the mathematics -------------------------------------------------------------

def test_singular_mass_matrix_error():
    x1, x2 = lg.coordinates("x1 x2")
    model = lg.Model(coordinates=[x1, x2], kinetic=0.5 * (x1.d + x2.d) ** 2)
    with pytest.raises(lg.SingularMassMatrixError, match="t = 0") as e:
        model.simulate([0.0, 0.0], [1.0, 0.0], 1.0)
    assert "check that every coordinate carries inertia" in str(e.value)
    assert isinstance(e.value, lg.LagrangianError)


def test_step_size_error_at_a_blow_up():
    # ẍ = x² blows up in finite time.
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=-(x**3) / 3)
    with pytest.raises(lg.StepSizeError, match=r"at t = 2\.97.*radau5"):
        model.simulate([1.0], [0.0], 10.0)


def test_too_many_steps_error(osc):
    with pytest.raises(lg.TooManyStepsError, match="raise max_steps") as e:
        osc.simulate([1.0], [0.0], 10.0, max_steps=5)
    assert isinstance(e.value, lg.StepSizeError)


def test_fixed_dt_takes_the_steps_asked_for(osc):
    # Issue 40: 3·10⁶ rk4 steps were refused with "1000000 steps taken by t = 0"; a fixed dt
    # has no step budget unless max_steps is given, and the refusal says no step was taken.
    sol = osc.simulate(q0=[1.0], qd0=[0.0], t_end=300.0, method="rk4", dt=1e-4)
    assert sol.t[-1] == 300.0
    assert sol.stats["accepted_steps"] == 3_000_000
    with pytest.raises(lg.TooManyStepsError, match="no step was taken") as e:
        osc.simulate([1.0], [0.0], 300.0, method="rk4", dt=1e-4, max_steps=10**6)
    assert "steps taken" not in str(e.value)


def test_stiffness_error():
    stiff = lg.scenes.damped_oscillator(1.0, 1e6, 1e6)
    with pytest.raises(lg.StiffnessError, match="at t = .*radau5"):
        stiff.simulate([1.0], [0.0], 1.0, method="dopri5", rtol=1e-3, atol=1e-6)
    # The suggested method copes.
    sol = stiff.simulate([1.0], [0.0], 1.0, method="radau5", rtol=1e-6, atol=1e-9)
    assert abs(sol.q[-1, 0] - math.exp(-1.0)) < 1e-5


def test_convergence_error():
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=x)
    with pytest.raises(lg.ConvergenceError, match="another initial guess.*t = 0"):
        model.equilibrium([0.0])


def test_non_finite_error():
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=lg.sqrt(x))
    with pytest.raises(lg.NonFiniteError, match="at t = 0.16"):
        model.simulate([0.5], [-3.0], 10.0, method="rk4", dt=0.01)


@pytest.mark.parametrize("method, dt", [("rk4", 0.01), ("midpoint", 0.01), ("gauss4", 0.01),
                                        ("gauss6", 0.01), ("radau5", 0.01), ("radau5", None)])
def test_non_finite_is_named_for_every_method(method, dt):
    # U = √x is NaN beyond x = 0, which the motion reaches at t* = 0.16254...: an implicit
    # method meets the NaN inside the Newton iteration of a stage, and reports it as the
    # explicit methods do — NonFiniteError naming the quantity and a time within a step of t* —
    # not as a ConvergenceError with a residual of NaN.
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=lg.sqrt(x))
    t_star = 0.16254048729668633
    with pytest.raises(lg.NonFiniteError) as info:
        model.simulate([0.5], [-3.0], 1.0, method=method, dt=dt, rtol=1e-8, atol=1e-10)
    message = str(info.value)
    assert "residual" not in message
    match = re.match(r"non-finite (\w[\w ]*) at t = ([0-9.e-]+):", message)
    assert match, message
    assert match.group(1) in ("state", "accelerations", "forces", "momenta", "stage positions",
                              "stage state", "Jacobian"), message
    assert abs(float(match.group(2)) - t_star) <= 0.01, message
    assert info.value.t is not None and abs(info.value.t - t_star) <= 0.01
    # The model still works.
    assert model.energy(0.0, [0.5], [-3.0]) == pytest.approx(4.5 + math.sqrt(0.5), rel=1e-15)


def test_keyboard_interrupt_stops_simulate():
    # A helper thread sends SIGINT while simulate runs: it can only do so because simulate
    # released the GIL, and the run must end with KeyboardInterrupt instead of finishing. The
    # test installs Python's SIGINT handler itself (a parent that ignores SIGINT — nohup, a
    # background job — leaves it ignored), and the run is bounded (4e7 steps, seconds): a signal
    # that never arrives fails the test instead of hanging it.
    model = lg.scenes.double_pendulum(1.0, 1.0, 1.0, 1.0, 9.81)
    sent = threading.Event()

    def interrupt():
        time.sleep(0.3)
        sent.set()
        os.kill(os.getpid(), signal.SIGINT)

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        threading.Thread(target=interrupt, daemon=True).start()
        with pytest.raises(KeyboardInterrupt):
            model.simulate([1.0, 0.5], [0.0, 0.0], 4e4, method="rk4", dt=1e-3, t_eval=[4e4],
                           max_steps=10**8)
        assert sent.is_set()
    finally:
        signal.signal(signal.SIGINT, previous)


def test_errors_leave_the_model_usable(osc):
    with pytest.raises(ValueError):
        osc.simulate([1.0], [0.0], 1.0, rtol=-1.0)
    sol = osc.simulate([1.0], [0.0], 1.0, rtol=1e-10, atol=1e-12)
    assert abs(sol.q[-1, 0] - math.cos(2.0)) < 1e-8
    assert np.all(np.isfinite(sol.energy))


def test_implicit_newton_failure_is_a_convergence_error():
    # Gauss–Legendre 4 with a step far too large for the blow-up of ẍ = x².
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=-(x**3) / 3)
    with pytest.raises(lg.ConvergenceError, match="at t = .*smaller dt"):
        model.simulate([1.0], [0.0], 10.0, method="gauss4", dt=0.5)
