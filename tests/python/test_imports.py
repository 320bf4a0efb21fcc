"""The package's modules import without cycles and in one-way layers: each one alone in a fresh
interpreter; the graph of ``from .`` imports — at module level and inside functions, type-only
imports under ``TYPE_CHECKING`` left out — has no cycle; and a module imports only from its own
layer or lower ones, but for the few lazy delegations listed in ``DELEGATIONS``. The
benchmark-only comparators are not in the wheel."""

import ast
import subprocess
import sys
from pathlib import Path
from typing import Dict, List, Set, Tuple

import pytest

import lagrangian

PACKAGE = Path(lagrangian.__file__).resolve().parent
MODULES = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__")

# The package's layers, lowest first: a module imports from its own layer or those below.
LAYERS: List[Tuple[str, Set[str]]] = [
    ("native module and expressions", {"_lagrangian", "_expr"}),
    ("validation", {"_validate"}),
    ("events, solution, linearization, drawing, sensitivities",
     {"_events", "_solution", "_linear", "_drawing", "_sensitivity", "_fit"}),
    ("model, scenes, SymPy bridge", {"_model", "_scene_model", "_constrained_scenes", "scenes", "_sympy"}),
    ("ensembles", {"_ensemble"}),
    ("plotting", {"_plot"}),
    ("report tooling",
     {"_cases", "_measure", "_scipy", "_stability", "_workprec", "_report", "__main__"}),
]

# Imports up the layers, each inside a method that hands its work to a higher layer when called
# (so that ``import lagrangian`` needs neither matplotlib nor the ensemble machinery first).
DELEGATIONS: Set[Tuple[str, str]] = {
    ("_model", "_plot"),  # Model.animate
    ("_model", "_ensemble"),  # Model.simulate_many
    ("_solution", "_plot"),  # Solution.plot
    ("_fit", "_plot"),  # Fit.plot
}


def _type_checking_nodes(tree: ast.AST) -> Set[int]:
    """The ids of the nodes under an ``if TYPE_CHECKING:`` (type-only imports)."""
    ids: Set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for stmt in node.body:
                ids.update(id(n) for n in ast.walk(stmt))
    return ids


def _imports(path: Path, module_level: bool = False) -> Set[str]:
    """The package modules ``path`` imports, at module level or inside functions (type-only
    imports left out); with ``module_level``, only those it imports when it is imported."""
    tree = ast.parse(path.read_text())
    type_only = _type_checking_nodes(tree)
    found: Set[str] = set()
    for node in tree.body if module_level else ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 1 and id(node) not in type_only:
            if node.module is None:
                found.update(a.name for a in node.names)
            else:
                found.add(node.module.split(".")[0])
    return found & (set(MODULES) | {"_lagrangian"})


GRAPH: Dict[str, Set[str]] = {m: _imports(PACKAGE / f"{m}.py") for m in MODULES}


def test_import_graph_has_no_cycle() -> None:
    graph = {m: deps - {"_lagrangian"} for m, deps in GRAPH.items()}
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


def test_the_delegations_are_imports_inside_functions() -> None:
    # A graph of module-level imports would miss them; a delegation at module level would import
    # the higher layer with the lower one.
    for module, dep in DELEGATIONS:
        assert dep in GRAPH[module], f"{module} no longer imports {dep}: drop it from DELEGATIONS"
        assert dep not in _imports(PACKAGE / f"{module}.py", module_level=True), (module, dep)


def test_every_module_has_one_layer() -> None:
    named = [m for _, members in LAYERS for m in members]
    assert len(named) == len(set(named)), "a module is in two layers"
    assert set(MODULES) - set(named) == set(), "modules in no layer"
    assert set(named) - set(MODULES) == {"_lagrangian"}, "layers name modules that do not exist"


def test_imports_point_down_the_layers() -> None:
    level = {m: i for i, (_, members) in enumerate(LAYERS) for m in members}
    upward = [
        f"{m} ({LAYERS[level[m]][0]}) imports {dep} ({LAYERS[level[dep]][0]})"
        for m in MODULES
        for dep in sorted(GRAPH[m])
        if level[dep] > level[m] and (m, dep) not in DELEGATIONS
    ]
    assert upward == []


@pytest.mark.parametrize("module", MODULES)
def test_each_module_imports_alone(module: str) -> None:
    run = subprocess.run([sys.executable, "-c", f"import lagrangian.{module}"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr


def test_benchmark_comparators_are_not_in_the_package() -> None:
    assert not (PACKAGE / "_peers.py").exists()
    assert "numpy_rhs" not in (PACKAGE / "_report.py").read_text()
