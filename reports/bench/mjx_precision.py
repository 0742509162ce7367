"""Benchmark: MJX in float32 against float64 on the events, beside MuJoCo C, by the canonical
reading.

Run with ``python -m hoopbench.reports.bench.mjx_precision [--scenes seed-mu hop-top ...]
[--dt 1e-3] [--mjwarp]``. A measurement, not a test: it prints figures and asserts nothing.

The catalogue's scenes of the default suite, tuned, at dt 1e-3 (the batched engines'
timestep in the suites), as a suite runs them: one task per scene and setting
(``suite_file.parse_suite``), each setting's scenes in one batch (``suite.run_task_batch``,
the runner's batch worker), so every number is a suite row's column. Settings: MuJoCo C,
MJX with ``precision = float64``, MJX in float32 (its default) and, with ``--mjwarp``,
MuJoCo Warp (float32, about a minute more on 2 cores). Printed per scene and setting: the
verdict and the errors of the slip onset (ms), the lift-off (ms) and the hop height
(relative) against the exact solution; then float32 minus float64 per event.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from itertools import groupby
from typing import Any

import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.reports.compare.suite import batch_key, run_task_batch
from hoopbench.reports.compare.suite_file import (
    DEFAULT_VARIANT,
    load_suite,
    parse_suite,
    suite_path,
)

DT = 1e-3
FLOAT64 = "precision=float64"
"""The variant name of MJX in float64 (the default suite's)."""
EVENTS: dict[str, str] = {
    Col.ERR_T_SLIP_MS: "slip ms",
    Col.ERR_T_LIFT_MS: "lift ms",
    Col.ERR_HOP_HEIGHT_REL: "height %",
}
"""The event errors compared, and their headers (height as a percentage)."""


def _suite(scenes: Sequence[str], dt: float, mjwarp: bool) -> dict[str, Any]:
    return {
        "name": "mjx-precision",
        "engines": ["mujoco", "mjx", *(["mjwarp"] if mjwarp else [])],
        "timesteps": [dt],
        "profiles": ["tuned"],
        "scenes": list(scenes),
        "variant": [{"engine": "mjx", "name": FLOAT64, "options": {"precision": "float64"}}],
    }


def setting_label(engine: str, variant: str) -> str:
    """'mujoco', 'mjx float32', 'mjx float64', 'mjwarp'."""
    if engine != "mjx":
        return engine
    return "mjx float64" if variant == FLOAT64 else "mjx float32"


def precision_rows(scenes: Sequence[str], dt: float = DT, mjwarp: bool = False) -> pd.DataFrame:
    """Every setting's suite rows on ``scenes`` (one batch per setting), with a ``setting``
    column (:func:`setting_label`)."""
    tasks = parse_suite(_suite(scenes, dt, mjwarp)).tasks()
    tasks = [t for t in tasks if t.variant in (DEFAULT_VARIANT, FLOAT64)]
    rows: list[dict[str, Any]] = []
    for _, group in groupby(sorted(tasks, key=lambda t: repr(batch_key(t))), key=batch_key):
        rows += run_task_batch(list(group))
    frame = pd.DataFrame(rows)
    return frame.assign(
        setting=[
            setting_label(e, v) for e, v in zip(frame[Col.ENGINE], frame[Col.VARIANT], strict=True)
        ]
    )


def event_table(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per scene and setting: verdict and event errors (height in %)."""
    table = rows[[Col.SCENE, "setting", Col.VERDICT, *EVENTS]].copy()
    table[Col.ERR_HOP_HEIGHT_REL] = 100 * pd.to_numeric(table[Col.ERR_HOP_HEIGHT_REL])
    return table.sort_values([Col.SCENE, "setting"]).reset_index(drop=True)


def float32_minus_float64(table: pd.DataFrame) -> pd.DataFrame:
    """Per scene: MJX float32's event errors minus float64's (NaN where either lacks the
    event), and both verdicts."""
    by = table.set_index([Col.SCENE, "setting"])
    out = []
    for scene in dict.fromkeys(table[Col.SCENE]):
        f32, f64 = by.loc[(scene, "mjx float32")], by.loc[(scene, "mjx float64")]
        line: dict[str, Any] = {Col.SCENE: scene}
        for column in EVENTS:
            line[column] = pd.to_numeric(f32[column]) - pd.to_numeric(f64[column])
        line["float32"], line["float64"] = f32[Col.VERDICT], f64[Col.VERDICT]
        out.append(line)
    return pd.DataFrame(out)


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:+.2f}"
    return str(value)


def _print(frame: pd.DataFrame, headers: dict[str, str]) -> None:
    print("| " + " | ".join(headers.values()) + " |")
    print("|" + "---|" * len(headers))
    for _, line in frame.iterrows():
        print("| " + " | ".join(_cell(line[c]) for c in headers) + " |")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", help="default: the default suite's scenes")
    parser.add_argument("--dt", type=float, default=DT)
    parser.add_argument("--mjwarp", action="store_true", help="MuJoCo Warp too (float32)")
    args = parser.parse_args(argv)
    scenes = args.scenes or [scene.name for scene in load_suite(suite_path("default")).scenes]
    table = event_table(precision_rows(scenes, args.dt, args.mjwarp))
    print(f"event errors against the exact solution, tuned, dt {args.dt:g} s, canonical reading")
    _print(table, {Col.SCENE: "scene", "setting": "setting", Col.VERDICT: "verdict", **EVENTS})
    print("\nMJX float32 minus float64 (event errors; height in percentage points)")
    _print(
        float32_minus_float64(table),
        {Col.SCENE: "scene", **EVENTS, "float32": "float32", "float64": "float64"},
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
