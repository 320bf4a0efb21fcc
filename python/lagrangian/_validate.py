"""Checking what the user gives, in one place for models, events, runs, ensembles and pictures:
state vectors, numbers and counts, coordinates, parameters and the symbols of expressions, a
model's parts and drawing, an event's arguments, the run options, an ensemble's sweep, a
linearization's inputs, a picture's file name. Each check raises ``TypeError`` or ``ValueError``
with a message that says what to give instead. Of the run options only the types are checked
here (:func:`run_options`, for ``simulate``, ``integrator`` and ``simulate_many`` alike); their
values are checked in Rust, one message each. What needs a type defined above this module stays
beside that type: the expression language checks its own operands (``_expr``, below this
module), ``_events`` that a list of events holds ``Event`` objects, ``_ensemble`` that an executor
is one, ``_plot`` and ``_solution`` that a solution's arrays fit its drawing, ``_sympy`` the SymPy
objects it converts, and the report tooling its own plans (``_workprec``)."""

from __future__ import annotations

import math
import numbers
import os
from pathlib import Path
from typing import Any, Dict, List, Mapping, NamedTuple, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from ._expr import Coordinate, Expr, Parameter

__all__ = [
    "FloatArray",
    "ModelParts",
    "at_least_one",
    "check_coordinates",
    "check_parameters",
    "check_symbols",
    "constraint_rows",
    "drawing_points",
    "event_direction",
    "event_expression",
    "event_reset",
    "event_samples",
    "event_terminal",
    "expressions",
    "file_suffix",
    "finite_positive",
    "flag",
    "input_names",
    "integer",
    "known_parameters",
    "model_parts",
    "number",
    "parameter_columns",
    "positive",
    "real",
    "run_count",
    "run_options",
    "state_pairs",
    "states",
    "states_at_times",
    "sweep_parameters",
    "taylor_order",
    "vector",
]

FloatArray = npt.NDArray[np.float64]

#: What :func:`run_options` returns: ``(t0, t_end, method, dt, rtol, atol, t_eval, max_steps,
#: output_every)``.
RunOptions = Tuple[
    float, Optional[float], str, Optional[float], float, float, Optional[FloatArray],
    Optional[int], Optional[int],
]


def _not_a_number(what: str, value: object, n: int) -> None:
    """Reject a string or ``None`` (which NumPy would read as characters or as NaN)."""
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{what} must be a sequence of {n} numbers, got a string")
    if value is None:
        raise ValueError(f"{what} is None, which is not a number: give a sequence of {n} numbers")


def _non_finite(what: str, value: object, arr: FloatArray) -> ValueError:
    """The error for the first entry of ``arr`` that is not finite: an entry given as ``None``
    (NaN to NumPy) is named as such."""
    index = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
    label = f"{what}[{', '.join(map(str, index))}]"
    try:
        given = np.asarray(value, dtype=object)
        entry = given[index] if given.shape == arr.shape else given.reshape(arr.shape)[index]
    except (TypeError, ValueError, IndexError):
        entry = arr[index]
    if entry is None:
        return ValueError(f"{label} is None, which is not a number")
    return ValueError(f"{label} = {arr[index]} is not finite")


def vector(what: str, value: object, n: int) -> FloatArray:
    """``value`` as a float vector of length ``n``, or a ``ValueError`` that says why not."""
    _not_a_number(what, value, n)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{what} must be a sequence of {n} numbers: {e}") from None
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1 or arr.shape[0] != n:
        raise ValueError(
            f"{what} has shape {arr.shape} but the model has {n} coordinates"
        )
    if not np.isfinite(arr).all():
        raise _non_finite(what, value, arr)
    return np.ascontiguousarray(arr)


