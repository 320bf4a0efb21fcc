"""The documentation site's examples run as written: the tutorial (docs/site/tutorial.rst), every
reference page with examples, the front page, and the README's Python quick start."""

import doctest
from pathlib import Path

import pytest

pytest.importorskip("matplotlib")
pytest.importorskip("PIL")

SITE = Path(__file__).resolve().parents[2] / "docs" / "site"
TUTORIAL = SITE / "tutorial.rst"
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
# The reference pages with examples, and how many examples each runs at least.
PAGES = {"python.rst": 19, "events.rst": 20, "ensembles.rst": 24, "modes.rst": 13,
         "constraints.rst": 40, "sensitivities.rst": 40,
         "report.rst": 8, "bodies.rst": 19, "joints.rst": 35,
         "bicycle.rst": 20, "loads.rst": 30, "robots.rst": 14}


def test_tutorial_examples_run(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    result = doctest.testfile(str(TUTORIAL), module_relative=False, report=True,
                              optionflags=FLAGS)
    assert result.attempted > 50
    assert result.failed == 0
    # The pictures the tutorial shows are the ones it writes.
    for name in ("pendulum.png", "forced_two_mass.png", "fit.png", "work_precision.png"):
        assert (tmp_path / name).read_bytes().startswith(b"\x89PNG")
        assert f"_static/{name}" in TUTORIAL.read_text()
    assert (tmp_path / "double_pendulum.gif").read_bytes().startswith(b"GIF89a")


def test_every_page_with_examples_is_run():
    with_examples = {page.name for page in SITE.glob("*.rst") if ">>>" in page.read_text()}
    assert with_examples - {"tutorial.rst", "index.rst"} == set(PAGES)


@pytest.mark.parametrize("page", sorted(PAGES))
def test_reference_page_examples_run(page, tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    result = doctest.testfile(str(SITE / page), module_relative=False, report=True,
                              optionflags=FLAGS)
    assert result.attempted >= PAGES[page]
    assert result.failed == 0


def test_front_page_example_runs():
    result = doctest.testfile(str(SITE / "index.rst"), module_relative=False)
    assert result.attempted >= 4 and result.failed == 0


def test_readme_python_quick_start_runs(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    readme = (SITE.parents[1] / "README.md").read_text()
    section = readme[readme.index("## Quick start (Python)"):readme.index("## Set-up")]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(compile(code, "README.md", "exec"), scope)
    assert scope["sol"].stats["method"] == "dop853"
    assert scope["driven"].parameters["A"] == 0.5
    assert (tmp_path / "pendulum.png").exists() and (tmp_path / "pendulum.gif").exists()
