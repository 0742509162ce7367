"""URDF text for the hoop and the floor, as PyBullet loads them (plain XML, no engine import).

The hoop is built one of two ways (``HOOP_BASES``). ``free`` (PyBullet's default in hoopbench):
one link and no joint, a floating base, loaded with ``useFixedBase=False`` as PyBullet's own
examples load a ball (``sphere2.urdf``). Its link frame is the hoop centre, turned about +y by
theta; PyBullet's base frame is the link's inertial frame, i.e. the centre of mass, and its
velocities are the centre of mass's. ``chain``: a planar chain fixed to the world::

    world --prismatic x--> slider_x --prismatic z--> slider_z --continuous y--> hoop

PyBullet's z is hoopbench's y (up). The joint positions are the hoop centre (x, y) and theta:

* ``x_joint`` and ``z_joint`` have their origins at the world origin, so their positions are the
  hoop centre's coordinates (the z joint starts at a, the hoop touching the floor);
* ``theta_joint`` turns about +y. A positive turn about +y carries +z toward +x, i.e. the top of
  the hoop moves forward: with the weight at +z in the hoop frame (theta = 0, on top), the
  joint angle is theta itself.

The hoop link's ``<inertial>`` is the whole hoop (ring plus weight) from the Scene: mass M,
centre of mass at (0, 0, lam*a) in the hoop frame (the weight's direction at theta = 0), and
the moment of inertia about the centre of mass I = M a^2 k about y. The out-of-plane moments
never act (no out-of-plane freedom, and with the spin along a principal axis no gyroscopic
torque); they are set to I each. The thin-plate values I/2 would sit exactly on the triangle
inequality that PyBullet checks, and a tensor failing it is replaced by zero inertia with
only a warning on stdout.

The two slider links carry ``DUMMY_MASS_FRACTION`` of M each (and a tiny inertia): PyBullet
handles massless links in a chain badly, and at this size they change the translational inertia
by 2e-6 relative, far below any tolerance. The weight has a visual only, no collision shape.
"""

from __future__ import annotations

import math
from xml.sax.saxutils import quoteattr

from hoopbench.models.checks import check_real
from hoopbench.models.scene import Scene

__all__ = [
    "CYLINDER_LENGTH_FRACTION",
    "DUMMY_MASS_FRACTION",
    "FLOOR_HALF_SIZE",
    "HOOP_BASES",
    "HOOP_GEOMETRIES",
    "JOINT_NAMES",
    "PLANAR_JOINT_NAME",
    "floor_urdf",
    "scene_to_planar_urdf",
    "scene_to_urdf",
]

HOOP_GEOMETRIES: tuple[str, ...] = ("sphere", "cylinder", "hull")
"""Collision shapes of the hoop. sphere: radius a (in the plane, exactly the hoop's circle);
cylinder and hull: a URDF cylinder with its axis along y. The URDF text is the same for both;
the loader decides (implicit cylinder, or PyBullet's default 32-vertex convex hull, which
PyBullet pads with a 1 mm collision margin: it reaches a + 1 mm below the centre with a vertex
down, and the adapter places it and reads its clearance by that surface)."""

HOOP_BASES: tuple[str, ...] = ("free", "chain")
"""How the hoop is attached: ``free`` (a floating base, one link) or ``chain`` (three joints to
the world through two slider links; see the module docstring)."""

JOINT_NAMES: tuple[str, str, str] = ("x_joint", "z_joint", "theta_joint")
"""The three joints in chain order: hoop-centre x (m), hoop-centre height (m), theta (rad)."""

PLANAR_JOINT_NAME = "planar"
"""The joint of :func:`scene_to_planar_urdf`: a URDF ``planar`` joint whose axis (+y) is the
normal of the plane of motion, x-z."""

DUMMY_MASS_FRACTION = 1e-6
"""Mass of each slider link as a fraction of M."""

CYLINDER_LENGTH_FRACTION = 0.1
"""Length of the cylinder collision shape along y, as a fraction of a."""

FLOOR_HALF_SIZE = 1000.0
"""Smallest half side of the floor box, m; larger when the scene can reach farther."""

_FLOOR_THICKNESS = 1.0
"""m; the box's top face is the plane z = 0."""


def _num(value: float) -> str:
    """Full-precision decimal text, so that the engine reads back exactly the scene's numbers."""
    return repr(float(value))


def _inertia_xml(mass: float, com_z: float, iyy: float, ixx: float, izz: float) -> str:
    return (
        "    <inertial>\n"
        f'      <origin xyz="0 0 {_num(com_z)}" rpy="0 0 0"/>\n'
        f'      <mass value="{_num(mass)}"/>\n'
        f'      <inertia ixx="{_num(ixx)}" ixy="0" ixz="0" iyy="{_num(iyy)}" iyz="0" '
        f'izz="{_num(izz)}"/>\n'
        "    </inertial>\n"
    )


