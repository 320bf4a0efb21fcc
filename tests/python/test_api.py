"""The module's surface: method names, solutions, statistics, docstrings and type stubs."""

import inspect
import re
import subprocess
import sys

import numpy as np
import pytest
from numpy.testing import assert_allclose

import lagrangian as lg

ISSUE_METHODS = ["rk4", "dopri5", "dop853", "verlet", "yoshida4", "yoshida6", "yoshida8",
                 "blanes_moan4", "midpoint", "gauss4", "gauss6", "radau5", "auto"]


def test_methods_lists_the_registry():
    names = lg.methods()
    assert names[0] == "auto"
    for name in ISSUE_METHODS:
        assert name in names or name == "verlet"
    assert "stormer_verlet" in names


@pytest.mark.parametrize("method", ISSUE_METHODS)
def test_every_method_integrates_the_oscillator(method):
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=2.0 * x**2)
    adaptive = method in ("dopri5", "dop853", "radau5", "auto")
    kw = dict(rtol=1e-10, atol=1e-12) if adaptive else dict(dt=1e-3)
    sol = model.simulate([1.0], [0.0], 1.0, method=method.upper(), **kw)
    assert sol.t[0] == 0.0 and sol.t[-1] == 1.0
    # x = cos 2t; the second-order methods at dt = 1e-3 err by ~1e-6.
    assert abs(sol.q[-1, 0] - np.cos(2.0)) < 1e-5
    assert sol.stats["accepted_steps"] > 0


def test_solution_arrays_and_stats(dp_params):
    model = lg.scenes.double_pendulum(**dp_params)
    t_eval = np.linspace(0.0, 2.0, 21)
    sol = model.simulate([1.0, 0.5], [0.0, 0.0], 2.0, rtol=1e-8, atol=1e-8, t_eval=t_eval)
    assert sol.t.shape == (21,) and sol.q.shape == (21, 2) and sol.qd.shape == (21, 2)
    assert sol.energy.shape == (21,)
    assert_allclose(sol.t, t_eval)
    assert_allclose(sol.energy, sol.energy[0], rtol=1e-6)
    assert sol.stats["method"] == "dop853" and "DOP853" in sol.stats["choice"]
    assert set(sol.stats) >= {"accepted_steps", "rejected_steps", "rhs_evaluations",
                              "jacobian_evaluations", "factorizations", "newton_failures"}
    assert len(sol) == 21 and "Solution(points=21" in repr(sol)
    # energy is h = q̇·p − L at every output
    for i in (0, 10, 20):
        assert_allclose(sol.energy[i], model.energy(sol.t[i], sol.q[i], sol.qd[i]), rtol=1e-14)


def test_solution_fields_are_made_on_first_read_in_any_order():
    import copy
    import pickle

    # x = cos t; the event x = 0 at t = π/2 and 3π/2.
    x, = lg.coordinates("x")
    model = lg.Model(coordinates=[x], kinetic=0.5 * x.d**2, potential=0.5 * x**2)
    kw = dict(method="dop853", rtol=1e-12, atol=1e-12, events=[lg.Event(x, name="zero")],
              dense=True)
    fields = ["t", "q", "qd", "energy", "stats", "t_events", "q_events", "qd_events",
              "status", "message", "interpolant"]
    first = model.simulate([1.0], [0.0], 5.0, **kw)
    seen = {name: getattr(first, name) for name in fields}
    assert_allclose(seen["q"][:, 0], np.cos(seen["t"]), atol=1e-10)
    assert_allclose(seen["t_events"][0], [np.pi / 2, 3 * np.pi / 2], atol=1e-10)
    assert seen["status"] == 0 and seen["message"] == "reached t_end"
    assert seen["stats"]["conserved"] is True
    for name in fields[:-1]:
        assert getattr(first, name) is seen[name]  # kept, not made again
    # Read in the reverse order, or never read before a copy: the same values.
    again = model.simulate([1.0], [0.0], 5.0, **kw)
    unread = [model.simulate([1.0], [0.0], 5.0, **kw) for _ in range(2)]
    for sol in (again, pickle.loads(pickle.dumps(unread[0])), copy.deepcopy(unread[1])):
        for name in reversed(fields):
            a, b = getattr(sol, name), seen[name]
            if isinstance(b, list):
                assert len(a) == len(b) and all(np.array_equal(u, v) for u, v in zip(a, b))
            elif isinstance(b, np.ndarray):
                assert np.array_equal(a, b)
            else:
                assert a == b
        assert np.array_equal(sol(2.0)[0], first(2.0)[0])
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        again.nothing
    again.t = np.zeros(3)  # a field can still be set
    assert again.t.shape == (3,)
    kept = again.q
    with pytest.raises(AttributeError):  # but not deleted: it keeps its value
        del again.q
    assert again.q is kept and np.array_equal(kept, seen["q"])
    assert isinstance(again, lg.Solution) and not hasattr(again, "__dict__")
    # A solution built from its fields (as an ensemble's run is) reads them back.
    built = lg.Solution(seen["t"], seen["q"], seen["qd"], seen["energy"], {}, ["x"])
    assert built.q is seen["q"] and built.names == ("x",) and built.status == 0
    assert built.t_events == [] and built.interpolant is None and built.y.shape[0] == 2
    # Fields are made from the run once: a field read before a pickle is not lost from it;
    # every pickle protocol keeps them.
    part = model.simulate([1.0], [0.0], 5.0, **kw)
    part.q
    assert np.array_equal(copy.deepcopy(part).q, seen["q"])
    for protocol in range(pickle.HIGHEST_PROTOCOL + 1):
        back = pickle.loads(pickle.dumps(part, protocol=protocol))
        assert type(back) is lg.Solution and np.array_equal(back.qd, seen["qd"])
        assert back.event_names == ("zero",) and np.array_equal(back(2.0)[0], first(2.0)[0])
    # An assigned field releases the value it replaces, and a cycle through a solution is
    # collected (the native fields are visited by the garbage collector).
    import gc
    import weakref

    old = weakref.ref(part.q)
    part.q = part.q[::2].copy()
    gc.collect()
    assert old() is None

    class Holder:
        pass

    holder = Holder()
    holder.sol, part.names = part, holder
    gone = weakref.ref(holder)
    del holder, part
    gc.collect()
    assert gone() is None
    # Threads reading a new solution's fields at once all get them whole.
    import threading

    for _ in range(5):
        sol = model.simulate([1.0], [0.0], 5.0, **kw)
        got = []
        readers = [threading.Thread(target=lambda: got.append((sol.q, sol.t_events)))
                   for _ in range(4)]
        for r in readers:
            r.start()
        for r in readers:
            r.join(timeout=60)
        assert len(got) == 4
        for q, te in got:
            assert np.array_equal(q, seen["q"]) and np.array_equal(te[0], seen["t_events"][0])


