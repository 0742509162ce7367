"""The hopping hoop as an MJX user builds it, from MuJoCo's and MJX's own documentation.

The model is the MJCF a MuJoCo user writes (see expert_mujoco.py's docstring for each
element: the planar root of DeepMind Control Suite's models, rootx/rootz slides and a rooty
hinge, https://github.com/google-deepmind/dm_control/blob/main/dm_control/suite/cheetah.xml;
an ``<inertial>``, https://mujoco.readthedocs.io/en/stable/XMLreference.html#body-inertial; a
sphere on a plane by MuJoCo's default collision and contact parameters,
https://mujoco.readthedocs.io/en/stable/modeling.html#contact-parameters; MuJoCo's default
solver options, https://mujoco.readthedocs.io/en/stable/XMLreference.html#option). MJX runs it
as its documentation and tutorial show (https://mujoco.readthedocs.io/en/stable/mjx.html,
"MJX: the basics"; the tutorial notebook mjx/tutorial.ipynb in google-deepmind/mujoco):

- ``mujoco.MjModel.from_xml_string`` and ``MjData`` on the host, the initial state set there,
  then ``mjx.put_model`` / ``mjx.put_data`` onto JAX's default device;
- ``mjx.step`` under ``jax.jit``, its steps in a ``jax.lax.scan`` (the tutorial's rollout);
  JAX's default float32 is what MJX's users run; ``run`` takes float64 by default
  (``jax.enable_x64``, ``PRECISION``) so that the comparison with hoopbench is not of two
  programs' float32 roundings (measured at RTOL below);
- the contact force of the hoop-floor contact from the data each step leaves (MuJoCo's
  default Euler integrator: the constraint forces of the state the step started from),
  with ``contact_force`` of MJX's support module, MJX's ``mj_contactForce`` (world frame).
  MJX keeps one contact slot per geom pair, inactive (zero force) while apart.
- Start: rolling, at the depth where the soft contact holds the hoop's weight (found with
  MuJoCo C's ``mj_forward`` by bisection, as in expert_mujoco.py; MJX's model and data are the
  C ones put on the device).

Cost: 1.5 s of hop-top or seed-mu at dt 1e-4 (15,000 steps) take about 10 s on 2 CPU cores,
the compile of the Euler step included.
"""

from __future__ import annotations

import math

import jax
import mujoco
import numpy as np
from mujoco import mjx
from mujoco.mjx._src.support import contact_force

SAME_AS_HOOPBENCH = True
HOOPBENCH_SETTINGS: dict = {"profile": "stock", "options": {"precision": "float64"}}
DIFFERENCE = ""
RTOL = 1e-12
"""Measured (dt 1e-4, the first 1.5 s, against hoopbench's stock profile, MuJoCo's defaults,
both in float64): the largest state difference over each state's scale was 3.1e-15 on hop-top
and 5.2e-15 on seed-mu, the contact forces within 2e-12 m/s^2. In float32 (JAX's default, what
MJX's users run, ``run(..., precision="float32")`` against hoopbench's float32) the two builds
compile to different programs (this scan of ``mjx.step``; hoopbench's vmap of forward, the
contact force and the integrator) and round differently: seed-mu's slip onset agreed to 1e-7 s
(0.11381 s both), but hop-top, whose slipping contact chatters step by step, lifted off
10.2 ms apart (1.1987 s here, 1.2089 s in hoopbench) with the states up to 0.7 % of their
scale apart; float64 takes the rounding out, so the comparison is made there."""
PRECISION = "float64"
"""The precision ``run`` uses by default: float64, to compare like with like (RTOL above)."""


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


def run(
    scene: dict, dt: float, t_end: float, precision: str | None = None
) -> dict[str, np.ndarray]:
    """One run: centre-of-mass state and contact force per unit mass, one row per step.
    ``precision``: "float32" (JAX's default) or "float64" (``jax_enable_x64`` for the run);
    None: ``PRECISION``."""
    # JAX keeps inner traces across a change of jax_enable_x64 and may then fail to lower
    # them ("operand type mismatch"): each run traces anew (a few seconds).
    jax.clear_caches()
    with jax.enable_x64((precision or PRECISION) == "float64"):
        return _run(scene, dt, t_end)


def _run(scene: dict, dt: float, t_end: float) -> dict[str, np.ndarray]:
    model = mujoco.MjModel.from_xml_string(model_xml(scene, dt))
    data = mujoco.MjData(model)
    a, lam, M = scene["a"], scene["lam"], scene["M"]
    theta0, thetadot0 = scene["theta0"], scene["thetadot0"]
    xdot0 = a * thetadot0 if scene["xdot0"] is None else scene["xdot0"]
    data.qpos[:] = (0.0, 0.0, theta0)
    data.qvel[:] = (xdot0, 0.0, thetadot0)
    data.qpos[1] = -resting_depth(model, data, a)
    mujoco.mj_forward(model, data)
    mx, dx = mjx.put_model(model), mjx.put_data(model, data)
    # Under x64, put_data's contact indices are int32 where a step makes int64: a scan's
    # carry must keep its types, so the data takes a step's types first.
    typed = jax.eval_shape(mjx.step, mx, dx)
    dx = jax.tree.map(lambda leaf, like: leaf.astype(like.dtype), dx, typed)

    def step(d, _):
        d = mjx.step(mx, d)
        return d, (d.qpos, d.qvel, contact_force(mx, d, 0, to_world_frame=True)[:3])

    n = round(t_end / dt)
    rollout = jax.jit(lambda d: jax.lax.scan(step, d, None, length=n))
    dx, (qpos, qvel, force) = rollout(dx)
    last = jax.jit(lambda d: contact_force(mx, mjx.forward(mx, d), 0, to_world_frame=True))
    q = np.concatenate([[data.qpos], np.asarray(qpos, dtype=float)])
    v = np.concatenate([[data.qvel], np.asarray(qvel, dtype=float)])
    f = np.concatenate([np.asarray(force, dtype=float), [np.asarray(last(dx)[:3], dtype=float)]])
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
    for precision in ("float32", "float64"):
        result = run(HOP_TOP, 1e-4, 3.0, precision)  # the whole window: about 1 min on the CPU
        height, lift_off = hop(result, HOP_TOP["a"], HOP_TOP["lam"])
        print(f"hop-top, {precision}: hop height {height:.4f} m, lift-off at {lift_off:.4f} s")