def _contact_xml(lateral_friction: float | None, restitution: float | None = None) -> str:
    if lateral_friction is None and restitution is None:
        return ""
    lines = ["    <contact>\n"]
    if lateral_friction is not None:
        lines.append(f'      <lateral_friction value="{_num(lateral_friction)}"/>\n')
        lines.append('      <rolling_friction value="0"/>\n')
        lines.append('      <spinning_friction value="0"/>\n')
    if restitution is not None:
        lines.append(f'      <restitution value="{_num(restitution)}"/>\n')
    lines.append("    </contact>\n")
    return "".join(lines)


def _dummy_link(name: str, mass: float) -> str:
    tiny = mass * 1e-3  # kg m^2; any small positive value: these links never rotate
    return (
        f"  <link name={quoteattr(name)}>\n"
        + _inertia_xml(mass, 0.0, tiny, tiny, tiny)
        + ("  </link>\n")
    )


def scene_to_urdf(
    scene: Scene, *, geometry: str = "sphere", mu: float | None = None, base: str = "free"
) -> str:
    """URDF of the hoop of ``scene``: one floating link (``base="free"``) or the planar chain
    (``base="chain"``); see the module docstring.

    ``geometry`` is one of HOOP_GEOMETRIES; ``mu`` (if given) is written as the hoop link's
    lateral friction in PyBullet's ``<contact>`` extension, with rolling and spinning friction
    0. Raises ValueError for an unknown geometry or base, a bad mu, or a scene with I = 0.
    """
    if geometry not in HOOP_GEOMETRIES:
        raise ValueError(f"geometry must be one of {', '.join(HOOP_GEOMETRIES)}, got {geometry!r}")
    if base not in HOOP_BASES:
        raise ValueError(f"base must be one of {', '.join(HOOP_BASES)}, got {base!r}")
    mu = None if mu is None else check_real("mu", mu, low=0.0)
    scene.require_inertia("a PyBullet hoop")
    a = scene.a
    inertia = scene.inertia_com
    dummy = DUMMY_MASS_FRACTION * scene.M

    if geometry == "sphere":
        shape = f'<sphere radius="{_num(a)}"/>'
        shape_origin = '<origin xyz="0 0 0" rpy="0 0 0"/>'
    else:
        # URDF cylinders lie along the local z axis; turn it onto y, the hoop's axle.
        shape = f'<cylinder radius="{_num(a)}" length="{_num(CYLINDER_LENGTH_FRACTION * a)}"/>'
        shape_origin = f'<origin xyz="0 0 0" rpy="{_num(math.pi / 2)} 0 0"/>'
    weight_radius = 0.05 * a

    header = (
        f"<!-- hoopbench hoop: written by models.urdf.scene_to_urdf for scene "
        f"{scene.name or '(unnamed)'}: lam={scene.lam!r} eps={scene.eps!r} a={scene.a!r} "
        f"M={scene.M!r} g={scene.g!r} geometry={geometry} mu={mu!r} base={base}. "
        + (
            "One floating link: load with useFixedBase=False; the base frame is the centre "
            "of mass. -->\n"
            if base == "free"
            else "Joint positions: hoop centre x, hoop centre height, theta. -->\n"
        )
    )
    chain_links = (
        '  <link name="world"/>\n' + _dummy_link("slider_x", dummy) + _dummy_link("slider_z", dummy)
        if base == "chain"
        else ""
    )
    chain_joints = (
        _joint("x_joint", "prismatic", "world", "slider_x", "1 0 0")
        + _joint("z_joint", "prismatic", "slider_x", "slider_z", "0 0 1")
        + _joint("theta_joint", "continuous", "slider_z", "hoop", "0 1 0")
        if base == "chain"
        else ""
    )
    return (
        '<?xml version="1.0"?>\n'
        + header
        + '<robot name="hoop">\n'
        + chain_links
        + '  <link name="hoop">\n'
        + _inertia_xml(scene.M, scene.com_offset, inertia, inertia, inertia)
        + "    <collision>\n"
        + f"      {shape_origin}\n"
        + f"      <geometry>{shape}</geometry>\n"
        + "    </collision>\n"
        + "    <visual>\n"
        + f"      {shape_origin}\n"
        + f"      <geometry>{shape}</geometry>\n"
        + "    </visual>\n"
        + "    <visual>\n"
        + f'      <origin xyz="0 0 {_num(a)}" rpy="0 0 0"/>\n'
        + f'      <geometry><sphere radius="{_num(weight_radius)}"/></geometry>\n'
        + "    </visual>\n"
        + _contact_xml(mu)
        + "  </link>\n"
        + chain_joints
        + "</robot>\n"
    )


