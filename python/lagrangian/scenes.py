"""Every ready-made Rust scene of ``lagrangian::scenes``, with the same parameters.

Each function returns a :class:`~lagrangian.scenes.SceneModel` (a :class:`~lagrangian.Model`)
backed by the native Rust system (its energies written in Rust, not compiled from expressions).
Every method of a model stated with :class:`~lagrangian.Model` applies, ``"taylor"`` included:
on the first ``method="taylor"`` run (or ``taylor_series``) the scene's Rust energies are traced
into the expression graph (the parameters' values as numbers in it) and its eq. 55 program is
derived and compiled as a model stated in Python is (about 1–10 ms). Every other method runs the
Rust code, as before, and pays nothing for it; ``"auto"`` does not trace, so it chooses among
the other methods.
The functions are made from the scene registry (``src/scenes/registry.rs``): their parameters,
defaults, docstrings and coordinate names are the ones declared there, and the arguments are
checked by name in Rust. ``model.coordinates`` gives the coordinates for loads in
``equilibrium``; ``model.exact`` gives the exact solution of the scenes that have one.

Beside them, the seed's systems with their constraints kept as equations (issue 41): plain
Python functions returning a constrained :class:`~lagrangian.Model` (``CONSTRAINED`` lists
them, outside ``__all__`` and the Rust catalog) — :func:`cartesian_pendulum`,
:func:`rolling_cylinder_constrained`, :func:`ball_in_sphere_constrained`,
:func:`rhombus_link_constrained` and :func:`spring_rhombus_constrained`; the vehicles on
rolling wheels (issue 50, ``VEHICLES``): :func:`whipple_bicycle`, the benchmark bicycle; and the
classics stated with rigid bodies (``BODIES``): :func:`spinning_top`, :func:`gyroscope`,
:func:`rolling_cylinder_body`
and :func:`ball_in_sphere_body`.

>>> import lagrangian as lg
>>> dp = lg.scenes.double_pendulum(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81)
>>> [c.name for c in dp.coordinates]
['th1', 'th2']
>>> lg.scenes.double_pendulum().parameters["g"]
9.81
"""

from __future__ import annotations

import inspect
from typing import Any, Callable, Dict, List, Tuple

from . import _body_scenes, _constrained_scenes, _lagrangian, _vehicle_scenes
from ._body_scenes import ball_in_sphere_body, gyroscope, rolling_cylinder_body, spinning_top
from ._constrained_scenes import (
    ball_in_sphere_constrained,
    cartesian_pendulum,
    rhombus_link_constrained,
    rolling_cylinder_constrained,
    spring_rhombus_constrained,
)
from ._scene_model import SceneModel
from ._vehicle_scenes import rolling_disc, whipple_bicycle
from ._scene_model import scene_model as _scene_model

# The scene functions only: ``SceneModel`` and ``catalog`` are public but not scenes.
__all__: List[str] = []

# The constrained scenes (Python functions returning a constrained ``Model``), in catalog order.
CONSTRAINED: Tuple[str, ...] = tuple(_constrained_scenes.__all__)
# The classics stated with rigid bodies (Python functions returning a ``Model`` with bodies).
BODIES: Tuple[str, ...] = tuple(_body_scenes.__all__)

# Vehicles on rolling wheels (issue 50): Python functions returning a constrained ``Model``.
VEHICLES: Tuple[str, ...] = tuple(_vehicle_scenes.__all__)


def catalog() -> List[Dict[str, Any]]:
    """The scene registry: for each scene its ``name``, ``doc``, ``parameters`` (a list of
    ``(name, kind, default, doc)`` with kind ``"number"`` or ``"list"``), ``coordinates`` (a
    list of names, or ``(prefix, list parameter)`` for one numbered coordinate per entry),
    ``route`` (``"energy"``, ``"particle"`` or ``"body"``) and ``exact`` (whether
    :meth:`SceneModel.exact` knows its exact solution)."""
    return [dict(s) for s in _lagrangian.scene_catalog()]


def _default(kind: str, default: Any) -> Any:
    if default is None:
        return inspect.Parameter.empty
    return tuple(default) if kind == "list" else float(default)


def _annotation(kind: str) -> str:
    return "Sequence[float]" if kind == "list" else "float"


