"""The package's modules import without cycles: each one alone in a fresh interpreter, and the
graph of module-level ``from .`` imports (type-only imports under ``TYPE_CHECKING`` and imports
inside functions left out) has no cycle. The benchmark-only comparators are not in the wheel."""

import ast
import subprocess
import sys
from pathlib import Path
from typing import Dict, List, Set

import pytest

import lagrangian

PACKAGE = Path(lagrangian.__file__).resolve().parent
MODULES = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__")


def _module_level_imports(path: Path) -> Set[str]:
    """The package modules ``path`` imports when it is imported."""
    found: Set[str] = set()
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            if node.module is None:
                found.update(a.name for a in node.names)
            else:
                found.add(node.module.split(".")[0])
    return found & set(MODULES)


def test_module_level_import_graph_has_no_cycle() -> None:
    graph: Dict[str, Set[str]] = {m: _module_level_imports(PACKAGE / f"{m}.py") for m in MODULES}
    done: Set[str] = set()

    def visit(m: str, path: List[str]) -> None:
        if m in path:
            raise AssertionError("import cycle: " + " → ".join(path[path.index(m):] + [m]))
        if m in done:
            return
        for dep in sorted(graph[m]):
            visit(dep, path + [m])
        done.add(m)

    for m in MODULES:
        visit(m, [])


@pytest.mark.parametrize("module", MODULES)
def test_each_module_imports_alone(module: str) -> None:
    run = subprocess.run([sys.executable, "-c", f"import lagrangian.{module}"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr


def test_benchmark_comparators_are_not_in_the_package() -> None:
    assert not (PACKAGE / "_peers.py").exists()
    assert "numpy_rhs" not in (PACKAGE / "_report.py").read_text()
