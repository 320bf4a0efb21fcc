"""Robots from URDF files: :func:`read_urdf` parses the file (``xml.etree``) into a
:class:`Robot` — links with their inertials, joints with origins, axes, limits, damping and
mimic tags, in the tree's order — and :func:`from_urdf` (bound as ``Model.from_urdf``) states it
as a fixed-base model: one coordinate per revolute, continuous or prismatic joint, links below
fixed joints lumped, the joints as :class:`~lagrangian.Frame` joints, T from the links'
velocities carried down the tree (or each link a :class:`~lagrangian.Body`), gravity and joint
damping."""

from __future__ import annotations

import keyword
import math
import os
import xml.etree.ElementTree as ET
from typing import Any, Callable, Dict, List, NamedTuple, Optional, Sequence, Tuple, TypeVar, Union

import numpy as np

from ._bodies import Body, cross, dot, plus, rotate, rotation_about, transpose
from ._expr import (
    Coordinate,
    Expr,
    _add,
    _mul,
    _sub,
    coordinates as make_coordinates,
    time_derivative,
)
from ._frames import Frame

__all__ = ["Robot", "Joint", "Link", "URDFError", "read_urdf", "from_urdf"]

M = TypeVar("M")
Vec = Tuple[float, float, float]
Mat = Tuple[Vec, Vec, Vec]

#: The joint types that give a coordinate, and the one that gives none.
MOVING = ("revolute", "continuous", "prismatic")
_UNSUPPORTED = ("planar", "floating")


class URDFError(ValueError):
    """A URDF file this package cannot read as a fixed-base robot: not URDF, a joint type it
    does not support, a joint naming a link that is not there, a loop, a link whose inertia no
    body has. The message names the file and the element."""


URDFError.__module__ = "lagrangian"  # as ``lg.URDFError`` in tracebacks


class Link(NamedTuple):
    """A link's inertial: ``mass``, the centre of mass ``center`` and the ``inertia`` tensor
    about it, both in the link's frame (the inertial origin's rpy already applied)."""

    name: str
    mass: float
    center: Vec
    inertia: Mat


class Joint(NamedTuple):
    """A joint as the file states it. ``limits`` is ``(lower, upper, effort, velocity)``
    (``None`` where absent): metadata only, not enforced. ``mimic`` is ``(joint, multiplier,
    offset)`` or ``None``; ``friction`` is read and not modelled."""

    name: str
    type: str
    parent: str
    child: str
    xyz: Vec
    rpy: Vec
    axis: Vec
    damping: float
    friction: float
    limits: Tuple[Optional[float], Optional[float], Optional[float], Optional[float]]
    mimic: Optional[Tuple[str, float, float]]


class Robot(NamedTuple):
    """A parsed URDF robot: its ``name``, ``root`` link, ``links`` by name and ``joints`` in the
    tree's order (depth first from the root, the children of a link by joint name, as urdfdom
    and Pinocchio order them); ``source`` is the file (or ``"<string>"``)."""

    name: str
    root: str
    links: Dict[str, Link]
    joints: Tuple[Joint, ...]
    source: str

    @property
    def moving(self) -> Tuple[Joint, ...]:
        """The revolute, continuous and prismatic joints, in order."""
        return tuple(j for j in self.joints if j.type in MOVING)

    @property
    def limits(self) -> Dict[str, Tuple[Optional[float], ...]]:
        """``{joint: (lower, upper, effort, velocity)}`` of the moving joints (not enforced)."""
        return {j.name: j.limits for j in self.moving}


# -- parsing -----------------------------------------------------------------------------------
def _numbers(text: Optional[str], n: int, default: Sequence[float], what: str,
             source: str) -> Tuple[float, ...]:
    if text is None:
        return tuple(float(x) for x in default)
    try:
        values = tuple(float(x) for x in text.split())
    except ValueError:
        values = ()
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise URDFError(f"{source}: {what} is {text!r}; give {n} finite numbers")
    return values


def _number(el: Optional[ET.Element], attr: str, default: Optional[float], what: str,
            source: str) -> Optional[float]:
    if el is None or el.get(attr) is None:
        return default
    return _numbers(el.get(attr), 1, (), what, source)[0]