def test_auto_picks_symplectic_for_separable_fixed_step():
    model = lg.scenes.kepler(1.0, 1.0)
    sol = model.simulate([1.0, 0.0], [0.0, 1.0], 1.0, dt=0.01)
    assert sol.stats["method"] == "blanes_moan4"


def test_every_public_name_has_a_docstring():
    for name in lg.__all__:
        obj = getattr(lg, name)
        if inspect.isclass(obj) or inspect.isfunction(obj) or inspect.ismodule(obj):
            assert obj.__doc__ and obj.__doc__.strip(), name
    for name in dir(lg.Model):
        if not name.startswith("_"):
            assert getattr(lg.Model, name).__doc__, name
    for name in lg.scenes.__all__:
        assert getattr(lg.scenes, name).__doc__, name
    assert issubclass(lg.StepSizeError, lg.LagrangianError)
    assert issubclass(lg.LagrangianError, Exception)


USER_SCRIPT = '''
import numpy as np
import lagrangian as lg

th1, th2 = lg.coordinates("th1 th2")
m, l, g = lg.parameters("m l g")
T = 0.5*m*l**2*(2*th1.d**2 + th2.d**2 + 2*th1.d*th2.d*lg.cos(th1 - th2))
U = -m*g*l*(2*lg.cos(th1) + lg.cos(th2))
model = lg.Model(coordinates=[th1, th2], kinetic=T, potential=U,
                 parameters={"m": 1.0, "l": 1.0, "g": 9.81})
sol: lg.Solution = model.simulate(q0=[1.0, 0.5], qd0=[0.0, 0.0], t_end=1.0)
q: np.ndarray = sol.q
e: float = model.energy(0.0, [1.0, 0.5], [0.0, 0.0])
eq: lg.Equilibrium = model.equilibrium([0.1, 0.1])
stable: bool = eq.stable
names: list[str] = lg.methods()
moon: lg.Model = model.with_parameters(g=1.62)
dp: lg.Model = lg.scenes.double_pendulum(1.0, 1.0, 1.0, 1.0, 9.81)
try:
    pass
except lg.StepSizeError as err:
    print(err)
'''


def test_mypy_accepts_the_package_and_a_user_script(tmp_path):
    pytest.importorskip("mypy")
    script = tmp_path / "user.py"
    script.write_text(USER_SCRIPT)
    # One run for both (the script as module `user`, found in the working directory): mypy reads
    # the standard library's and NumPy's stubs once.
    run = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", "-m", "user", "-p", "lagrangian"],
        capture_output=True, text=True, cwd=tmp_path,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    # The script and every module of the package (with its stubs) were checked.
    checked = re.search(r"no issues found in (\d+) source files", run.stdout)
    assert checked and int(checked.group(1)) > 10, run.stdout