def _signature(entry: Dict[str, Any]) -> inspect.Signature:
    return inspect.Signature(
        [
            inspect.Parameter(
                name,
                inspect.Parameter.POSITIONAL_OR_KEYWORD,
                default=_default(kind, default),
                annotation=_annotation(kind),
            )
            for name, kind, default, _ in entry["parameters"]
        ],
        return_annotation="SceneModel",
    )


def _docstring(entry: Dict[str, Any]) -> str:
    lines = [entry["doc"]]
    if entry["parameters"]:
        lines += ["", "Parameters", "----------"]
        for name, kind, default, doc in entry["parameters"]:
            shown = "" if default is None else f", default {_default(kind, default)!r}"
            lines += [f"{name} : {_annotation(kind)}{shown}", f"    {doc[:1].upper()}{doc[1:]}."]
    coords = entry["coordinates"]
    named = (
        ", ".join(f"``{c}``" for c in coords)
        if isinstance(coords, list)
        else f"``{coords[0]}1`` … ``{coords[0]}N``, one per entry of ``{coords[1]}``"
    )
    lines += [
        "",
        "Returns",
        "-------",
        "SceneModel",
        f"    Coordinates {named}; the {entry['route']} route"
        + ("; :meth:`SceneModel.exact` gives the exact solution." if entry["exact"] else "."),
        "",
        "Raises",
        "------",
        "TypeError",
        "    For an unknown or repeated parameter, a missing one, or a value that is not a "
        "real number.",
        "ValueError",
        "    For a value that is not finite or does not fit the others.",
    ]
    return "\n".join(lines)


def _function(entry: Dict[str, Any]) -> Callable[..., SceneModel]:
    name: str = entry["name"]
    signature = _signature(entry)

    def scene(*args: Any, **kwargs: Any) -> SceneModel:
        # Binding raises TypeError for unknown, repeated and missing arguments, as a function
        # with this signature would; Rust fills in the defaults and checks the values by name.
        return _scene_model(name, signature.bind(*args, **kwargs).arguments)

    scene.__name__ = scene.__qualname__ = name
    scene.__doc__ = _docstring(entry)
    scene.__module__ = __name__
    setattr(scene, "__signature__", signature)
    return scene


def _stub() -> str:
    """The text of ``scenes.pyi``: the scene functions' signatures for static typing."""
    entries = _lagrangian.scene_catalog()
    out = [
        '"""Generated from the scene registry by ``lagrangian.scenes._stub()``: do not edit; '
        'regenerate with\n``python -c "from lagrangian import scenes; '
        "print(scenes._stub(), end='')\" > python/lagrangian/scenes.pyi``.\"\"\"",
        "",
        "from typing import Any, Dict, List, Sequence, Tuple",
        "",
        "from ._constrained_scenes import (",
        *(f"    {name} as {name}," for name in sorted(CONSTRAINED)),
        ")",
        "from ._body_scenes import (",
        *(f"    {name} as {name}," for name in sorted(BODIES)),
        ")",
        "from ._scene_model import SceneModel as SceneModel",
        "from ._vehicle_scenes import (",
        *(f"    {name} as {name}," for name in sorted(VEHICLES)),
        ")",
        "",
        "__all__: List[str]",
        "CONSTRAINED: Tuple[str, ...]",
        "VEHICLES: Tuple[str, ...]",
        "BODIES: Tuple[str, ...]",
        "",
        "def catalog() -> List[Dict[str, Any]]: ...",
    ]
    for entry in entries:
        params = ", ".join(
            f"{p.name}: {p.annotation}"
            + ("" if p.default is inspect.Parameter.empty else f" = {p.default!r}")
            for p in _signature(entry).parameters.values()
        )
        out.append(f"def {entry['name']}({params}) -> SceneModel: ...")
    return "\n".join(out) + "\n"


def _install() -> Tuple[str, ...]:
    names = []
    for entry in _lagrangian.scene_catalog():
        globals()[entry["name"]] = _function(entry)
        names.append(entry["name"])
    return tuple(names)


__all__ += _install()


def __dir__() -> List[str]:
    """The public names only (PEP 562): the scenes, the constrained scenes, the vehicles, the
    scenes with bodies, ``SceneModel``, ``catalog``, ``CONSTRAINED``, ``VEHICLES`` and ``BODIES``
    — not the helpers this module imports to make them."""
    public = {*__all__, *CONSTRAINED, *VEHICLES, *BODIES, "SceneModel", "catalog", "CONSTRAINED",
              "VEHICLES", "BODIES"}
    return sorted(public | {n for n in globals() if n.startswith("__") and n.endswith("__")})
