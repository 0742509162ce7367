"""The hoop scene as an MJCF document (MuJoCo's XML model format).

Plain XML building: this module does not import MuJoCo, so a model file can be written (and
inspected, or opened in MuJoCo's viewer) without the engine, and models/ stays free of engine
imports.

Frames. MuJoCo's world has x forward and z up; hoopbench's y is MuJoCo's z. The one body,
``hoop``, has its frame origin at the hoop centre, which starts at (0, 0, a). Three joints sit at
that origin, in this order: slide ``x`` (centre displacement along x), slide ``z`` (centre
displacement along z, 0 at the start height a) and hinge ``theta`` about +y. A positive rotation
about +y carries the body's +z axis toward +x, so the hinge angle is hoopbench's theta (clockwise
from the top, seen with x to the right and z up). In the body frame the weight sits at
(0, 0, a) and the centre of mass at (0, 0, lam*a).

Contact. Every geom has contype = conaffinity = 0, so MuJoCo makes no contact pairs of its own;
the hoop-floor contacts are explicit ``<pair>`` elements. A pair's friction is used as given,
which sidesteps MuJoCo's element-wise max rule for combining the two geoms' coefficients. The
geoms carry the same coefficient anyway, so the pair is mu whichever rule applies.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from typing import Any

import numpy as np

from hoopbench.models import kinematics
from hoopbench.models.checks import check_real
from hoopbench.models.kinematics import Polygon
from hoopbench.models.scene import Scene

__all__ = [
    "CONES",
    "INTEGRATORS",
    "MJCF_GEOMETRIES",
    "check_restitution",
    "com_rows",
    "contact_shape",
    "scene_to_mjcf",
]

MJCF_GEOMETRIES: tuple[str, ...] = ("sphere", "cylinder", "ring")
"""sphere: radius a (exactly the hoop's circle in the plane); cylinder: radius a, axis along y;
ring: ring_segments capsules around the rim (a polygon, with bumps)."""

CONES: tuple[str, ...] = ("pyramidal", "elliptic")
INTEGRATORS: tuple[str, ...] = ("Euler", "RK4", "implicit", "implicitfast", "discrete")

CYLINDER_HALF_LENGTH = 0.02
"""Half-length of the cylinder geometry, in units of a. Its two end contacts balance about x."""
CAPSULE_RADIUS = 0.01
"""Radius of the ring's capsules, in units of a."""
INERTIA_PAD = 1e-6
"""Relative padding of the out-of-plane principal moments over the thin-plate values
I/2 each; without it, rounding can fail MuJoCo's A + B >= C check. They do not enter the
planar dynamics."""


def _num(value: float) -> str:
    """Shortest decimal text that reads back as the same double."""
    value = float(value)
    if value == 0.0:
        return "0"
    return repr(value)


def _vec(*values: float) -> str:
    return " ".join(_num(v) for v in values)


def check_restitution(restitution: float) -> None:
    """ValueError unless restitution is 0: see :func:`scene_to_mjcf` for why."""
    value = check_real("restitution", restitution, low=0.0, high=1.0)
    if value != 0.0:
        raise ValueError(
            f"restitution must be 0 for MuJoCo, got {restitution}: MuJoCo has no coefficient "
            "of restitution. A bounce comes from solref's dampratio < 1, but how much depends "
            "on timeconst, solimp and timestep (a linear spring-damper law was off by up to "
            "0.17 at the default solref); set solref yourself to study bounces"
        )


def _comment_safe(text: str) -> str:
    # "--" may not appear inside an XML comment.
    while "--" in text:
        text = text.replace("--", "- -")
    return text


def _header(
    scene: Scene, mu: float, timestep: float, restitution: float, geometry: str, opts: Mapping
) -> str:
    fields = ", ".join(
        f"{k}={_num(v) if isinstance(v, float) else v}"
        for k, v in scene.to_dict().items()
        if k not in ("name",)
    )
    settings = ", ".join(
        f"{k}={_vec(*v) if isinstance(v, tuple) else v}" for k, v in sorted(opts.items())
    )
    lines = [
        "Written by hoopbench (models/mjcf.py) from",
        f"  scene {scene.name or '(unnamed)'!r}: {fields}",
        f"  mu={_num(mu)}, timestep={_num(timestep)} s, restitution={_num(restitution)}, "
        f"geometry={geometry}",
        f"  mujoco options: {settings}",
        "Frames: MuJoCo z is hoopbench y; the hinge angle is theta (clockwise from the top);",
        "joints sit at the hoop centre; the weight has no collision geom.",
    ]
    return "<!--\n" + "\n".join(_comment_safe(line) for line in lines) + "\n-->\n"


def _ring(scene: Scene, segments: int) -> Polygon:
    """The ring's capsule centrelines as a polygon rounded by the capsule radius.

    The centreline vertices lie on a circle of radius a - rc, so the vertices reach radius a.
    A vertex is put straight below the centre at the start: the hoop starts on a vertex,
    touching the floor with clearance 0 like the other geometries.
    """
    rc = CAPSULE_RADIUS * scene.a
    # Straight down in the body frame, when the hinge angle is theta0: (sin th0, 0, -cos th0).
    phi0 = math.atan2(-math.cos(scene.theta0), math.sin(scene.theta0))
    return Polygon.regular(segments, scene.a - rc, phi0, rounding=rc)


def contact_shape(scene: Scene, geometry: str, options: Mapping[str, Any]) -> Polygon | None:
    """The contact shape of ``geometry`` in the plane of the hoop, for clearance and slip
    velocity (hoopbench.models.kinematics): None for the sphere and the cylinder, whose
    section is the hoop's circle; the ring's polygon of capsules."""
    if geometry not in MJCF_GEOMETRIES:
        raise ValueError(f"geometry must be one of {', '.join(MJCF_GEOMETRIES)}, got {geometry!r}")
    return _ring(scene, options["ring_segments"]) if geometry == "ring" else None


def com_rows(scene: Scene, qpos: Any, qvel: Any) -> Any:
    """(n, 6) centre-of-mass rows (X, Y, theta, Xdot, Ydot, thetadot: m, rad, m/s, rad/s)
    from the joints' positions and velocities, each (n, 3) (slide x, slide z from the start
    height a, hinge theta; the frames of the module doc), as the backends that step this
    model's joints (MJX, MuJoCo Warp) give them."""
    qpos, qvel = np.atleast_2d(qpos), np.atleast_2d(qvel)
    com = kinematics.com_state(scene, qpos[:, 0], scene.a + qpos[:, 1], qpos[:, 2], *qvel.T)
    return np.stack(list(com.values()), axis=-1)


def _hoop_geoms(body: ET.Element, scene: Scene, geometry: str, opts: Mapping, mu: float) -> list:
    """Collision geoms of the hoop; their names, for the contact pairs."""
    a = scene.a
    # Attributes as dicts, which ElementTree writes in order: the shape's first, then these.
    common = {"contype": "0", "conaffinity": "0", "friction": _vec(mu, 0, 0), "condim": "3"}
    rgba = "0.3 0.5 0.8 0.35"
    if geometry == "sphere":
        attrib = {"name": "hoop", "type": "sphere", "size": _num(a), "rgba": rgba}
        ET.SubElement(body, "geom", {**attrib, **common})
        return ["hoop"]
    if geometry == "cylinder":
        attrib = {
            "name": "hoop",
            "type": "cylinder",
            "size": _vec(a, CYLINDER_HALF_LENGTH * a),
            "zaxis": "0 1 0",
            "rgba": rgba,
        }
        ET.SubElement(body, "geom", {**attrib, **common})
        return ["hoop"]
    # ring: one capsule along each side of the polygon (see _ring).
    ring = _ring(scene, opts["ring_segments"])
    n = len(ring.vertices)
    names = []
    width = len(str(n - 1))
    for i in range(n):
        (u0, w0), (u1, w1) = ring.vertices[i], ring.vertices[(i + 1) % n]
        name = f"hoop_{i:0{width}d}"
        attrib = {
            "name": name,
            "type": "capsule",
            "size": _num(ring.rounding),
            "fromto": _vec(u0, 0, w0, u1, 0, w1),
            "rgba": "0.3 0.5 0.8 1",
        }
        ET.SubElement(body, "geom", {**attrib, **common})
        names.append(name)
    return names


def scene_to_mjcf(
    scene: Scene,
    *,
    mu: float,
    timestep: float,
    restitution: float = 0.0,
    geometry: str = "sphere",
    options: Mapping[str, Any],
    contact_sensor: bool = True,
) -> str:
    """A complete MJCF document of the scene, ready for ``mujoco.MjModel.from_xml_string``.

    Mass, centre of mass and moment of inertia come from the scene (``<inertial>``), not from
    the geoms. ``options`` is the full mujoco option dict, as checked and normalised by the
    MuJoCo engine's option declarations (hoopbench.engines.mujoco_engine). Restitution must be
    0: MuJoCo has no restitution coefficient, and its contact with dampratio 1 (the default)
    does not bounce. A bounce can be studied through solref's dampratio, but no honest mapping
    from a coefficient exists: measured on a drop at timestep 1e-4, the linear spring-damper law
    e = exp(-pi z / sqrt(1 - z^2)) held within 0.01 at solref timeconst 0.02 s, and was off by
    up to 0.17 (and unreliable above e = 0.7) at 0.0005 s. The body starts at the reference pose
    (hoop centre at (0, 0, a), hinge angle 0): the initial state is the adapter's job (qpos,
    qvel).

    Raises ValueError for a bad mu, timestep or geometry, for restitution != 0, and
    DegenerateSceneError (a ValueError) when the scene has no moment of inertia.
    """
    scene.require_inertia("a MuJoCo model")
    mu = check_real("mu", mu, low=0.0)
    timestep = check_real("timestep", timestep, low=0.0, low_open=True, unit="s")
    if geometry not in MJCF_GEOMETRIES:
        raise ValueError(f"geometry must be one of {', '.join(MJCF_GEOMETRIES)}, got {geometry!r}")
    check_restitution(restitution)
    opts = options

    root = ET.Element("mujoco", model=f"hoopbench {scene.name}".strip())
    _add_settings(root, scene, timestep, opts)
    names = _add_world(root, scene, mu, geometry, opts)
    _add_contacts(root, names, mu, opts)
    if contact_sensor:
        _add_sensor(root)
    ET.indent(root, space="  ")
    return (
        _header(scene, mu, timestep, restitution, geometry, opts)
        + ET.tostring(root, encoding="unicode")
        + "\n"
    )


def _add_settings(root: ET.Element, scene: Scene, timestep: float, opts: Mapping) -> None:
    """Compiler, solver options, and the look of the viewer."""
    ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false")
    option = {
        "timestep": _num(timestep),
        "gravity": _vec(0, 0, -scene.g),
        "integrator": opts["integrator"],
        "cone": opts["cone"],
        "impratio": _num(opts["impratio"]),
        # A backend without a noslip pass (MJX) declares no such option: MuJoCo's default 0.
        **(
            {"noslip_iterations": str(opts["noslip_iterations"])}
            if "noslip_iterations" in opts
            else {}
        ),
        "tolerance": _num(opts["tolerance"]),
        "iterations": str(opts["iterations"]),
    }
    ET.SubElement(root, "option", option)
    visual = ET.SubElement(root, "visual")
    ET.SubElement(visual, "global", azimuth="90", elevation="-10")
    asset = ET.SubElement(root, "asset")
    ET.SubElement(
        asset,
        "texture",
        name="grid",
        type="2d",
        builtin="checker",
        width="256",
        height="256",
        rgb1="0.85 0.85 0.85",
        rgb2="0.7 0.7 0.7",
    )
    ET.SubElement(
        asset, "material", name="grid", texture="grid", texrepeat="1 1", texuniform="true"
    )


def _add_world(
    root: ET.Element, scene: Scene, mu: float, geometry: str, opts: Mapping
) -> list[str]:
    """The floor and the hoop's body; the names of the hoop's collision geoms."""
    a, M, r, inertia = scene.a, scene.M, scene.com_offset, scene.inertia_com
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "light", pos=_vec(0, -4 * a, 4 * a), dir="0 1 -1", directional="true")
    ET.SubElement(
        world,
        "geom",
        name="floor",
        type="plane",
        size=_vec(0, 0, a),
        material="grid",
        contype="0",
        conaffinity="0",
        friction=_vec(mu, 0, 0),
        condim="3",
    )
    body = ET.SubElement(world, "body", name="hoop", pos=_vec(0, 0, a))
    ET.SubElement(body, "joint", name="x", type="slide", axis="1 0 0")
    ET.SubElement(body, "joint", name="z", type="slide", axis="0 0 1")
    ET.SubElement(body, "joint", name="theta", type="hinge", axis="0 1 0")
    side = 0.5 * inertia * (1.0 + INERTIA_PAD)
    ET.SubElement(
        body, "inertial", pos=_vec(0, 0, r), mass=_num(M), diaginertia=_vec(side, inertia, side)
    )
    names = _hoop_geoms(body, scene, geometry, opts, mu)
    # The weight is drawn, never touched: no collision, no mass (the inertial holds it).
    ET.SubElement(
        body,
        "geom",
        name="weight",
        type="sphere",
        size=_num(0.06 * a),
        pos=_vec(0, 0, a),
        contype="0",
        conaffinity="0",
        group="1",
        mass="0",
        rgba="0.8 0.2 0.1 1",
    )
    return names


def _add_contacts(root: ET.Element, names: list[str], mu: float, opts: Mapping) -> None:
    """One contact pair per hoop geom with the floor."""
    contact = ET.SubElement(root, "contact")
    for name in names:
        ET.SubElement(
            contact,
            "pair",
            name=f"{name}_floor",
            geom1=name,
            geom2="floor",
            condim="3",
            # tangent1, tangent2, torsional, rolling1, rolling2
            friction=_vec(mu, mu, 0, 0, 0),
            solref=_vec(*opts["solref"]),
            solreffriction=_vec(*opts["solreffriction"]),
            solimp=_vec(*opts["solimp"]),
        )


def _add_sensor(root: ET.Element) -> None:
    """The contact-force sensor the MuJoCo adapter reads."""
    sensor = ET.SubElement(root, "sensor")
    # One synthetic contact: the net contact force on the hoop, world frame (adapter reads it).
    ET.SubElement(
        sensor,
        "contact",
        name="contact_force",
        body1="world",
        body2="hoop",
        reduce="netforce",
        data="found force",
    )
