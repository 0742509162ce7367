"""The standalone script of one run: what ``hoopbench export`` writes.

A script reproduces one engine run with the engine's own API alone: it imports the engine and
numpy, never hoopbench, builds the model, steps it, and writes the trajectory to the CSV path
given as its first argument, with the columns and format of ``hoopbench simulate --csv``
(``Trajectory.write``). It is what a user attaches to an engine's bug tracker.

The script has three parts:

1. the header (engine, release, scene, settings, how it was made) and the scene's constants,
   every float written as its ``repr`` so that the script starts from the run's own numbers;
2. the engine's part, from the adapter's ``_script`` hook (``Engine.export_script``): its
   imports and a function ``simulate()`` that returns the centre-of-mass states and contact
   forces per unit mass, row i the state at i*DT and the force of the step taken from it, as
   the adapter's ``_trajectory`` gives them;
3. the shared tail: the derived columns (clearance, slip velocity, energy, contact) by the
   expressions of :mod:`hoopbench.models.kinematics` for the hoop's circle, and the CSV writer.

The helpers the engine's part may call (``com_state``, ``com_state_ccw``, ``step_forces``)
repeat the expressions of ``kinematics.com_state``, ``kinematics.com_state_ccw`` and
``base.states_and_step_forces`` operation for operation, so a deterministic engine's script
gives the adapter's trajectory bit for bit (tests/test_export.py runs every engine's). The
script has none of the run loop's divergence checks: it steps the whole window.
"""

from __future__ import annotations

import shlex
import textwrap
from collections.abc import Mapping
from typing import Any

from hoopbench.models import kinematics
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import COLUMNS, FORMAT_VERSION

__all__ = ["EXPORT_GEOMETRY", "SIMULATE_KEYS", "standalone_script"]

EXPORT_GEOMETRY = "sphere"
"""The contact geometry a script builds: the hoop's exact circle (a sphere or a disc), whose
clearance and slip velocity the tail computes. Faceted shapes need the adapter's polygon."""

SIMULATE_KEYS = ("X", "Y", "theta", "Xdot", "Ydot", "thetadot", "normal_force", "friction_force")
"""What the engine part's ``simulate()`` returns (and optionally ``contact``)."""

_HELPERS = '''
def com_state(x, y, theta, xdot, ydot, thetadot):
    """Centre-of-mass state from the hoop centre's (x, y, theta clockwise, and their rates)."""
    r = COM_OFFSET
    theta = np.asarray(theta, dtype=float)
    thetadot = np.asarray(thetadot, dtype=float)
    s, c = np.sin(theta), np.cos(theta)
    return {
        "X": np.asarray(x) + r * np.sin(theta),
        "Y": np.asarray(y) + r * np.cos(theta),
        "theta": theta,
        "Xdot": np.asarray(xdot) + r * c * thetadot,
        "Ydot": np.asarray(ydot) - r * s * thetadot,
        "thetadot": thetadot,
    }


def com_state_ccw(x, y, angle, com_xdot, com_ydot, omega):
    """Centre-of-mass state from a 2D body: hoop centre (x, y), counter-clockwise angle, the
    centre of mass's velocity and the counter-clockwise angular velocity."""
    r = COM_OFFSET
    theta = -np.asarray(angle, dtype=float)
    return {
        "X": np.asarray(x) + r * np.sin(theta),
        "Y": np.asarray(y) + r * np.cos(theta),
        "theta": theta,
        "Xdot": np.asarray(com_xdot),
        "Ydot": np.asarray(com_ydot),
        "thetadot": -np.asarray(omega),
    }


def step_forces(first, blocks, last):
    """States, and beside each the force of the step taken from it. ``first``: the initial
    state row; ``blocks``: rows recorded after each step (the state reached, then that step's
    force); ``last``: the force of one more step from the last state."""
    first = np.atleast_2d(first)
    width = first.shape[1] + len(last)
    rows = np.concatenate(blocks) if len(blocks) else np.empty((0, width))
    states = np.concatenate([first, rows[:, : first.shape[1]]])
    forces = np.concatenate([rows[:, first.shape[1] :], np.atleast_2d(last)])
    return states, forces
'''

