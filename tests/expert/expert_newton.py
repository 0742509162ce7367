"""The hopping hoop in Newton 1.8 (NVIDIA Warp), built as Newton's own examples build bodies.

Followed (newton 1.8.0, the installed package's examples and docstrings; the documentation at
https://newton-physics.github.io/newton/):

* ``newton/examples/basic/example_basic_shapes.py``: ``newton.ModelBuilder()``, a shape
  configuration with the friction coefficient ``mu`` and Newton's rolling and torsional
  friction set explicitly (``mu_rolling``, ``mu_torsional``), ``add_ground_plane()``,
  ``add_body(xform=wp.transform(p, q))`` and ``add_shape_sphere(body, radius=...)``,
  ``builder.finalize()``, ``newton.solvers.SolverXPBD(model)``, two states and a control,
  ``newton.CollisionPipeline(model)`` and its ``contacts()``, and the substep loop
  ``state_0.clear_forces(); collision_pipeline.collide(state_0, contacts);
  solver.step(state_0, state_1, control, contacts, dt); state_0, state_1 = state_1, state_0``;
  its Kamino branch requests the contact forces as a solver observable
  (``solver.observables(contacts=..., kinds={solver.ObservableKind.CONTACT_F})``, passed to
  ``step``), which XPBD supports too (``SolverXPBD.supported_observables``).
* ``ModelBuilder.add_body``'s docstring: ``mass``, ``com`` (body frame) and ``inertia``
  (about the centre of mass) given, ``lock_inertia=True`` so that the shape (density 0)
  adds nothing.
* ``newton.eval_ik`` after setting ``state.body_qd`` (the centre of mass's linear velocity
  and the angular velocity, world frame), as the examples that start bodies moving do.

The hoop: radius a, mass M, a point weight (fraction lam) on the rim, so the centre of mass
is lam a from the centre and the inertia about it is M a^2 (1 - lam^2 + lam eps). Newton's z
is up: the motion is in the x-z plane and the hoop turns about +y; a rotation about +y
carries +z toward +x, so the angle from the top, clockwise in (x, up), is the rotation angle.
The contact force: XPBD's own ``contact_f`` (the force on the pair's first body, spatial
vector, linear part first), summed over the contacts and given on the hoop, per unit mass.

Cost: about 2 ms a step on one CPU core after Warp's kernel cache is warm (tens of seconds
the first time): 1.5 s at dt 1e-4 takes about 30-60 s.
"""

from __future__ import annotations

import math

import newton
import numpy as np
import warp as wp

SAME_AS_HOOPBENCH = True
"""hoopbench's tuned run (XPBD, no rolling or torsional friction) builds the same body."""
HOOPBENCH_SETTINGS: dict = {"profile": "tuned", "options": {}}
DIFFERENCE = ""
RTOL = 1e-6
"""Relative to each state's scale. Measured: the same trajectory to the bit on hop-top's first
10 ms at dt 1e-4 (since the adapter's warm-up step stopped moving its run), and within 1e-6
over 1.5 s of hop-top and seed-mu (tests/test_expert_builds.py)."""


