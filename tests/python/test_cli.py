"""The command line (`lagrangian`, `python -m lagrangian`): its version, the scenes, cases and
methods its help lists, and names it refuses before any run starts."""

from __future__ import annotations

import subprocess
import sys
from typing import List

import pytest

import lagrangian as lg
from lagrangian import _stability
from lagrangian.__main__ import DEFAULT_OUT, main
from lagrangian._cases import report_scenes


def _exit(argv: List[str], capsys: pytest.CaptureFixture[str]) -> "tuple[int, str, str]":
    with pytest.raises(SystemExit) as info:
        main(argv)
    out, err = capsys.readouterr()
    code = info.value.code
    assert isinstance(code, int)
    return code, out, err


def test_version() -> None:
    done = subprocess.run([sys.executable, "-m", "lagrangian", "--version"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"lagrangian {lg.__version__}"


def test_report_help_lists_the_scenes_and_the_default_folder(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _exit(["report", "--help"], capsys)
    assert code == 0
    assert f"(default: {DEFAULT_OUT})" in out
    scenes = report_scenes()
    assert len(scenes) >= 8
    for scene in scenes:
        assert f"  {scene.key}  " in out, scene.key
        assert scene.title in out


def test_stability_help_lists_the_cases_and_the_methods(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _exit(["stability", "--help"], capsys)
    assert code == 0
    cases = _stability.stability_cases()
    assert len(cases) >= 10
    for case in cases:
        assert f"  {case.key}  " in out, case.key
    listed = out.split("methods:")[-1]
    for method in lg.methods():
        assert (method in listed) == (method != "auto"), method


@pytest.mark.parametrize("methods, says", [
    ("rk4,nope", "unknown method 'nope'"),
    ("auto", "'auto' picks a method per run"),
    (",", "no methods given"),
])
def test_bad_methods_are_refused_before_any_run(
        methods: str, says: str, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    def no_work(*args: object, **kwargs: object) -> None:
        raise AssertionError("a run started")

    monkeypatch.setattr(_stability, "run_case", no_work)
    monkeypatch.setattr(_stability, "_reference", no_work)
    code, out, err = _exit(["stability", "--quick", "--methods", methods], capsys)
    assert code == 2 and says in err, err
    assert "rk4, dopri5, dop853" in err
    assert out == ""


def test_method_aliases_are_accepted() -> None:
    assert _stability.check_methods(["RK4", "verlet"]) == ["rk4", "stormer_verlet"]


def test_unknown_case_is_refused_before_any_run(capsys: pytest.CaptureFixture[str],
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_stability, "run_case", lambda *a, **k: pytest.fail("a run started"))
    code, _, err = _exit(["stability", "--cases", "separatrix,nope"], capsys)
    assert code == 2 and "unknown cases ['nope']" in err
