"""The package's modules import without cycles and in one-way layers: each one alone in a fresh
interpreter; the graph of ``from .`` imports — every one of them: at module level, inside
functions and under ``TYPE_CHECKING`` (a type-only import is still an arrow between modules) —
has no cycle; and a module imports only from its own layer or lower ones, with no exceptions. A
worker that a class hands its work to sits below that class and names its argument by a protocol
of ``_protocols`` instead of importing the caller. The benchmark-only comparators are not in the
wheel."""

import ast
import subprocess
import sys
from pathlib import Path
from typing import Dict, List, Optional, Set, Tuple

import pytest

import lagrangian

PACKAGE = Path(lagrangian.__file__).resolve().parent
MODULES = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__")

# The package's layers, lowest first: a module imports from its own layer or those below.
LAYERS: List[Tuple[str, Set[str]]] = [
    ("native module and expressions", {"_lagrangian", "_expr"}),
    ("protocols of what the workers read", {"_protocols"}),
    ("validation", {"_validate"}),
    ("rigid bodies", {"_bodies"}),
    ("frames and joints", {"_frames"}),
    ("rolling contact", {"_contact"}),
    ("loads on bodies", {"_loads"}),
    ("robots from URDF files", {"_urdf"}),
    ("events, drawing, sensitivities", {"_events", "_drawing", "_sensitivity"}),
    ("pictures", {"_plot", "_plot_bodies"}),
    ("solution and bodies along it", {"_solution", "_motion"}),
    ("the model's workers: ensembles, fits, statics and modes, its statement",
     {"_ensemble", "_fit", "_linear", "_steady", "_statement"}),
    ("model", {"_model"}),
    ("scenes, SymPy bridge", {"_scene_model", "_constrained_scenes", "_vehicle_scenes",
                              "_body_scenes", "scenes", "_sympy"}),
    ("report tooling",
     {"_measure", "_workprec", "_cases", "_scipy", "_stability", "_report", "__main__"}),
]


def imports_of(source: str, known: Set[str]) -> Set[str]:
    """The modules of ``known`` that ``source`` (a module of the package) imports: every
    ``from . import x`` and ``from .x import y``, wherever it stands — at module level, inside a
    function or method, under ``if TYPE_CHECKING:`` — and every absolute import of
    ``lagrangian.x``."""
    found: Set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            if node.level == 1:
                if node.module is None:
                    found.update(a.name for a in node.names)
                else:
                    found.add(node.module.split(".")[0])
            elif node.level == 0 and node.module is not None:
                parts = node.module.split(".")
                if parts[0] == "lagrangian":
                    if len(parts) > 1:
                        found.add(parts[1])
                    else:
                        found.update(a.name for a in node.names)
        elif isinstance(node, ast.Import):
            for a in node.names:
                parts = a.name.split(".")
                if parts[0] == "lagrangian" and len(parts) > 1:
                    found.add(parts[1])
    return found & known


def find_cycle(graph: Dict[str, Set[str]]) -> Optional[List[str]]:
    """A cycle of ``graph`` (module → the modules it imports) as a path that ends where it
    starts, or ``None``."""
    done: Set[str] = set()

    def visit(m: str, path: List[str]) -> Optional[List[str]]:
        if m in path:
            return path[path.index(m):] + [m]
        if m in done:
            return None
        for dep in sorted(graph.get(m, ())):
            cycle = visit(dep, path + [m])
            if cycle is not None:
                return cycle
        done.add(m)
        return None

    for m in sorted(graph):
        cycle = visit(m, [])
        if cycle is not None:
            return cycle
    return None


def upward(graph: Dict[str, Set[str]], layers: List[Tuple[str, Set[str]]]) -> List[str]:
    """Every import of ``graph`` from a module to one in a higher layer, in words."""
    level = {m: i for i, (_, members) in enumerate(layers) for m in members}
    return [
        f"{m} ({layers[level[m]][0]}) imports {dep} ({layers[level[dep]][0]})"
        for m in sorted(graph)
        for dep in sorted(graph[m])
        if level[dep] > level[m]
    ]


KNOWN = set(MODULES) | {"_lagrangian"}
GRAPH: Dict[str, Set[str]] = {m: imports_of((PACKAGE / f"{m}.py").read_text(), KNOWN)
                              for m in MODULES}


def test_the_analysis_counts_type_only_and_in_function_imports():
    source = '''
from typing import TYPE_CHECKING
from ._a import x
from . import _b, _c as c
import lagrangian._f
if TYPE_CHECKING:
    from ._d import D

def f():
    from ._e import e
    return e

class K:
    def m(self):
        from lagrangian import _g
'''
    known = {"_a", "_b", "_c", "_d", "_e", "_f", "_g", "_h"}
    assert imports_of(source, known) == {"_a", "_b", "_c", "_d", "_e", "_f", "_g"}


