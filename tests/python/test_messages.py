"""Messages and results a first user reads: None is not a number, the reason of the automatic
choice, what the structure keys mean, NumPy's functions on expressions, NumPy arrays wherever a
state is taken, and no evaluation that hands back an infinity or a NaN."""

from __future__ import annotations

import math
import re
from typing import Any, Callable, Dict

import numpy as np
import pytest

import lagrangian as lg


@pytest.fixture
def osc() -> lg.Model:
    x, = lg.coordinates("x")
    return lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2)


# -- None is not a number ---------------------------------------------------------------------

@pytest.mark.parametrize("q0, says", [
    (None, "q0 is None, which is not a number"),
    ([None, 1.0], "q0[0] is None, which is not a number"),
    ([1.0, None], "q0[1] is None, which is not a number"),
    ([1.0, math.nan], "q0[1] = nan is not finite"),
])
def test_none_is_named_as_none(q0: Any, says: str) -> None:
    x, y = lg.coordinates("x y")
    model = lg.Model(coordinates=[x, y], kinetic=0.5 * (x.d**2 + y.d**2))
    with pytest.raises(ValueError, match=re.escape(says)):
        model.simulate(q0, [0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match=re.escape(says.replace("q0", "q"))):
        model.energy(0.0, q0, [0.0, 0.0])
    if q0 is not None:
        # The same entry in the first of two states given as rows.
        row = re.escape(says.replace("q0[", "q[0, "))
        with pytest.raises(ValueError, match=row):
            model.energy(0.0, [q0, [0.0, 0.0]], [[0.0, 0.0]] * 2)


# -- the reason of the automatic choice -------------------------------------------------------

def test_auto_reason_is_true_with_default_and_given_tolerances(osc: lg.Model) -> None:
    # The default tolerances: DOP853, the Taylor method's estimated cost in the reason. Tight
    # ones: the Taylor method (its expansion of this oscillator is cheap), with its estimate.
    for kwargs, method in (({}, "dop853"), ({"rtol": 1e-10, "atol": 1e-12}, "taylor")):
        sol = osc.simulate([1.0], [0.0], 1.0, **kwargs)
        choice = sol.stats["choice"]
        assert sol.stats["method"] == method
        assert "tolerances given" not in choice
        assert choice.startswith("no fixed dt")
        ratio = float(re.search(r"estimated at ([0-9.]+) times", choice).group(1))
        assert (ratio < 1.0) == (method == "taylor")


def test_simulate_docstring_describes_what_auto_does() -> None:
    doc = lg.Model.simulate.__doc__ or ""
    method = doc[doc.index("method : str"):doc.index("dt : float")]
    for word in ("blanes_moan4", "gauss4", "radau5", "taylor", "dop853", "stiff",
                 'stats["choice"]'):
        assert word in method, word
    # What it says happens: gauss4 for a conservative non-separable system with a fixed dt,
    # blanes_moan4 for a separable one, dop853 given tolerances.
    pend = lg.scenes.double_pendulum(1.0, 1.0, 1.0, 1.0, 9.81)
    assert pend.simulate([1.0, 0.5], [0.0, 0.0], 0.1, dt=0.01).stats["method"] == "gauss4"
    assert pend.simulate([1.0, 0.5], [0.0, 0.0], 0.1).stats["method"] == "dop853"
    spring = lg.scenes.damped_oscillator(1.0, 1.0, 0.0)
    assert spring.simulate([1.0], [0.0], 0.1, dt=0.01).stats["method"] == "blanes_moan4"


# -- structure: forcing is reported, each key documented ---------------------------------------

def test_structure_reports_a_drive_separately() -> None:
    x, = lg.coordinates("x")
    base: Dict[str, Any] = dict(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2)
    driven = lg.Model(**base, forces=[lg.cos(2.0 * lg.t)]).structure
    assert driven["time_dependent"] is False  # L does not read t …
    assert driven["driven"] is True and driven["forced"] is True  # … but the forcing does
    assert driven["conservative"] is False
    pushed = lg.Model(**base, forces=[-0.1 * x.d]).structure
    assert pushed["forced"] is True and pushed["driven"] is False
    swept = lg.Model(**base, dissipation=0.5 * (1 + lg.t) * x.d**2).structure
    assert swept["driven"] is True and swept["time_dependent"] is False
    moving = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=lg.sin(lg.t) * x).structure
    assert moving["time_dependent"] is True and moving["driven"] is True
    free = lg.Model(**base).structure
    assert not free["driven"] and not free["forced"] and free["conservative"]
    # Scenes: the seed's harmonically forced two masses, the driven pendulum, a free one.
    assert lg.scenes.forced_two_mass(1.0, 0.5, 10.0, 5.0, 1.0, 0.5, 2.0).structure["driven"]
    assert lg.scenes.double_pendulum(1.0, 1.0, 1.0, 1.0, 9.81).structure["driven"] is False
    doc = lg.Model.structure.__doc__ or ""
    for key in free:
        assert f"``{key}``" in doc, key


# -- NumPy on expressions ---------------------------------------------------------------------

@pytest.mark.parametrize("ufunc, function", [
    (np.sin, lg.sin), (np.cos, lg.cos), (np.tan, lg.tan), (np.exp, lg.exp), (np.log, lg.log),
    (np.sqrt, lg.sqrt), (np.sinh, lg.sinh), (np.cosh, lg.cosh), (np.tanh, lg.tanh),
    (np.abs, lg.abs), (np.fabs, lg.abs),
])
def test_numpy_functions_dispatch_to_expressions(ufunc: Any, function: Callable[..., Any]) -> None:
    x, = lg.coordinates("x")
    assert ufunc(x) == function(x)
    assert ufunc(2.0 * x) == function(2.0 * x)