def states(what: str, value: object, n: int) -> FloatArray:
    """``value`` as one state (a float vector of length ``n``) or ``k`` states as the rows of a
    float array of shape ``(k, n)``, or a ``ValueError`` that says why not."""
    _not_a_number(what, value, n)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{what} must be a sequence of {n} numbers: {e}") from None
    if arr.ndim != 2:
        return vector(what, value, n)
    if arr.shape[1] != n:
        raise ValueError(
            f"{what} has shape {arr.shape} but needs ({n},) or (k, {n}) for k states: "
            f"the model has {n} coordinates"
        )
    if not np.isfinite(arr).all():
        raise _non_finite(what, value, arr)
    return np.ascontiguousarray(arr)


def real(what: str, value: object) -> float:
    """``value`` as a finite float: ``TypeError`` for a non-number, ``ValueError`` if not finite."""
    if type(value) is float:  # the common case, without the ABC check below
        x = value
    elif isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{what} must be a real number, got {value!r}")
    else:
        x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{what} = {x} is not finite")
    return x


def check_coordinates(coordinates: object) -> Tuple[Coordinate, ...]:
    """The model's coordinates as a tuple: distinct ``Coordinate`` objects, at least one."""
    if isinstance(coordinates, Expr) or not isinstance(coordinates, (list, tuple)):
        raise TypeError(
            "coordinates must be a list of coordinates from lagrangian.coordinates(...)"
        )
    coords = tuple(coordinates)
    if not coords:
        raise ValueError("a model needs at least one coordinate")
    for c in coords:
        if not isinstance(c, Coordinate):
            raise TypeError(
                f"{c!r} is not a coordinate: make coordinates with lagrangian.coordinates(...)"
            )
    names = [c.name for c in coords]
    if len(set(names)) != len(names):
        raise ValueError(f"repeated coordinate names in {names}")
    return coords


def check_parameters(parameters: Optional[Mapping[str, float]]) -> Dict[str, float]:
    """Parameter values by name (a ``Parameter`` key is read as its name), each finite."""
    if parameters is None:
        return {}
    if not isinstance(parameters, Mapping):
        raise TypeError("parameters must be a mapping of names to numbers")
    values: Dict[str, float] = {}
    for k, v in parameters.items():
        name = k.name if isinstance(k, Expr) and k.op == "param" else k
        if not isinstance(name, str):
            raise TypeError(f"parameter names must be strings, got {k!r}")
        values[name] = real(f"parameter {name!r}", v)
    return values


def check_symbols(
    what: str,
    e: Expr,
    coordinates: Any,
    values: Mapping[str, Any],
    velocities: bool,
    used: Dict[str, None],
) -> None:
    """Check the free symbols of ``e`` (the ``what`` of a model): coordinates of the model,
    velocities only where ``velocities``, parameters with a value; record the parameters in
    ``used``."""
    for s in e.free_symbols():
        if s.op in ("q", "qd"):
            name = s.args[0]
            if name not in coordinates:
                raise ValueError(
                    f"{s!r} in the {what} is not a coordinate of this model "
                    f"(coordinates: {', '.join(sorted(coordinates))})"
                )
            if s.op == "qd" and not velocities:
                raise ValueError(
                    f"the {what} depends on the velocity {s!r}: velocity-dependent terms belong "
                    "in the kinetic energy (or the forces)"
                )
        elif s.op == "param":
            name = s.args[0]
            if name not in values:
                raise ValueError(
                    f"parameter {name!r} in the {what} has no value: pass "
                    f"parameters={{{name!r}: ...}}"
                )
            used.setdefault(name, None)


def number(what: str, value: object) -> float:
    """``value`` as a float, checking its type only (``TypeError`` for a non-number): for the
    options, whose values are validated in Rust."""
    if type(value) is float:
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{what} must be a real number, got {value!r}")
    return float(value)