def test_stubs_match_the_extension_module(tmp_path):
    pytest.importorskip("mypy")
    run = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "lagrangian._lagrangian"],
        capture_output=True, text=True, cwd=tmp_path,
    )
    assert run.returncode == 0, run.stdout + run.stderr


@pytest.mark.parametrize(
    "module", ["lagrangian", "lagrangian._expr", "lagrangian._events", "lagrangian._model", "lagrangian._sympy",
               "lagrangian.scenes", "lagrangian._workprec", "lagrangian._scipy",
               "lagrangian._ensemble", "lagrangian._fit", "lagrangian._linear",
               "lagrangian._contact", "lagrangian._steady",
               "lagrangian._loads", "lagrangian._motion", "lagrangian._urdf"]
)
def test_docstring_examples_run(module):
    import doctest
    import importlib

    if module == "lagrangian._sympy":
        pytest.importorskip("sympy")
    if module in ("lagrangian._scipy", "lagrangian._fit"):
        pytest.importorskip("scipy")
    result = doctest.testmod(importlib.import_module(module))
    assert result.attempted > 0 and result.failed == 0


@pytest.mark.parametrize("method, module, keywords", [
    ("simulate", "lagrangian._model", ["t0", "method", "dt", "rtol", "atol", "t_eval", "max_steps",
                                       "output_every", "events", "dense", "sensitivities",
                                       "sensitivity_error_control"]),
    ("simulate_many", "lagrangian._ensemble",
     ["parameters", "t_eval", "t0", "method", "dt", "rtol", "atol", "max_steps", "final_only",
      "events", "workers", "executor", "chunks", "timeout", "sensitivities",
      "sensitivity_error_control"]),
    ("fit", "lagrangian._fit", ["q0", "qd0", "fit_initial_state", "weights", "bounds", "method",
                                "rtol", "atol", "max_nfev", "tolerance"]),
])
def test_run_keywords_are_stated_once_where_the_work_is_done(method, module, keywords):
    import ast
    import importlib
    import pydoc
    from pathlib import Path

    # The user sees the keywords, their defaults and their documentation on the method ...
    function = getattr(lg.Model, method)
    params = inspect.signature(function).parameters
    assert [p.name for p in params.values() if p.kind is p.KEYWORD_ONLY] == keywords
    assert params["rtol"].default == (1e-10 if method == "fit" else 1e-6)
    text = pydoc.render_doc(function, renderer=pydoc.plaintext)
    line = next(x for x in text.splitlines() if x.startswith(f"{method}("))
    assert all(f" {k}: " in line for k in keywords) and "Parameters" in text
    # ... and they are written once, in the module that does the work: no other function of
    # the package spells that keyword list out again.
    assert function.__module__ == module
    package = Path(lg.__file__).parent
    spelled = [p.name for p in sorted(package.glob("*.py"))
               for node in ast.walk(ast.parse(p.read_text()))
               if isinstance(node, ast.FunctionDef) and node.name == method and node.args.kwonlyargs]
    assert spelled == [importlib.import_module(module).__file__.rsplit("/", 1)[-1]]


def test_backend_names_what_computes_the_accelerations():
    # A model stated by expressions runs eq. 55 derived on its graph as machine code; the
    # same system written in Rust is a scene; a model stated by its particles gets its T derived
    # from the positions and runs the same way.
    th1, th2 = lg.coordinates("th1 th2")
    m, l, g = lg.parameters("m l g")
    T = 0.5 * m * l**2 * (2 * th1.d**2 + th2.d**2 + 2 * th1.d * th2.d * lg.cos(th1 - th2))
    U = -m * g * l * (2 * lg.cos(th1) + lg.cos(th2))
    model = lg.Model(coordinates=[th1, th2], kinetic=T, potential=U,
                     parameters={"m": 1.0, "l": 1.0, "g": 9.81})
    scene = lg.scenes.double_pendulum(1.0, 1.0, 1.0, 1.0, 9.81)
    assert model.structure["backend"] == "native"
    assert scene.structure["backend"] == "rust"
    x, = lg.coordinates("x")
    particle = lg.Model(coordinates=[x], positions=[(x, 0.0)], masses=[1.0])
    assert particle.structure["backend"] == "native"
    rng = np.random.default_rng(5)
    for _ in range(20):
        q, qd = rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
        a = scene.accelerations(0.0, q, qd)
        assert_allclose(model.accelerations(0.0, q, qd), a, rtol=1e-13, atol=1e-13 * np.abs(a).max())
    # New parameter values reuse the compiled code.
    moon = model.with_parameters(g=1.62)
    assert moon.structure["backend"] == "native"
    assert_allclose(moon.accelerations(0.0, [0.3, 0.0], [0.0, 0.0]),
                    lg.scenes.double_pendulum(1.0, 1.0, 1.0, 1.0, 1.62).accelerations(0.0, [0.3, 0.0], [0.0, 0.0]),
                    rtol=1e-13)
