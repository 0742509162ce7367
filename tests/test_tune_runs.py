"""How a search runs (issue 28): its trials in batches as compare runs them, its held-out
neighbours of the training scenes, a search folder from before them resumed, and the
smallest search of every engine."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import pandas as pd
import pytest

import hoopbench as hb
from hoopbench.engines.judging.columns import COST_COLUMNS, Col
from hoopbench.engines.options import Profile
from hoopbench.engines.registry import engine_names
from hoopbench.engines.run import REFERENCE_ENGINE
from hoopbench.models.scene import Scene
from hoopbench.reference.regimes import classify
from hoopbench.reports.cli import main
from hoopbench.reports.compare.settings_file import load_settings
from hoopbench.reports.compare.suite import compare, runs_frame
from hoopbench.reports.compare.suite_file import Suite
from hoopbench.reports.sweep.results import TIMING_COLUMNS
from hoopbench.reports.sweep.runner import IDENTITY_NAME
from hoopbench.reports.tune.heldout import HELDOUT_DIR, heldout_scenes
from hoopbench.reports.tune.neighbours import NEIGHBOUR_RANGE, neighbours
from hoopbench.reports.tune.search import (
    DEFAULT_TRAINING_SCENES,
    SPEC_NAME,
    TRIALS_DIR,
    TuneSpec,
)

pytest.importorskip("optuna")

pytestmark = pytest.mark.slow

TIMING = {*TIMING_COLUMNS, *COST_COLUMNS}
HELDOUT_SEED = TuneSpec.heldout_seed


def _comparable(frame: pd.DataFrame) -> pd.DataFrame:
    keep = [c for c in frame.columns if c not in TIMING]
    return frame[keep].sort_values(Col.RUN_ID).reset_index(drop=True)


# --------------------------------------------------------------------------- batches
def test_a_batched_engines_trials_run_in_batches_with_compares_rows(tmp_path: Path) -> None:
    """MuJoCo steps many worlds at once: a trial's scenes share batches, and the baselines'
    rows are those compare gives for the same settings (timing aside)."""
    scenes = tuple(
        hb.scene(name, t_end=0.2) for name in ("seed-mu", "hop-top", "hop-bottom", "high-spin")
    )
    out = tmp_path / "search"
    hb.tune("mujoco", out, scenes=scenes, trials=1, heldout_per_regime=0, jobs=1, quiet=True)
    tuned = runs_frame(out / TRIALS_DIR)
    assert (tuned[Col.BATCH_SIZE] > 1).all(), tuned[Col.BATCH_SIZE].tolist()
    suite = Suite("same", ("mujoco",), (1e-4,), scenes, (), (Profile.STOCK, Profile.TUNED))
    compare("", tmp_path / "compare", suite=suite, jobs=1, quiet=True)
    compared = runs_frame(tmp_path / "compare")
    baselines = tuned[tuned[Col.VARIANT] == "default"]
    assert len(baselines) == len(compared) == 8
    pd.testing.assert_frame_equal(_comparable(baselines), _comparable(compared))


# --------------------------------------------------------------------------- neighbours
@pytest.fixture(scope="module")
def drawn() -> dict[str, tuple[Scene, ...]]:
    return {name: neighbours(hb.scene(name), HELDOUT_SEED, 2) for name in DEFAULT_TRAINING_SCENES}


def test_every_training_scene_has_neighbours_with_its_events(
    drawn: dict[str, tuple[Scene, ...]],
) -> None:
    for name, near in drawn.items():
        train = hb.scene(name)
        exact = classify(train)
        assert [s.name for s in near] == [f"near-{name}-1", f"near-{name}-2"]
        for scene in near:
            point = classify(scene)
            assert point.regime is exact.regime, (name, scene)
            assert point.events.phase_code == exact.events.phase_code, (name, scene)
            assert (scene.eps, scene.t_end, scene.a, scene.g) == (
                train.eps,
                train.t_end,
                train.a,
                train.g,
            )
            assert scene.mus == scene.muk  # as the training scene's
            assert abs(scene.thetadot0 / train.thetadot0 - 1) <= NEIGHBOUR_RANGE
            assert abs(scene.mus / train.mus - 1) <= NEIGHBOUR_RANGE
            assert abs(scene.lam - train.lam) <= NEIGHBOUR_RANGE * min(train.lam, 1 - train.lam)
            assert abs(scene.theta0 - train.theta0) <= NEIGHBOUR_RANGE * math.pi / 2
            assert scene.thetadot0 != train.thetadot0 and scene.lam != train.lam


def test_neighbours_move_the_events_they_keep(drawn: dict[str, tuple[Scene, ...]]) -> None:
    """Not copies: a setting fitted to a training scene's event times meets other times."""
    for name, near in drawn.items():
        exact = classify(hb.scene(name)).events
        for scene in near:
            moved = classify(scene).events
            assert moved.phases[0].t_end != pytest.approx(exact.phases[0].t_end, abs=1e-3), name


def test_neighbours_are_drawn_from_the_seed_alone() -> None:
    scene = hb.scene("hop-top")
    again = neighbours(scene, HELDOUT_SEED, 1)
    assert again == neighbours(scene, HELDOUT_SEED, 1)
    assert again != neighbours(scene, HELDOUT_SEED + 1, 1)


