"""Frames chained by joints: a frame is an orientation R(t, q) (its axes in world coordinates as
columns) and an origin o(t, q) in world coordinates; a joint makes a child frame from its parent
and the joint's coordinate. Bodies hang on frames (:meth:`Frame.body`), so a kinematic tree gives
each body's position and orientation as expressions, and :class:`~lagrangian.Body` derives T."""

from __future__ import annotations

from typing import Any, Optional, Sequence

from ._bodies import (
    Body,
    Rotation,
    Vector,
    plus,
    vector3,
    matmul,
    rotate,
    rotation_about,
    unit,
)
from ._expr import ExprLike, _mul

__all__ = ["Frame"]

_IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


class Frame:
    """A reference frame: ``orientation`` R (3×3 expressions; v_world = R v_frame) and ``origin``
    (world coordinates). ``Frame()`` is the world frame. Joints return child frames::

        upper = lg.Frame().revolute(th1, axis=(0, 1, 0))
        lower = upper.revolute(th2, axis=(0, 1, 0), offset=(0, 0, -l))
    """

    __slots__ = ("orientation", "origin")

    def __init__(self, orientation: Optional[Sequence[Sequence[ExprLike]]] = None,
                 origin: Sequence[ExprLike] = (0.0, 0.0, 0.0)) -> None:
        if isinstance(orientation, Rotation):  # keeps the angular velocity it carries
            self.orientation = orientation
        else:
            rows = _IDENTITY if orientation is None else orientation
            if len(rows) != 3:
                raise ValueError(f"a frame's orientation must be 3×3, got {orientation!r}")
            self.orientation = matmul(_IDENTITY, [vector3(r, "a frame's orientation row")
                                                  for r in rows])
        self.origin: Vector = vector3(origin, "a frame's origin")

    # -- where things are ----------------------------------------------------------------------
    def point(self, p: Sequence[ExprLike]) -> Vector:
        """World coordinates o + R p of the point ``p`` given in this frame."""
        return plus(self.origin, self.vector(p))

    def vector(self, v: Sequence[ExprLike]) -> Vector:
        """World components R v of the vector ``v`` given in this frame's axes."""
        return rotate(self.orientation, vector3(v, "a vector"))

    # -- joints ----------------------------------------------------------------------------------
    def fixed(self, offset: Sequence[ExprLike] = (0.0, 0.0, 0.0),
              rotation: Optional[Sequence[Sequence[ExprLike]]] = None) -> "Frame":
        """The frame at ``offset`` (in this frame's axes), turned by ``rotation`` relative to this
        frame (default none): a fixed joint, and the placement every other joint starts from."""
        r = self.orientation if rotation is None else matmul(self.orientation, rotation)
        return Frame(r, self.point(offset))

    def revolute(self, angle: ExprLike, axis: Sequence[float] = (0.0, 0.0, 1.0),
                 offset: Sequence[ExprLike] = (0.0, 0.0, 0.0),
                 rotation: Optional[Sequence[Sequence[ExprLike]]] = None) -> "Frame":
        """A revolute joint placed at ``offset``/``rotation`` (as :meth:`fixed`): the child frame
        turned by ``angle`` about ``axis`` (in the placed frame's axes)."""
        placed = self.fixed(offset, rotation)
        return Frame(matmul(placed.orientation, rotation_about(axis, angle)), placed.origin)

    def prismatic(self, distance: ExprLike, axis: Sequence[float] = (1.0, 0.0, 0.0),
                  offset: Sequence[ExprLike] = (0.0, 0.0, 0.0),
                  rotation: Optional[Sequence[Sequence[ExprLike]]] = None) -> "Frame":
        """A prismatic joint placed at ``offset``/``rotation``: the child frame moved by
        ``distance`` along the unit ``axis`` (in the placed frame's axes)."""
        k = unit(axis, "prismatic")
        placed = self.fixed(offset, rotation)
        return placed.fixed(tuple(_mul(distance, x) for x in k))

    # -- bodies ----------------------------------------------------------------------------------
    def body(self, mass: ExprLike, inertia: Any,
             center: Sequence[ExprLike] = (0.0, 0.0, 0.0), name: Optional[str] = None,
             gravity: Optional[Sequence[ExprLike]] = None) -> Body:
        """A :class:`~lagrangian.Body` fixed in this frame: centre of mass at ``center`` (this
        frame's axes), inertia about it in this frame's axes, oriented as the frame."""
        return Body(mass, inertia, self.point(center), self.orientation, name=name,
                    gravity=gravity)

    def __repr__(self) -> str:
        return f"Frame(orientation={self.orientation!r}, origin={self.origin!r})"