def rpy_matrix(rpy: Sequence[float]) -> np.ndarray:
    """R = R_z(yaw) R_y(pitch) R_x(roll) of URDF's (roll, pitch, yaw), numerically."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), \
        math.cos(y), math.sin(y)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    out: np.ndarray = rz @ ry @ rx
    return out


def _origin(el: ET.Element, what: str, source: str) -> Tuple[Vec, Vec]:
    o = el.find("origin")
    xyz = _numbers(None if o is None else o.get("xyz"), 3, (0, 0, 0), f"{what} origin xyz",
                   source)
    rpy = _numbers(None if o is None else o.get("rpy"), 3, (0, 0, 0), f"{what} origin rpy",
                   source)
    return (xyz[0], xyz[1], xyz[2]), (rpy[0], rpy[1], rpy[2])


def _link(el: ET.Element, source: str) -> Link:
    name = el.get("name") or ""
    what = f"link {name!r}"
    inertial = el.find("inertial")
    if inertial is None:
        return Link(name, 0.0, (0.0, 0.0, 0.0), ((0.0,) * 3,) * 3)
    xyz, rpy = _origin(inertial, f"{what}'s inertial", source)
    mass = _number(inertial.find("mass"), "value", 0.0, f"{what}'s mass", source) or 0.0
    i = inertial.find("inertia")
    names = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    v = {k: (_number(i, k, 0.0, f"{what}'s {k}", source) or 0.0) for k in names}
    local = np.array([[v["ixx"], v["ixy"], v["ixz"]], [v["ixy"], v["iyy"], v["iyz"]],
                      [v["ixz"], v["iyz"], v["izz"]]])
    r = rpy_matrix(rpy)
    inertia = r @ local @ r.T
    try:  # the body's own checks: m ≥ 0, I positive semidefinite, the triangle inequality
        Body(mass, local.tolist(), (0.0, 0.0, 0.0), np.eye(3).tolist(), name=name)
    except ValueError as exc:
        raise URDFError(f"{source}: link {name!r} has a non-physical inertial: {exc}") from None
    rows = tuple(tuple(float(x) for x in row) for row in inertia)
    return Link(name, mass, xyz, rows)  # type: ignore[arg-type]


def _joint(el: ET.Element, source: str) -> Joint:
    name = el.get("name") or ""
    kind = el.get("type") or ""
    what = f"joint {name!r}"
    if kind in _UNSUPPORTED:
        raise URDFError(
            f"{source}: {what} is {kind!r}, which a fixed-base robot does not support: give "
            "revolute, continuous, prismatic or fixed joints (a floating base is not read)"
        )
    if kind not in MOVING + ("fixed",):
        raise URDFError(
            f"{source}: {what} has the unknown type {kind!r}: URDF joints are revolute, "
            "continuous, prismatic or fixed (planar and floating are not supported)"
        )
    links = []
    for tag in ("parent", "child"):
        sub = el.find(tag)
        if sub is None or not sub.get("link"):
            raise URDFError(f"{source}: {what} has no <{tag} link=…/>")
        links.append(sub.get("link") or "")
    xyz, rpy = _origin(el, what, source)
    a = el.find("axis")
    axis = _numbers(None if a is None else a.get("xyz"), 3, (1, 0, 0), f"{what}'s axis", source)
    if kind in MOVING and not math.hypot(*axis) > 0.0:
        raise URDFError(f"{source}: {what} has the zero axis {axis}; give a non-zero axis")
    dyn = el.find("dynamics")
    damping = _number(dyn, "damping", 0.0, f"{what}'s damping", source) or 0.0
    if damping < 0.0:
        raise URDFError(f"{source}: {what} has the damping {damping}; give a damping ≥ 0")
    friction = _number(dyn, "friction", 0.0, f"{what}'s friction", source) or 0.0
    lim = el.find("limit")
    limits = tuple(_number(lim, k, None, f"{what}'s limit {k}", source)
                   for k in ("lower", "upper", "effort", "velocity"))
    mim = el.find("mimic")
    mimic = None
    if mim is not None:
        if not mim.get("joint"):
            raise URDFError(f"{source}: {what}'s <mimic> names no joint")
        mimic = (mim.get("joint") or "",
                 _number(mim, "multiplier", 1.0, f"{what}'s mimic multiplier", source) or 0.0,
                 _number(mim, "offset", 0.0, f"{what}'s mimic offset", source) or 0.0)
    return Joint(name, kind, links[0], links[1], (xyz[0], xyz[1], xyz[2]),
                 (rpy[0], rpy[1], rpy[2]), (axis[0], axis[1], axis[2]), damping, friction,
                 limits, mimic)  # type: ignore[arg-type]


def read_urdf(source: Union[str, "os.PathLike[str]", Robot]) -> Robot:
    """The robot of a URDF file (a path) or text (a string starting with ``<``), checked: every
    joint's links declared, each link the child of one joint at most, one root, no loop, every
    inertial physical. Visuals, collisions, transmissions and Gazebo tags are ignored.

    >>> import lagrangian as lg
    >>> robot = lg.read_urdf('''<robot name="arm"><link name="base"/><link name="a"/>
    ...   <joint name="j" type="revolute"><parent link="base"/><child link="a"/>
    ...   <limit lower="-1" upper="1" effort="5" velocity="2"/></joint></robot>''')
    >>> [j.name for j in robot.moving], robot.limits["j"]
    (['j'], (-1.0, 1.0, 5.0, 2.0))
    """
    if isinstance(source, Robot):
        return source
    text_given = isinstance(source, str) and source.lstrip().startswith("<")
    label = "<string>" if text_given else os.fspath(source)
    try:
        root = ET.fromstring(str(source)) if text_given else ET.parse(label).getroot()
    except ET.ParseError as exc:
        raise URDFError(f"{label}: not a URDF file: the XML does not parse ({exc})") from None
    if root.tag != "robot":
        raise URDFError(
            f"{label}: not a URDF file: the root element is <{root.tag}>, not <robot>"
        )
    links: Dict[str, Link] = {}
    for el in root.findall("link"):
        link = _link(el, label)
        if link.name in links or not link.name:
            raise URDFError(f"{label}: a link is named {link.name!r} twice or not at all")
        links[link.name] = link
    joints: Dict[str, Joint] = {}
    parent_of: Dict[str, Joint] = {}
    for el in root.findall("joint"):
        j = _joint(el, label)
        if j.name in joints or not j.name:
            raise URDFError(f"{label}: a joint is named {j.name!r} twice or not at all")
        for which, link_name in (("parent", j.parent), ("child", j.child)):
            if link_name not in links:
                raise URDFError(
                    f"{label}: joint {j.name!r} names the {which} link {link_name!r}, which the "
                    "file does not declare"
                )
        if j.child in parent_of:
            raise URDFError(
                f"{label}: link {j.child!r} is the child of joints {parent_of[j.child].name!r} "
                f"and {j.name!r}: a loop (closed chains are not a URDF tree)"
            )
        parent_of[j.child] = j
        joints[j.name] = j
    if not links:
        raise URDFError(f"{label}: the robot has no links")
    roots = [name for name in links if name not in parent_of]
    if len(roots) != 1:
        raise URDFError(
            f"{label}: " + ("no root link: the joints form a loop" if not roots else
                            f"several root links {roots}: the links are not one tree")
        )
    children: Dict[str, List[Joint]] = {}
    for j in joints.values():
        children.setdefault(j.parent, []).append(j)
    ordered = _preorder(roots[0], children)
    if len(ordered) != len(joints):
        lost = sorted(set(joints) - {j.name for j in ordered})
        raise URDFError(f"{label}: the joints {lost} form a loop not attached to the root")
    for j in ordered:
        if j.mimic is not None and (j.mimic[0] not in joints
                                    or joints[j.mimic[0]].type not in MOVING):
            raise URDFError(
                f"{label}: joint {j.name!r} mimics {j.mimic[0]!r}, which is not a revolute, "
                "continuous or prismatic joint of the file"
            )
    return Robot(root.get("name") or "", roots[0], links, tuple(ordered), label)


def _preorder(root: str, children: Dict[str, List[Joint]]) -> List[Joint]:
    """The joints below ``root`` depth first, siblings by joint name (as urdfdom orders them)."""
    out: List[Joint] = []
    stack: List[Joint] = sorted(children.get(root, []), key=lambda j: j.name, reverse=True)
    while stack:
        j = stack.pop()
        out.append(j)
        stack.extend(sorted(children.get(j.child, []), key=lambda k: k.name, reverse=True))
    return out


# -- the model -----------------------------------------------------------------------------------
def coordinate_name(joint: str, taken: Sequence[str]) -> str:
    """The joint's name as a coordinate: itself when it is a Python identifier, otherwise with
    every other character replaced by ``_`` (and a leading ``q_`` before a digit or a keyword),
    made unique."""
    name = joint if joint.isidentifier() and not keyword.iskeyword(joint) else \
        "".join(c if (c.isalnum() or c == "_") else "_" for c in joint)
    if not name.isidentifier() or keyword.iskeyword(name):
        name = "q_" + name
    base, k = name, 1
    while name in taken:
        name, k = f"{base}_{k}", k + 1
    return name


class _Anchor(NamedTuple):
    """A link's place: the frame of the nearest moving link at or above it (``None``: the root,
    which does not move), and the link's constant placement in that frame."""

    frame: Optional[Frame]
    name: str
    offset: np.ndarray
    rotation: np.ndarray
    #: The moving frame's angular velocity and its origin's velocity, in its own axes.
    omega: Tuple[Expr, Expr, Expr]
    velocity: Tuple[Expr, Expr, Expr]