def integer(what: str, value: object) -> int:
    """``value`` as an int, checking its type only (``TypeError`` for a non-integer)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{what} must be an integer, got {value!r}")
    return int(value)


def drawing_points(points: object, what: str) -> Tuple[Tuple[Expr, ...], ...]:
    """Points to draw: a non-empty sequence of 2- or 3-tuples of expressions (all the same
    length) without velocities."""
    if isinstance(points, (Expr, str)) or not isinstance(points, Sequence):
        raise TypeError(
            f"{what} must be a sequence of points (x, y) or (x, y, z) of expressions, "
            f"got {points!r}"
        )
    out = []
    for j, p in enumerate(points):
        if isinstance(p, (Expr, str)) or not isinstance(p, Sequence):
            raise TypeError(f"{what} point {j} must be a tuple (x, y) or (x, y, z), got {p!r}")
        out.append(tuple(Expr.lift(x) for x in p))
    if not out:
        raise ValueError(f"{what} is empty: give at least one point (x, y)")
    dims = {len(r) for r in out}
    if len(dims) != 1 or dims.pop() not in (2, 3):
        raise ValueError(f"every {what} point must have 2 or 3 components, all the same")
    for j, r in enumerate(out):
        for x in r:
            for sym in x.free_symbols():
                if sym.op == "qd":
                    raise ValueError(
                        f"{what} point {j} depends on the velocity {sym!r}: a drawing is a "
                        "function of t, the coordinates and parameters"
                    )
    return tuple(out)


def flag(what: str, value: object) -> bool:
    """``value`` if it is ``True`` or ``False``, else a ``TypeError``."""
    if value is not True and value is not False:
        raise TypeError(f"{what} must be True or False, got {value!r}")
    return value


def positive(what: str, value: object) -> float:
    """``value`` as a float > 0 (``TypeError`` for a non-number, ``ValueError`` otherwise)."""
    x = number(what, value)
    if not x > 0:
        raise ValueError(f"{what} = {value} must be > 0")
    return x


def finite_positive(what: str, value: object) -> float:
    """``value`` as a finite float > 0 (``TypeError`` for a non-number, ``ValueError``
    otherwise): a frame rate."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{what} must be a number, got {value!r}")
    x = float(value)
    if not (math.isfinite(x) and x > 0.0):
        raise ValueError(f"{what} = {value} must be finite and > 0")
    return x


def file_suffix(path: Union[str, "os.PathLike[str]"], allowed: Sequence[str], what: str) -> Path:
    """``path`` as a ``Path`` whose suffix (any case) is one of ``allowed``: how to write
    ``what`` is told by the file name."""
    p = Path(os.fspath(path))
    if p.suffix.lower() not in allowed:
        raise ValueError(
            f"cannot tell how to write {what} to {str(p)!r}: the file name must end in "
            + ", ".join(allowed)
        )
    return p


def at_least_one(what: str, value: object, unit: str = "") -> int:
    """``value`` as an int of at least 1 (``TypeError`` for a non-integer, ``ValueError`` below
    1): a number of threads, chunks or frames."""
    n = integer(what, value)
    if n < 1:
        raise ValueError(f"{what} = {n}: give at least one{' ' + unit if unit else ''}")
    return n


def run_options(
    t0: Any,
    t_end: Any,
    method: Any,
    dt: Any,
    rtol: Any,
    atol: Any,
    t_eval: Any = None,
    max_steps: Any = None,
    output_every: Any = None,
) -> RunOptions:
    """The options of a run — of ``simulate``, ``integrator`` (no ``t_end``, no ``t_eval``) and
    each of ``simulate_many``'s runs — with their types checked, in this one place: the times
    finite floats, the tolerances and ``dt`` floats, ``t_eval`` a float vector, the counts
    integers. Their values (a known method, tolerances > 0, a ``dt`` towards ``t_end``) are
    checked in Rust, one message each. A finite float passes at the cost of a comparison
    (x − x is 0 unless x is not finite): a short run's fixed cost is most of what it costs."""
    if type(method) is not str and not isinstance(method, str):
        raise TypeError(f"method must be a string such as 'dop853', got {method!r}")
    if type(t0) is not float or t0 - t0 != 0.0:
        t0 = real("t0", t0)
    if t_end is not None and (type(t_end) is not float or t_end - t_end != 0.0):
        t_end = real("t_end", t_end)
    if type(rtol) is not float:
        rtol = number("rtol", rtol)
    if type(atol) is not float:
        atol = number("atol", atol)
    if dt is not None:
        dt = number("dt", dt)
    times = None
    if t_eval is not None:
        times = np.ascontiguousarray(np.asarray(t_eval, dtype=np.float64))
        if times.ndim != 1:
            raise ValueError(f"t_eval must be one-dimensional, got shape {times.shape}")
    if max_steps is not None:
        max_steps = integer("max_steps", max_steps)
    if output_every is not None and type(output_every) is not int:
        output_every = integer("output_every", output_every)
    return t0, t_end, method, dt, rtol, atol, times, max_steps, output_every