def test_the_heldout_set_is_random_regimes_then_neighbours() -> None:
    spec = TuneSpec("pymunk", (hb.scene("hop-top"), hb.scene("seed-mu")))
    names = [s.name for s in heldout_scenes(spec)]
    assert len(names) == 6
    assert all(n.startswith("heldout-random-") for n in names[:4])
    assert names[4:] == ["heldout-near-hop-top-1", "heldout-near-seed-mu-1"]
    only_near = TuneSpec("pymunk", spec.scenes, heldout_per_regime=0, heldout_neighbours=2)
    assert [s.name for s in heldout_scenes(only_near)] == [
        "heldout-near-hop-top-1",
        "heldout-near-hop-top-2",
        "heldout-near-seed-mu-1",
        "heldout-near-seed-mu-2",
    ]


def test_a_search_folder_from_before_the_neighbours_resumes_and_adds_their_rows(
    tmp_path: Path,
) -> None:
    """A folder made before the neighbours has the random held-out scenes only and no
    heldout_neighbours key: it resumes, keeps its held-out rows and adds the neighbours'."""
    out = tmp_path / "search"
    scene = hb.scene("hop-bottom", t_end=0.6)
    old = hb.tune("pymunk", out, scenes=[scene], trials=1, heldout_neighbours=0, quiet=True)
    for name in (SPEC_NAME, IDENTITY_NAME):  # as the search of before wrote them
        data = json.loads((out / name).read_text())
        del data["heldout_neighbours"]
        (out / name).write_text(json.dumps(data))
    before = runs_frame(out / HELDOUT_DIR)
    assert len(before) == 4 * 3  # four random scenes, tuned (trial-0), stock and tuned
    front = hb.tune("pymunk", out, scenes=[scene], trials=1, resume=True, quiet=True)
    after = runs_frame(out / HELDOUT_DIR)
    kept = after[after[Col.RUN_ID].isin(before[Col.RUN_ID])]
    pd.testing.assert_frame_equal(  # the same rows, timings too: not run again
        kept.sort_values(Col.RUN_ID).reset_index(drop=True),
        before.sort_values(Col.RUN_ID).reset_index(drop=True),
    )
    new = after[~after[Col.RUN_ID].isin(before[Col.RUN_ID])]
    assert sorted(set(new[Col.SCENE])) == ["heldout-near-hop-bottom-1"]
    assert len(new) == 3 and (new[Col.STATUS] == "ok").all()
    assert json.loads((out / SPEC_NAME).read_text())["heldout_neighbours"] == 1
    provenance = load_settings(out / "settings.toml").provenance
    assert provenance["heldout_scenes"][-1] == "heldout-near-hop-bottom-1"
    assert front["heldout_near_error"].notna().all() and old["heldout_near_error"].isna().all()
    pd.testing.assert_series_equal(  # the error on the random scenes is the old held-out error
        front["heldout_random_error"], old["heldout_error"], check_names=False
    )


# --------------------------------------------------------------------------- every engine
SEARCHED = [name for name in engine_names() if name != REFERENCE_ENGINE]
SHORT_T_END = 0.05
"""s: the smallest search's one scene (hop-bottom's first roll): 500 steps at the tuned
timestep, which MuJoCo Warp steps at about 20 ms each on a CPU."""


@pytest.mark.parametrize("engine", SEARCHED)
def test_the_smallest_search_runs_for_every_engine(
    engine: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / engine
    started = time.monotonic()
    front = hb.tune(
        engine,
        out,
        scenes=[hb.scene("hop-bottom", t_end=SHORT_T_END)],
        trials=1,
        heldout_per_regime=0,
        heldout_neighbours=1,
        jobs=1,
        quiet=True,
    )
    seconds = time.monotonic() - started
    assert (out / "front.csv").is_file()
    assert list(front["setting"]) == ["trial-0", "stock", "tuned"]
    rows = pd.concat([runs_frame(out / TRIALS_DIR), runs_frame(out / HELDOUT_DIR)])
    assert (rows[Col.STATUS] == "ok").all(), rows[[Col.VARIANT, Col.STATUS, Col.MESSAGE]]
    settings = str(out / "settings.toml")
    assert load_settings(settings).engine == engine
    capsys.readouterr()
    args = ["simulate", "--engine", engine, "--scene", "hop-bottom"]
    assert main([*args, "--t-end", "0.01", "--settings", settings, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["engine"] == engine
    print(f"{engine}: the smallest search took {seconds:.1f} s")


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--heldout-neighbours", "-1"], "--heldout-neighbours: must be >= 0, got -1"),
        (["--heldout-neighbours", "x"], "--heldout-neighbours: must be a whole number"),
        (
            ["--heldout-neighbours", "0", "--heldout-per-regime", "0"],
            "--heldout-per-regime and the neighbours cannot both be 0",
        ),
        (["--batch-size", "0"], "--batch-size: must be >= 1, got 0"),
        (["--tls-cert", "c.pem"], "--tls-cert: only with --scheduler tls://HOST:PORT"),
        (["--scheduler", "nosuch://h:1"], "the scheme must be tcp:// or tls://"),
    ],
)
def test_bad_run_options_are_one_line_and_exit_2(
    args: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "x"
    assert main(["tune", "--engine", "pymunk", "--trials", "1", "--out", str(out), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert not out.exists()