_ZERO = (Expr.lift(0.0),) * 3


def from_urdf(
    cls: Callable[..., M],
    source: Union[str, "os.PathLike[str]", Robot],
    *,
    mimic: str = "independent",
    gravity: Union[float, Sequence[float]] = 9.81,
    velocities: str = "recursive",
    backend: str = "native",
) -> M:
    """A fixed-base robot from a URDF file (a path), URDF text (a string starting with ``<``) or
    a :class:`Robot` from :func:`read_urdf`.

    One coordinate per revolute, continuous and prismatic joint, named as the joint (characters
    a Python name cannot hold replaced by ``_``), in the tree's order — depth first, siblings by
    joint name, as Pinocchio orders them. Each link is a rigid body (its inertial: mass, centre
    of mass and inertia at the inertial origin's xyz/rpy) on the :class:`~lagrangian.Frame` of
    the joint above it (origin xyz/rpy, then the motion about/along the joint's axis); links
    below fixed joints are lumped into the moving link they hang from (masses, centres and
    inertias combined by the parallel-axis theorem). The root link is the world: it does not
    move. T = Σ ½ m ‖v‖² + ½ ΩᵀIΩ with, by default (``velocities="recursive"``), each link's
    angular velocity Ω and its origin's velocity V carried down the tree in the link's own axes
    (Ωₖ = Eₖᵀ Ωₚ + aₖ θ̇ₖ, Vₖ = Eₖᵀ (Vₚ + Ωₚ × rₖ), Eₖ the joint's turn, as the Newton–Euler
    recursion does), so T's graph grows linearly with the links; ``velocities="bodies"`` makes
    each link a :class:`~lagrangian.Body` instead, whose Ω = vee(RᵀṘ) is differentiated from R —
    the same T, on a graph that grows with the cube of the chain's depth (slow to build past 8
    links). Gravity acts along −z (``gravity`` is g, or the vector g itself); joint damping dᵢ
    gives Rayleigh's Φ = ½ Σ dᵢ θ̇ᵢ². Not modelled: joint friction, limits (kept as
    :attr:`Robot.limits`), effort and velocity limits, visuals and collisions.

    ``mimic="independent"`` (the default, as Pinocchio reads a URDF): a mimic joint is a
    coordinate of its own. ``mimic="couple"``: its angle is multiplier·q + offset of the joint it
    mimics, and it has no coordinate.

    >>> import lagrangian as lg
    >>> arm = lg.Model.from_urdf('''<robot name="pendulum"><link name="base"/>
    ...   <link name="bob"><inertial><origin xyz="0 0 -1"/><mass value="2"/>
    ...     <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
    ...   <joint name="swing" type="continuous"><parent link="base"/><child link="bob"/>
    ...     <axis xyz="0 1 0"/></joint></robot>''')
    >>> arm.coordinates
    (swing,)
    >>> round(float(arm.accelerations(0.0, [0.5], [0.0])[0]), 6)  # −g sin θ / l
    -4.703165

    Raises
    ------
    URDFError
        A file that is not URDF, a planar, floating or unknown joint type (naming the joint), a
        joint naming a link that is not declared, a loop, a link with a non-physical inertial
        (naming the link), a mimic of a joint that does not move or a loop of mimics.
    ValueError
        An unknown ``mimic`` or ``velocities`` option, a ``gravity`` that is not a number or
        three.
    """
    if mimic not in ("independent", "couple"):
        raise ValueError(f"from_urdf: mimic={mimic!r}; give 'independent' or 'couple'")
    if velocities not in ("recursive", "bodies"):
        raise ValueError(f"from_urdf: velocities={velocities!r}; give 'recursive' or 'bodies'")
    g = _gravity(gravity)
    robot = read_urdf(source)
    moving = robot.moving
    if not moving:
        raise URDFError(f"{robot.source}: the robot has no revolute, continuous or prismatic "
                        "joint: nothing moves")
    coupled = {j.name: j.mimic for j in moving if mimic == "couple" and j.mimic is not None}
    names: List[str] = []
    for j in moving:
        if j.name not in coupled:
            names.append(coordinate_name(j.name, names))
    coords: Tuple[Coordinate, ...] = make_coordinates(" ".join(names)) if names else ()
    own = dict(zip((j.name for j in moving if j.name not in coupled), coords))

    def position(joint: str, seen: Tuple[str, ...] = ()) -> Expr:
        """The joint's angle or distance as an expression of the coordinates."""
        if joint in own:
            return own[joint]
        if joint in seen:
            raise URDFError(f"{robot.source}: the mimic joints {list(seen)} form a loop")
        target, multiplier, offset = coupled[joint]
        return _add(_mul(multiplier, position(target, seen + (joint,))), offset)

    anchors: Dict[str, _Anchor] = {
        robot.root: _Anchor(None, robot.root, np.zeros(3), np.eye(3), _ZERO, _ZERO)
    }
    values: Dict[str, Expr] = {}
    drawing: List[Tuple[Expr, ...]] = [(Expr.lift(0.0),) * 3]
    for j in robot.joints:
        up = anchors[j.parent]
        offset = up.offset + up.rotation @ np.array(j.xyz)
        rotation = up.rotation @ rpy_matrix(j.rpy)
        if j.type == "fixed":
            anchors[j.child] = _Anchor(up.frame, up.name, offset, rotation, up.omega, up.velocity)
            continue
        base = up.frame if up.frame is not None else Frame()
        q = values[j.name] = position(j.name)
        rate = time_derivative(q, list(coords))
        axis = np.array(j.axis) / np.linalg.norm(j.axis)
        placement = (offset.tolist(), rotation.tolist())
        # Velocities in each frame's own axes (the Newton–Euler recursion's): the child's origin
        # sits at r in the parent's axes, its axes turned by E = C·Rot(a, θ) (C the placement).
        r: Sequence[Any] = offset.tolist()
        if j.type == "prismatic":
            r = tuple(_add(float(x), _mul(float(y), q)) for x, y in zip(offset, rotation @ axis))
        velocity = rotate(transpose(rotation), plus(up.velocity, cross(up.omega, r)))
        omega = rotate(transpose(rotation), up.omega)
        step = tuple(_mul(float(x), rate) for x in axis)
        if j.type == "prismatic":
            frame = base.prismatic(q, j.axis, *placement)
            velocity = plus(velocity, step)
        else:
            frame = base.revolute(q, j.axis, *placement)
            turn = rotation_about(axis.tolist(), q)
            velocity, omega = rotate(transpose(turn), velocity), rotate(transpose(turn), omega)
            omega = plus(omega, step)
        anchors[j.child] = _Anchor(frame, j.child, np.zeros(3), np.eye(3), omega, velocity)
        drawing.append(frame.origin)
    lumps = _lumped(robot, anchors)
    if not lumps:
        raise URDFError(f"{robot.source}: no link below a moving joint has a mass or inertia: "
                        "give the links inertials")
    kinetic: Optional[Expr] = None
    bodies: Optional[List[Body]] = None
    potential: Expr = Expr.lift(0.0)
    if velocities == "bodies":
        bodies = [a.frame.body(mass, inertia.tolist(), center.tolist(), name=a.name, gravity=g)
                  for a, mass, center, inertia in lumps if a.frame is not None]
        for b in bodies:
            potential = _add(potential, b.potential)
    else:
        kinetic = Expr.lift(0.0)
        for a, mass, center, inertia in lumps:  # T in each link's own axes
            assert a.frame is not None
            v = plus(a.velocity, cross(a.omega, [Expr.lift(float(x)) for x in center]))
            spin = Expr.lift(0.0)
            for i in range(3):
                for k in range(3):
                    if inertia[i][k] != 0.0:
                        spin = _add(spin, _mul(_mul(float(inertia[i][k]), a.omega[i]),
                                               a.omega[k]))
            kinetic = _add(kinetic, _add(_mul(0.5 * mass, dot(v, v)), _mul(0.5, spin)))
            height = dot(tuple(Expr.lift(x) for x in g), a.frame.point(center.tolist()))
            potential = _sub(potential, _mul(mass, height))
    dissipation: Expr = Expr.lift(0.0)
    for j in moving:
        if j.damping > 0.0:
            rate = time_derivative(values[j.name], list(coords))
            dissipation = _add(dissipation, _mul(0.5 * j.damping, _mul(rate, rate)))
    return cls(
        coordinates=list(coords),
        kinetic=kinetic,
        potential=None if potential.op == "const" else potential,
        dissipation=None if dissipation.op == "const" else dissipation,
        bodies=bodies,
        backend=backend,
        drawing=drawing,
    )