def sweep_parameters(
    parameters: Optional[Mapping[str, Any]], known: Mapping[str, Any]
) -> Tuple[Dict[str, float], Dict[str, FloatArray]]:
    """An ensemble's ``parameters=``: the values fixed for every run and the swept ones (a finite
    value per run), each a parameter of the model (``known``)."""
    fixed: Dict[str, float] = {}
    sweep: Dict[str, FloatArray] = {}
    known_parameters(parameters or {}, known)
    for name, value in (parameters or {}).items():
        arr = np.asarray(value, dtype=np.float64)
        if arr.ndim == 0:
            fixed[name] = real(f"parameter {name!r}", value)
            continue
        if arr.ndim != 1:
            raise ValueError(
                f"parameter {name!r} must be a number or one value per run, got shape {arr.shape}"
            )
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ValueError(f"parameter {name!r}[{bad[0]}] = {arr[bad[0]]} is not finite")
        sweep[name] = np.ascontiguousarray(arr)
    return fixed, sweep


def run_count(q: FloatArray, qd: FloatArray, sweep: Mapping[str, FloatArray]) -> int:
    """The number of runs of an ensemble: the rows of the initial states (k, n) and the values
    of the swept parameters, which must agree (one row for all runs counts for any number)."""
    sizes: Dict[str, int] = {}
    for what, a in (("q0", q), ("qd0", qd)):
        if a.ndim == 2:
            sizes[f"{what} has {len(a)} rows"] = len(a)
    for name, v in sweep.items():
        sizes[f"parameter {name!r} has {len(v)} values"] = len(v)
    if len(set(sizes.values())) > 1:
        raise ValueError(
            "the runs do not agree in number: " + ", ".join(sizes)
            + " (give one row or value per run, or one for all)"
        )
    return next(iter(sizes.values()), 1)


def parameter_columns(
    names: Sequence[str], sweep: Mapping[str, FloatArray], values: Mapping[str, Any], k: int
) -> FloatArray:
    """The values of the parameters ``names`` in each of k runs, shape (k, len(names)): the
    swept ones from ``sweep``, the others fixed at ``values``."""
    if not names:
        return np.zeros((k, 0), dtype=np.float64)
    return np.ascontiguousarray(
        np.column_stack(
            [sweep[name] if name in sweep else np.full(k, values[name]) for name in names]
        ),
        dtype=np.float64,
    )

class ModelParts(NamedTuple):
    """What :class:`Model` is made of, checked by :func:`model_parts`."""

    coordinates: Tuple[Coordinate, ...]
    energies: Tuple[Optional[Expr], Optional[Expr], Optional[Expr]]
    forces: Optional[Tuple[Expr, ...]]
    positions: Optional[Tuple[Tuple[Expr, ...], ...]]
    masses: Optional[Tuple[Expr, ...]]
    parameters: Dict[str, float]
    backend: str
    drawing: Optional[Tuple[Tuple[Expr, ...], ...]]
    #: Holonomic rows g(t, q) = 0 and velocity rows a(t, q)·q̇ + b(t, q) = 0, each as
    #: (name, expression); empty without constraints.
    constraints: Tuple[Tuple[str, Expr], ...] = ()
    velocity_constraints: Tuple[Tuple[str, Expr], ...] = ()


