"""The hopping hoop as a MuJoCo user builds it, from MuJoCo's own documentation.

Each construction follows a page of MuJoCo's documentation or one of its examples:

- Planar base: one body with two slide joints (x, z) and a hinge about y, as DeepMind
  Control Suite's planar models root their torso (``rootx`` slide, ``rootz`` slide,
  ``rooty`` hinge: https://github.com/google-deepmind/dm_control/blob/main/dm_control/suite/cheetah.xml,
  .../hopper.xml, .../walker.xml), and the XML reference's ``joint`` (type slide / hinge,
  https://mujoco.readthedocs.io/en/stable/XMLreference.html#body-joint). A freejoint
  (https://mujoco.readthedocs.io/en/stable/XMLreference.html#body-freejoint) would leave the
  hoop free to tip out of its plane; the planar joints are what MuJoCo's own 2D models use.
- Mass and inertia: an ``<inertial>`` element (pos = the centre of mass, mass, diaginertia),
  https://mujoco.readthedocs.io/en/stable/XMLreference.html#body-inertial; with it MuJoCo
  takes the body's inertia from the element, not from the geoms (``inertiafromgeom="auto"``).
  The weight on the rim is part of that inertia: it needs no geom of its own.
- Contact: the hoop is a sphere of radius a (in the plane of the joints its section is the
  hoop's circle; one contact point with a plane), the floor a plane, both colliding by
  MuJoCo's defaults (contype = conaffinity = 1, condim 3), friction given on the geoms
  (MuJoCo combines two geoms' friction by the maximum:
  https://mujoco.readthedocs.io/en/stable/modeling.html#contact-parameters); contact
  softness left at MuJoCo's defaults (solref 0.02 1, solimp 0.9 0.95 0.001,
  https://mujoco.readthedocs.io/en/stable/modeling.html#solver-parameters).
- Solver: MuJoCo's defaults (Euler integrator, pyramidal cone, impratio 1, Newton solver,
  https://mujoco.readthedocs.io/en/stable/XMLreference.html#option); only timestep and
  gravity set.
- Python: ``MjModel.from_xml_string``, ``MjData``, ``mj_step``, and ``mj_contactForce`` for
  each contact of ``data.contact``, rotated from the contact frame to the world
  (https://mujoco.readthedocs.io/en/stable/python.html,
  https://mujoco.readthedocs.io/en/stable/APIreference/APIfunctions.html#mj-contactforce).
  With the Euler integrator the contacts and constraint forces left by ``mj_step`` are those
  of the state the step started from.
- Start: rolling (qpos, qvel set directly), at rest on the floor. MuJoCo's contacts are soft:
  a body at rest on a plane sits a little into it, where the constraint force balances its
  weight (https://mujoco.readthedocs.io/en/stable/computation/index.html#soft-contacts,
  "penetration"). Started exactly touching, the hoop gets no contact force in its first step,
  falls into the floor and rings; so the depth where the vertical acceleration of the rootz
  slide (``data.qacc`` after ``mj_forward``) is zero is found by bisection, and the hoop starts
  there. ``run(..., start="touching")`` starts it exactly touching instead (measured below).

Cost: hop-top and seed-mu at dt 1e-4 (30,000 steps each) take about 2 s each.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

SAME_AS_HOOPBENCH = True
HOOPBENCH_SETTINGS: dict = {"profile": "stock"}
DIFFERENCE = ""
RTOL = 1e-12
"""Measured (dt 1e-4, 3 s, against hoopbench's stock profile, which is MuJoCo's defaults): the
largest state difference over each state's scale was 1.4e-14 on hop-top and 7.8e-15 on seed-mu
(the bisected depth against hoopbench's Brent root); with hoopbench's own depth the runs are
identical bit for bit. Started touching instead, hop-top lifts off 11.4 ms later (1.2033 s
against 1.1919 s) and hops 0.6 % lower: the start matters on stock."""


def model_xml(scene: dict, dt: float) -> str:
    """The MJCF: floor plane, and the hoop body at height a with the planar joints."""
    a, M, lam, eps, mu = scene["a"], scene["M"], scene["lam"], scene["eps"], scene["mus"]
    inertia = M * a**2 * (1.0 - lam**2 + lam * eps)  # about the centre of mass, kg m^2
    # Only the moment about the hinge axis (y) acts in the plane; the others are any valid ones.
    diag = f"{inertia!r} {inertia!r} {inertia!r}"
    return f"""
<mujoco model="hoop">
  <option timestep="{dt!r}" gravity="0 0 {-scene["g"]!r}"/>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 1" friction="{mu!r} 0.005 0.0001"/>
    <body name="hoop" pos="0 0 {a!r}">
      <joint name="rootx" type="slide" axis="1 0 0"/>
      <joint name="rootz" type="slide" axis="0 0 1"/>
      <joint name="rooty" type="hinge" axis="0 1 0"/>
      <inertial pos="0 0 {lam * a!r}" mass="{M!r}" diaginertia="{diag}"/>
      <geom name="rim" type="sphere" size="{a!r}" friction="{mu!r} 0.005 0.0001"/>
    </body>
  </worldbody>
</mujoco>
"""


def contact_force(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Summed contact force on the hoop (the floor is geom1 of each contact), world frame, N."""
    total = np.zeros(3)
    local = np.zeros(6)
    for i in range(data.ncon):
        mujoco.mj_contactForce(model, data, i, local)
        frame = data.contact[i].frame.reshape(3, 3)  # rows: normal, tangent 1, tangent 2
        on_second = frame.T @ local[:3]  # force on geom2 (the rim) from geom1
        total += on_second if data.contact[i].geom2 == 1 else -on_second
    return total


def resting_depth(model: mujoco.MjModel, data: mujoco.MjData, a: float) -> float:
    """Depth, m, at which the contact holds the hoop centre with zero vertical acceleration
    (0 if it would leave the floor touching): bisection on qacc of the rootz slide, which
    rises as the hoop sinks."""

    def zacc(depth: float) -> float:
        data.qpos[1] = -depth
        mujoco.mj_forward(model, data)
        return float(data.qacc[1])

    if zacc(0.0) >= 0.0:
        return 0.0
    lo, hi = 0.0, 1e-7 * a
    while zacc(hi) < 0.0:
        lo, hi = hi, 2.0 * hi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        lo, hi = (mid, hi) if zacc(mid) < 0.0 else (lo, mid)
    return 0.5 * (lo + hi)


def run(scene: dict, dt: float, t_end: float, start: str = "equilibrium") -> dict[str, np.ndarray]:
    """One run: centre-of-mass state and contact force per unit mass, one row per step.
    ``start``: "equilibrium" (at the resting depth) or "touching"."""
    model = mujoco.MjModel.from_xml_string(model_xml(scene, dt))
    data = mujoco.MjData(model)
    a, lam, M = scene["a"], scene["lam"], scene["M"]
    theta0, thetadot0 = scene["theta0"], scene["thetadot0"]
    xdot0 = a * thetadot0 if scene["xdot0"] is None else scene["xdot0"]
    data.qpos[:] = (0.0, 0.0, theta0)
    data.qvel[:] = (xdot0, 0.0, thetadot0)
    if start == "equilibrium":
        data.qpos[1] = -resting_depth(model, data, a)
    mujoco.mj_forward(model, data)
    n = round(t_end / dt)
    q, v, f = np.empty((n + 1, 3)), np.empty((n + 1, 3)), np.empty((n + 1, 3))
    q[0], v[0] = data.qpos, data.qvel
    for i in range(n):
        mujoco.mj_step(model, data)
        f[i] = contact_force(model, data)  # the contacts of the state step i started from
        q[i + 1], v[i + 1] = data.qpos, data.qvel
    mujoco.mj_forward(model, data)
    f[n] = contact_force(model, data)
    return _com_rows(q, v, f, a, lam, M, dt)


def _com_rows(q, v, f, a, lam, M, dt):  # type: ignore[no-untyped-def]
    """Centre of mass from the joints (the weight at (0, 0, a) in the body frame)."""
    x, z, theta = q.T
    xdot, zdot, thetadot = v.T
    r = lam * a
    return {
        "t": np.arange(len(q)) * dt,
        "X": x + r * np.sin(theta),
        "Y": a + z + r * np.cos(theta),
        "theta": theta,
        "Xdot": xdot + r * np.cos(theta) * thetadot,
        "Ydot": zdot - r * np.sin(theta) * thetadot,
        "thetadot": thetadot,
        "normal_force": f[:, 2] / M,
        "friction_force": f[:, 0] / M,
    }


HOP_TOP = {
    "g": 9.8,
    "a": 1.0,
    "M": 1.0,
    "lam": 0.95,
    "eps": 0.01,
    "mus": 0.8,
    "muk": 0.8,
    "theta0": 0.0,
    "thetadot0": math.sqrt(0.5 * 9.8),
    "xdot0": None,
}
"""hop-top's parameters (chi = a thetadot0^2 / g = 0.5)."""


def hop(out: dict[str, np.ndarray], a: float, lam: float) -> tuple[float, float]:
    """(hop height m, lift-off time s): the highest clearance of the rim's lowest point, and
    the last time before it that the clearance was at most 0.1 mm."""
    clearance = out["Y"] - lam * a * np.cos(out["theta"]) - a
    top = int(np.argmax(clearance))
    low = np.flatnonzero(clearance[:top] <= 1e-4)
    return float(clearance[top]), float(out["t"][low[-1]] if len(low) else 0.0)


if __name__ == "__main__":
    for how in ("equilibrium", "touching"):
        result = run(HOP_TOP, 1e-4, 3.0, start=how)
        height, lift_off = hop(result, HOP_TOP["a"], HOP_TOP["lam"])
        print(f"hop-top, start {how}: hop height {height:.4f} m, lift-off at {lift_off:.4f} s")