def _joint(name: str, kind: str, parent: str, child: str, axis: str) -> str:
    # Unbounded limits and no damping or friction: the joint must not act on the motion.
    limit = (
        '    <limit lower="-1e9" upper="1e9" effort="0" velocity="1e9"/>\n'
        if kind == "prismatic"
        else ""
    )
    return (
        f'  <joint name="{name}" type="{kind}">\n'
        f'    <parent link="{parent}"/>\n'
        f'    <child link="{child}"/>\n'
        '    <origin xyz="0 0 0" rpy="0 0 0"/>\n'
        f'    <axis xyz="{axis}"/>\n'
        f"{limit}"
        '    <dynamics damping="0" friction="0"/>\n'
        "  </joint>\n"
    )


def floor_urdf(
    *, lateral_friction: float = 1.0, restitution: float = 1.0, half_size: float = FLOOR_HALF_SIZE
) -> str:
    """URDF of a static floor whose top face is the plane z = 0, ``half_size`` m each way.

    PyBullet multiplies the two bodies' friction (and restitution) coefficients, so the floor's
    defaults are 1: the pair then gets exactly the hoop's values.
    """
    lateral_friction = check_real("lateral_friction", lateral_friction, low=0.0)
    r = check_real("restitution", restitution, low=0.0, high=1.0)
    side = 2 * half_size
    box = f'<box size="{_num(side)} {_num(side)} {_num(_FLOOR_THICKNESS)}"/>'
    origin = f'<origin xyz="0 0 {_num(-_FLOOR_THICKNESS / 2)}" rpy="0 0 0"/>'
    return (
        '<?xml version="1.0"?>\n'
        "<!-- hoopbench floor: written by models.urdf.floor_urdf; top face at z = 0, "
        f"lateral_friction={lateral_friction!r}, restitution={r!r}. -->\n"
        '<robot name="floor">\n'
        '  <link name="floor">\n'
        + _inertia_xml(0.0, 0.0, 0.0, 0.0, 0.0)
        + "    <collision>\n"
        + f"      {origin}\n"
        + f"      <geometry>{box}</geometry>\n"
        + "    </collision>\n"
        + _contact_xml(lateral_friction, r)
        + "  </link>\n"
        + "</robot>\n"
    )


def scene_to_planar_urdf(scene: Scene, *, comment: str = "") -> str:
    """URDF of the hoop of ``scene`` on one ``planar`` joint to the world, as DART's
    ``DartLoader`` reads it (PyBullet does not take URDF planar joints).

    The joint's axis +y is the normal of the plane: DART makes it a ``PlanarJoint`` with
    positions (hoop-centre height z, hoop-centre x, theta) and turns the link about +y, so the
    angle is theta itself (the top moves toward +x). The link frame is the hoop centre; its
    ``<inertial>`` is the whole hoop, as in :func:`scene_to_urdf`, and a sphere of radius a
    collides. No contact values: DART's loader reads none, the adapter sets them.
    ``comment`` goes into an XML comment. ValueError for a scene with I = 0.
    """
    scene.require_inertia("a DART hoop")
    a, inertia = scene.a, scene.inertia_com
    shape = f'<sphere radius="{_num(a)}"/>'
    head = '<?xml version="1.0"?>\n'
    if comment:
        head += "<!--\n" + comment.replace("--", "- -") + "\n-->\n"
    return (
        head
        + '<robot name="hoop">\n'
        + '  <link name="world"/>\n'
        + '  <link name="hoop">\n'
        + _inertia_xml(scene.M, scene.com_offset, inertia, inertia, inertia)
        + "    <collision>\n"
        + '      <origin xyz="0 0 0" rpy="0 0 0"/>\n'
        + f"      <geometry>{shape}</geometry>\n"
        + "    </collision>\n"
        + "    <visual>\n"
        + f'      <origin xyz="0 0 {_num(a)}" rpy="0 0 0"/>\n'
        + f'      <geometry><sphere radius="{_num(0.05 * a)}"/></geometry>\n'
        + "    </visual>\n"
        + "  </link>\n"
        + f'  <joint name="{PLANAR_JOINT_NAME}" type="planar">\n'
        + '    <parent link="world"/>\n'
        + '    <child link="hoop"/>\n'
        + '    <origin xyz="0 0 0" rpy="0 0 0"/>\n'
        + '    <axis xyz="0 1 0"/>\n'
        + "  </joint>\n"
        + "</robot>\n"
    )