def expressions(what: str, value: Any, n: int) -> Tuple[Expr, ...]:
    """``value`` as n expressions, one per coordinate (generalized forces, loads)."""
    if isinstance(value, (Expr, numbers.Real)):
        raise ValueError(f"{what} must be a sequence of {n} expressions, one per coordinate")
    out = tuple(Expr.lift(x) for x in value)
    if len(out) != n:
        raise ValueError(f"{what} has {len(out)} entries but the model has {n} coordinates")
    return out


def constraint_rows(what: str, value: Any, default: str) -> Tuple[Tuple[str, Expr], ...]:
    """``constraints=`` or ``velocity_constraints=`` as (name, expression) rows: a sequence of
    expressions (named ``default`` + index) or a mapping of names to expressions."""
    if value is None:
        return ()
    if isinstance(value, (Expr, numbers.Real, str, bytes)):
        raise TypeError(
            f"{what} must be a list of expressions or a dict of names to expressions, "
            f"got {value!r}"
        )
    if isinstance(value, Mapping):
        items = list(value.items())
        for name, _ in items:
            if not isinstance(name, str) or not name:
                raise TypeError(f"the names of {what} must be non-empty strings, got {name!r}")
    else:
        try:
            items = [(f"{default} {i}", e) for i, e in enumerate(value)]
        except TypeError:
            raise TypeError(
                f"{what} must be a list of expressions or a dict of names to expressions, "
                f"got {value!r}"
            ) from None
    return tuple((name, Expr.lift(e)) for name, e in items)


def model_parts(
    coordinates: object,
    kinetic: Any,
    potential: Any,
    dissipation: Any,
    forces: Any,
    parameters: Any,
    positions: Any,
    masses: Any,
    backend: object,
    drawing: Any,
    constraints: Any = None,
    velocity_constraints: Any = None,
) -> ModelParts:
    """The arguments of :class:`Model` checked: the coordinates, the route (energies, or
    particle positions and masses), the symbols of every expression (coordinates of the model,
    velocities where they may appear, parameters with values, each value used), the backend and
    the constraints (a holonomic row may not read a velocity; names distinct)."""
    if not isinstance(backend, str):
        raise TypeError(
            f"backend must be a string, 'native' or 'interpreter', got {backend!r}"
        )
    coords = check_coordinates(coordinates)
    dof = len(coords)
    t_ = None if kinetic is None else Expr.lift(kinetic)
    u_ = None if potential is None else Expr.lift(potential)
    r_ = None if dissipation is None else Expr.lift(dissipation)
    f_ = None if forces is None else expressions("forces", forces, dof)
    pos: Optional[Tuple[Tuple[Expr, ...], ...]] = None
    mass: Optional[Tuple[Expr, ...]] = None
    if (positions is None) != (masses is None):
        raise ValueError("positions and masses go together (the particle route)")
    if positions is not None and masses is not None:
        if kinetic is not None:
            raise ValueError(
                "give either kinetic= (the energy route) or positions= and masses= "
                "(the particle route), not both"
            )
        pos = tuple(tuple(Expr.lift(x) for x in r) for r in positions)
        mass = tuple(Expr.lift(m) for m in masses)
        if not pos:
            raise ValueError("positions is empty")
        dims = {len(r) for r in pos}
        if len(dims) != 1 or dims.pop() not in (2, 3):
            raise ValueError("every position must have 2 or 3 components, all the same")
        if len(mass) != len(pos):
            raise ValueError(
                f"{len(mass)} masses for {len(pos)} positions: give one mass per position"
            )
    elif kinetic is None:
        raise ValueError(
            "the model needs kinetic= (T) or positions= and masses= (the particle route)"
        )

    values = check_parameters(parameters)
    names = {c.name for c in coords}
    used: Dict[str, None] = {}
    checks: List[Tuple[str, Expr, bool]] = []
    for what, e, velocities in (
        ("kinetic energy", t_, True),
        ("potential", u_, False),
        ("dissipation function", r_, True),
    ):
        if e is not None:
            checks.append((what, e, velocities))
    for i, f in enumerate(f_ or ()):
        checks.append((f"force on {coords[i].name}", f, True))
    for j, r in enumerate(pos or ()):
        for x in r:
            checks.append((f"position of particle {j}", x, False))
    points = None if drawing is None else drawing_points(drawing, "drawing")
    for j, r in enumerate(points or ()):
        for x in r:
            checks.append((f"drawing point {j}", x, False))
    held = constraint_rows("constraints", constraints, "constraint")
    moving = constraint_rows("velocity_constraints", velocity_constraints, "velocity constraint")
    row_names = [name for name, _ in held + moving]
    if len(set(row_names)) != len(row_names):
        repeated = next(n for n in row_names if row_names.count(n) > 1)
        raise ValueError(f"two constraints are named {repeated!r}: give each row its own name")
    for name, e in held:
        read = [s for s in e.free_symbols() if s.op == "qd"]
        if read:
            raise ValueError(
                f"the constraint {name!r} reads the velocity {read[0]!r}: a holonomic "
                "constraint g(t, q) = 0 is stated in t, the coordinates and parameters; give a "
                "constraint on the velocities in velocity_constraints=[a(t, q)·q̇ + b(t, q)] "
                "instead"
            )
        checks.append((f"constraint {name!r}", e, False))
    for name, e in moving:
        checks.append((f"velocity constraint {name!r}", e, True))
    for what, e, velocities in checks:
        check_symbols(what, e, names, values, velocities, used)
    for j, m in enumerate(mass or ()):
        for s in m.free_symbols():
            if s.op != "param":
                raise ValueError(
                    f"the mass of particle {j} depends on {s!r}: masses are numbers and "
                    "parameters only"
                )
        check_symbols(f"mass of particle {j}", m, names, values, False, used)
    unknown = [k for k in values if k not in used]
    if unknown:
        raise ValueError(
            f"unknown parameter {unknown[0]!r}: no expression of the model uses it "
            f"(parameters used: {', '.join(used) or 'none'})"
        )

    return ModelParts(
        coords, (t_, u_, r_), f_, pos, mass, values, backend, points, held, moving
    )


