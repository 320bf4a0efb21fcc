"""Events: conditions whose sign changes :meth:`Model.simulate` locates along a run."""

from __future__ import annotations

import numbers
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

from ._expr import Coordinate, Expr, ExprLike, serialize, to_raw
from ._validate import (
    check_symbols,
    event_direction,
    event_expression,
    event_reset,
    event_samples,
    event_terminal,
)

__all__ = ["Event"]


class Event:
    """A condition g(t, q, q̇) whose sign changes are located along a run.

    Pass events to :meth:`Model.simulate` (``events=[...]``); each occurrence is recorded in
    the solution's ``t_events``, ``q_events`` and ``qd_events`` (one array per event, in the
    order given). The condition is compiled like the energies. Every step is searched at its
    end and at ``samples`` interior points, so a condition that changes sign and back inside
    one step is still seen, and each sign change is refined by Brent's method to round-off in
    t on the method's own interpolant: the continuous extension of DOPRI5 and DOP853 (which
    screen each step on the free quintic Hermite polynomial through its ends first, and build
    the extension only where the condition changes sign), the quintic Hermite polynomial for
    every other method. After a reset the events at its time sit on their roots: each takes
    its sign again a thousandth into the next step (a crossing closer than that is not seen).
    Events at one time are all recorded; of their resets, the first event's applies.

    >>> import lagrangian as lg
    >>> y, = lg.coordinates("y")
    >>> ball = lg.Model(coordinates=[y], kinetic=0.5 * y.d**2, potential=9.81 * y)
    >>> floor = lg.Event(y, direction=-1, reset={y.d: -0.8 * y.d}, name="floor")
    >>> sol = ball.simulate([1.0], [0.0], 3.0, events=[floor], rtol=1e-10, atol=1e-12)
    >>> [round(float(t), 6) for t in sol.t_events[0][:3]]   # √(2h/g), then + 2 eʲ v₁/g
    [0.451524, 1.173961, 1.751912]

    Parameters
    ----------
    condition : expression
        g in the model's coordinates, their velocities (``x.d``), the time ``lg.t`` and the
        model's parameters. An event is a change of its sign between non-zero values (touching
        zero and turning back is none).
    direction : int
        +1: only rising changes (− to +), −1: only falling ones, 0: both.
    terminal : bool or int
        ``True`` stops the run at the first occurrence; an int k ≥ 1 at the k-th. The
        solution then ends at the event (``status`` 1, ``message`` names it).
    reset : mapping, optional
        New values of coordinates or velocities at each occurrence, as expressions evaluated
        at the state of the event (all from the state before the reset): an impact law such as
        ``{y.d: -e * y.d}``. The run goes on from the new state, with the same method; the
        trajectory keeps the state before and after the jump at the event time. A terminal
        occurrence ends the run before its reset.
    name : str, optional
        Used in messages and ``Solution.event_names``; by default the condition's formula.
    samples : int
        Interior points of each step at which g is sampled (default 4). More find sign
        changes that come closer together, at the cost of evaluations.

    Raises
    ------
    TypeError, ValueError
        For a condition or reset that is not an expression, a direction other than −1, 0, +1,
        a terminal count below 1, a reset of something that is not a coordinate or a velocity.
    """

    __slots__ = ("condition", "direction", "terminal", "reset", "name", "samples")

    condition: Expr
    direction: int
    terminal: int
    reset: Tuple[Tuple[Expr, Expr], ...]
    name: str
    samples: int

    def __init__(
        self,
        condition: ExprLike,
        direction: int = 0,
        terminal: Union[bool, int] = False,
        reset: Optional[Mapping[Expr, ExprLike]] = None,
        name: Optional[str] = None,
        samples: int = 4,
    ) -> None:
        self.condition = event_expression("condition", condition)
        self.direction = event_direction(direction)
        self.terminal = event_terminal(terminal)
        self.reset = event_reset(reset)
        self.name = str(self.condition) if name is None else str(name)
        self.samples = event_samples(samples)

    def __repr__(self) -> str:
        parts = [repr(self.condition)]
        if self.direction:
            parts.append(f"direction={self.direction:+d}")
        if self.terminal:
            parts.append(f"terminal={self.terminal}")
        if self.reset:
            parts.append("reset={" + ", ".join(f"{k!r}: {v!r}" for k, v in self.reset) + "}")
        parts.append(f"name={self.name!r}")
        return f"Event({', '.join(parts)})"


def event_specs(
    events: Sequence[Event],
    coordinates: Sequence[Coordinate],
    parameters: Mapping[str, Any],
) -> Tuple[List[Tuple[Any, ...]], List[List[str]]]:
    """The events as the native ``simulate`` reads them, each checked against the model, and
    the names of the parameters each one reads, in the order of its spec's values."""
    if isinstance(events, Event):
        raise TypeError("events must be a sequence of lagrangian.Event: pass events=[event]")
    index = {c.name: i for i, c in enumerate(coordinates)}
    numeric = {k: v for k, v in parameters.items() if isinstance(v, numbers.Real)}
    specs: List[Tuple[Any, ...]] = []
    reads: List[List[str]] = []
    for event in events:
        if not isinstance(event, Event):
            raise TypeError(f"events must hold lagrangian.Event objects, got {event!r}")
        roots = [event.condition] + [value for _, value in event.reset]
        used: Dict[str, None] = {}
        for e in roots + [key for key, _ in event.reset]:
            check_symbols(f"event {event.name!r}", e, index, numeric, True, used)
        nodes, ids = serialize(roots)
        order = list(used)
        targets = [(key.op == "qd", index[key.args[0]]) for key, _ in event.reset]
        specs.append(
            (
                to_raw(nodes, coordinates, order),
                ids[0],
                targets,
                ids[1:],
                [float(numeric[k]) for k in order],
                event.direction,
                event.terminal,
                event.name,
                event.samples,
            )
        )
        reads.append(order)
    return specs, reads
