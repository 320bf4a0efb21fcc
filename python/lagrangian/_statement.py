"""A model's statement — the checked parts it is made of (``_validate.ModelParts``) — in the three
forms it takes: compiled to the native model, written back as ``Model(...)`` (``repr``), and as
plain data that pickles and rebuilds it."""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence

from . import _lagrangian
from ._expr import Coordinate, Expr, deserialize, serialize, to_raw
from ._validate import ModelParts

__all__ = ["arguments_of", "compile_parts", "describe", "state_of"]

_PART_NAMES = ("kinetic", "potential", "dissipation")


def compile_parts(p: ModelParts) -> Any:
    """The native model of these parts: the expressions serialized into one graph, symbol names
    to the indices Rust reads, eq. 55 derived and compiled there."""
    roots: List[Expr] = []
    slots: Dict[str, Any] = {}
    for key, e in (
        ("kinetic", p.energies[0]),
        ("potential", p.energies[1]),
        ("dissipation", p.energies[2]),
    ):
        if e is not None:
            slots[key] = len(roots)
            roots.append(e)
    if p.forces is not None:
        slots["forces"] = list(range(len(roots), len(roots) + len(p.forces)))
        roots.extend(p.forces)
    dim = 0
    if p.positions is not None and p.masses is not None:
        dim = len(p.positions[0])
        flat = [x for r in p.positions for x in r]
        slots["positions"] = list(range(len(roots), len(roots) + len(flat)))
        roots.extend(flat)
        slots["masses"] = list(range(len(roots), len(roots) + len(p.masses)))
        roots.extend(p.masses)
    names: List[str] = []
    for key, rows in (
        ("constraints", p.constraints),
        ("velocity_constraints", p.velocity_constraints),
    ):
        if rows:
            slots[key] = list(range(len(roots), len(roots) + len(rows)))
            roots.extend(e for _, e in rows)
            names.extend(name for name, _ in rows)
    nodes, ids = serialize(roots)
    raw = to_raw(nodes, p.coordinates, list(p.parameters))

    def at(x: Any) -> Any:
        return [ids[i] for i in x] if isinstance(x, list) else ids[x]

    return _lagrangian.NativeModel.compile(
        raw,
        len(p.coordinates),
        [float(v) for v in p.parameters.values()],
        dim=dim,
        backend=p.backend,
        constraint_names=names,
        **{k: at(v) for k, v in slots.items()},
    )


def describe(p: ModelParts) -> str:
    """``Model(...)``: the parts as they would be given."""
    parts = [f"coordinates=[{', '.join(c.name for c in p.coordinates)}]"]
    if p.energies[0] is not None:
        parts.append(f"kinetic={p.energies[0]!r}")
    if p.positions is not None and p.masses is not None:
        parts.append(
            "positions=["
            + ", ".join("(" + ", ".join(repr(x) for x in r) + ")" for r in p.positions)
            + "]"
        )
        parts.append("masses=[" + ", ".join(repr(m) for m in p.masses) + "]")
    if p.energies[1] is not None:
        parts.append(f"potential={p.energies[1]!r}")
    if p.energies[2] is not None:
        parts.append(f"dissipation={p.energies[2]!r}")
    if p.forces is not None:
        parts.append("forces=[" + ", ".join(repr(f) for f in p.forces) + "]")
    if p.parameters:
        parts.append(f"parameters={p.parameters!r}")
    if p.backend != "native":
        parts.append(f"backend={p.backend!r}")
    for key, rows in (
        ("constraints", p.constraints),
        ("velocity_constraints", p.velocity_constraints),
    ):
        if rows:
            parts.append(
                f"{key}={{" + ", ".join(f"{n!r}: {e!r}" for n, e in rows) + "}"
            )
    if p.drawing is not None:
        parts.append(
            "drawing=["
            + ", ".join("(" + ", ".join(repr(x) for x in r) + ")" for r in p.drawing)
            + "]"
        )
    return "Model(" + ", ".join(parts) + ")"


def state_of(p: ModelParts) -> Dict[str, Any]:
    """The parts as plain data for pickling: names, the serialized expression graph and where
    each part's expressions sit in it (rebuilt, and compiled again, by :func:`arguments_of`)."""
    roots: List[Expr] = []
    layout: Dict[str, Any] = {}

    def add(key: str, items: Sequence[Expr]) -> None:
        layout[key] = (len(roots), len(items))
        roots.extend(items)

    for key, e in (
        ("kinetic", p.energies[0]),
        ("potential", p.energies[1]),
        ("dissipation", p.energies[2]),
    ):
        if e is not None:
            add(key, [e])
    if p.forces is not None:
        add("forces", p.forces)
    if p.positions is not None and p.masses is not None:
        layout["dim"] = len(p.positions[0])
        add("positions", [x for r in p.positions for x in r])
        add("masses", p.masses)
    if p.drawing is not None:
        layout["drawing_dim"] = len(p.drawing[0])
        add("drawing", [x for r in p.drawing for x in r])
    names: Dict[str, List[str]] = {}
    for key, rows in (
        ("constraints", p.constraints),
        ("velocity_constraints", p.velocity_constraints),
    ):
        if rows:
            add(key, [e for _, e in rows])
            names[key] = [n for n, _ in rows]
    nodes, ids = serialize(roots)
    state: Dict[str, Any] = {
        "coordinates": [c.name for c in p.coordinates],
        "nodes": nodes,
        "roots": ids,
        "layout": layout,
        "parameters": dict(p.parameters),
        "backend": p.backend,
    }
    if names:
        state["constraint_names"] = names
    return state


def arguments_of(state: Dict[str, Any]) -> Dict[str, Any]:
    """The keyword arguments of ``Model`` that :func:`state_of` stored."""
    exprs = deserialize(state["nodes"], state["roots"])
    layout = state["layout"]

    def get(key: str) -> Optional[List[Expr]]:
        if key not in layout:
            return None
        start, count = layout[key]
        return exprs[start : start + count]

    one = {k: (v[0] if v else None) for k in _PART_NAMES for v in [get(k)]}
    positions = None
    flat = get("positions")
    if flat is not None:
        dim = layout["dim"]
        positions = [tuple(flat[i : i + dim]) for i in range(0, len(flat), dim)]
    drawing = None
    flat = get("drawing")
    if flat is not None:
        dim = layout["drawing_dim"]
        drawing = [tuple(flat[i : i + dim]) for i in range(0, len(flat), dim)]
    named = state.get("constraint_names", {})

    def rows(key: str) -> Optional[Dict[str, Expr]]:
        exprs = get(key)
        return None if exprs is None else dict(zip(named[key], exprs))

    return dict(
        coordinates=[Coordinate(n) for n in state["coordinates"]],
        kinetic=one["kinetic"],
        potential=one["potential"],
        dissipation=one["dissipation"],
        forces=get("forces"),
        parameters=state["parameters"],
        positions=positions,
        masses=get("masses"),
        backend=state.get("backend", "native"),
        drawing=drawing,
        constraints=rows("constraints"),
        velocity_constraints=rows("velocity_constraints"),
    )