def input_names(
    inputs: object, parameters: Mapping[str, Any], has_expressions: bool
) -> Tuple[str, ...]:
    """The parameter names ``inputs`` of ``Model.linearize`` (a ``Parameter`` stands for its
    name), each a parameter of a model stated by its expressions."""
    if isinstance(inputs, str) or not isinstance(inputs, (Sequence, np.ndarray)):
        raise TypeError(
            f"inputs must be a sequence of parameter names, such as inputs=['F'], "
            f"got {inputs!r}"
        )
    names = tuple(k.name if isinstance(k, Parameter) else k for k in inputs)
    if not has_expressions:
        raise ValueError(
            "inputs= needs a model stated by its expressions: a ready-made scene is written "
            "in Rust and has none to differentiate; state it as lg.Model(..., "
            "parameters={...}) and name those parameters as inputs"
        )
    if not parameters:
        raise ValueError(
            "the model has no parameters to take as inputs: give it parameters={name: "
            "value} (lg.parameters) where the inputs enter, and name them in inputs="
        )
    for k in names:
        if not isinstance(k, str) or k not in parameters:
            raise ValueError(
                f"unknown input {k!r}: inputs are parameter names; the model's parameters "
                f"are {', '.join(parameters)}"
            )
    return names


def known_parameters(values: Mapping[str, Any], parameters: Mapping[str, Any]) -> None:
    """A ``ValueError`` naming the first of ``values`` that is not one of ``parameters``."""
    unknown = [k for k in values if k not in parameters]
    if unknown:
        raise ValueError(
            f"unknown parameter {unknown[0]!r}; the model's parameters are "
            f"{', '.join(parameters) or 'none'}"
        )


