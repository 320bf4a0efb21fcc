"""``Drawing``: how a model's particles are drawn (rods, bodies, fixed marks), below both the
models that declare one (a ready-made scene's own drawing) and :mod:`._plot`, which draws it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional, Tuple

import numpy as np
import numpy.typing as npt

__all__ = ["Drawing"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Drawing:
    """How :meth:`Model.animate` draws a model's particles, beyond points with trails.

    Particles are referred to by their index in :meth:`Model.positions`; index −1 is the pivot.

    Attributes
    ----------
    rods : tuple of (int, int)
        Segments drawn between two particles (or a particle and the pivot): a pendulum chain is
        ``((-1, 0), (0, 1), …)``.
    pivot : callable, optional
        Pivot positions at the given times, ``f(t) -> array of shape (len(t), 2)``; the origin
        when ``None``.
    bodies : tuple of (int, int, int)
        Rolling bodies as (centre, rim point, opposite rim point): drawn as a circle through the
        rim points with the diameter between them, which shows the rotation.
    circles : tuple of (x, y, radius)
        Fixed circles (a hollow sphere the ball rolls in).
    lines : tuple of (x, y, dx, dy)
        Fixed infinite lines through (x, y) along (dx, dy) (a slope).
    marks : tuple of (x, y)
        Fixed points (a centre of attraction, a pivot).
    trail : tuple of int, optional
        The particles that leave a trail; by default every particle that is not a body's rim
        point.
    """

    rods: Tuple[Tuple[int, int], ...] = ()
    pivot: Optional[Callable[[FloatArray], FloatArray]] = None
    bodies: Tuple[Tuple[int, int, int], ...] = ()
    circles: Tuple[Tuple[float, float, float], ...] = ()
    lines: Tuple[Tuple[float, float, float, float], ...] = ()
    marks: Tuple[Tuple[float, float], ...] = ()
    trail: Optional[Tuple[int, ...]] = None

    @staticmethod
    def chain(links: int, pivot: Optional[Callable[[FloatArray], FloatArray]] = None) -> "Drawing":
        """A pendulum chain of ``links`` bobs: rods from the pivot through the bobs in order, the
        last bob trailed."""
        rods = tuple((k - 1, k) for k in range(links))
        return Drawing(rods=rods, pivot=pivot, marks=((0.0, 0.0),) if pivot is None else (),
                       trail=(links - 1,))