def test_numpy_operators_and_binary_functions_on_expressions() -> None:
    x, y = lg.coordinates("x y")
    assert np.arctan2(y, x) == lg.atan2(y, x)
    assert np.arctan2(np.float64(1.0), x) == lg.atan2(1.0, x)
    assert np.add(x, np.float64(2.0)) == x + 2.0
    assert np.multiply(np.int64(3), x) == 3 * x
    assert np.power(x, 2) == x**2 and np.square(x) == x**2
    assert np.negative(x) == -x and np.divide(1.0, x) == 1.0 / x
    assert np.float64(2.0) * x == 2.0 * x and np.array(2.0) * x == 2.0 * x
    # Comparing with a NumPy number is comparing with a number: never equal, never an error.
    assert (np.float64(1.0) == x) is False and (x == np.float64(1.0)) is False
    assert (np.float64(1.0) != x) is True and x not in [np.float64(2.0)]
    assert np.equal(x, x) is True and np.not_equal(x, 2 * x) is True
    # The model built with NumPy's functions is the one built with lagrangian's.
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=-np.cos(x))
    assert model.accelerations(0.0, [0.3], [0.0])[0] == pytest.approx(-math.sin(0.3), rel=1e-15)


def test_unsupported_numpy_use_says_what_to_do() -> None:
    x, = lg.coordinates("x")
    with pytest.raises(TypeError, match=r"numpy.floor is not defined for expressions.*lg.cos"):
        np.floor(x)
    with pytest.raises(TypeError, match=r"numpy.arcsin is not defined"):
        np.arcsin(x)
    with pytest.raises(TypeError, match="real numbers only"):
        np.array([1.0, 2.0]) * x
    with pytest.raises(TypeError, match="out"):
        np.cos(x, out=np.zeros(1))
    with pytest.raises(TypeError, match="numpy.add.outer"):
        np.add.outer(x, x)


# -- NumPy arrays are states everywhere -------------------------------------------------------

def test_work_precision_takes_numpy_arrays(osc: lg.Model) -> None:
    exact = ([math.cos(1.0)], [-math.sin(1.0)])
    kwargs: Dict[str, Any] = dict(methods=["rk4", "dop853"], tolerances=[1e-6], repeats=1)
    listed = lg.work_precision(osc, [1.0], [0.0], 1.0, dts=[0.1], reference=exact, **kwargs)
    arrays = lg.work_precision(osc, np.array([1.0]), np.array([0.0]), np.float64(1.0),
                               dts=np.array([0.1]), reference=tuple(map(np.array, exact)),
                               **kwargs)
    assert [r.error for r in arrays] == [r.error for r in listed]
    assert all(r.failure is None for r in arrays)


# -- no evaluation returns a non-finite value ------------------------------------------------

EVALUATIONS = ["energy", "momenta", "lagrangian", "mass_matrix", "accelerations"]


@pytest.mark.parametrize("name", EVALUATIONS)
@pytest.mark.parametrize("q, qd", [([1.0], [1e200]), ([1e200], [1.0]), ([1e155], [1e155]),
                                   ([-1e300], [-1e300])])
def test_extreme_finite_states_give_finite_values_or_non_finite_error(
        name: str, q: Any, qd: Any) -> None:
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * (1 + x**2) * x.d**2, potential=0.25 * x**4)
    for args in ((q, qd), ([q, [0.5]], [qd, [0.5]]), (np.array(q), np.array(qd))):
        try:
            value = getattr(model, name)(0.0, *args)
        except lg.LagrangianError as e:
            assert "non-finite" in str(e) and "t = 0" in str(e), e
        else:
            assert np.all(np.isfinite(value)), (name, args, value)
    # The model still works.
    assert model.energy(0.0, [1.0], [1.0]) == pytest.approx(1.25, rel=1e-15)


def test_energy_that_overflows_is_a_non_finite_error_naming_it(osc: lg.Model) -> None:
    # ½ q̇² overflows at q̇ = 1e200: the energy is named, not returned as inf.
    with pytest.raises(lg.NonFiniteError, match="non-finite energy at t = 2"):
        osc.energy(2.0, [0.0], [1e200])
    with pytest.raises(lg.NonFiniteError, match="non-finite Lagrangian"):
        osc.lagrangian(0.0, [[0.0], [1e200]], [[1e200], [0.0]])
    assert osc.momenta(0.0, [0.0], [1e200])[0] == 1e200


def test_linearize_and_positions_at_extreme_states() -> None:
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.25 * x**4)
    # K = 3 x² overflows at x = 1e160.
    with pytest.raises(lg.LagrangianError, match="non-finite"):
        model.linearize([1e160])
    lin = model.linearize([1e100], [1e300])
    assert all(np.all(np.isfinite(m)) for m in (lin.M, lin.C, lin.K, lin.A))
    bob = lg.Model(coordinates=[x], positions=[(x**3, 0.0 * x)], masses=[1.0])
    with pytest.raises(lg.NonFiniteError, match="non-finite positions at t = 1.5"):
        bob.positions([0.0, 1.5], [[1.0], [1e200]])
    assert np.all(np.isfinite(bob.positions(0.0, [1e100])))