def state_pairs(q: object, qd: object, n: int) -> Tuple[FloatArray, FloatArray]:
    """One state (q, q̇), or k states as the rows of both, with the same shape."""
    q_arr, qd_arr = states("q", q, n), states("qd", qd, n)
    if q_arr.shape != qd_arr.shape:
        raise ValueError(
            f"q has shape {q_arr.shape} but qd has shape {qd_arr.shape}: give one "
            "state, or k states as the rows of both"
        )
    return q_arr, qd_arr


def states_at_times(times: FloatArray, q: object, n: int) -> Tuple[FloatArray, FloatArray]:
    """The times (one-dimensional) and the coordinates at each of them (one row per time)."""
    if times.ndim != 1:
        raise ValueError(f"t must be a number or one-dimensional, got shape {times.shape}")
    rows = np.ascontiguousarray(np.asarray(q, dtype=np.float64))
    if rows.shape != (times.shape[0], n):
        raise ValueError(
            f"q has shape {rows.shape} but {times.shape[0]} times need "
            f"({times.shape[0]}, {n})"
        )
    return np.ascontiguousarray(times), rows


def taylor_order(order: object) -> int:
    """The order of a Taylor expansion: an integer of at least 1 (at most 100, checked in
    Rust)."""
    k = integer("order", order)
    if k < 1:
        raise ValueError(f"order = {k}: give an order from 1 to 100")
    return k


# -- the arguments of an Event -------------------------------------------------------------


def event_expression(what: str, value: object) -> Expr:
    """An event's condition or reset value: an expression, or a number lifted to one."""
    if isinstance(value, Expr):
        return value
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return Expr.lift(float(value))
    raise TypeError(f"the event's {what} must be an expression or a number, got {value!r}")


def event_direction(direction: object) -> int:
    """The direction of the sign changes an event looks for: +1, −1 or 0."""
    if isinstance(direction, bool) or not isinstance(direction, numbers.Integral):
        raise TypeError(f"direction must be +1, -1 or 0, got {direction!r}")
    if direction not in (-1, 0, 1):
        raise ValueError(
            f"direction = {direction}: use +1 (rising), -1 (falling) or 0 (either)"
        )
    return int(direction)


def event_terminal(terminal: object) -> int:
    """Whether an event ends the run (a bool) or after how many occurrences (an int ≥ 1)."""
    if isinstance(terminal, bool):
        return int(terminal)
    if isinstance(terminal, numbers.Integral):
        if terminal < 1:
            raise ValueError(
                f"terminal = {terminal}: give True, False or a count of occurrences ≥ 1"
            )
        return int(terminal)
    raise TypeError(f"terminal must be a bool or an int, got {terminal!r}")


def event_reset(reset: object) -> Tuple[Tuple[Expr, Expr], ...]:
    """An event's reset: (coordinate or velocity, new value) pairs from a mapping."""
    pairs: List[Tuple[Expr, Expr]] = []
    if reset is not None:
        if not isinstance(reset, Mapping):
            raise TypeError(
                "reset must be a mapping from coordinates or velocities to expressions, "
                f"such as {{y.d: -e * y.d}}; got {reset!r}"
            )
        for key, value in reset.items():
            if not (isinstance(key, Expr) and key.op in ("q", "qd")):
                raise ValueError(
                    f"reset key {key!r} is neither a coordinate nor a velocity (x or x.d)"
                )
            pairs.append((key, event_expression(f"reset of {key!r}", value)))
    return tuple(pairs)


def event_samples(samples: object) -> int:
    """The interior points per step where an event's condition is sampled: 0 to 1000."""
    if isinstance(samples, bool) or not isinstance(samples, numbers.Integral):
        raise TypeError(f"samples must be an int, got {samples!r}")
    n = int(samples)
    if not 0 <= n <= 1000:
        raise ValueError(f"samples = {samples}: give 0 to 1000 interior points per step")
    return n
