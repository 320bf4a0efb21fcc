"""Robots from URDF (``lg.read_urdf``, ``lg.Model.from_urdf``): a hand-written 2-link arm
against its hand-written Lagrangian, the mimic coupling against the independent joints reduced
by hand, the errors; and, where Pinocchio is installed (``pip install pin
example-robot-data``), the UR5 and the Panda of example-robot-data against ``pin.crba`` and
``pin.aba`` at random states."""

import importlib.metadata
from pathlib import Path

import numpy as np
import pytest

import lagrangian as lg

G = 9.81
L1, C1, M1, IY1 = 0.7, 0.3, 1.5, 0.08
L2, C2, M2, IY2 = 0.5, 0.2, 0.9, 0.03
MT = 0.4  # a tip mass on a fixed joint at the end of link 2
D1, D2 = 0.05, 0.02


def inertial(mass, xyz="0 0 0", rpy="0 0 0", ixx=0.0, iyy=0.0, izz=0.0, ixy=0.0, ixz=0.0,
             iyz=0.0):
    return (f'<inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx}" ixy="{ixy}" ixz="{ixz}" iyy="{iyy}" iyz="{iyz}" '
            f'izz="{izz}"/></inertial>')


# Two links swinging about y under gravity −z, hanging along −z at θ = 0; link 2's inertial is
# turned about y (which keeps I_yy, all that the planar motion reads); a tip mass hangs on a fixed
# joint with an arbitrary rpy (a point mass), lumped into link 2.
ARM = f"""<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="upper">{inertial(M1, xyz=f"0 0 {-C1}", ixx=0.1, iyy=IY1, izz=0.05)}</link>
  <link name="lower">{inertial(M2, xyz=f"0 0 {-C2}", rpy="0 0.4 0", ixx=0.02, iyy=IY2,
                               izz=0.025)}</link>
  <link name="tip">{inertial(MT)}
    <visual><geometry><sphere radius="0.05"/></geometry></visual></link>
  <joint name="shoulder" type="continuous">
    <parent link="base"/><child link="upper"/><axis xyz="0 1 0"/>
    <dynamics damping="{D1}" friction="0.3"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="lower"/><origin xyz="0 0 {-L1}"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="2.5" effort="10" velocity="3"/>
    <dynamics damping="{D2}"/>
  </joint>
  <joint name="tip_joint" type="fixed">
    <parent link="lower"/><child link="tip"/><origin xyz="0 0 {-L2}" rpy="0.3 -0.2 1.1"/>
  </joint>
</robot>
"""


def hand_arm():
    """The same arm's Lagrangian and Rayleigh function written by hand (θ from −z, about +y:
    x = −ℓ sin θ, z = −ℓ cos θ)."""
    th1, th2 = lg.coordinates("shoulder elbow")
    a, w1, w12 = th1 + th2, th1.d, th1.d + th2.d
    iy2 = IY2  # a rotation about y keeps I_yy
    T = (0.5 * (M1 * C1**2 + IY1 + M2 * L1**2) * w1**2 + 0.5 * (M2 * C2**2 + iy2) * w12**2
         + M2 * L1 * C2 * lg.cos(th2) * w1 * w12)
    vx = -L1 * lg.cos(th1) * w1 - L2 * lg.cos(a) * w12
    vz = L1 * lg.sin(th1) * w1 + L2 * lg.sin(a) * w12
    T = T + 0.5 * MT * (vx**2 + vz**2)
    U = -G * (M1 * C1 * lg.cos(th1) + M2 * (L1 * lg.cos(th1) + C2 * lg.cos(a))
              + MT * (L1 * lg.cos(th1) + L2 * lg.cos(a)))
    phi = 0.5 * D1 * th1.d**2 + 0.5 * D2 * th2.d**2
    return lg.Model([th1, th2], kinetic=T, potential=U, dissipation=phi)


def states(n, dof, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-np.pi, np.pi, (n, dof)), rng.uniform(-2.0, 2.0, (n, dof))


