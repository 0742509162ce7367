"""MJX's line search under ``jax.vmap`` computes all ``ls_iterations`` for every world.

For MJX's tracker; imports only jax, mujoco and numpy (mujoco-mjx 3.17.0, jax 0.10.2, CPU).
``mujoco.mjx._src.solver._linesearch`` runs ``_while_loop_scan``: a ``lax.scan`` of
``ls_iterations`` steps, each a ``lax.cond`` that does nothing once the search is done. Under
``vmap`` the predicate is batched and the ``cond`` becomes a select, so every world computes
every iteration. The same step with a ``lax.while_loop`` of the same cond, body and bound
gives the same states bit for bit at a fraction of the CPU time (measured 2026-11-29 on
2 CPU cores: 0.30-0.36 against 0.08-0.10 CPU-ms a step, 8 worlds).

Run: ``python mjx_linesearch_vmap.py``.
"""

import time

import jax
import mujoco
import numpy as np
from mujoco import mjx
from mujoco.mjx._src import solver

XML = """<mujoco><option cone="elliptic"/><worldbody><geom type="plane" size="5 5 .1"
friction=".3"/><body pos="0 0 .1"><freejoint/><geom type="sphere" size=".1"/></body>
</worldbody></mujoco>"""
WORLDS, STEPS = 8, 500


def while_loop_scan(cond_fun, body_fun, init_val, max_iter):
    """``solver._while_loop_scan``'s contract as a ``lax.while_loop``: the same bound."""

    def cond(carry):
        return (carry[1] < max_iter) & cond_fun(carry[0])

    def body(carry):
        return body_fun(carry[0]), carry[1] + 1

    return jax.lax.while_loop(cond, body, (init_val, 0))[0]


def run(label: str) -> np.ndarray:
    model = mujoco.MjModel.from_xml_string(XML)
    data = mujoco.MjData(model)
    data.qvel[:] = [1.0, 0, 0, 0, 30.0, 5.0]  # slides and spins
    mx, dx = mjx.put_model(model, impl="jax"), mjx.put_data(model, data, impl="jax")
    dx = jax.tree.map(lambda x: jax.numpy.stack([x] * WORLDS), dx)

    def steps(d):
        return jax.lax.fori_loop(0, STEPS, lambda i, d: mjx.step(mx, d), d)

    compiled = jax.jit(jax.vmap(steps)).lower(dx).compile()
    jax.block_until_ready(compiled(dx))
    start = time.process_time()
    out = jax.block_until_ready(compiled(dx))
    cost = 1e3 * (time.process_time() - start) / STEPS
    print(f"{label}: {cost:.3f} CPU-ms a step, {WORLDS} worlds")
    return np.asarray(out.qpos)


if __name__ == "__main__":
    scan = run("MJX (scan of lax.cond)")
    solver._while_loop_scan = while_loop_scan
    loop = run("lax.while_loop        ")
    print("same states bit for bit:", np.array_equal(scan, loop))