_TAIL = '''
# ---------------------------------------------------------------- the trajectory file
COLUMNS = {columns!r}


def trajectory(run):
    """Every column of the trajectory file from simulate()'s states and forces."""
    X, Y, theta = run["X"], run["Y"], run["theta"]
    Xdot, Ydot, thetadot = run["Xdot"], run["Ydot"], run["thetadot"]
    normal_force = np.asarray(run["normal_force"], dtype=float)
    columns = {{
        "t": np.arange(len(normal_force)) * DT,
        "X": X,
        "Y": Y,
        "theta": theta,
        "Xdot": Xdot,
        "Ydot": Ydot,
        "thetadot": thetadot,
        # the lowest point of the hoop's circle: height and horizontal velocity
        "clearance": Y - COM_OFFSET * np.cos(theta) - A,
        "slip_velocity": Xdot - COM_OFFSET * np.cos(theta) * thetadot - A * thetadot,
        "normal_force": normal_force,
        "friction_force": run["friction_force"],
        "contact": run.get("contact", normal_force > 0),
        "energy": G * Y + 0.5 * (Xdot**2 + Ydot**2) + 0.5 * K * A**2 * thetadot**2,
    }}
    return {{name: np.asarray(columns[name], dtype=bool if name == "contact" else float)
            for name in COLUMNS}}


def _cell(value):
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    return "" if np.isnan(value) else "%.17g" % value


def write_csv(path, columns):
    """The trajectory as CSV, one row per step, SI units (hoopbench's trajectory format)."""
    rows = zip(*(columns[name] for name in COLUMNS))
    with open(path, "w", newline="") as fh:
        fh.write("# hoopbench trajectory format {version}; SI units\\n")
        fh.write(",".join(COLUMNS) + "\\n")
        for row in rows:
            fh.write(",".join(_cell(value) for value in row) + "\\n")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python " + sys.argv[0] + " TRAJECTORY.csv")
    write_csv(sys.argv[1], trajectory(simulate()))
'''


def standalone_script(
    *,
    engine: str,
    release: str | None,
    scene: Scene,
    timestep: float,
    n_steps: int,
    mu: float,
    restitution: float,
    settings: Mapping[str, Any],
    engine_part: str,
    command: list[str] | None = None,
) -> str:
    """The whole script: header and constants, ``engine_part`` (the adapter's ``_script``),
    the helpers and the shared tail. ``settings``: the run's settings as plain values (the
    header lists them); ``command``: the command line that made it, for the header."""
    return "\n".join(
        [
            _header(engine, release, scene, timestep, settings, command),
            "import sys\n\nimport numpy as np\n",
            _constants(scene, timestep, n_steps, mu, restitution),
            _HELPERS,
            "\n# ---------------------------------------------------------------- the engine",
            textwrap.dedent(engine_part).strip("\n") + "\n",
            _TAIL.format(columns=COLUMNS, version=FORMAT_VERSION),
        ]
    )


def _header(
    engine: str,
    release: str | None,
    scene: Scene,
    timestep: float,
    settings: Mapping[str, Any],
    command: list[str] | None,
) -> str:
    made = "hoopbench export" if command is None else shlex.join(["hoopbench", *command])
    listed = "\n".join(f"    {key} = {value!r}" for key, value in settings.items())
    name = repr(scene.name) if scene.name else "(given by its parameters)"
    return (
        "#!/usr/bin/env python3\n"
        f'"""One run of {engine} ({release or "release not installed where exported"}) on '
        f"the hopping hoop, scene {name}, dt {timestep!r} s.\n\n"
        "A rigid hoop of radius A with a point weight on its rim (a fraction LAM of the mass M)\n"
        "rolls on a flat floor with friction MU; theta is the weight's angle from the top,\n"
        "clockwise. The script uses the engine's own API and numpy alone. Run it as\n\n"
        "    python THIS_FILE trajectory.csv\n\n"
        "It writes one row per step: the centre-of-mass state (X, Y, theta and rates), the\n"
        "contact force per unit mass the engine reported (normal_force, friction_force), and\n"
        "the derived clearance, slip velocity and energy. It steps the whole window, with no\n"
        "divergence checks.\n\n"
        f"Written by `{made}`. The run's settings:\n\n{listed}\n"
        '"""\n'
    )


def _constants(scene: Scene, timestep: float, n_steps: int, mu: float, restitution: float) -> str:
    centre = kinematics.rolling_start(scene)
    com = scene.initial_state()
    values = [
        ("G", scene.g, "gravity, m/s^2"),
        ("A", scene.a, "hoop radius, m"),
        ("M", scene.M, "total mass, kg"),
        ("LAM", scene.lam, "fraction of the mass in the weight on the rim"),
        ("EPS", scene.eps, "the weight's own inertia, as a fraction of M a^2 / lam"),
        ("K", scene.k, "inertia about the centre of mass over M a^2: 1 - lam^2 + lam eps"),
        ("I_COM", scene.inertia_com, "moment of inertia about the centre of mass, kg m^2"),
        ("COM_OFFSET", scene.com_offset, "centre of mass from the hoop centre, m: lam a"),
        ("MU", mu, "friction coefficient of the hoop-floor pair"),
        ("RESTITUTION", restitution, "restitution of the hoop-floor pair"),
        ("THETA0", scene.theta0, "initial angle of the weight from the top, rad, clockwise"),
        ("THETADOT0", scene.thetadot0, "initial angular velocity, rad/s, clockwise"),
        ("T_END", scene.t_end, "end of the window, s"),
        ("DT", timestep, "timestep, s"),
        ("N_STEPS", n_steps, "steps in the window"),
        ("CENTRE0", tuple(centre), "hoop centre at t = 0: x, y, theta, xdot, ydot, thetadot"),
        ("COM0", tuple(com), "centre of mass at t = 0: X, Y, theta, Xdot, Ydot, thetadot"),
    ]
    lines = ["# ---------------------------------------------------------------- the scene, SI"]
    lines += [f"{name} = {value!r}  # {what}" for name, value, what in values]
    return "\n".join(lines) + "\n"
