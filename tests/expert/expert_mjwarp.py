"""The hopping hoop as a MuJoCo Warp user builds it, from MuJoCo's and MuJoCo Warp's documentation.

The model is the MJCF a MuJoCo user writes (see expert_mujoco.py's docstring for each
element: the planar root of DeepMind Control Suite's models, rootx/rootz slides and a rooty
hinge, https://github.com/google-deepmind/dm_control/blob/main/dm_control/suite/cheetah.xml;
an ``<inertial>``, https://mujoco.readthedocs.io/en/stable/XMLreference.html#body-inertial; a
sphere on a plane by MuJoCo's default collision and contact parameters,
https://mujoco.readthedocs.io/en/stable/modeling.html#contact-parameters; MuJoCo's default
solver options, https://mujoco.readthedocs.io/en/stable/XMLreference.html#option). MuJoCo
Warp runs it as its README shows (https://github.com/google-deepmind/mujoco_warp, "Usage";
https://mujoco.readthedocs.io/en/latest/mjwarp/index.html):

- ``mujoco.MjModel.from_xml_string`` and ``MjData`` on the host, the initial state set there,
  then ``mujoco_warp.put_model`` / ``put_data`` (one world) and ``mujoco_warp.step``;
- the contact force from ``mujoco_warp.contact_force`` (world frame) of the contacts the step
  found: with MuJoCo's default Euler integrator they and their constraint forces are the
  state's the step started from; summed over the contacts;
- Warp's default device (a GPU if Warp sees one, else the CPU); single precision, MuJoCo
  Warp's only one.
- Start: rolling, at the depth where the soft contact holds the hoop's weight (found with
  MuJoCo C's ``mj_forward`` by bisection, as in expert_mujoco.py).

Cost: 0.05 s at dt 1e-4 (500 steps, one kernel launch series each) take about 5 s on the
CPU after Warp's kernel compile (about 20 s the first time, then cached).
"""

from __future__ import annotations

import math

import mujoco
import mujoco_warp as mjw
import numpy as np
import warp as wp

SAME_AS_HOOPBENCH = True
HOOPBENCH_SETTINGS: dict = {"profile": "stock"}
DIFFERENCE = ""
RTOL = 1e-6
"""Measured (dt 1e-4, the first 0.05 s, rolling, against hoopbench's stock profile, MuJoCo's
defaults; both single precision): positions equal to 1.1e-12 of their scale (the float64
start row: this build's bisected depth against hoopbench's Brent root), velocities to 3.4e-8
(hop-top) and 2.9e-8 (seed-mu), about one float32 rounding (6e-8), normal forces identical
from the second row on. RTOL leaves room for float32's rounding, not for a different build."""


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


def run(scene: dict, dt: float, t_end: float) -> dict[str, np.ndarray]:
    """One run: centre-of-mass state and contact force per unit mass, one row per step."""
    model = mujoco.MjModel.from_xml_string(model_xml(scene, dt))
    data = mujoco.MjData(model)
    a, lam, M = scene["a"], scene["lam"], scene["M"]
    theta0, thetadot0 = scene["theta0"], scene["thetadot0"]
    xdot0 = a * thetadot0 if scene["xdot0"] is None else scene["xdot0"]
    data.qpos[:] = (0.0, 0.0, theta0)
    data.qvel[:] = (xdot0, 0.0, thetadot0)
    data.qpos[1] = -resting_depth(model, data, a)
    mujoco.mj_forward(model, data)
    m = mjw.put_model(model)
    d = mjw.put_data(model, data)
    ids = wp.array(np.arange(d.naconmax, dtype=np.int32), dtype=wp.int32)
    per_contact = wp.zeros(d.naconmax, dtype=wp.spatial_vector)
    n = round(t_end / dt)
    q, v, f = np.empty((n + 1, 3)), np.empty((n + 1, 3)), np.empty((n + 1, 3))
    q[0], v[0] = data.qpos, data.qvel

    def force() -> np.ndarray:
        mjw.contact_force(m, d, ids, True, per_contact)
        found = int(d.nacon.numpy()[0])
        return per_contact.numpy()[:found, :3].astype(float).sum(axis=0)

    for i in range(n):
        mjw.step(m, d)
        f[i] = force()
        q[i + 1], v[i + 1] = d.qpos.numpy()[0], d.qvel.numpy()[0]
    mjw.forward(m, d)
    f[n] = force()
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
    wp.config.quiet = True  # no start-up banner
    wp.config.log_level = wp.LOG_WARNING  # no per-module load times
    result = run(HOP_TOP, 1e-4, 3.0)  # the whole window: about 4 min on the CPU
    height, lift_off = hop(result, HOP_TOP["a"], HOP_TOP["lam"])
    print(f"hop-top: hop height {height:.4f} m, lift-off at {lift_off:.4f} s")
