"""The hoop scene as an SDFormat document, as Drake's ``Parser`` loads it (no engine import).

Plain XML building: this module does not import pydrake, so the model file can be written and
inspected without Drake (``hoopbench model --engine drake``), and models/ stays free of engine
imports. Drake-specific elements use the ``drake:`` namespace.

Frames. Drake's world has x forward and z up; hoopbench's y is Drake's z. SDFormat has no planar
joint, and Drake's ``<drake:joint type="planar">`` takes no pose and no ``world`` parent: its
frames are the parent and child link frames, and it moves the child in the parent frame's x-y
plane, turning it about the parent's z axis. So:

* ``plane``, a massless link welded to the world at (0, 0, a), turned +90 deg about x: its x axis
  is the world's x, its y axis the world's z (up) and its z axis the world's -y;
* ``hoop``, the hoop's link, starts at the same pose: its origin is the hoop centre, which starts
  on the floor at (0, 0, a), with the weight on top (theta = 0);
* the planar joint ``planar`` (parent ``plane``, child ``hoop``) has positions
  (x, y - a, phi): the centre's x, its height above the start height a, and the turn about the
  world's -y axis. A turn about +y carries the top of the hoop toward +x, so phi = -theta.

The joint's parent is ``plane`` and not the floor link: Drake filters collisions between bodies
joined by a joint, which would remove the hoop-floor contact.

Mass, centre of mass and inertia come from the scene, never from geometry: the hoop link's
``<inertial>`` has mass M, the centre of mass at (0, lam*a, 0) in the link frame (toward the
weight, the link's +y being up at theta = 0) and I = M a^2 k about the link's z axis, which is
the axle. The out-of-plane moments never act (the joint allows no out-of-plane motion); they are
set to I each, safely inside the triangle inequality.

Contact. The floor is a half space (``<plane>``, infinite in Drake whatever its size), the hoop
a sphere of radius a (in the plane, exactly the hoop's circle), the weight a visual only. Both
collision geometries carry the same ``drake:proximity_properties``, which makes Drake's
combination rules give the pair exactly the wanted values:

* friction, combined as 2 mu1 mu2 / (mu1 + mu2): mu on both gives mu;
* point-contact stiffness, combined in series, k1 k2 / (k1 + k2): each geometry gets 2 k;
* Hunt-Crossley dissipation, the stiffness-weighted mean: d on both gives d;
* SAP's relaxation time, combined as the sum tau1 + tau2: each geometry gets tau / 2.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

from hoopbench.models.checks import check_real
from hoopbench.models.scene import Scene

__all__ = [
    "DRAKE_NAMESPACE",
    "GEOMETRY_NAMES",
    "JOINT_NAME",
    "MODEL_NAME",
    "check_restitution",
    "scene_to_sdformat",
]

DRAKE_NAMESPACE = "http://drake.mit.edu"
MODEL_NAME = "hoop_scene"
JOINT_NAME = "planar"
"""The planar joint: positions (centre x, centre height - a, -theta)."""
GEOMETRY_NAMES: tuple[str, str] = ("floor", "hoop")
"""Collision geometries of the floor and the hoop (link and geometry share the name)."""

_WEIGHT_RADIUS = 0.05
"""Radius of the weight's visual sphere, in units of a (drawn only, never collides)."""
_PLANE_SIZE = 100.0
"""Drawn size of the floor, in units of a; the half space itself is infinite."""


def _num(value: float) -> str:
    """Shortest decimal text that reads back as the same double."""
    value = float(value)
    return "0" if value == 0.0 else repr(value)


def _vec(*values: float) -> str:
    return " ".join(_num(v) for v in values)


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attrib: str) -> ET.Element:
    element = ET.SubElement(parent, tag, attrib)
    if text is not None:
        element.text = text
    return element


def check_restitution(restitution: float) -> None:
    """ValueError unless restitution is 0: Drake's point contact has no restitution."""
    value = check_real("restitution", restitution, low=0.0, high=1.0)
    if value != 0.0:
        raise ValueError(
            f"restitution must be 0 for Drake, got {restitution}: Drake's point contact has no "
            "coefficient of restitution (Hunt-Crossley dissipation gives a bounce that depends "
            "on the impact speed)"
        )


@dataclass(frozen=True)
class _PairContact:
    """The contact values wanted for the hoop-floor pair; None leaves a value to Drake."""

    mu: float
    stiffness: float | None
    """N/m."""
    dissipation: float | None
    """Hunt-Crossley, s/m."""
    relaxation_time: float | None
    """s, SAP only."""

    @classmethod
    def checked(
        cls,
        mu: float,
        stiffness: float | None,
        dissipation: float | None,
        relaxation_time: float | None,
    ) -> _PairContact:
        """The values as floats; ValueError naming a bad one."""
        mu = check_real("mu", mu, low=0.0)
        if stiffness is not None:
            stiffness = check_real("stiffness", stiffness, low=0.0, low_open=True, unit="N/m")
        if dissipation is not None:
            dissipation = check_real("dissipation", dissipation, low=0.0, unit="s/m")
        if relaxation_time is not None:
            relaxation_time = check_real("relaxation_time", relaxation_time, low=0.0, unit="s")
        return cls(mu, stiffness, dissipation, relaxation_time)

    def add_to(self, collision: ET.Element) -> None:
        """Per-geometry values that Drake's combination rules turn into the pair's own; None
        leaves a value out (Drake then uses its own estimate, or default)."""
        props = _sub(collision, "drake:proximity_properties")
        if self.stiffness is not None:
            _sub(props, "drake:point_contact_stiffness", _num(2.0 * self.stiffness))
        if self.dissipation is not None:
            _sub(props, "drake:hunt_crossley_dissipation", _num(self.dissipation))
        if self.relaxation_time is not None:
            _sub(props, "drake:relaxation_time", _num(self.relaxation_time / 2.0))
        _sub(props, "drake:mu_dynamic", _num(self.mu))
        _sub(props, "drake:mu_static", _num(self.mu))