def run(scene: dict, dt: float, t_end: float) -> dict[str, np.ndarray]:
    """The hoop of ``scene`` (keys of hoopbench's Scene.to_dict) stepped at ``dt`` to
    ``t_end``: t, centre-of-mass X, Y, theta (clockwise from the top), their rates, and the
    contact force per unit mass (normal_force, friction_force), one row per step."""
    g, a, M, lam, eps = (float(scene[k]) for k in ("g", "a", "M", "lam", "eps"))
    theta0, thetadot0, mu = float(scene["theta0"]), float(scene["thetadot0"]), float(scene["mus"])
    xdot0 = a * thetadot0 if scene.get("xdot0") is None else float(scene["xdot0"])  # rolling
    inertia = M * a * a * (1.0 - lam * lam + lam * eps)
    r = lam * a

    wp.config.quiet = True
    builder = newton.ModelBuilder(gravity=(0.0, 0.0, -g))
    cfg = newton.ModelBuilder.ShapeConfig(density=0.0, mu=mu, mu_rolling=0.0, mu_torsional=0.0)
    builder.add_ground_plane(cfg=cfg)
    hoop = builder.add_body(
        xform=wp.transform(
            p=wp.vec3(0.0, 0.0, a), q=wp.quat_from_axis_angle(wp.vec3(0.0, 1.0, 0.0), theta0)
        ),
        mass=M,
        com=wp.vec3(0.0, 0.0, r),
        inertia=wp.mat33(inertia / 2, 0, 0, 0, inertia, 0, 0, 0, inertia / 2),
        lock_inertia=True,
        label="hoop",
    )
    builder.add_shape_sphere(hoop, radius=a, cfg=cfg)
    model = builder.finalize()

    solver = newton.solvers.SolverXPBD(model)
    state_0, state_1, control = model.state(), model.state(), model.control()
    pipeline = newton.CollisionPipeline(model)
    contacts = pipeline.contacts()
    observables = solver.observables(contacts=contacts, kinds={solver.ObservableKind.CONTACT_F})

    s, c = math.sin(theta0), math.cos(theta0)
    v_com = (xdot0 + r * c * thetadot0, -r * s * thetadot0)
    state_0.body_qd.assign(np.array([[v_com[0], 0.0, v_com[1], 0.0, thetadot0, 0.0]], np.float32))
    newton.eval_ik(model, state_0, state_0.joint_q, state_0.joint_qd)

    n = round(t_end / dt)
    rows = np.zeros((n + 1, 6))
    force = np.zeros((n + 1, 2))
    theta = theta0
    for i in range(n + 1):
        q = state_0.body_q.numpy()[hoop].astype(float)
        qd = state_0.body_qd.numpy()[hoop].astype(float)
        turn = 2.0 * math.atan2(q[4], q[6])
        theta += (turn - theta + math.pi) % (2.0 * math.pi) - math.pi  # unwrapped
        rows[i] = (
            q[0] + r * math.sin(theta),
            q[2] + r * math.cos(theta),
            theta,
            qd[0],
            qd[2],
            qd[4],
        )
        state_0.clear_forces()
        pipeline.collide(state_0, contacts)
        solver.step(state_0, state_1, control, contacts, dt, observables=observables)
        state_0, state_1 = state_1, state_0
        force[i] = _contact_force_on(hoop, model, contacts, observables) / M
    t = np.arange(n + 1) * dt
    X, Y, th, Xdot, Ydot, thetadot = rows.T
    return dict(
        t=t,
        X=X,
        Y=Y,
        theta=th,
        Xdot=Xdot,
        Ydot=Ydot,
        thetadot=thetadot,
        normal_force=force[:, 0],
        friction_force=force[:, 1],
    )


def _contact_force_on(body: int, model, contacts, observables) -> np.ndarray:
    """(normal +z, friction +x), N: XPBD's contact forces of the step just taken, on ``body``."""
    count = int(contacts.rigid_contact_count.numpy()[0])
    if count == 0:
        return np.zeros(2)
    f = observables.contact_f.numpy()[:count, :3].astype(float)
    shape_body = model.shape_body.numpy()
    first = shape_body[contacts.rigid_contact_shape0.numpy()[:count]] == body
    second = shape_body[contacts.rigid_contact_shape1.numpy()[:count]] == body
    on_body = f[first].sum(axis=0) - f[second].sum(axis=0)
    return np.array([on_body[2], on_body[0]])


def main() -> None:
    """hop-top's parameters: the hop height and the lift-off time."""
    scene = dict(
        g=9.8,
        a=1.0,
        M=1.0,
        lam=0.95,
        eps=0.01,
        mus=0.8,
        muk=0.8,
        theta0=0.0,
        thetadot0=2.2135943621178655,
        xdot0=None,
        t_end=3.0,
    )
    out = run(scene, 1e-4, 3.0)
    clearance = out["Y"] - scene["lam"] * scene["a"] * np.cos(out["theta"]) - scene["a"]
    peak = int(np.argmax(clearance))
    touching = np.flatnonzero(out["normal_force"][:peak] > 0.0)
    lift = out["t"][touching[-1] + 1] if len(touching) else None  # the flight's first row
    print(f"hop height {clearance[peak]:.4f} m, lift-off {lift} s")


if __name__ == "__main__":
    main()