def test_the_analysis_finds_a_cycle_and_an_upward_import():
    # A circle closed only by a type-only import, as the package had one: _plot → _model under
    # TYPE_CHECKING, _model → _plot inside a method.
    sources = {
        "_model": "def animate(self):\n    from . import _plot\n",
        "_plot": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                 "    from ._model import Model\n",
    }
    graph = {m: imports_of(s, set(sources)) for m, s in sources.items()}
    assert find_cycle(graph) in (["_model", "_plot", "_model"], ["_plot", "_model", "_plot"])
    layers = [("low", {"_plot"}), ("high", {"_model"})]
    assert upward(graph, layers) == ["_plot (low) imports _model (high)"]
    assert find_cycle({"_model": {"_plot"}, "_plot": set()}) is None
    assert upward({"_model": {"_plot"}, "_plot": set()}, layers) == []


def test_import_graph_has_no_cycle():
    cycle = find_cycle({m: deps - {"_lagrangian"} for m, deps in GRAPH.items()})
    assert cycle is None, "import cycle: " + " → ".join(cycle or [])


def test_every_module_has_one_layer():
    named = [m for _, members in LAYERS for m in members]
    assert len(named) == len(set(named)), "a module is in two layers"
    assert set(MODULES) - set(named) == set(), "modules in no layer"
    assert set(named) - set(MODULES) == {"_lagrangian"}, "layers name modules that do not exist"


def test_imports_point_down_the_layers():
    assert upward(GRAPH, LAYERS) == []


def test_the_delegating_methods_import_down():
    # Model.animate, Model.simulate_many, Solution.plot, Fit.plot: the classes import their
    # workers, never the other way.
    for caller, worker in (("_model", "_plot"), ("_model", "_ensemble"), ("_model", "_fit"),
                           ("_solution", "_plot"), ("_fit", "_plot"), ("_workprec", "_plot")):
        assert worker in GRAPH[caller], (caller, worker)
        assert caller not in GRAPH[worker], (worker, caller)


def test_import_lagrangian_loads_no_pictures():
    run = subprocess.run(
        [sys.executable, "-c",
         "import sys, lagrangian; assert 'matplotlib' not in sys.modules, 'matplotlib'; "
         "assert 'scipy' not in sys.modules, 'scipy'; "
         "assert 'lagrangian._plot' not in sys.modules, 'lagrangian._plot'"],
        capture_output=True, text=True, timeout=120,
    )
    assert run.returncode == 0, run.stderr


@pytest.mark.parametrize("module", MODULES)
def test_each_module_imports_alone(module: str) -> None:
    run = subprocess.run([sys.executable, "-c", f"import lagrangian.{module}"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr


def _defined_private_names(tree: ast.AST) -> Set[str]:
    """The ``_names`` a module defines: its functions, classes, module-level names, the
    attributes its code assigns (``x._a = …``), its classes' ``__slots__`` and annotations."""
    names: Set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
        elif isinstance(node, ast.Assign):
            for target in node.targets:
                if isinstance(target, ast.Name) and target.id == "__slots__":
                    for elt in ast.walk(node.value):
                        if isinstance(elt, ast.Constant) and isinstance(elt.value, str):
                            names.add(elt.value)
    return names


def foreign_private_reads(source: str) -> List[str]:
    """The ``x._name`` reads of ``source`` whose ``_name`` the module does not define itself:
    private members of another module's class (or module)."""
    tree = ast.parse(source)
    own = _defined_private_names(tree)
    return sorted(
        {
            f"line {node.lineno}: .{node.attr}"
            for node in ast.walk(tree)
            if isinstance(node, ast.Attribute)
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
            and node.attr not in own
        }
    )


def test_the_private_read_check_can_fail():
    source = "class E:\n    _own = 1\n\ndef f(model, e):\n    return model._native, e._own\n"
    assert foreign_private_reads(source) == ["line 5: ._native"]


@pytest.mark.parametrize("module", MODULES)
def test_modules_read_each_other_through_public_members(module: str) -> None:
    # _ensemble reads a model by its public surface (native, parameters, scene,
    # with_parameters, ...), as every other worker does.
    assert foreign_private_reads((PACKAGE / f"{module}.py").read_text()) == []


def test_benchmark_comparators_are_not_in_the_package() -> None:
    assert not (PACKAGE / "_peers.py").exists()
    assert "numpy_rhs" not in (PACKAGE / "_report.py").read_text()