def _gravity(gravity: Union[float, Sequence[float]]) -> Vec:
    if isinstance(gravity, (int, float)) and not isinstance(gravity, bool):
        return (0.0, 0.0, -float(gravity))
    try:
        g = [float(x) for x in gravity]  # type: ignore[union-attr]
    except (TypeError, ValueError):
        g = []
    if len(g) != 3 or not all(math.isfinite(x) for x in g):
        raise ValueError(f"from_urdf: gravity={gravity!r}; give g (along −z) or three numbers")
    return (g[0], g[1], g[2])


def _lumped(robot: Robot, anchors: Dict[str, _Anchor]
            ) -> List[Tuple[_Anchor, float, np.ndarray, np.ndarray]]:
    """Per moving link: its own inertial and those of the links fixed below it, lumped — total
    mass, centre of mass, inertia about it by the parallel-axis theorem — in its frame."""
    parts: Dict[str, List[Tuple[float, np.ndarray, np.ndarray]]] = {}
    owner: Dict[str, _Anchor] = {}
    for name, link in robot.links.items():
        a = anchors[name]
        if a.frame is None or link.mass == 0.0 and not np.any(np.array(link.inertia)):
            continue  # fixed to the world, or massless
        owner[a.name] = anchors[a.name]
        center = a.offset + a.rotation @ np.array(link.center)
        inertia = a.rotation @ np.array(link.inertia) @ a.rotation.T
        parts.setdefault(a.name, []).append((link.mass, center, inertia))
    out = []
    for name, items in parts.items():
        mass = sum(m for m, _, _ in items)
        center = sum((m * c for m, c, _ in items), np.zeros(3)) / mass if mass > 0.0 \
            else items[0][1]
        inertia = np.zeros((3, 3))
        for m, c, i in items:
            d = c - center
            inertia += i + m * (float(d @ d) * np.eye(3) - np.outer(d, d))
        out.append((owner[name], float(mass), center, inertia))
    return out
