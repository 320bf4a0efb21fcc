"""The model of a ready-made Rust scene (:mod:`lagrangian.scenes`): a :class:`Model` whose system
is written in Rust and declared in the scene registry (``src/scenes/registry.rs``), rebuilt from
its name and parameter values rather than from expressions."""

from __future__ import annotations

from typing import Any, Dict, Mapping, Optional, Sequence, Tuple

import numpy as np

from . import _lagrangian
from ._drawing import Drawing
from ._expr import Coordinate
from ._model import Model
from ._protocols import FloatArray
from ._validate import real as _real
from ._validate import vector as _vector

__all__ = ["SceneModel", "scene_model"]


class SceneModel(Model):
    """A model backed by a Rust scene; made by the functions of :mod:`lagrangian.scenes`.

    Everything a :class:`Model` does, every method included (``"taylor"`` runs on the scene's
    energies traced into the expression graph), plus the scene's own drawing and, for the scenes
    that have one, its exact solution (:meth:`exact`). ``kinetic``, ``potential`` and the other
    expressions are ``None``: the energies are written in Rust.
    """

    __slots__ = ("_scene",)

    _scene: str

    @classmethod
    def _make(cls, scene: str, arguments: Mapping[str, Any]) -> "SceneModel":
        """The scene ``scene`` with these named arguments (checked by name in Rust)."""
        native, values, names = _lagrangian.scene_model(scene, dict(arguments))
        self = cls.__new__(cls)
        self._coordinates = tuple(Coordinate(n) for n in names)
        self._names = tuple(c.name for c in self._coordinates)
        self._kinetic = self._potential = self._dissipation = None
        self._forces = self._positions = self._masses = None
        self._constraints = self._velocity_constraints = ()
        self._parameters = dict(values)
        self._backend = "native"  # of the conditions of events; the scene itself is Rust
        self._native = native
        self._scene = scene
        return self

    @property
    def scene(self) -> str:
        """The scene's name in :mod:`lagrangian.scenes`."""
        return self._scene

    @property
    def has_exact(self) -> bool:
        """Whether :meth:`exact` knows the scene's exact solution."""
        return bool(_catalog_entry(self._scene)["exact"])

    def exact(self, t: float, q0: Sequence[float], qd0: Sequence[float]) -> Tuple[FloatArray, FloatArray]:
        """The exact state (q, q̇) at time ``t`` of the motion from (``q0``, ``qd0``) at t = 0,
        from the Rust scene's closed form.

        >>> import lagrangian as lg
        >>> osc = lg.scenes.damped_oscillator(m=1.0, k=4.0, c=0.0)
        >>> q, qd = osc.exact(0.25 * 3.141592653589793, [1.0], [0.0])
        >>> round(float(q[0]), 12), round(float(qd[0]), 12)
        (0.0, -2.0)

        Raises
        ------
        ValueError
            For a scene without an exact solution (see :attr:`has_exact`), states of the wrong
            size, non-finite input, or parameters and states outside the closed form (a
            resonant forcing, an unbound orbit).
        """
        n = self.dof
        q, qd = _lagrangian.scene_exact(
            self._scene, self._parameters, _vector("q0", q0, n).tolist(),
            _vector("qd0", qd0, n).tolist(), _real("t", t),
        )
        return np.asarray(q, dtype=np.float64), np.asarray(qd, dtype=np.float64)

    def _no_positions(self) -> str:
        return f"the scene {self._scene} has no particle positions: it cannot be drawn"

    def _drawing(self) -> Optional[Drawing]:
        d = _lagrangian.scene_drawing(self._scene, self._parameters)
        if d is None:
            return None
        scene, params = self._scene, dict(self._parameters)

        def pivot(t: FloatArray) -> FloatArray:
            at = np.ascontiguousarray(np.asarray(t, dtype=np.float64))
            return np.asarray(_lagrangian.scene_pivot(scene, params, at), dtype=np.float64)

        trail = d["trail"]
        return Drawing(
            rods=tuple((int(i), int(j)) for i, j in d["rods"]),
            pivot=pivot if d["moving_pivot"] else None,
            bodies=tuple((int(c), int(a), int(b)) for c, a, b in d["bodies"]),
            circles=tuple((float(x), float(y), float(r)) for x, y, r in d["circles"]),
            lines=tuple((float(x), float(y), float(u), float(v)) for x, y, u, v in d["lines"]),
            marks=tuple((float(x), float(y)) for x, y in d["marks"]),
            trail=None if trail is None else tuple(int(i) for i in trail),
        )

    def _rebound(self, values: Mapping[str, float]) -> "SceneModel":
        return SceneModel._make(self._scene, {**self._parameters, **values})

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self._parameters.items())
        return f"lagrangian.scenes.{self._scene}({args})"

    def __reduce__(self) -> Tuple[Any, ...]:
        return (_scene_from_state, (self._scene, dict(self._parameters)))


def scene_model(name: str, arguments: Mapping[str, Any]) -> SceneModel:
    """The scene ``name`` with these named arguments (checked by name in Rust): what each
    function of :mod:`lagrangian.scenes` returns."""
    return SceneModel._make(name, arguments)


def _scene_from_state(name: str, parameters: Dict[str, Any]) -> SceneModel:
    return SceneModel._make(name, parameters)


_CATALOG: Dict[str, Dict[str, Any]] = {}


def _catalog_entry(name: str) -> Dict[str, Any]:
    if not _CATALOG:
        _CATALOG.update((s["name"], s) for s in _lagrangian.scene_catalog())
    return _CATALOG[name]