def _inertial(link: ET.Element, mass: float, com: tuple[float, float, float], i: tuple) -> None:
    inertial = _sub(link, "inertial")
    _sub(inertial, "pose", _vec(*com, 0, 0, 0))
    _sub(inertial, "mass", _num(mass))
    inertia = _sub(inertial, "inertia")
    for name, value in zip(("ixx", "iyy", "izz", "ixy", "ixz", "iyz"), (*i, 0, 0, 0), strict=True):
        _sub(inertia, name, _num(value))


def _weld(model: ET.Element, name: str, child: str) -> None:
    weld = _sub(model, "joint", name=name, type="fixed")
    _sub(weld, "parent", "world")
    _sub(weld, "child", child)


def _add_floor(model: ET.Element, a: float, contact: _PairContact) -> None:
    """The floor: a half space welded to the world."""
    floor = _sub(model, "link", name="floor")
    collision = _sub(floor, "collision", name=GEOMETRY_NAMES[0])
    plane = _sub(_sub(collision, "geometry"), "plane")
    _sub(plane, "normal", "0 0 1")
    _sub(plane, "size", _vec(_PLANE_SIZE * a, _PLANE_SIZE * a))
    contact.add_to(collision)
    visual = _sub(floor, "visual", name="floor")
    plane = _sub(_sub(visual, "geometry"), "plane")
    _sub(plane, "normal", "0 0 1")
    _sub(plane, "size", _vec(_PLANE_SIZE * a, _PLANE_SIZE * a))
    _weld(model, "floor_weld", "floor")
    _inertial(floor, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # SDFormat's default is 1 kg


def _add_hoop(model: ET.Element, scene: Scene, contact: _PairContact) -> None:
    """The massless ``plane`` link, the hoop's link and the planar joint between them."""
    a, r, inertia = scene.a, scene.com_offset, scene.inertia_com
    turn = _vec(math.pi / 2, 0, 0)  # link x: world x, link y: world z (up), link z: world -y
    anchor = _sub(model, "link", name="plane")
    _sub(anchor, "pose", f"{_vec(0, 0, a)} {turn}")
    _inertial(anchor, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    _weld(model, "plane_weld", "plane")

    hoop = _sub(model, "link", name="hoop")
    _sub(hoop, "pose", f"{_vec(0, 0, a)} {turn}")
    _inertial(hoop, scene.M, (0.0, r, 0.0), (inertia, inertia, inertia))
    collision = _sub(hoop, "collision", name=GEOMETRY_NAMES[1])
    _sub(_sub(_sub(collision, "geometry"), "sphere"), "radius", _num(a))
    contact.add_to(collision)
    visual = _sub(hoop, "visual", name="weight")
    _sub(visual, "pose", _vec(0, a, 0, 0, 0, 0))
    _sub(_sub(_sub(visual, "geometry"), "sphere"), "radius", _num(_WEIGHT_RADIUS * a))

    joint = _sub(model, "drake:joint", name=JOINT_NAME, type="planar")
    _sub(joint, "drake:parent", "plane")
    _sub(joint, "drake:child", "hoop")
    _sub(joint, "drake:damping", "0 0 0")


def scene_to_sdformat(
    scene: Scene,
    *,
    mu: float,
    stiffness: float | None,
    dissipation: float | None,
    relaxation_time: float | None = None,
    restitution: float = 0.0,
    comment: str = "",
) -> str:
    """SDFormat text of the hoop of ``scene`` on its floor (see the module docstring).

    ``mu`` is the pair's friction coefficient, ``stiffness`` (N/m) and ``dissipation``
    (Hunt-Crossley, s/m) the pair's point-contact values, ``relaxation_time`` (s, SAP only) the
    pair's, or None for Drake's default (0.1 s per geometry, 0.2 s for the pair). Each is written
    so that Drake's combination rule gives the pair that value. A stiffness or dissipation of
    None is left out: Drake then estimates it from the plant's penetration allowance.
    ``comment`` goes into an XML comment at the top. ValueError for a bad value, restitution
    other than 0, or a scene with I = 0.
    """
    contact = _PairContact.checked(mu, stiffness, dissipation, relaxation_time)
    check_restitution(restitution)
    scene.require_inertia("a Drake hoop")
    sdf = ET.Element("sdf", {"version": "1.9", "xmlns:drake": DRAKE_NAMESPACE})
    model = _sub(sdf, "model", name=MODEL_NAME)
    _add_floor(model, scene.a, contact)
    _add_hoop(model, scene, contact)
    ET.indent(sdf)
    text = ET.tostring(sdf, encoding="unicode")
    head = '<?xml version="1.0"?>\n'
    if comment:
        safe = comment.replace("--", "- -")
        head += f"<!--\n{safe}\n-->\n"
    return head + text + "\n"
