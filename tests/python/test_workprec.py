"""Work–precision rows: errors against exact solutions fall as tolerances and steps tighten, at the
methods' orders; references, failures and the equal-error comparison."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import lagrangian as lg
from lagrangian._cases import kepler_exact, kepler_periapsis, oscillator_exact, report_scenes
from lagrangian._measure import Reference, state_error
from lagrangian._report import _time_to_reach, equal_error_ratios
from lagrangian._workprec import Row, WorkPrecision


def damped() -> lg.Model:
    return lg.scenes.damped_oscillator(m=1.0, k=4.0, c=0.4)


EXACT = oscillator_exact(1.0, 4.0, 0.4, 1.0, 0.0)


def test_errors_fall_as_tolerances_tighten_adaptive() -> None:
    wp = lg.work_precision(damped(), [1.0], [0.0], 10.0, methods=["dopri5", "dop853", "radau5"],
                           tolerances=[1e-4, 1e-6, 1e-8, 1e-10], reference=EXACT, repeats=1)
    assert wp.reference.kind == "exact"
    for method in wp.methods:
        errors = [r.error for r in wp.by_method(method)]
        assert all(e is not None for e in errors)
        # Each hundredfold tightening buys at least a tenfold smaller error…
        assert all(b < a / 10 for a, b in zip(errors, errors[1:])), (method, errors)
        # …and the error stays near the tolerance (tolerance proportionality).
        assert errors[-1] < 1e-8, (method, errors)
        steps = [r.steps for r in wp.by_method(method)]
        assert steps == sorted(steps)
        # A dissipative system conserves no energy: no energy error is reported.
        assert all(r.energy_error is None for r in wp.by_method(method))


def test_fixed_step_errors_fall_at_the_methods_order() -> None:
    osc = lg.scenes.damped_oscillator(m=1.0, k=1.0, c=0.0)
    exact = oscillator_exact(1.0, 1.0, 0.0, 1.0, 0.0)
    dts = [0.1, 0.05, 0.025]
    wp = lg.work_precision(osc, [1.0], [0.0], 5.0, methods=["stormer_verlet", "rk4", "gauss6"],
                           dts=dts, reference=exact, repeats=1)
    for method, order in (("stormer_verlet", 2), ("rk4", 4), ("gauss6", 6)):
        errors = [r.error for r in wp.by_method(method)]
        observed = [math.log2(a / b) for a, b in zip(errors, errors[1:])]  # type: ignore[operator]
        assert all(abs(p - order) < 0.3 for p in observed), (method, observed)
        # The oscillator conserves energy: the symplectic methods' error stays bounded and
        # small, and is reported for every row.
        assert all(r.energy_error is not None for r in wp.by_method(method))
    assert wp.by_method("gauss6")[0].energy_error < 1e-12  # type: ignore[operator]


def test_computed_reference_matches_exact_kepler() -> None:
    # Without an exact solution, DOP853 at 1e-13 and Radau IIA at 1e-12 are the references;
    # their agreement is reported and both are close to Kepler's exact orbit.
    q0, qd0 = kepler_periapsis(1.0, 1.0, 0.6)
    wp = lg.work_precision(lg.scenes.kepler(m=1.0, mu=1.0), q0, qd0, 2 * math.pi,
                           methods=["dop853", "gauss4"], tolerances=[1e-8], dts=[0.01],
                           repeats=1)
    ref = wp.reference
    assert ref.kind == "computed" and ref.agreement is not None
    assert ref.agreement < 1e-9
    q, qd = kepler_exact(1.0, 1.0, 0.6)(2 * math.pi)
    assert state_error(ref.q, ref.qd, q, qd) < 1e-10
    # DOP853 rows are measured against the Radau run, never against themselves.
    assert ref.method == "dop853" and ref.alternate is not None
    assert ref.against("dop853")[0] is ref.alternate[1]
    assert ref.against("gauss4")[0] is ref.q


def test_unsupported_method_is_one_failed_row_double_pendulum() -> None:
    dp = lg.scenes.double_pendulum(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81)
    wp = lg.work_precision(dp, [1.0, 0.5], [0.0, 0.0], 1.0, methods=["yoshida4", "rk4"],
                           dts=[0.01, 0.005], repeats=1)
    rows = wp.by_method("yoshida4")
    assert len(rows) == 1 and rows[0].failure is not None
    assert "not separable" in rows[0].failure and rows[0].error is None
    assert len(wp.by_method("rk4")) == 2
    assert "failed" in wp.table()


def test_table_json_and_plot_carry_the_rows() -> None:
    pytest.importorskip("matplotlib")
    wp = lg.work_precision(damped(), [1.0], [0.0], 2.0, methods=["dop853", "rk4"],
                           tolerances=[1e-5, 1e-8], dts=[0.01], reference=EXACT, repeats=2,
                           title="damped")
    data = json.loads(wp.to_json())
    assert [r["method"] for r in data["rows"]] == ["dop853", "dop853", "rk4"]
    assert data["rows"][0]["error"] == wp.rows[0].error
    assert wp.table().count("\n") == 2 + len(wp.rows) - 1
    fig = wp.plot()
    lines = fig.axes[0].get_lines()
    dop = next(line for line in lines if line.get_label() == "dop853")
    assert list(dop.get_ydata()) == [r.error for r in wp.by_method("dop853")]


def test_bad_input_is_refused() -> None:
    m = damped()
    with pytest.raises(ValueError, match="fixed steps"):
        lg.work_precision(m, [1.0], [0.0], 1.0, methods=["rk4"])
    with pytest.raises(ValueError, match="> 0"):
        lg.work_precision(m, [1.0], [0.0], 1.0, methods=["dop853"], tolerances=[-1e-6])
    with pytest.raises(ValueError, match="unknown method"):
        lg.work_precision(m, [1.0], [0.0], 1.0, methods=["euler"])
    with pytest.raises(ValueError, match="auto"):
        lg.work_precision(m, [1.0], [0.0], 1.0, methods=["auto"])
    with pytest.raises(ValueError, match="coordinates"):
        lg.work_precision(m, [1.0, 2.0], [0.0], 1.0, methods=["dop853"])
    with pytest.raises(ValueError, match="reference"):
        lg.work_precision(m, [1.0], [0.0], 1.0, methods=["dop853"], reference=3.0)  # type: ignore[arg-type]


def _rows(method: str, points: list) -> list:
    return [Row(method, None, None, e, None, t, 1, 1) for t, e in points]


def test_equal_error_ratio_interpolates_along_the_front() -> None:
    ref = Reference(np.zeros(1), np.zeros(1), "exact", "")
    ours = WorkPrecision(_rows("a", [(1e-3, 1e-4), (1e-2, 1e-8)]), ref)
    theirs = WorkPrecision(_rows("b", [(1e-1, 1e-4), (1.0, 1e-6), (2.0, 1e-3)]), ref)
    # Ours reaches 1e-6 halfway (in logs) between 1 ms and 10 ms.
    assert _time_to_reach(ours.rows, 1e-6) == pytest.approx(10**-2.5)
    # A slower run with a worse error is not on the front.
    assert _time_to_reach(theirs.rows, 1e-3) == pytest.approx(0.1)
    ratios = equal_error_ratios(ours, theirs, levels=[1e-3, 1e-6, 1e-9])
    assert [r["error"] for r in ratios] == [1e-3, 1e-6]  # nobody reaches 1e-9 on both sides
    assert ratios[1]["ratio"] == pytest.approx(10**-2.5 / 1.0)


def test_report_scenes_exact_solutions_solve_their_equations() -> None:
    # The exact solutions the report measures against satisfy the model's equations of motion:
    # a central difference of q̇(t) equals the model's q̈.
    for scene in report_scenes():
        if scene.exact is None:
            continue
        model = scene.model()
        q0, qd0 = scene.exact(0.0)
        np.testing.assert_allclose(q0, scene.q0, atol=1e-14)
        np.testing.assert_allclose(qd0, scene.qd0, atol=1e-14)
        for t in (0.3, 1.7):
            q, qd = scene.exact(t)
            h = 1e-5
            accel = (scene.exact(t + h)[1] - scene.exact(t - h)[1]) / (2 * h)
            np.testing.assert_allclose(accel, model.accelerations(t, q, qd), rtol=1e-7, atol=1e-7)


def _small_work_precision() -> WorkPrecision:
    osc = lg.scenes.damped_oscillator(m=1.0, k=1.0, c=0.0)
    return lg.work_precision(osc, [1.0], [0.0], 1.0, methods=["dop853", "rk4"],
                             tolerances=[1e-6, 1e-9], dts=[0.1, 0.01], repeats=1,
                             reference=([math.cos(1.0)], [-math.sin(1.0)]), title="osc")


def test_work_precision_len_iteration_and_indexing_are_its_rows() -> None:
    wp = _small_work_precision()
    assert len(wp) == len(wp.rows) == 4
    assert list(wp) == wp.rows
    assert [r.setting for r in wp] == ["tol=1e-06", "tol=1e-09", "dt=0.1", "dt=0.01"]
    assert wp[0] is wp.rows[0] and wp[-1] is wp.rows[-1]
    assert wp[2].method == "rk4" and wp[2].dt == 0.1
    with pytest.raises(IndexError):
        wp[4]
    assert wp.rows[1] in wp and list(reversed(wp)) == wp.rows[::-1]


def test_work_precision_slice_keeps_reference_and_title() -> None:
    wp = _small_work_precision()
    part = wp[2:]
    assert isinstance(part, WorkPrecision)
    assert part.rows == wp.rows[2:] and part.reference is wp.reference and part.title == "osc"
    assert part.methods == ["rk4"] and len(wp[::2]) == 2 and len(wp[5:]) == 0
    assert repr(part) == "WorkPrecision('osc', rows=2, methods=['rk4'])"
    assert repr(wp) == "WorkPrecision('osc', rows=4, methods=['dop853', 'rk4'])"


def test_options_have_one_message_from_simulate_and_work_precision() -> None:
    # The options are validated once, in Rust: the same value gets the same message wherever it
    # is given.
    m = damped()
    with pytest.raises(ValueError) as direct:
        m.simulate([1.0], [0.0], 1.0, method="dop853", rtol=-1e-6, atol=-1e-6)
    with pytest.raises(ValueError) as planned:
        lg.work_precision(m, [1.0], [0.0], 1.0, methods=["dop853"], tolerances=[-1e-6])
    assert str(direct.value) == str(planned.value) == (
        "invalid rtol: rtol = -0.000001: tolerances must be finite and > 0")
    with pytest.raises(ValueError) as direct:
        m.simulate([1.0], [0.0], 1.0, method="rk4", dt=0.0)
    with pytest.raises(ValueError) as planned:
        lg.work_precision(m, [1.0], [0.0], 1.0, methods=["rk4"], dts=[0.0])
    assert str(direct.value) == str(planned.value)
    with pytest.raises(ValueError, match="max_steps = 0: at least one step is needed"):
        m.simulate([1.0], [0.0], 1.0, max_steps=0)
    with pytest.raises(ValueError, match="max_steps = -3: a count cannot be negative"):
        m.simulate([1.0], [0.0], 1.0, max_steps=-3)
    with pytest.raises(ValueError, match="k ≥ 1"):
        m.simulate([1.0], [0.0], 1.0, output_every=0)
    with pytest.raises(TypeError, match="max_steps must be an integer"):
        m.simulate([1.0], [0.0], 1.0, max_steps=2.5)  # type: ignore[arg-type]
