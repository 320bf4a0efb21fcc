"""Equations of motion from energies.

State a mechanical system the way Lagrange does — kinetic energy T, potential U, Rayleigh
dissipation Φ, generalized forces Q — as expressions; ``lagrangian`` compiles them once to a tape
that Rust evaluates over dual numbers, derives the equations of motion

    M q̈ = Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇ − ∂²L/∂q̇∂t − ∂Φ/∂q̇,   L = T − U,  M = ∂²T/∂q̇²

(eq. 55 of the seed document) by automatic differentiation, and integrates them with
Runge–Kutta, symplectic or implicit methods — no Python runs in the integration loop.

>>> import lagrangian as lg
>>> th1, th2 = lg.coordinates("th1 th2")
>>> m, l, g = lg.parameters("m l g")
>>> T = 0.5*m*l**2*(2*th1.d**2 + th2.d**2 + 2*th1.d*th2.d*lg.cos(th1 - th2))
>>> U = -m*g*l*(2*lg.cos(th1) + lg.cos(th2))
>>> model = lg.Model(coordinates=[th1, th2], kinetic=T, potential=U,
...                  parameters={"m": 1.0, "l": 1.0, "g": 9.81})
>>> sol = model.simulate(q0=[1.0, 0.5], qd0=[0.0, 0.0], t_end=10.0, rtol=1e-8, atol=1e-8)
>>> sol.q.shape[1]
2
"""

from . import _expr, scenes
from ._events import Event
# The expression language — symbols, t and the elementary functions (lg.sin, …) — is _expr's
# __all__; `abs` is exported but left out of it, so that `from lagrangian import *` does not
# shadow the builtin (which works on expressions too).
from ._expr import *  # noqa: F403
from ._expr import abs
from ._lagrangian import (
    ConvergenceError,
    Integrator,
    LagrangianError,
    NonFiniteError,
    SingularMassMatrixError,
    StepSizeError,
    StiffnessError,
    TooManyStepsError,
    __version__,
)
from ._ensemble import BatchIntegrator, Ensemble
from ._fit import Fit
from ._linear import Equilibrium, Linearization, Modes
from ._steady import SteadyLinearization
from ._bodies import (
    Body,
    PlanarBody,
    euler_rotation,
    quaternion_rotation,
    rotation_x,
    rotation_y,
    rotation_about,
    rotation_z,
)
from ._frames import Frame, Joint, Loop, Reaction, coincide, joint_reaction, loop_reaction
from ._contact import RollingContact, knife_edge, rolling_contact
from ._loads import Damper, Force, Spring, Torque
from ._urdf import Robot, URDFError, read_urdf
from ._model import Model, methods
from ._solution import Solution
from ._sympy import from_sympy
from ._workprec import WorkPrecision, work_precision

__all__ = [
    "Body",
    "PlanarBody",
    "euler_rotation",
    "quaternion_rotation",
    "rotation_x",
    "rotation_y",
    "rotation_z",
    "rotation_about",
    "Frame",
    "Joint",
    "Loop",
    "Reaction",
    "coincide",
    "joint_reaction",
    "loop_reaction",
    "RollingContact",
    "SteadyLinearization",
    "rolling_contact",
    "knife_edge",
    "Force",
    "Torque",
    "Spring",
    "Damper",
    "Robot",
    "URDFError",
    "read_urdf",
    "ConvergenceError",
    "BatchIntegrator",
    "Ensemble",
    "Equilibrium",
    "Event",
    "Fit",
    "Integrator",
    "LagrangianError",
    "Linearization",
    "Model",
    "Modes",
    "NonFiniteError",
    "SingularMassMatrixError",
    "Solution",
    "WorkPrecision",
    "StepSizeError",
    "StiffnessError",
    "TooManyStepsError",
    "__version__",
    "from_sympy",
    "methods",
    "scenes",
    "work_precision",
]
__all__ += _expr.__all__
