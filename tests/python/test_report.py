"""`lagrangian report --quick` end to end: the folder it writes, the equal-error comparison with
SciPy, the long-run energy table, and the expected outcome of every stability case."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any, Dict

import pytest

pytest.importorskip("matplotlib")


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> Dict[str, Any]:
    out = tmp_path_factory.mktemp("report")
    env = dict(os.environ, MPLBACKEND="Agg")
    done = subprocess.run(
        [sys.executable, "-m", "lagrangian", "report", "--quick", "--out", str(out)],
        capture_output=True, text=True, env=env, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "report written" in done.stdout
    data: Dict[str, Any] = json.loads((out / "report.json").read_text())
    data["_folder"] = str(out)
    return data


SCENES = ["double_pendulum", "forced_two_mass", "ball_in_sphere", "rolling_cylinder",
          "damped_oscillator", "kepler", "elastic_pendulum", "n_pendulum", "cartesian_pendulum"]


def test_folder_has_tables_plots_and_json(report: Dict[str, Any]) -> None:
    folder = Path(report["_folder"])
    text = (folder / "README.md").read_text()
    for key in SCENES:
        png = folder / f"{key}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", key
        assert f"({key}.png)" in text
    assert "## Stability matrix" in text and (folder / "stability.md").exists()
    assert [s["key"] for s in report["scenes"]] == SCENES
    assert report["quick"] is True


def test_errors_fall_as_tolerances_tighten_every_scene(report: Dict[str, Any]) -> None:
    for scene in report["scenes"]:
        rows = scene["work_precision"]["rows"]
        floor = scene["work_precision"]["reference"]["agreement"] or 0.0
        for method in ("dop853", "radau5"):
            errors = [r["error"] for r in rows if r["method"] == method]
            assert len(errors) == 3 and all(e is not None for e in errors), (scene["key"], method)
            # Tightening 1e-4 → 1e-7 → 1e-10 lowers the error each time, down to the reference's
            # own accuracy.
            for a, b in zip(errors, errors[1:]):
                assert b < a or b < 10 * floor + 1e-13, (scene["key"], method, errors)
            assert errors[-1] < 1e-7, (scene["key"], method, errors)


def test_exact_references_where_known(report: Dict[str, Any]) -> None:
    kinds = {s["key"]: s["work_precision"]["reference"]["kind"] for s in report["scenes"]}
    for key in ("forced_two_mass", "rolling_cylinder", "damped_oscillator", "kepler"):
        assert kinds[key] == "exact"
    for key in ("double_pendulum", "ball_in_sphere", "elastic_pendulum", "n_pendulum",
                "cartesian_pendulum"):
        assert kinds[key] == "computed"
        agreement = next(s for s in report["scenes"] if s["key"] == key)[
            "work_precision"]["reference"]["agreement"]
        assert agreement is not None and agreement < 1e-9, (key, agreement)


def test_peers_compared_at_equal_error(report: Dict[str, Any]) -> None:
    pytest.importorskip("scipy")
    for key in ("double_pendulum", "forced_two_mass"):
        scene = next(s for s in report["scenes"] if s["key"] == key)
        methods = {r["method"] for r in scene["peers"]["rows"]}
        assert methods == {"scipy RK45", "scipy DOP853", "scipy Radau", "scipy LSODA"}
        ratios = scene["equal_error"]
        assert ratios, key
        for r in ratios:
            assert r["ratio"] == pytest.approx(r["our_seconds"] / r["their_seconds"])


def test_long_run_energy_of_symplectic_methods_stays_bounded(report: Dict[str, Any]) -> None:
    for scene in report["scenes"]:
        if "long_run" not in scene:
            continue
        runs = {r["method"]: r for r in scene["long_run"]["runs"]}
        # Every conservative scene has a symplectic method whose energy error after 100× more
        # steps stays within 10× (the target, here at --quick length) — or stays at
        # round-off (the rolling cylinder's energy terms grow as it accelerates, and so does the
        # round-off in their difference).
        symplectic = [m for m in ("gauss4", "gauss6", "blanes_moan4", "yoshida4", "yoshida6",
                                  "yoshida8", "stormer_verlet", "midpoint") if m in runs]
        assert any(runs[m]["growth"] <= 10 or runs[m]["long"] < 1e-10 for m in symplectic), (
            scene["key"], runs)
    keys = {s["key"] for s in report["scenes"] if "long_run" in s}
    assert keys == {"double_pendulum", "ball_in_sphere", "rolling_cylinder", "kepler",
                    "elastic_pendulum", "n_pendulum", "cartesian_pendulum"}


def _outcomes(report: Dict[str, Any]) -> Dict[str, Dict[str, Dict[str, Any]]]:
    table: Dict[str, Dict[str, Dict[str, Any]]] = {}
    for o in report["stability"]["outcomes"]:
        table.setdefault(o["case"], {})[o["method"]] = o
    return table


def test_stability_matrix_has_no_wrong_answer(report: Dict[str, Any]) -> None:
    outcomes = [o for o in report["stability"]["outcomes"]]
    assert outcomes
    assert [o for o in outcomes if o["status"] == "WRONG"] == []
    assert {o["status"] for o in outcomes} <= {"solved", "error", "n/a", "coarse", "chaotic"}


def test_stability_expected_outcomes(report: Dict[str, Any]) -> None:
    m = _outcomes(report)
    # A stiff spring: the fixed-step explicit RK4 is refused before it starts (the step is
    # beyond its stability limit), the implicit methods solve it.
    rk4 = m["spring_k1e+09"]["rk4"]
    assert rk4["status"] == "error" and "stability limit" in rk4["detail"]
    for method in ("radau5", "gauss4", "gauss6"):
        assert m["spring_k1e+09"][method]["status"] == "solved", method
    # Heavy damping on a stiff spring: every explicit method stops with a typed stiffness error;
    # Radau IIA solves every stiffness.
    for k in ("1e+06", "1e+09"):
        for method in ("rk4", "dopri5", "dop853"):
            o = m[f"damped_k{k}"][method]
            assert o["status"] == "error" and o["detail"].startswith("StiffnessError"), (k, o)
    for case in ("spring_k1e+03", "spring_k1e+06", "spring_k1e+09", "damped_k1e+03",
                 "damped_k1e+06", "damped_k1e+09", "separatrix", "ball_tight", "light_bob",
                 "kepler_e099"):
        assert m[case]["radau5"]["status"] == "solved", case
        assert m[case]["dop853"]["status"] in ("solved", "error"), case
    # Extreme scales: the scaled systems give the scaled answer with every applicable method.
    for case, row in m.items():
        if case.startswith("scale_"):
            for method, o in row.items():
                assert o["status"] in ("solved", "n/a"), (case, method, o)
                if o["status"] == "solved":
                    assert o["error"] < 1e-4
    # A singular mass matrix is refused by every method with a typed error (taylor included: it
    # expands the scene's energies traced into the expression graph).
    for method, o in m["ball_singular"].items():
        assert o["status"] == "error", method
        assert o["detail"].split(":")[0] in ("SingularMassMatrixError", "ConvergenceError")
    # Long run: every symplectic method keeps the oscillator's energy.
    for method in ("stormer_verlet", "yoshida4", "yoshida6", "yoshida8", "blanes_moan4",
                   "midpoint", "gauss4", "gauss6"):
        assert m["long_run"][method]["status"] == "solved", method
    # A constrained model: the methods that keep a run on the constraints (projection, RATTLE,
    # the constrained midpoint) solve it; the others do not apply, each saying why.
    constrained = m["constrained_pendulum"]
    for method in ("rk4", "dopri5", "dop853", "radau5", "stormer_verlet", "yoshida4",
                   "yoshida6", "yoshida8", "midpoint"):
        assert constrained[method]["status"] in ("solved", "coarse"), (method, constrained[method])
    for method in ("dopri5", "dop853", "radau5"):
        assert constrained[method]["status"] == "solved", method
    for method in ("gauss4", "gauss6", "blanes_moan4", "taylor"):
        o = constrained[method]
        assert o["status"] == "n/a" and "constrained" in o["detail"], (method, o)
    text = (Path(report["_folder"]) / "stability.md").read_text()
    line = next(x for x in text.splitlines() if x.startswith("- **Cartesian pendulum"))
    assert "Not applicable (" in line and "gauss4" in line
    # The chaotic pendulum: answers beyond the Lyapunov horizon are reported as such.
    chaotic = m["chaotic"]
    assert all(o["status"] in ("solved", "chaotic", "coarse", "n/a") for o in chaotic.values())
    assert any(o["status"] == "chaotic" for o in chaotic.values())
    ref = next(c for c in report["stability"]["cases"] if c["key"] == "chaotic")["reference"]
    assert "Lyapunov time" in ref


def test_console_command_help() -> None:
    exe = shutil.which("lagrangian")
    if exe is None:
        pytest.skip("console script not on PATH (package not installed)")
    done = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and "report" in done.stdout and "stability" in done.stdout


def test_unknown_scene_is_a_usage_error() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "lagrangian", "report", "--quick", "--scenes", "nope"],
        capture_output=True, text=True, timeout=120,
    )
    assert done.returncode == 2 and "unknown scenes" in done.stderr


def test_report_without_scipy_skips_the_scipy_rows_with_a_note(tmp_path: Path) -> None:
    # A fresh install without the `peers` extra: a None entry in sys.modules makes the import
    # of SciPy fail as if it were not installed.
    script = (
        "import sys; sys.modules['scipy'] = None; sys.modules['scipy.integrate'] = None\n"
        "from lagrangian.__main__ import main\n"
        f"sys.exit(main(['report', '--quick', '--no-stability', '--scenes', 'double_pendulum', "
        f"'--out', {str(tmp_path)!r}]))\n"
    )
    env = dict(os.environ, MPLBACKEND="Agg")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          env=env, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "SciPy is not installed" in (tmp_path / "README.md").read_text()
    data = json.loads((tmp_path / "report.json").read_text())
    assert [s["key"] for s in data["scenes"]] == ["double_pendulum"]
    assert "peers" not in data["scenes"][0] and "SciPy is not installed" in data["peers_note"]


def test_report_scipy_rows_run_on_the_model_rhs(report: Dict[str, Any]) -> None:
    pytest.importorskip("scipy")
    text = (Path(report["_folder"]) / "README.md").read_text()
    assert "model's own right-hand side (`model.rhs`" in text
    for key in ("double_pendulum", "forced_two_mass"):
        scene = next(s for s in report["scenes"] if s["key"] == key)
        radau = [r for r in scene["peers"]["rows"] if r["method"] == "scipy Radau"]
        assert radau and all(r["error"] is not None and r["error"] < 1e-2 for r in radau)


def test_not_applicable_methods_are_listed_under_their_own_reason() -> None:
    # Each method the report leaves out is named under the reason its own fit check in Rust gives
    # (the double pendulum once listed every left-out method as "not separable").
    import lagrangian as lg
    from lagrangian._measure import UNSUPPORTED, unsupported_reason
    from lagrangian._report import _table_without_unsupported

    model = lg.scenes.double_pendulum()
    q0, qd0 = [1.0, 0.5], [0.0, 0.0]
    own: Dict[str, str] = {}
    for method in lg.methods()[1:]:
        adaptive = bool(lg._lagrangian.method_info(method)[1])
        options: Dict[str, Any] = {} if adaptive else {"dt": 0.01}
        try:
            model.simulate(q0, qd0, 0.01, method=method, **options)
        except ValueError as e:
            assert UNSUPPORTED in str(e), (method, str(e))
            reason = unsupported_reason(str(e))
            assert reason and reason in str(e) and "methods that fit" not in reason
            own[method] = reason
    assert own, "some method cannot integrate the double pendulum (the explicit splittings)"
    wp = lg.work_precision(model, q0, qd0, 0.01, tolerances=[1e-6], dts=[0.01], repeats=1,
                           reference=([0.0, 0.0], [0.0, 0.0]))
    table = _table_without_unsupported(wp)
    listed: Dict[str, str] = {}
    for line in table.splitlines():
        if line.startswith("Not applicable ("):
            reason, methods = line[len("Not applicable ("):].rsplit("): ", 1)
            for m in methods.rstrip(".").split(", "):
                listed[m] = reason
    assert listed == own
    assert all(f"| {m} " not in table for m in own)
