"""``Model``: a mechanical system stated by its energies, compiled to Rust once.

What a model does with its compiled system itself — evaluate the state functions, run
``simulate`` and ``integrator`` — is written here. The methods that hand their work to a module
below (``simulate_many``, ``batch_integrator``, ``fit``, ``equilibrium``, ``linearize``,
``modes``) are those modules' functions bound as methods: each keyword list, its defaults and its
documentation live once, beside the work; they read the model by its public members
(``_protocols.ModelLike``). The statement's compilation, ``repr`` and pickled form are in
``_statement``."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _ensemble, _fit, _lagrangian, _linear, _motion, _sensitivity, _steady, _urdf
from ._drawing import Drawing
from ._events import Event, event_specs
from ._bodies import Body, with_bodies
from ._loads import Load, with_loads
from ._expr import Coordinate, Expr, ExprLike
from ._lagrangian import Integrator
from ._protocols import ArrayLike, FloatArray
from ._solution import Solution, keep_leading
from ._statement import arguments_of, compile_parts, describe, state_of
from ._validate import (
    check_symbols,
    drawing_points,
    flag,
    known_parameters,
    ModelParts,
    model_parts,
    positive,
    real,
    run_options,
    state_pairs,
    states_at_times,
    taylor_order,
    vector,
)

__all__ = ["ArrayLike", "FloatArray", "Model", "methods"]

PathLike = Union[str, "os.PathLike[str]"]


def methods() -> List[str]:
    """The names of the integration methods ``Model.simulate`` accepts, ``"auto"`` first.

    ``"verlet"`` is accepted as an alias of ``"stormer_verlet"``; names ignore case.

    >>> import lagrangian as lg
    >>> "dop853" in lg.methods()
    True
    """
    return list(_lagrangian.methods())



class Model:
    """A mechanical system stated by its energies, as in Lagrange's equations with dissipation
    (seed eq. 55)::

        d/dt(∂L/∂q̇) − ∂L/∂q + ∂Φ/∂q̇ = Q,   L = T − U

    Give the kinetic energy ``kinetic`` = T(t, q, q̇) — or, for the particle route, the
    ``positions`` r_j(t, q) of point masses and their ``masses`` — and optionally the
    ``potential`` U(t, q), the Rayleigh ``dissipation`` function Φ(t, q, q̇) and generalized
    ``forces`` Q(t, q, q̇) (one expression per coordinate). Parameters named in the expressions
    get their values from ``parameters``.

    The expressions are compiled once in Rust: the equations of motion (M and the force vector
    of eq. 55) are derived on the expression graph and compiled to machine code, and the model
    is integrated without running Python. ``backend="interpreter"`` runs the same derived
    program through the tape interpreter instead — the reference the machine code is tested
    against, with the same results to rounding, only slower. ``structure["backend"]`` says what
    runs: ``"native"``, or ``"interpreter"`` (asked for, or on a platform Cranelift does not
    support).

    >>> import lagrangian as lg
    >>> th, = lg.coordinates("th")
    >>> m, l, g = lg.parameters("m l g")
    >>> pendulum = lg.Model(coordinates=[th], kinetic=0.5*m*l**2*th.d**2,
    ...                     potential=-m*g*l*lg.cos(th),
    ...                     parameters={"m": 1.0, "l": 2.0, "g": 9.81})
    >>> round(float(pendulum.accelerations(0.0, [0.3], [0.0])[0]), 6)
    -1.449527
    >>> sol = pendulum.simulate(q0=[0.3], qd0=[0.0], t_end=2.0, rtol=1e-10, atol=1e-10)
    >>> bool(abs(sol.energy[-1] - sol.energy[0]) < 1e-8)
    True

    Parameters
    ----------
    coordinates : sequence of Coordinate
        The generalized coordinates, from :func:`lagrangian.coordinates`.
    kinetic : expression, optional
        T(t, q, q̇). Terms linear in q̇ (a magnetic q̇·A, Coriolis terms) belong here too.
    potential : expression, optional
        U(t, q); it may not contain velocities.
    dissipation : expression, optional
        Rayleigh's Φ(t, q, q̇); the viscous forces are −∂Φ/∂q̇.
    forces : sequence of expressions, optional
        Generalized forces Q(t, q, q̇), one per coordinate.
    parameters : mapping of str to float, optional
        A value for every parameter in the expressions, and nothing else.
    positions : sequence of 2- or 3-tuples of expressions, optional
        The particle route: position r_j(t, q) of each point mass instead of ``kinetic``.
    masses : sequence of expressions, optional
        The masses m_j (numbers and parameters only), with ``positions``.
    backend : {"native", "interpreter"}
        What evaluates the derived equations of motion: machine code (the default) or the
        interpreter. Kept by :meth:`with_parameters` and by pickling.
    drawing : sequence of 2- or 3-tuples of expressions, optional
        Points to draw in :meth:`animate`, as expressions in t, the coordinates and parameters
        — for pictures only: they take no part in the dynamics (an energy-route model, say a
        double pendulum stated by T and U, gets its bobs this way).
    constraints : sequence or mapping of expressions, optional
        Holonomic constraints g(t, q) = 0, one expression g per row (no velocities); a mapping
        ``{name: g}`` names the rows (default names ``"constraint 0"``, …). The model then
        obeys Lagrange's equations of the first kind, M q̈ = f + Gᵀλ with G = ∂g/∂q, and
        reports the multipliers λ and the reactions Gᵀλ (:meth:`multipliers`,
        :meth:`constraint_forces`, ``Solution.multipliers``); see :doc:`constraints`.
    velocity_constraints : sequence or mapping of expressions, optional
        Velocity (nonholonomic) constraints a(t, q)·q̇ + b(t, q) = 0, linear in the velocities
        (rolling without slipping, a knife edge); named as ``constraints`` (default names
        ``"velocity constraint 0"``, …). Their rows follow the holonomic ones.
    bodies : sequence of Body, optional
        Rigid bodies (:class:`Body`, :class:`PlanarBody`): their kinetic energy is derived and
        added to ``kinetic`` (with particles, the particles' T is derived beside it and their
        positions become ``drawing`` points); see :doc:`bodies`.
    loads : sequence of Force, Torque, Spring or Damper, optional
        Loads on bodies (:class:`Force`, :class:`Torque`, :class:`Spring`, :class:`Damper`):
        their generalized forces (by virtual power), spring potentials and dampers' Rayleigh
        functions are derived and added to ``forces``, ``potential`` and ``dissipation``; see
        :doc:`loads`.

    Raises
    ------
    ValueError
        For a symbol that is not a coordinate of the model, a velocity or parameter, a parameter
        without a value or a value for no parameter, a velocity in the potential or positions,
        wrong lengths, an unknown ``backend``; a holonomic constraint that reads a velocity, a
        velocity constraint not linear in the velocities, two constraints with one name.
    TypeError
        For something that is not an expression or a number.
    """


    __slots__ = (
        "_coordinates",
        "_names",
        "_kinetic",
        "_potential",
        "_dissipation",
        "_forces",
        "_positions",
        "_masses",
        "_parameters",
        "_backend",
        "_native",
        "_drawing_points",
        "_constraints",
        "_velocity_constraints",
        "_bodies",
    )

    _coordinates: Tuple[Coordinate, ...]
    _names: Tuple[str, ...]
    _kinetic: Optional[Expr]
    _potential: Optional[Expr]
    _dissipation: Optional[Expr]
    _forces: Optional[Tuple[Expr, ...]]
    _positions: Optional[Tuple[Tuple[Expr, ...], ...]]
    _masses: Optional[Tuple[Expr, ...]]
    _parameters: Dict[str, Any]
    _backend: str
    _native: Any
    _drawing_points: Optional[Tuple[Tuple[Expr, ...], ...]]
    _constraints: Tuple[Tuple[str, Expr], ...]
    _velocity_constraints: Tuple[Tuple[str, Expr], ...]
    _bodies: Tuple[Body, ...]

    def __init__(
        self,
        coordinates: Sequence[Coordinate],
        kinetic: Optional[ExprLike] = None,
        potential: Optional[ExprLike] = None,
        dissipation: Optional[ExprLike] = None,
        forces: Optional[Sequence[ExprLike]] = None,
        parameters: Optional[Mapping[str, float]] = None,
        *,
        positions: Optional[Sequence[Sequence[ExprLike]]] = None,
        masses: Optional[Sequence[ExprLike]] = None,
        backend: str = "native",
        drawing: Optional[Sequence[Sequence[ExprLike]]] = None,
        constraints: Optional[Union[Sequence[ExprLike], Mapping[str, ExprLike]]] = None,
        velocity_constraints: Optional[Union[Sequence[ExprLike], Mapping[str, ExprLike]]] = None,
        bodies: Optional[Sequence[Body]] = None,
        loads: Optional[Sequence[Load]] = None,
    ) -> None:
        if loads is not None:
            potential, dissipation, forces = with_loads(
                loads, coordinates, parameters, potential, dissipation, forces
            )
        if bodies is not None:
            kinetic, positions, masses, drawing = with_bodies(
                bodies, coordinates, parameters, kinetic, positions, masses, drawing
            )
        parts = model_parts(
            coordinates, kinetic, potential, dissipation, forces, parameters, positions, masses,
            backend, drawing, constraints, velocity_constraints,
        )
        self._constraints = parts.constraints
        self._velocity_constraints = parts.velocity_constraints
        self._coordinates = coords = parts.coordinates
        # The coordinates' names, as every solution carries them.
        self._names = tuple(c.name for c in coords)
        self._kinetic, self._potential, self._dissipation = parts.energies
        self._forces, self._positions, self._masses = parts.forces, parts.positions, parts.masses
        self._parameters = parts.parameters
        self._backend = parts.backend
        self._drawing_points = parts.drawing
        self._native = compile_parts(parts)
        self._bodies = (bodies,) if isinstance(bodies, Body) else tuple(bodies or ())

    # -- description -------------------------------------------------------------------
    @property
    def dof(self) -> int:
        """Number of generalized coordinates."""
        return len(self._coordinates)

    @property
    def coordinates(self) -> Tuple[Coordinate, ...]:
        """The generalized coordinates (for a scene: named as in its documentation)."""
        return self._coordinates

    @property
    def parameters(self) -> Dict[str, Any]:
        """The parameter values (a copy)."""
        return dict(self._parameters)

    @property
    def kinetic(self) -> Optional[Expr]:
        """T, or ``None`` for the particle route and for scenes."""
        return self._kinetic

    @property
    def potential(self) -> Optional[Expr]:
        """U, or ``None``."""
        return self._potential

    @property
    def dissipation(self) -> Optional[Expr]:
        """Rayleigh's Φ, or ``None``."""
        return self._dissipation

    @property
    def forces(self) -> Optional[Tuple[Expr, ...]]:
        """The generalized forces Q, or ``None``."""
        return self._forces

    @property
    def bodies(self) -> Tuple[Body, ...]:
        """The bodies given as ``bodies=`` (what :meth:`body_motion` follows by default; kept by
        :meth:`with_parameters`, not by pickling, which keeps the derived T)."""
        return getattr(self, "_bodies", ())

    @property
    def position_expressions(self) -> Optional[Tuple[Tuple[Expr, ...], ...]]:
        """The particles' position expressions (particle route), or ``None``; evaluate them with
        :meth:`positions`."""
        return self._positions

    @property
    def drawing(self) -> Optional[Tuple[Tuple[Expr, ...], ...]]:
        """The points given as ``drawing=`` (expressions for :meth:`animate`), or ``None``."""
        return getattr(self, "_drawing_points", None)

    @property
    def backend(self) -> str:
        """What evaluates the derived equations of motion, as given to the constructor:
        ``"native"`` or ``"interpreter"`` (kept by :meth:`with_parameters` and pickling; a
        scene's events compile natively). ``structure["backend"]`` says what runs."""
        return self._backend

    @property
    def scene(self) -> Optional[str]:
        """The name of the ready-made scene of :mod:`lagrangian.scenes` the model is, or
        ``None`` for a model stated by expressions."""
        return None

    @property
    def native(self) -> Any:
        """The compiled system in the extension module: what :meth:`simulate`,
        :meth:`simulate_many` and :meth:`integrator` run. For the package's own workers
        (ensembles, equilibria, fits), which take a model by its public members; its methods
        are not a stable interface."""
        return self._native

    @property
    def has_positions(self) -> bool:
        """Whether the model has particles to draw: the particle route, or a scene whose
        bodies have positions (every scene but ``forced_two_mass``, ``damped_oscillator`` and
        ``two_springs``)."""
        return bool(self._native.has_positions)

    def positions(self, t: Union[float, ArrayLike], q: ArrayLike) -> FloatArray:
        """The particles' positions r_j(t, q), evaluated in Rust.

        For a scene they are the bodies of its Rust ``Particles`` implementation: pendulum bobs
        top to bottom; for ``rolling_cylinder`` and ``ball_in_sphere`` the body's centre and two
        opposite points of its rim, which turn with it (the rolling constraint).

        >>> import lagrangian as lg
        >>> pend = lg.scenes.simple_pendulum(m=1.0, l=2.0, g=9.81)
        >>> pend.positions(0.0, [0.0]).tolist()
        [[0.0, -2.0]]

        Parameters
        ----------
        t : float or array_like, shape (n,)
            A time, or n times.
        q : array_like, shape (dof,) or (n, dof)
            The coordinates at that time (at each of those times).

        Returns
        -------
        numpy.ndarray
            Shape (particles, dim), or (n, particles, dim) for n states.

        Raises
        ------
        ValueError
            For a model without positions (stated by its energies), wrong shapes, non-finite
            values.
        """
        if not self.has_positions:
            raise ValueError(self._no_positions())
        n = self.dof
        times = np.asarray(t, dtype=np.float64)
        if times.ndim == 0:
            at = np.array([real("t", t)])
            one = self._native.positions(at, vector("q", q, n).reshape(1, n))
            return np.asarray(one[0], dtype=np.float64)
        times, rows = states_at_times(times, q, n)
        return np.asarray(self._native.positions(times, rows))

    def animate(
        self,
        sol: "Solution",
        path: PathLike,
        *,
        fps: float = 30,
        max_frames: int = 300,
        trail: bool = True,
        chain: Optional[bool] = None,
        drawing: Optional[Sequence[Sequence[ExprLike]]] = None,
    ) -> "Path":
        """Write a movie of the solution ``sol`` of this model: a GIF (pillow) or an MP4
        (ffmpeg), by the suffix of ``path``.

        What moves: the points of ``drawing`` (here or given to the model), else the model's
        particles (:meth:`positions`). Frames are evenly spaced in t (``max_frames`` of them,
        or one per point of a shorter solution); between the solution's points q is the cubic
        Hermite interpolant of q and q̇. The axes have equal aspect and fixed limits that hold
        the whole trajectory. Pendulum scenes are drawn as rods from the pivot through the
        bobs, rolling bodies as circles with a diameter that shows their rotation; for any other
        model rods join the points whose distance the motion keeps (a chain stated by its
        positions gets its rods), the rest are points. Trails follow the particles (the last
        bob of a chain, the centre of a rolling body). Only the moving parts are redrawn per
        frame: a 300-frame GIF takes a few seconds. Needs matplotlib and pillow
        (``pip install lagrangian[plot]``).

        >>> import lagrangian as lg
        >>> th1, th2 = lg.coordinates("th1 th2")
        >>> T = th1.d**2 + 0.5*th2.d**2 + th1.d*th2.d*lg.cos(th1 - th2)
        >>> U = -9.81*(2*lg.cos(th1) + lg.cos(th2))
        >>> x1, y1 = lg.sin(th1), -lg.cos(th1)
        >>> dp = lg.Model(coordinates=[th1, th2], kinetic=T, potential=U,
        ...               drawing=[(x1, y1), (x1 + lg.sin(th2), y1 - lg.cos(th2))])
        >>> sol = dp.simulate([1.0, 0.5], [0.0, 0.0], 2.0)
        >>> dp.animate(sol, "dp.gif", max_frames=60)     # doctest: +SKIP
        PosixPath('dp.gif')

        Parameters
        ----------
        sol : Solution
            A trajectory of this model, from :meth:`simulate`.
        path : str or path-like
            Where to write; ``.gif`` or ``.mp4``.
        fps : float
            Frames per second of the movie.
        max_frames : int
            At most this many frames (fewer if ``sol`` has fewer points).
        trail : bool
            Draw the particles' paths so far.
        chain : bool, optional
            ``True``: draw the points as a chain of rods from the origin in their order;
            ``False``: as points only; by default as described above.
        drawing : sequence of 2- or 3-tuples of expressions, optional
            The points to draw, as expressions in t, the coordinates and parameters; by
            default the model's ``drawing=``, if it has one.

        Returns
        -------
        pathlib.Path
            ``path``.

        Raises
        ------
        ValueError
            For a model without positions or drawing, an empty or non-finite solution, a
            solution with another number of coordinates, a suffix other than
            ``.gif``/``.mp4``, ``fps`` ≤ 0, ``max_frames`` < 1, a drawing point that is not
            an expression of t, the coordinates and parameters.
        RuntimeError
            For ``.mp4`` without ffmpeg.
        ImportError
            Without matplotlib.
        """
        from . import _plot  # not loaded by `import lagrangian`

        points = self.drawing if drawing is None else drawing_points(drawing, "drawing")
        if drawing is not None and points is not None:
            names = {c.name for c in self._coordinates}
            for j, r in enumerate(points):
                for x in r:
                    check_symbols(f"drawing point {j}", x, names, self._parameters, False, {})
        scene_drawing = self._drawing() if points is None else None
        return _plot.animate(
            self, sol, path, fps=fps, max_frames=max_frames, trail=trail, drawing=scene_drawing,
            chain=chain, points=points,
        )

    @property
    def masses(self) -> Optional[Tuple[Expr, ...]]:
        """The particles' masses (particle route), or ``None``."""
        return self._masses

    @property
    def constraints(self) -> Dict[str, Expr]:
        """The holonomic constraints g(t, q) = 0 by row name (empty without constraints)."""
        return dict(self._constraints)

    @property
    def velocity_constraints(self) -> Dict[str, Expr]:
        """The velocity constraints a(t, q)·q̇ + b(t, q) = 0 by row name."""
        return dict(self._velocity_constraints)

    @property
    def constraint_names(self) -> Tuple[str, ...]:
        """The names of the constraint rows in the order of the multipliers: holonomic rows
        first, then velocity rows."""
        return tuple(name for name, _ in self._constraints + self._velocity_constraints)

    @property
    def structure(self) -> Dict[str, Any]:
        """What the engine found the system to be, as a dict:

        - ``dof``: the number of coordinates;
        - ``time_dependent``: the Lagrangian L = T − U reads t (a moving support, a potential
          that changes with time), so the energy function h = q̇·p − L changes;
        - ``driven``: the equations of motion read t at all — L, the dissipation Φ or the
          forces Q″ do (a harmonic drive F cos ωt is ``driven`` but not ``time_dependent``);
        - ``forced``: generalized forces Q″ are present, driven or not;
        - ``dissipative``: a Rayleigh dissipation function Φ is present;
        - ``conservative``: none of ``time_dependent``, ``forced``, ``dissipative``: h is
          conserved;
        - ``constant_mass``: M is one constant matrix, factored once;
        - ``separable``: constant M and U(t, q), so the explicit symplectic methods apply;
        - ``backend``: what computes the accelerations: ``"native"`` (eq. 55 derived on the
          expression graph and compiled to machine code), ``"interpreter"`` (the same,
          interpreted: ``backend="interpreter"``, or where no native code could be made) or
          ``"rust"`` (a ready-made scene);
        - ``instructions``: the size of the compiled program of M and f, what one evaluation
          of the equations of motion costs (``None`` for a ready-made scene);
        - ``constraints``: the number of constraint rows (holonomic and velocity; 0 without
          constraints); :doc:`constraints` says which methods take them.

        A model stated by particles gets its T derived from the positions and runs the same
        way."""
        return dict(self._native.structure())

    def with_parameters(self, **values: float) -> "Model":
        """The same model with some parameter values changed; nothing is recompiled.

        >>> import lagrangian as lg
        >>> moon = lg.scenes.simple_pendulum(m=1.0, l=1.0, g=9.81).with_parameters(g=1.62)
        >>> moon.parameters["g"]
        1.62
        """
        known_parameters(values, self._parameters)
        return self._rebound(values)

    def _no_positions(self) -> str:
        """Why :meth:`positions` has nothing to give."""
        return (
            "this model has no positions: it is stated by its energies (kinetic=…); state it "
            "by positions=… and masses=… (the particle route) to draw it"
        )

    def _drawing(self) -> Optional[Drawing]:
        """How :meth:`animate` draws the model beyond points with trails (``None``: points)."""
        return None

    def _rebound(self, values: Mapping[str, float]) -> "Model":
        """The model with the (known) parameters ``values`` changed."""
        new = dict(self._parameters)
        for k, v in values.items():
            new[k] = real(f"parameter {k!r}", v)
        other = Model.__new__(Model)
        for slot in Model.__slots__:
            object.__setattr__(other, slot, getattr(self, slot))
        other._parameters = new
        other._native = self._native.with_parameters([float(v) for v in new.values()])
        return other

    # -- evaluation --------------------------------------------------------------------
    def _evaluate(self, name: str, t: object, q: object, qd: object) -> Any:
        """The native ``name`` at (t, q, q̇): straight to Rust when the arguments are floats and
        float64 arrays or lists (the fast form, checked there), otherwise converted and checked
        here first, each with a message that says what to give instead."""
        out = getattr(self._native, name)(t, q, qd)
        return self._evaluate_checked(name, t, q, qd) if out is None else out

    def _evaluate_checked(self, name: str, t: object, q: object, qd: object) -> Any:
        """The native ``name`` at (t, q, q̇) after converting and checking them here."""
        n = self.dof
        q_arr, qd_arr = state_pairs(q, qd, n)
        return getattr(self._native, name)(real("t", t), q_arr, qd_arr)

    def accelerations(self, t: float, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """The accelerations q̈ at (t, q, q̇) from Lagrange's equations (seed eq. 55).

        ``q`` and ``qd`` of shape ``(dof,)`` give one state; of shape ``(k, dof)`` they give
        ``k`` states (one per row), all evaluated in Rust in one call, and the result has the
        same shape.

        >>> import lagrangian as lg
        >>> osc = lg.scenes.damped_oscillator(m=2.0, k=8.0, c=0.4)
        >>> osc.accelerations(0.0, [1.0], [0.5]).tolist()
        [-4.1]
        >>> osc.accelerations(0.0, [[1.0], [0.0]], [[0.5], [1.0]]).tolist()
        [[-4.1], [-0.2]]
        """
        out: FloatArray = self._native.accelerations(t, q, qd)  # the fast path, inline
        return self._evaluate_checked("accelerations", t, q, qd) if out is None else out

    def taylor_series(
        self, q: ArrayLike, qd: ArrayLike, *, t: float = 0.0, order: int = 20
    ) -> Tuple[FloatArray, FloatArray]:
        """The Taylor coefficients of the motion through (t, q, q̇): arrays ``cq`` and ``cqd``
        of shape ``(order + 1, dof)`` with ``cq[k] = q⁽ᵏ⁾(t) / k!`` (and the same for q̇), so
        that q(t + h) ≈ Σₖ cq[k] hᵏ within the series' radius of convergence.

        These are what ``method="taylor"`` sums at every step: found order by order by series
        arithmetic on the model's expressions, with one solve by the mass matrix per order (no
        symbolic inverse); a scene's from its energies traced into the expression graph. ``order``
        from 1 to 100. ``"auto"`` runs ``taylor`` where it estimates it cheaper than
        ``dop853`` (see ``simulate``); ``method="taylor"`` asks for it by name.

        >>> import lagrangian as lg
        >>> x, = lg.coordinates("x")
        >>> osc = lg.Model(coordinates=[x], kinetic=x.d**2 / 2, potential=x**2 / 2)
        >>> cq, _ = osc.taylor_series([1.0], [0.0], order=4)
        >>> cq[::2, 0].tolist()  # cos t = 1 − t²/2 + t⁴/24
        [1.0, -0.5, 0.041666666666666664]
        """
        n = self.dof
        q_, qd_ = vector("q", q, n).tolist(), vector("qd", qd, n).tolist()
        k = taylor_order(order)
        cq, cqd = self._native.taylor_series(real("t", t), q_, qd_, k)
        return cq, cqd

    def mass_matrix(self, t: float, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """The mass matrix M = ∂²T/∂q̇² at (t, q, q̇), shape (dof, dof); for ``k`` states as rows
        of ``q`` and ``qd`` (see :meth:`accelerations`), shape (k, dof, dof)."""
        out: FloatArray = self._evaluate("mass_matrix", t, q, qd)
        return out

    def energy(self, t: float, q: ArrayLike, qd: ArrayLike) -> Any:
        """The energy function h = q̇·p − L at (t, q, q̇): T + U for natural systems. A float;
        for ``k`` states as rows of ``q`` and ``qd``, an array of shape (k,)."""
        return self._evaluate("energy", t, q, qd)

    def momenta(self, t: float, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """The momenta p = ∂L/∂q̇ at (t, q, q̇), shape (dof,), or (k, dof) for ``k`` states."""
        out: FloatArray = self._evaluate("momenta", t, q, qd)
        return out

    def lagrangian(self, t: float, q: ArrayLike, qd: ArrayLike) -> Any:
        """The Lagrangian L = T − U at (t, q, q̇): a float, or shape (k,) for ``k`` states."""
        return self._evaluate("lagrangian", t, q, qd)

    # -- constraints -------------------------------------------------------------------
    def _constrained(self, what: str) -> None:
        """Refuse ``what`` on a model without constraints, saying how to state them."""
        if not (self._constraints or self._velocity_constraints):
            raise ValueError(
                f"{what} needs a constrained model: state constraints=[g(t, q), ...] or "
                "velocity_constraints=[a(t, q)·q̇ + b(t, q), ...] in lg.Model"
            )

    def multipliers(self, t: float, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """The Lagrange multipliers λ at (t, q, q̇): one per constraint row, in the order of
        :attr:`constraint_names` (holonomic rows first).

        They come with the accelerations from one factorization of the augmented system
        M q̈ = f + Gᵀλ, G q̈ = −γ (G = ∂g/∂q for the holonomic rows, the coefficients a of the
        velocity rows; γ the rest of the constraints' derivative along the motion, by automatic
        differentiation). Sign convention: the reaction is +Gᵀλ, so λ has the sign of the
        force along ∂g/∂q — a pendulum's rod x² + y² − l² = 0 in tension pulls towards the
        pivot, against ∂g/∂q = 2(x, y): λ < 0, and the tension is −2 l λ.

        ``q`` and ``qd`` of shape ``(dof,)`` give shape ``(k,)``; of shape ``(s, dof)`` (s
        states), shape ``(s, k)``.

        Raises
        ------
        ValueError
            For bad input, a model without constraints, dependent constraint rows (a row stated
            twice, a mechanism at a dead point: the message names the rows and the time).
        """
        self._constrained("multipliers")
        return self._evaluate("multipliers", t, q, qd)  # type: ignore[no-any-return]

    def constraint_forces(self, t: float, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """The generalized reaction forces Gᵀλ at (t, q, q̇), one per coordinate: the forces
        the constraints exert, in the coordinates' own units (a force for a length, a torque
        for an angle). They do no work in any virtual displacement (G δq = 0), which is why
        minimal coordinates never see them (seed §3.1).

        Shapes as :meth:`accelerations`. Raises as :meth:`multipliers`.
        """
        self._constrained("constraint_forces")
        return self._evaluate("constraint_forces", t, q, qd)  # type: ignore[no-any-return]

    def constraint_power(self, t: float, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """The reactions' power Gᵀλ·q̇ at (t, q, q̇): zero for constraints that hold still,
        otherwise the rate at which a moving constraint (a driven wire, a moving support) feeds
        energy in, so that the energy function balances as dh/dt = Gᵀλ·q̇ + Q″·q̇ − q̇·∂Φ/∂q̇ −
        ∂L/∂t. A float for one state, shape (states,) for several. Raises as
        :meth:`multipliers`.
        """
        forces = np.asarray(self.constraint_forces(t, q, qd))
        return np.einsum("...i,...i->...", forces, np.asarray(qd, dtype=float))  # type: ignore[no-any-return]

    def particle_reactions(self, t: float, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """The Cartesian reaction force on each particle at (t, q, q̇) (particle route):
        Rᵢ = mᵢ (J M⁻¹ Gᵀλ)ᵢ with J = ∂r/∂q — the particle's mass times the part of its
        acceleration the reactions cause. When the coordinates are the particles' Cartesian
        coordinates this is Gᵀλ itself, particle by particle.

        Shape ``(count, dim)`` for one state, ``(s, count, dim)`` for s states.

        Raises
        ------
        ValueError
            For bad input, a model without constraints or without particles.
        """
        self._constrained("particle_reactions")
        return self._evaluate("particle_reactions", t, q, qd)  # type: ignore[no-any-return]

    def project(
        self, q: ArrayLike, qd: ArrayLike, t: float = 0.0, *, tol: Optional[float] = None
    ) -> Tuple[FloatArray, FloatArray]:
        """The consistent state nearest (q, q̇) at time ``t``: positions onto g(t, q) = 0 by
        Gauss–Newton in the metric of the mass matrix, then velocities onto the velocity-level
        constraints (ġ = 0 and a·q̇ + b = 0) by the M-orthogonal projection. A state already
        consistent comes back unchanged: each row's residual, as a distance, within
        ``tol`` (1 + ℓ), ℓ the size of what the row reads (positions up to 1), ``tol``
        default 1e-12 (the constraints page has the rule).

        :meth:`simulate` refuses an inconsistent initial state; this repairs it.

        Raises
        ------
        ValueError
            For bad input, a model without constraints, dependent rows, or when the
            iterations do not reach the constraints (a start far from them, constraints
            without a real solution): the message names the worst row and its residual.
        """
        self._constrained("project")
        n = self.dof
        qv, qdv = vector("q", q, n), vector("qd", qd, n)
        at = real("t", t)
        eps = None if tol is None else positive("tol", tol)
        pq, pqd = self._native.project(at, list(qv), list(qdv), eps)
        return np.asarray(pq), np.asarray(pqd)

    def rhs(self, t: float, y: ArrayLike) -> FloatArray:
        """The first-order right-hand side dy/dt = (q̇, q̈) at y = (q, q̇), in SciPy's
        ``fun(t, y)`` convention: the model itself can be given to
        :func:`scipy.integrate.solve_ivp`, its events and its ``vectorized=True`` mode.

        >>> import lagrangian as lg
        >>> osc = lg.scenes.damped_oscillator(m=2.0, k=8.0, c=0.4)
        >>> osc.rhs(0.0, [1.0, 0.5]).tolist()
        [0.5, -4.1]
        >>> osc.rhs(0.0, [[1.0, 0.0], [0.5, 1.0]]).tolist()  # two states, one per column
        [[0.5, 1.0], [-4.1, -0.2]]

        Parameters
        ----------
        t : float
            The time.
        y : array_like, shape (2·dof,) or (2·dof, k)
            The state (q, q̇), or k states as columns.

        Returns
        -------
        numpy.ndarray
            dy/dt, of the shape of ``y``.

        Raises
        ------
        ValueError
            For another shape or a non-finite entry.
        SingularMassMatrixError
            Where the mass matrix cannot be inverted.
        """
        return np.asarray(self._native.rhs(t, np.asarray(y, dtype=np.float64)))

    def jacobian(self, t: float, y: ArrayLike) -> FloatArray:
        """The Jacobian ∂(dy/dt)/∂y of :meth:`rhs` at y = (q, q̇), shape (2·dof, 2·dof), by
        forward-mode automatic differentiation (exact to rounding, no finite differences):
        ``[[0, I], [∂q̈/∂q, ∂q̈/∂q̇]]``. SciPy's ``jac(t, y)`` for the implicit methods
        (``Radau``, ``BDF``, ``LSODA``).

        >>> import lagrangian as lg
        >>> osc = lg.scenes.damped_oscillator(m=2.0, k=8.0, c=0.4)
        >>> osc.jacobian(0.0, [1.0, 0.5]).tolist()
        [[0.0, 1.0], [-4.0, -0.2]]

        Parameters
        ----------
        t : float
            The time.
        y : array_like, shape (2·dof,)
            The state (q, q̇); the errors are those of :meth:`rhs`.
        """
        return np.asarray(self._native.jacobian(t, np.asarray(y, dtype=np.float64)))

    def simulate(
        self,
        q0: ArrayLike,
        qd0: ArrayLike,
        t_end: float,
        *,
        t0: float = 0.0,
        method: str = "auto",
        dt: Optional[float] = None,
        rtol: float = 1e-6,
        atol: float = 1e-9,
        t_eval: Optional[ArrayLike] = None,
        max_steps: Optional[int] = None,
        output_every: Optional[int] = None,
        events: Optional[Sequence[Event]] = None,
        dense: bool = False,
        sensitivities: Optional[Sequence[str]] = None,
        sensitivity_error_control: bool = True,
    ) -> Solution:
        """Integrate the equations of motion from (q0, qd0) at ``t0`` to ``t_end``.

        The run happens in Rust with the GIL released; Ctrl-C stops it with
        ``KeyboardInterrupt`` within about 20 ms of model evaluation.

        Parameters
        ----------
        q0, qd0 : array_like, shape (dof,)
            Initial coordinates and velocities.
        t_end : float
            End time; before ``t0`` integrates backwards.
        t0 : float
            Start time.
        method : str
            One of :func:`lagrangian.methods`. ``"auto"`` chooses from the system's structure,
            the options and the initial state, and says why in ``sol.stats["choice"]``: for a
            conservative system (no dissipation, no forces, no explicit t) with a fixed ``dt``,
            ``blanes_moan4`` when it is separable (constant mass matrix, U(q)), ``gauss4``
            otherwise (symplectic for any L); in every other case (forced, dissipative,
            time-dependent, or tolerances without ``dt``) ``radau5`` when the system is stiff
            at the initial state; else, with tolerances only, ``taylor`` where its cost,
            estimated from the sizes of the model's programs and the tolerance, is below
            DOP853's (small smooth models from about 1e-9 down; not the N-link chains, nor a
            model with ``abs`` or ``sign`` of the state); else ``dop853`` (adaptive, or at the
            fixed ``dt``). Stiff means a decaying mode of the Jacobian at least 1000 times
            faster than every mode the solution must follow, so that an explicit step would be
            set by stability.
        dt : float, optional
            Fixed step, with the sign of ``t_end - t0``; without it the adaptive methods
            control the local error with ``rtol`` and ``atol``.
        rtol, atol : float
            Tolerances of the adaptive methods, > 0.
        t_eval : array_like, optional
            Output only at these times (ordered in the direction of integration, inside the
            span), from the method's dense output; by default every step is kept.
        max_steps : int, optional
            Step budget: one million by default, none with ``dt`` (a fixed step takes the
            steps the span needs).
        output_every : int, optional
            Keep the initial state, every k-th step and the final state (for long runs whose
            every step would not fit in memory); not together with ``t_eval``.
        events : sequence of Event, optional
            Conditions whose sign changes are located along the run, with every method (see
            :class:`Event`): recorded in ``t_events``, ``q_events``, ``qd_events``; a terminal
            event ends the run there, a reset changes the state and the run goes on. Events
            are searched on every step's interpolant (DOPRI5 and DOP853 screen each step on
            the free Hermite interpolant first; see :class:`Event`).
        dense : bool
            Keep every step's interpolant, so that the solution is callable: ``sol(t)`` gives
            (q, q̇) anywhere in the span (``sol.interpolant`` says which interpolant and its
            order). Off by default: nothing extra is stored.
        sensitivities : sequence of str, optional
            Also compute how the motion depends on these parameters of the model and on the
            initial state (``"q0"``, ``"qd0"``), exactly: the variational equations are derived
            on the expression graph and integrated with the state by the same method (any
            method; the explicit symplectic ones where the model is separable, as without
            sensitivities). ``sol.sensitivities[name]`` is
            ∂(q, q̇)/∂p at each output, shape (len(t), 2 dof), or for ``"q0"`` / ``"qd0"``
            shape (len(t), 2 dof, dof) (column j: ∂(q, q̇)/∂q0[j]); ``sol.event_sensitivities``
            holds, per event, the derivatives of its times, {name: (k,)} or (k, dof). A
            parameter the model does not depend on gives zeros. Under constraints the initial
            sensitivities are projected onto the constraints and the index-1 equations run
            without projecting the steps. Not with events that reset the state. See
            :doc:`sensitivities`.
        sensitivity_error_control : bool
            With ``sensitivities``: control the local error of the sensitivities too (the
            default), or of (q, q̇) only (fewer steps; CVODES's ``errconS``; with ``dop853``,
            ``dopri5``, ``radau5`` and ``taylor``).

        Returns
        -------
        Solution

        Raises
        ------
        ValueError
            For bad input: lengths, non-finite values, an unknown method, a fixed-step method
            without ``dt``, tolerances ≤ 0, a ``dt`` pointing away from ``t_end``, a method that
            cannot integrate this system.
        LagrangianError
            When the mathematics fails (subclasses say how). A failure during the run keeps
            what was computed: ``err.solution`` is the :class:`Solution` up to the last
            accepted step, with the ``stats`` of the work done (without ``t_eval`` its last
            point is the last accepted state), and ``err.t``, ``err.q``, ``err.qd`` are that
            last accepted state, from which the failing step started. A failure before the
            first step (a fixed ``dt`` beyond the stability limit) has all four ``None``; a
            fixed-step run refused because ``max_steps`` is below its number of steps carries
            the initial state only. ``ValueError`` has none of these attributes.
        KeyboardInterrupt
            On Ctrl-C; it carries nothing.
        """
        # The options' types are checked in `run_options`, their values in Rust (one message
        # each). The initial state goes to Rust as it is when it has the form Rust reads (float64
        # arrays, lists of numbers; `None` otherwise), else it is converted and checked here
        # first. The native call takes its arguments by position (no keyword dictionary to build
        # and parse: a short run's fixed cost is most of what it costs).
        t0, end, method, dt, rtol, atol, times, max_steps, every = run_options(
            t0, t_end, method, dt, rtol, atol, t_eval, max_steps, output_every
        )
        event_names: Tuple[str, ...] = ()
        specs: List[Any] = []
        reads: List[List[str]] = []
        if events is not None and not isinstance(events, Event):
            events = list(events)  # read three times below: a generator would be spent
        if events is not None:
            specs, reads = event_specs(events, self._coordinates, self._parameters)
            event_names = tuple(e.name for e in events)
        if dense is not False and dense is not True:
            flag("dense", dense)
        native, backend = self._native, self._backend
        if sensitivities is not None:
            return self._simulate_sensitivities(
                q0, qd0, (t0, end), (method, dt, rtol, atol, times, max_steps, every),
                (specs, reads, event_names), dense, sensitivities, sensitivity_error_control,
            )
        # The arguments spelled out (a vectorcall): unpacked from a tuple with *, the call went
        # through an argument tuple, 1 000 more instructions (callgrind). A failure during the
        # run raises with the partial solution as `err.solution` (see `Raises`).
        out: Optional[Solution] = native.simulate(q0, qd0, end, t0, method, dt, rtol, atol,
                                                  times, max_steps, every, specs, dense, backend,
                                                  Solution, self._names, event_names)
        if out is not None:
            return out
        # q0 or qd0 not in the form Rust reads: converted and checked here, then called again.
        n = self.dof
        q0, qd0 = vector("q0", q0, n), vector("qd0", qd0, n)
        sol: Solution = native.simulate(q0, qd0, end, t0, method, dt, rtol, atol, times,
                                        max_steps, every, specs, dense, backend, Solution,
                                        self._names, event_names)
        return sol

    def _simulate_sensitivities(
        self,
        q0: ArrayLike,
        qd0: ArrayLike,
        span: Tuple[float, Any],
        run: Tuple[Any, ...],
        events: Tuple[List[Any], List[List[str]], Tuple[str, ...]],
        dense: bool,
        names: object,
        error_control: object,
    ) -> Solution:
        """``simulate`` with sensitivities (see there): the variational system runs in the
        model's place and its sensitivities are named here. ``events`` are the specs, the names
        of the parameters each reads and the events' names."""
        if error_control is not False and error_control is not True:
            flag("sensitivity_error_control", error_control)
        n = self.dof
        scene = self.scene
        wanted, layout = _sensitivity.directions(names, self._parameters, n, scene)
        q0, qd0 = vector("q0", q0, n), vector("qd0", qd0, n)
        (t0, end), (method, dt, rtol, atol, times, max_steps, every) = span, run
        specs, reads, event_names = events
        order = list(self._parameters)
        event_reads = [[order.index(name) for name in r] for r in reads]
        params = [float(v) for v in self._parameters.values()] if scene is None else []
        sol: Solution = self._native.simulate_sensitivities(
            q0, qd0, end, t0, method, dt, rtol, atol, times, max_steps, every, specs, dense,
            self._backend, Solution, self._names, event_names, wanted, params,
            bool(error_control), event_reads,
        )
        raw: Any = sol.sensitivities
        raw_events: Any = sol.event_sensitivities
        sol.sensitivities = _sensitivity.named(raw, layout)
        sol.event_sensitivities = _sensitivity.named_events(raw_events, layout)
        if dense:
            keep_leading(sol, n)
        return sol

    def integrator(
        self,
        q0: ArrayLike,
        qd0: ArrayLike,
        *,
        t0: float = 0.0,
        method: str = "auto",
        dt: Optional[float] = None,
        rtol: float = 1e-6,
        atol: float = 1e-9,
        max_steps: Optional[int] = None,
        events: Optional[Sequence[Event]] = None,
    ) -> Integrator:
        """An integrator standing at (q0, qd0) at ``t0``, for runs taken piece by piece:
        ``ig.propagate_until(t)`` integrates its state to ``t`` and stands there, the next call
        going on from there (heyoka's ``propagate_until``; SciPy's solvers step the same way).

        For many short runs, or a loop that reads or changes the state between them (control,
        co-simulation, impact laws of your own): the method and options are parsed once, only the
        final state is kept, and a call costs little beside its steps (a
        ``simulate`` also builds a :class:`Solution`). ``ig.t``, ``ig.q``, ``ig.qd`` read the
        state (copies) and can be assigned, each checked as ``q0`` is; ``ig.stats`` is the work
        of the last call that finished, as in ``Solution.stats``; ``ig.method`` the method, once
        ``"auto"`` has chosen.

        >>> import lagrangian as lg
        >>> th, = lg.coordinates("th")
        >>> pendulum = lg.Model(coordinates=[th], kinetic=0.5 * th.d**2, potential=-lg.cos(th))
        >>> ig = pendulum.integrator([0.1], [0.0], method="taylor", rtol=1e-12, atol=1e-12)
        >>> [ig.propagate_until(t) for t in (0.5, 1.0)]
        ['finished', 'finished']
        >>> ig.t
        1.0

        Parameters
        ----------
        q0, qd0 : array_like, shape (dof,)
            Initial coordinates and velocities.
        t0 : float
            Initial time.
        method, rtol, atol, max_steps, events
            As in :meth:`simulate`, for every call (``max_steps`` is each call's budget).
            ``"auto"`` chooses at the first call, from the state and that call's span, and
            keeps the method. A terminal event stops a call where it fires (the call returns
            ``"terminated"`` and ``ig.event`` names it; ``terminal=k`` counts k occurrences
            within one call), and the next call goes on from there without firing it again —
            its sign is taken a thousandth into the first step — as long as ``ig.t`` is not
            moved, also after ``ig.q`` or ``ig.qd`` were assigned (an impact law: reverse
            ``ig.qd`` and go on). Resets apply as in :meth:`simulate`. Occurrences are not
            recorded (``simulate`` records them).
        dt : float, optional
            Fixed step size, > 0, for the fixed-step methods: each call divides its own span
            into ⌈|span| / dt⌉ equal steps in the direction of its target (as ``simulate``
            does, with the same stability check at the call's start).

        Returns
        -------
        Integrator
            ``propagate_until(t)`` returns ``"finished"`` (it reached t) or ``"terminated"``.
            A failed call raises as :meth:`simulate` does, with the last accepted state as
            ``err.t``, ``err.q``, ``err.qd`` (no ``err.solution``), and leaves the integrator
            where it stood; Ctrl-C raises ``KeyboardInterrupt``. The GIL is released while it
            runs; one integrator is not for two threads at once (``RuntimeError``).

        Raises
        ------
        ValueError
            For bad input, as :meth:`simulate`.
        """
        t0, _, method, dt, rtol, atol, _, max_steps, _ = run_options(
            t0, None, method, dt, rtol, atol, None, max_steps
        )
        # q0 and qd0 go to Rust as they are: it reads the fast forms (lists of numbers, float64
        # arrays) and hands anything else to `vector`, as the setters of `ig.q` and `ig.qd` do.
        specs: List[Any] = []
        if events is not None:
            specs = event_specs(events, self._coordinates, self._parameters)[0]
        integrator: Integrator = self._native.integrator(
            q0, qd0, t0, method, dt, rtol, atol, max_steps, specs, self._backend
        )
        return integrator

    # -- the workers' functions, bound as methods ---------------------------------------
    batch_integrator = _ensemble.batch_integrator
    simulate_many = _ensemble.simulate_many
    fit = _fit.fit
    equilibrium = _linear.equilibrium
    linearize = _linear.linearize
    linearize_steady = _steady.linearize_steady
    modes = _linear.modes
    body_motion = _motion.body_motion
    from_urdf: "classmethod[Model, ..., Model]" = classmethod(_urdf.from_urdf)

    # -- Python protocol ---------------------------------------------------------------
    def _statement(self) -> ModelParts:
        """The parts the model is made of (see ``_statement``)."""
        return ModelParts(
            self._coordinates, (self._kinetic, self._potential, self._dissipation), self._forces,
            self._positions, self._masses, self._parameters, self._backend, self.drawing,
            self._constraints, self._velocity_constraints,
        )

    def __repr__(self) -> str:
        return describe(self._statement())

    def __reduce__(self) -> Tuple[Any, ...]:
        return (_model_from_state, (state_of(self._statement()),))


def _model_from_state(state: Dict[str, Any]) -> Model:
    return Model(**arguments_of(state))