def test_two_link_arm_against_its_hand_written_lagrangian(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(ARM)
    robot = lg.Model.from_urdf(path)
    hand = hand_arm()
    bodies = lg.Model.from_urdf(path, velocities="bodies")
    assert [c.name for c in robot.coordinates] == ["shoulder", "elbow"]
    q, qd = states(12, 2)
    for qi, qdi in zip(q, qd):
        m_hand = hand.mass_matrix(0.0, qi, qdi)
        np.testing.assert_allclose(robot.mass_matrix(0.0, qi, qdi), m_hand, rtol=0,
                                   atol=1e-13 * np.max(np.abs(m_hand)))
        a_hand = hand.accelerations(0.0, qi, qdi)
        for model in (robot, bodies):
            np.testing.assert_allclose(model.accelerations(0.0, qi, qdi), a_hand, rtol=0,
                                       atol=1e-12 * max(1.0, np.max(np.abs(a_hand))))
    # the text and the file read alike; the damping is the dissipation, friction left out
    same = lg.Model.from_urdf(ARM)
    np.testing.assert_array_equal(same.accelerations(0.0, q[0], qd[0]),
                                  robot.accelerations(0.0, q[0], qd[0]))
    undamped = lg.Model.from_urdf(ARM.replace(f'damping="{D1}"', 'damping="0"')
                                  .replace(f'damping="{D2}"', 'damping="0"'))
    diff = robot.accelerations(0.0, q[0], qd[0]) - undamped.accelerations(0.0, q[0], qd[0])
    m = hand.mass_matrix(0.0, q[0], qd[0])
    np.testing.assert_allclose(m @ diff, -np.array([D1, D2]) * qd[0], rtol=1e-12, atol=1e-14)
    assert undamped.dissipation is None


def test_the_robots_metadata():
    robot = lg.read_urdf(ARM)
    assert robot.name == "arm" and robot.root == "base"
    assert [j.name for j in robot.joints] == ["shoulder", "elbow", "tip_joint"]
    assert [j.name for j in robot.moving] == ["shoulder", "elbow"]
    assert robot.limits == {"shoulder": (None, None, None, None),
                            "elbow": (-2.5, 2.5, 10.0, 3.0)}
    assert robot.joints[0].friction == 0.3 and robot.joints[0].damping == D1
    assert robot.links["tip"].mass == MT
    # an inertial turned by its rpy: I = R diag R^T (about y here)
    c, s = np.cos(0.4), np.sin(0.4)
    r = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    np.testing.assert_allclose(robot.links["lower"].inertia,
                               r @ np.diag([0.02, IY2, 0.025]) @ r.T, atol=1e-15)
    assert lg.Model.from_urdf(robot).dof == 2


SIBLINGS = """<robot name="siblings">
  <link name="base"/>
  <link name="l1">{i}</link><link name="l2">{i}</link><link name="l3">{i}</link>
  <joint name="zz" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="cc" type="prismatic"><parent link="l1"/><child link="l3"/><axis xyz="1 1 0"/>
    <origin xyz="0.3 0 0" rpy="0.2 0.1 -0.4"/><dynamics damping="0.2"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="my-joint" type="continuous"><parent link="base"/><child link="l2"/>
    <axis xyz="0 1 0"/></joint>
</robot>""".format(i=inertial(1.0, xyz="0.1 0.2 0.3", ixx=0.3, iyy=0.2, izz=0.25, ixy=0.01))


def test_tree_order_and_names():
    """Depth first, siblings by joint name (urdfdom's order); a name Python cannot hold has its
    characters replaced."""
    model = lg.Model.from_urdf(SIBLINGS)
    assert [c.name for c in model.coordinates] == ["my_joint", "zz", "cc"]


MIMIC = f"""<robot name="mimic">
  <link name="base"/>
  <link name="a">{inertial(1.2, xyz="0 0 -0.4", ixx=0.02, iyy=0.03, izz=0.01)}</link>
  <link name="b">{inertial(0.7, xyz="0.1 0 -0.3", ixx=0.01, iyy=0.015, izz=0.02)}</link>
  <joint name="drive" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 1 0"/>
    <dynamics damping="0.1"/></joint>
  <joint name="follower" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0 0 -0.5"/><axis xyz="1 0 0"/>
    <mimic joint="drive" multiplier="2.0" offset="0.1"/><dynamics damping="0.05"/></joint>
</robot>"""


def test_mimic_couple_is_the_independent_robot_reduced_by_hand():
    """θ = J q + c with J = (1, 2): M_c = Jᵀ M J and M_c q̈ = Jᵀ M a, a the independent robot's
    accelerations at θ, θ̇ = J q̇ (J is constant, so no velocity term); damping included."""
    free = lg.Model.from_urdf(MIMIC)
    coupled = lg.Model.from_urdf(MIMIC, mimic="couple")
    assert [c.name for c in free.coordinates] == ["drive", "follower"]
    assert [c.name for c in coupled.coordinates] == ["drive"]
    j = np.array([1.0, 2.0])
    q, qd = states(10, 1, seed=3)
    for qi, qdi in zip(q, qd):
        th, thd = j * qi[0] + np.array([0.0, 0.1]), j * qdi[0]
        m = free.mass_matrix(0.0, th, thd)
        a = free.accelerations(0.0, th, thd)
        m_c = j @ m @ j
        np.testing.assert_allclose(coupled.mass_matrix(0.0, qi, qdi), [[m_c]], rtol=1e-13)
        expected = (j @ m @ a) / m_c
        np.testing.assert_allclose(coupled.accelerations(0.0, qi, qdi), [expected], rtol=0,
                                   atol=1e-12 * max(1.0, abs(expected)))


def urdf_with(joints="", links="", base='<link name="base"/>'):
    return f"<robot name='r'>{base}{links}{joints}</robot>"


LINK_A = f'<link name="a">{inertial(1.0, ixx=0.1, iyy=0.1, izz=0.1)}</link>'


@pytest.mark.parametrize("kind", ["planar", "floating"])
def test_planar_and_floating_joints_are_refused_by_name(kind):
    text = urdf_with(f'<joint name="free" type="{kind}"><parent link="base"/>'
                     f'<child link="a"/></joint>', LINK_A)
    with pytest.raises(lg.URDFError, match=f"joint 'free' is '{kind}'.*fixed-base"):
        lg.Model.from_urdf(text)


@pytest.mark.parametrize("text, match", [
    (urdf_with('<joint name="j" type="ball"><parent link="base"/><child link="a"/></joint>',
               LINK_A), "joint 'j' has the unknown type 'ball'"),
    (urdf_with('<joint name="j" type="revolute"><parent link="nowhere"/><child link="a"/>'
               '</joint>', LINK_A), "parent link 'nowhere'.*does not declare"),
    (urdf_with('<joint name="j" type="revolute"><parent link="base"/><child link="a"/></joint>'
               '<joint name="k" type="revolute"><parent link="base"/><child link="a"/></joint>',
               LINK_A), "child of joints 'j' and 'k': a loop"),
    (urdf_with('<joint name="j" type="revolute"><parent link="base"/><child link="a"/></joint>'
               '<joint name="k" type="revolute"><parent link="a"/><child link="base"/></joint>',
               LINK_A), "no root link: the joints form a loop"),
    (urdf_with('<joint name="j" type="revolute"><parent link="base"/><child link="a"/></joint>'
               '<joint name="k" type="revolute"><parent link="b"/><child link="c"/></joint>'
               '<joint name="l" type="revolute"><parent link="c"/><child link="b"/></joint>',
               LINK_A + '<link name="b"/><link name="c"/>'), "form a loop not attached"),
    ("<sdf version='1.6'><model name='m'/></sdf>", "not a URDF file: the root element is <sdf>"),
    ("<robot name='r'><link name='base'>", "not a URDF file: the XML does not parse"),
    (urdf_with('<joint name="j" type="revolute"><parent link="base"/><child link="a"/></joint>',
               f'<link name="a">{inertial(1.0, ixx=0.1, iyy=0.1, izz=0.5)}</link>'),
     "link 'a' has a non-physical inertial.*triangle"),
    (urdf_with('<joint name="j" type="revolute"><parent link="base"/><child link="a"/></joint>',
               f'<link name="a">{inertial(-1.0, ixx=0.1, iyy=0.1, izz=0.1)}</link>'),
     "link 'a' has a non-physical inertial.*mass"),
    (urdf_with('<joint name="j" type="revolute"><parent link="base"/><child link="a"/>'
               '<axis xyz="0 0 0"/></joint>', LINK_A), "joint 'j' has the zero axis"),
    (urdf_with('<joint name="j" type="revolute"><parent link="base"/><child link="a"/>'
               '<origin xyz="0 1"/></joint>', LINK_A), "joint 'j' origin xyz is '0 1'"),
    (urdf_with('<joint name="j" type="revolute"><parent link="base"/><child link="a"/>'
               '<mimic joint="f"/></joint><joint name="f" type="fixed"><parent link="a"/>'
               '<child link="b"/></joint>', LINK_A + '<link name="b"/>'),
     "joint 'j' mimics 'f', which is not a revolute"),
    (urdf_with('<joint name="j" type="fixed"><parent link="base"/><child link="a"/></joint>',
               LINK_A), "no revolute, continuous or prismatic joint"),
    (urdf_with('<joint name="j" type="revolute"><parent link="base"/><child link="a"/></joint>',
               '<link name="a"/>'), "no link below a moving joint has a mass"),
])
def test_bad_files_are_typed_errors_that_name_the_culprit(text, match):
    with pytest.raises(lg.URDFError, match=match):
        lg.Model.from_urdf(text)


def test_bad_options_and_missing_files(tmp_path):
    with pytest.raises(ValueError, match="mimic='both'"):
        lg.Model.from_urdf(ARM, mimic="both")
    with pytest.raises(ValueError, match="velocities='fast'"):
        lg.Model.from_urdf(ARM, velocities="fast")
    with pytest.raises(ValueError, match="gravity"):
        lg.Model.from_urdf(ARM, gravity=(0.0, -9.81))
    with pytest.raises(FileNotFoundError):
        lg.Model.from_urdf(tmp_path / "missing.urdf")
    # a loop of mimics
    loop = MIMIC.replace('<dynamics damping="0.1"/></joint>',
                         '<mimic joint="follower"/></joint>', 1)
    with pytest.raises(lg.URDFError, match="form a loop"):
        lg.Model.from_urdf(loop, mimic="couple")
    assert issubclass(lg.URDFError, ValueError)


def test_gravity_as_a_vector():
    """g along +x: the arm at rest at θ = 0 (hanging along −z) is pulled to +x, which a turn
    about +y by a negative angle reaches (x = −ℓ sin θ)."""
    model = lg.Model.from_urdf(ARM, gravity=(9.81, 0.0, 0.0))
    a = model.accelerations(0.0, [0.0, 0.0], [0.0, 0.0])
    assert a[0] < 0.0
    hand = lg.Model.from_urdf(ARM, gravity=9.81)
    np.testing.assert_allclose(hand.accelerations(0.0, [0.0, 0.0], [0.0, 0.0]), [0.0, 0.0],
                               atol=1e-15)


# -- against Pinocchio -----------------------------------------------------------------------
def robots_dir():
    """example-robot-data's robots folder (its wheel installs them under cmeel.prefix)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed")
    folder = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    if not folder.is_dir():
        pytest.skip(f"example-robot-data's robots are not at {folder}")
    return folder


ROBOTS = {"ur5": "ur_description/urdf/ur5_robot.urdf",
          "panda": "panda_description/urdf/panda.urdf"}


def pin_configuration(pmodel, q):
    """Pinocchio's configuration vector of the angles ``q``: a continuous joint is (cos, sin)."""
    out = []
    for joint, angle in zip(list(pmodel.joints)[1:], q):
        out += [np.cos(angle), np.sin(angle)] if joint.nq == 2 else [angle]
    return np.array(out)


def pinocchio_agrees(model, pmodel, pin, seed=7):
    """M = pin.crba (symmetrized) and q̈ = pin.aba with τ = −d q̇ (the joint damping, which
    Pinocchio's model carries and its aba leaves out) at 12 random states, to 1e-9 of the
    scale."""
    data = pmodel.createData()
    q, qd = states(12, model.dof, seed=seed)
    for qi, qdi in zip(q, qd):
        pq = pin_configuration(pmodel, qi)
        m = pin.crba(pmodel, data, pq)
        m = np.triu(m) + np.triu(m, 1).T
        a = pin.aba(pmodel, data, pq, qdi, -np.asarray(pmodel.damping) * qdi)
        np.testing.assert_allclose(model.mass_matrix(0.0, qi, qdi), m, rtol=0,
                                   atol=1e-9 * np.max(np.abs(m)))
        np.testing.assert_allclose(model.accelerations(0.0, qi, qdi), a, rtol=0,
                                   atol=1e-9 * max(1.0, np.max(np.abs(a))))


@pytest.mark.parametrize("velocities", ["recursive", "bodies"])
@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_against_pinocchio(name, velocities):
    """Both ways of stating T; the coordinates are Pinocchio's joints, in order."""
    pin = pytest.importorskip("pinocchio")
    path = str(robots_dir() / ROBOTS[name])
    pmodel = pin.buildModelFromUrdf(path)
    model = lg.Model.from_urdf(path, velocities=velocities)
    assert [c.name for c in model.coordinates] == list(pmodel.names)[1:]
    pinocchio_agrees(model, pmodel, pin)


@pytest.mark.parametrize("velocities", ["recursive", "bodies"])
def test_a_prismatic_tree_against_pinocchio(velocities):
    """Siblings, a continuous joint, a prismatic joint along a slanted axis (not unit length in
    the file) placed with a turn, centres and inertias off the axes."""
    pin = pytest.importorskip("pinocchio")
    pmodel = pin.buildModelFromXML(SIBLINGS)
    model = lg.Model.from_urdf(SIBLINGS, velocities=velocities)
    assert [c.name for c in model.coordinates] == [n.replace("-", "_")
                                                   for n in list(pmodel.names)[1:]]
    pinocchio_agrees(model, pmodel, pin, seed=5)


def test_mimic_couple_against_pinocchio():
    """The Panda's second finger mimics the first: Pinocchio's mimic model (``mimic=True``) has
    8 coordinates as ``mimic="couple"``; its aba does not take mimic joints, so q̈ = M⁻¹(τ − h)
    from crba and nonLinearEffects, with τ the damping of both fingers on the one coordinate
    (Pinocchio's mimic model drops the follower's)."""
    pin = pytest.importorskip("pinocchio")
    path = str(robots_dir() / ROBOTS["panda"])
    pmodel = pin.buildModelFromUrdf(path, mimic=True)
    data = pmodel.createData()
    model = lg.Model.from_urdf(path, mimic="couple")
    assert [c.name for c in model.coordinates] == list(pmodel.names)[1:-1]
    damping = lg.read_urdf(path).joints
    d = np.array([j.damping for j in damping if j.type != "fixed"])
    d = np.r_[d[:7], d[7] + d[8]]
    q, qd = states(10, model.dof, seed=11)
    for qi, qdi in zip(q, qd):
        m = pin.crba(pmodel, data, qi)
        m = np.triu(m) + np.triu(m, 1).T
        a = np.linalg.solve(m, -d * qdi - pin.nonLinearEffects(pmodel, data, qi, qdi))
        np.testing.assert_allclose(model.mass_matrix(0.0, qi, qdi), m, rtol=0,
                                   atol=1e-9 * np.max(np.abs(m)))
        np.testing.assert_allclose(model.accelerations(0.0, qi, qdi), a, rtol=0,
                                   atol=1e-9 * max(1.0, np.max(np.abs(a))))
