"""Stored tables carry their format version: an older table is read migrated, a newer one is
refused with one line naming both versions (the command line: exit 2 with that line).

The old tables are made as an older release wrote them: a current table rewritten without the
columns the newer versions added, and with an older version (or none) in meta.json.
"""

from __future__ import annotations

import json
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pandas as pd
import pytest

from hoopbench.engines.judging.columns import (
    BATCH_COLUMNS,
    FLOOR_COLUMNS,
    FORCE_COLUMNS,
    RENAMED_FROM_CONTACT,
    RENAMED_TO_KIN,
    TRANSITION_COLUMNS,
    Col,
)
from hoopbench.engines.judging.verdict import verdict_columns
from hoopbench.models.formats import FileFormat, FormatVersionError
from hoopbench.models.trajectory import FORMAT_VERSION as TRAJECTORY_VERSION
from hoopbench.models.trajectory import Trajectory
from hoopbench.reports.cli import main
from hoopbench.reports.compare.rows import ONE_READING_VERSION
from hoopbench.reports.compare.suite import FORMAT_VERSION, ROW_COLUMNS, compare, runs_frame
from hoopbench.reports.hop_map.spec import MapSpec
from hoopbench.reports.hop_map.stages import ONE_READING_MAP_VERSION, run_map
from hoopbench.reports.hop_map.stages import ROWS_FORMAT_VERSION as MAP_VERSION
from hoopbench.reports.hop_map.table import map_frame
from hoopbench.reports.sweep import results
from hoopbench.reports.sweep.runner import RunnerError

SUITE = """
name = "formats"
engines = ["reference", "pymunk"]
timesteps = [1e-3]
scenes = ["seed-mu"]
"""

NEW_IN_3 = ["exact_t_painleve", "rms_position_m", "max_clearance", "consistent", "event_flags"]
NEW_IN_4 = ["g", "exact_t_last_phase", "t_last_phase", "t_final", "exact_max_slip_speed"]
VERSION_2 = [*NEW_IN_3, "verdict", *NEW_IN_4, "profile"]
"""The columns an early version-2 table lacks (profile came late in 2)."""
NEW_IN_7 = [
    *FLOOR_COLUMNS,
    Col.CONE_STICK_TIME_S,
    Col.CHATTERING_TIME_S,
    Col.THETA_SLIP_DEG,
    Col.ERR_THETA_SLIP_DEG,
]
"""The columns issue 24 (format 7) added; a table stored before reads them empty."""
BATCHES_VERSION = 8
"""Issue 27: the batch cost columns (BATCH_COLUMNS); a table stored before reads each run as a
batch of one."""
BATCHES_MAP_VERSION = 5
"""The same in a map's table."""
TRANSITIONS_VERSION = 9
"""Issue 33: every transition timed; a table stored before reads NEW_IN_9 empty."""
NEW_IN_9 = [Col.PHASE_TIMES, Col.FLOOR_PHASE_TIMES, Col.EXACT_PHASE_TIMES, *TRANSITION_COLUMNS]
VERDICT_COLUMNS = [Col.VERDICT, Col.OUTCOME_AGREES, Col.VERDICT_FLAGS, Col.VERDICT_REASON]


def untimed(frame: pd.DataFrame) -> pd.DataFrame:
    """The verdict columns of ``frame``'s rows judged again without NEW_IN_9, as a table
    stored before format 9 is judged when a migration judges it again: its later transitions
    untimed (pymunk's seed-mu at 1 ms re-sticks 34 ms early: early-transition with them,
    agrees without)."""
    rows = frame.drop(columns=NEW_IN_9).to_dict("records")
    judged = pd.DataFrame([verdict_columns(row) for row in rows], index=frame.index)
    return judged[VERDICT_COLUMNS]


def before_7(rows: pd.DataFrame) -> pd.DataFrame:
    """Current rows in the layout before format 7: the kinematic reading unprefixed, the
    contact reading in contact_* columns, the columns 7 added absent."""
    canonical = [c for c in (*RENAMED_TO_KIN, *NEW_IN_7) if c in rows.columns]
    rows = rows.drop(columns=[c for c in canonical if c not in RENAMED_FROM_CONTACT.values()])
    back = {new: old for old, new in RENAMED_FROM_CONTACT.items()}
    back |= {new: old for old, new in RENAMED_TO_KIN.items()}
    return rows.rename(columns=back)


def run_suite(out: Path, *, resume: bool = False) -> None:
    suite = out.parent / "formats.toml"
    suite.write_text(SUITE)
    with ThreadPoolExecutor(2) as pool:
        summary = compare(
            suite, out, executor=pool, quiet=True, resume=resume, trajectories="default"
        )
    assert summary.completed


@pytest.fixture(scope="module")
def current(tmp_path_factory) -> Path:
    """A results folder as this hoopbench writes it: two runs, their trajectories."""
    out = tmp_path_factory.mktemp("current") / "out"
    run_suite(out)
    return out


def older(
    current: Path,
    folder: Path,
    *,
    drop: list[str],
    version: int | None,
    timed_out: str | None = None,
    layout: int | None = None,
) -> Path:
    """The rows of ``current`` stored again without the columns ``drop``, meta.json saying
    ``version`` (None: no meta.json, as before the sweep ended); the run of engine
    ``timed_out``, if given, stored as a timeout (a resume runs it again); in the layout of
    format ``layout`` (default: ``version``, or 2 without one): before format 7 as
    ``before_7`` makes it, before 8 without the batch columns."""
    rows = results.read_runs(current)
    if layout is None:
        layout = 2 if version is None else version
    if layout < TRANSITIONS_VERSION:
        rows = rows.drop(columns=NEW_IN_9)
    if layout < ONE_READING_VERSION:
        rows = before_7(rows)
    if layout < BATCHES_VERSION:
        rows = rows.drop(columns=list(BATCH_COLUMNS))
    rows = rows.drop(columns=[*drop, "seq"])
    if timed_out is not None:
        rows.loc[rows["engine"] == timed_out, "status"] = "timeout"
    writer = results.RunsWriter(folder / results.RUNS_NAME)
    for row in rows.to_dict("records"):
        writer.add(row)
    writer.flush()
    if version is not None:
        meta = json.loads((current / results.META_NAME).read_text())
        results.write_meta({**meta, results.FORMAT_KEY: version}, folder / results.META_NAME)
    shutil.copy(current / "suite.toml", folder / "suite.toml")
    return folder


def newer_message(source: object, what: str, version: int) -> str:
    return (
        f"{source}: {what} format version {version + 1} is newer than this hoopbench's "
        f"{version}: use a newer hoopbench"
    )


# --------------------------------------------------------------------------- runs tables
def test_a_new_table_records_the_current_version_and_reads_unchanged(current):
    meta = json.loads((current / results.META_NAME).read_text())
    assert meta[results.FORMAT_KEY] == FORMAT_VERSION
    frame = runs_frame(current)
    stored = results.read_runs(current)
    pd.testing.assert_frame_equal(frame[stored.columns], stored)
    assert set(frame["profile"]) == {"tuned"} and frame["verdict"].notna().all()


@pytest.mark.parametrize("version", [2, None], ids=["version-2", "no-version"])
def test_an_early_version_2_table_is_read_migrated(current, tmp_path, version):
    # Version 2 had no contact reading (5) either: its canonical columns read empty.
    old = older(current, tmp_path, drop=[*VERSION_2, *RENAMED_FROM_CONTACT], version=version)
    frame = runs_frame(old)
    assert list(frame["profile"]) == ["tuned", "tuned"]  # the profile every run had then
    assert frame[[*NEW_IN_3, "verdict", *NEW_IN_4]].isna().all().all()
    assert set(ROW_COLUMNS) <= set(frame.columns)
    assert frame[[*NEW_IN_7, *RENAMED_FROM_CONTACT.values()]].isna().all().all()
    skip = {*VERSION_2, *NEW_IN_7, *NEW_IN_9, *RENAMED_FROM_CONTACT.values(), "seq"}
    skip |= {"kin_t_last_phase"}
    skip |= {Col.VERDICT_FLAGS, Col.VERDICT_REASON, Col.OUTCOME, Col.ERR_HOP_HEIGHT_REL}
    skip |= {Col.PHASES_AGREE}
    kept = [c for c in results.read_runs(current).columns if c not in skip]
    expected = runs_frame(current)[kept]
    pd.testing.assert_frame_equal(frame[kept], expected, check_dtype=False)


def test_the_recorded_version_chooses_the_migrations(current, tmp_path):
    """The same rows without a profile: a version-4 table is not patched (its rows always have
    one), so an empty profile stays empty."""
    old = older(current, tmp_path, drop=["profile"], version=4)
    assert runs_frame(old)["profile"].isna().all()


def test_a_version_5_table_reads_the_force_columns_empty(current, tmp_path):
    """Runs judged before the contact-force columns (format 6) have them empty; the rest of
    each row is read as stored."""
    old = older(current, tmp_path, drop=list(FORCE_COLUMNS), version=5)
    frame = runs_frame(old)
    assert frame[list(FORCE_COLUMNS)].isna().all().all()
    assert runs_frame(current)[list(FORCE_COLUMNS)].notna().all().all()
    skip = {*FORCE_COLUMNS, *NEW_IN_7, *NEW_IN_9, *VERDICT_COLUMNS, "seq"}
    kept = [c for c in results.read_runs(current).columns if c not in skip]
    pd.testing.assert_frame_equal(frame[kept], runs_frame(current)[kept], check_dtype=False)
    expected = untimed(runs_frame(current))
    pd.testing.assert_frame_equal(frame[VERDICT_COLUMNS], expected, check_dtype=False)


def test_a_version_6_table_is_read_with_one_reading(current, tmp_path):
    """Format 7 (issue 24): a version-6 table's unprefixed events (the clearance reading)
    become kin_*, its contact_* columns the unprefixed ones, and the verdict is judged again
    by today's rules; the same rows read as the current table reads them."""
    old = older(current, tmp_path, drop=[], version=6)
    assert "contact_phases" in results.read_runs(old).columns
    frame = runs_frame(old)
    assert not any(c.startswith("contact_") for c in frame.columns)
    skip = {*NEW_IN_7, *NEW_IN_9, *VERDICT_COLUMNS, "seq"}
    kept = [c for c in results.read_runs(current).columns if c not in skip]
    pd.testing.assert_frame_equal(frame[kept], runs_frame(current)[kept], check_dtype=False)
    expected = untimed(runs_frame(current))
    pd.testing.assert_frame_equal(frame[VERDICT_COLUMNS], expected, check_dtype=False)


def test_a_version_7_table_reads_each_run_as_a_batch_of_one(current, tmp_path):
    """Format 8 (issue 27): a version-7 table's runs were stepped alone, each a batch of one at
    its own cost; the same rows read as the current table reads them (its runs, of engines
    that do not batch, were batches of one too)."""
    old = older(current, tmp_path, drop=[], version=7)
    assert not set(BATCH_COLUMNS) & set(results.read_runs(old).columns)
    frame = runs_frame(old)
    assert list(frame[Col.BATCH_SIZE]) == [1, 1]
    assert frame[Col.US_PER_WORLD_STEP].tolist() == pytest.approx(frame[Col.US_PER_STEP].tolist())
    kept = [c for c in results.read_runs(current).columns if c not in {*NEW_IN_9, "seq"}]
    pd.testing.assert_frame_equal(frame[kept], runs_frame(current)[kept], check_dtype=False)


def test_a_version_8_table_reads_the_transition_columns_empty_and_keeps_its_verdict(
    current, tmp_path
):
    """Format 9 (issue 33): a version-8 table's runs were judged before every transition was
    timed; the phases' start times and the worst transition read empty, the rest of each row
    (its verdict too) as stored."""
    old = older(current, tmp_path, drop=[], version=8)
    assert not set(NEW_IN_9) & set(results.read_runs(old).columns)
    frame = runs_frame(old)
    assert frame[NEW_IN_9].isna().all().all()
    assert runs_frame(current)[NEW_IN_9].notna().all().all()
    kept = [c for c in results.read_runs(current).columns if c not in {*NEW_IN_9, "seq"}]
    pd.testing.assert_frame_equal(frame[kept], runs_frame(current)[kept], check_dtype=False)


def test_a_row_with_its_batch_cost_keeps_it_in_an_older_table(current, tmp_path):
    """A version-7 folder resumed by this hoopbench keeps its version and holds rows of both
    layouts: a batched run's new row keeps its own cost, the old row reads as a batch of one."""
    old = older(current, tmp_path, drop=[], version=7)
    rows = results.read_runs(current).drop(columns=["seq"])
    batched = rows[rows["engine"] == "pymunk"].assign(
        **{Col.BATCH_SIZE: 4, Col.US_PER_WORLD_STEP: 12.5, Col.WORLD_STEPS_PER_S: 8e4}
    )
    writer = results.RunsWriter(old / results.RUNS_NAME)
    writer.add(batched.to_dict("records")[0])
    writer.flush()
    frame = runs_frame(old).set_index("engine")
    assert frame.loc["pymunk", [*BATCH_COLUMNS]].tolist() == [4, 12.5, 8e4]
    assert frame.loc["reference", Col.BATCH_SIZE] == 1


def test_a_newer_table_is_refused_with_both_versions(current, tmp_path):
    new = older(current, tmp_path / "new", drop=[], version=FORMAT_VERSION + 1)
    message = newer_message(new, "runs table", FORMAT_VERSION)
    with pytest.raises(FormatVersionError) as caught:
        runs_frame(new)
    assert str(caught.value) == message


def test_the_command_line_refuses_a_newer_table_in_one_line(current, tmp_path, capsys):
    new = older(current, tmp_path / "new", drop=[], version=FORMAT_VERSION + 1)
    code = main(["report", "--results", str(new), "--out", str(tmp_path / "report")])
    err = capsys.readouterr().err
    assert code == 2
    assert err == f"hoopbench: error: {newer_message(new, 'runs table', FORMAT_VERSION)}\n"
    assert not (tmp_path / "report" / "report.md").exists()


@pytest.mark.parametrize("text", ["{not json", "[4]"])
def test_a_meta_json_that_is_not_a_json_object_is_one_line(current, tmp_path, text):
    old = older(current, tmp_path, drop=[], version=FORMAT_VERSION)
    (old / results.META_NAME).write_text(text)
    with pytest.raises(ValueError, match=r"^\S+meta\.json is unreadable: \w[^\n]*$"):
        runs_frame(old)


def test_resuming_a_table_from_before_one_reading_is_refused(current, tmp_path):
    """A version-3 folder whose pymunk run timed out: before issue 24 it was resumed and kept
    its version; its rows name their columns apart from this hoopbench's (format 7), so the
    resume stops in one line before any run, and the folder reads as before."""
    out = older(current, tmp_path / "out", drop=NEW_IN_4, version=3, timed_out="pymunk")
    with pytest.raises(RunnerError, match="from before one reading"):
        run_suite(out, resume=True)
    assert runs_frame(out).set_index("engine").loc["pymunk", "status"] == "timeout"


def test_a_table_without_a_version_in_todays_layout_is_read_as_it_is(current, tmp_path):
    """A sweep still running (no meta.json yet) counts as version 2, yet its rows are this
    hoopbench's: one reading leaves them as they are."""
    stored = results.read_runs(current).drop(columns=["seq"])
    writer = results.RunsWriter(tmp_path / results.RUNS_NAME)
    for row in stored.to_dict("records"):
        writer.add(row)
    writer.flush()
    frame = runs_frame(tmp_path)
    kept = [c for c in stored.columns if c != "profile"]
    pd.testing.assert_frame_equal(frame[kept], runs_frame(current)[kept], check_dtype=False)


def test_resuming_a_table_without_a_version_records_the_oldest(current, tmp_path):
    out = older(current, tmp_path / "out", drop=[], version=None, layout=FORMAT_VERSION)
    run_suite(out, resume=True)  # nothing to run: it writes the missing runs.csv and meta.json
    assert json.loads((out / results.META_NAME).read_text())[results.FORMAT_KEY] == 2


def test_resuming_a_newer_table_is_refused_before_any_run(current, tmp_path):
    out = older(current, tmp_path / "out", drop=[], version=FORMAT_VERSION + 1, timed_out="pymunk")
    with pytest.raises(FormatVersionError) as caught:
        run_suite(out, resume=True)
    assert str(caught.value) == newer_message(out, "runs table", FORMAT_VERSION)
    stored = results.read_runs(out, latest=False)
    assert len(stored) == 2 and "timeout" in set(stored["status"])


# --------------------------------------------------------------------------- hop maps
def map_folder(folder: Path, version: int | None) -> Path:
    """Two rows as a map stores them before the batch columns: the reference's classification
    (no steps) and a pymunk run of 2000 steps in 0.5 s."""
    writer = results.RunsWriter(folder / results.RUNS_NAME)
    for k, engine in enumerate(("reference", "pymunk")):
        ran = {"n_steps": 2000} if engine != "reference" else {}
        row = {"run_id": f"r000-00{k}-{engine}", "status": "ok", "ix": 0, "iy": k}
        writer.add({**row, "engine": engine, "wall_time_s": 0.5, **ran})
    writer.flush()
    if version is not None:
        results.write_meta({results.FORMAT_KEY: version}, folder / results.META_NAME)
    return folder


@pytest.mark.parametrize("version", [MAP_VERSION, None])
def test_a_map_table_is_read_at_its_version_or_without_one(tmp_path, version):
    frame = map_frame(map_folder(tmp_path, version))
    assert list(frame["run_id"]) == ["r000-000-reference", "r000-001-pymunk"]


@pytest.mark.parametrize("version", [BATCHES_MAP_VERSION - 1, ONE_READING_MAP_VERSION - 1, None])
def test_a_map_table_from_before_batches_reads_each_run_as_a_batch_of_one(tmp_path, version):
    """Map format 5 (issue 27), after one reading (4) or with it (3, or no meta.json)."""
    frame = map_frame(map_folder(tmp_path, version)).set_index("engine")
    assert frame.loc["pymunk", [*BATCH_COLUMNS]].tolist() == [1, 250.0, 4000.0]
    assert frame.loc["reference", [*BATCH_COLUMNS]].isna().all()  # no steps: no batch


def test_a_map_table_from_before_transitions_reads_their_columns_empty(tmp_path):
    """Map format 6 (issue 33): a version-5 map's rows lack the phases' start times and the
    worst transition; they read empty."""
    frame = map_frame(map_folder(tmp_path, MAP_VERSION - 1))
    assert set(NEW_IN_9) <= set(frame.columns) and frame[NEW_IN_9].isna().all().all()


def test_a_current_map_table_is_not_patched(tmp_path):
    frame = map_frame(map_folder(tmp_path, MAP_VERSION))
    assert frame[list(BATCH_COLUMNS)].isna().all().all()


BATCH_MAP = MapSpec(
    nx=3, ny=1, engines=("mujoco",), timestep=1e-3, t_end=0.5, x_range=(0.1, 0.3), y_range=(0.5, 1)
)
"""Three MuJoCo runs, which batch."""


@pytest.fixture(scope="module")
def batch_map(tmp_path_factory) -> Path:
    """A map folder as this hoopbench writes it, its runs stepped alone."""
    out = tmp_path_factory.mktemp("map") / "map"
    with ThreadPoolExecutor(2) as pool:
        run_map(BATCH_MAP, out, executor=pool, quiet=True, batch_size=1)
    return out


def older_map(current: Path, folder: Path, version: int) -> Path:
    """``current`` as a map of table format ``version`` interrupted in stage 2 stored it: its
    MuJoCo runs but the first timed out, the batch columns absent."""
    shutil.copytree(current, folder, ignore=shutil.ignore_patterns(results.RUNS_NAME))
    rows = results.read_runs(current).drop(columns=["seq", *BATCH_COLUMNS])
    later = (rows["engine"] == "mujoco") & (rows["ix"] > 0)
    rows.loc[later, "status"] = "timeout"
    writer = results.RunsWriter(folder / results.RUNS_NAME)
    for row in rows.to_dict("records"):
        writer.add(row)
    writer.flush()
    meta = json.loads((current / results.META_NAME).read_text())
    results.write_meta({**meta, results.FORMAT_KEY: version}, folder / results.META_NAME)
    return folder


def test_resuming_a_map_from_before_batches_keeps_its_version(batch_map, tmp_path):
    """A version-4 map resumed: its two timed-out runs go in one batch of two; the folder keeps
    version 4, so its old run reads as a batch of one and the new rows keep their batch's cost."""
    out = older_map(batch_map, tmp_path / "old", ONE_READING_MAP_VERSION)
    with ThreadPoolExecutor(1) as pool:  # one call at a time: the two runs in one batch
        run_map(BATCH_MAP, out, executor=pool, quiet=True, resume=True, batch_size=2)
    assert json.loads((out / results.META_NAME).read_text())[results.FORMAT_KEY] == 4
    frame = map_frame(out)
    mujoco = frame[frame["engine"] == "mujoco"].set_index("ix")
    assert mujoco[Col.BATCH_SIZE].tolist() == [1, 2, 2]
    first = mujoco.loc[0]
    assert first[Col.US_PER_WORLD_STEP] == pytest.approx(
        1e6 * first["wall_time_s"] / first["n_steps"]
    )


def test_resuming_a_map_from_before_one_reading_is_refused(batch_map, tmp_path):
    out = older_map(batch_map, tmp_path / "old", ONE_READING_MAP_VERSION - 1)
    with pytest.raises(RunnerError, match="map table format 3, from before one reading"):
        run_map(BATCH_MAP, out, quiet=True, resume=True)
    stored = results.read_runs(out)
    assert (stored["status"] == "timeout").sum() == 2


def test_a_newer_map_table_is_refused_with_both_versions(tmp_path):
    folder = map_folder(tmp_path, MAP_VERSION + 1)
    with pytest.raises(FormatVersionError) as caught:
        map_frame(folder)
    assert str(caught.value) == newer_message(folder, "hop map runs table", MAP_VERSION)


# --------------------------------------------------------------------------- trajectories
@pytest.fixture
def trajectory(current) -> Path:
    return sorted((current / "trajectories").glob("*.parquet"))[0]


def test_a_trajectory_records_its_version(trajectory, tmp_path):
    assert pd.read_parquet(trajectory).attrs == {"hoopbench_trajectory_format": 1}
    csv = Trajectory.read(trajectory).write(tmp_path / "t.csv")
    assert csv.read_text().startswith("# hoopbench trajectory format 1; SI units\n")


def test_a_parquet_trajectory_is_compressed_and_reads_back_bit_for_bit(trajectory, tmp_path):
    """Each float column split into byte streams, then zstd: this 3,001-sample run takes 0.59
    of its doubles' 8 bytes a sample, where snappy alone took 0.80 (a make report's 407
    trajectories: 378 MB with snappy, 241 MB so written)."""
    written = Trajectory.read(trajectory)
    frame = written.to_frame()
    path = written.write(tmp_path / "t.parquet")
    size, raw = path.stat().st_size, frame.memory_usage(index=False).sum()
    assert size < 0.7 * raw, (size, raw)
    pd.testing.assert_frame_equal(Trajectory.read(path).to_frame(), frame, check_exact=True)


def test_trajectories_without_a_version_are_read_as_the_oldest(trajectory, tmp_path):
    expected = Trajectory.read(trajectory).to_frame()
    bare = pd.read_parquet(trajectory)
    bare.attrs.clear()
    bare.to_parquet(tmp_path / "bare.parquet", index=False)
    bare.to_csv(tmp_path / "bare.csv", index=False, float_format="%.17g")  # no comment line
    for path in (tmp_path / "bare.parquet", tmp_path / "bare.csv"):
        pd.testing.assert_frame_equal(Trajectory.read(path).to_frame(), expected)


def test_a_newer_trajectory_is_refused_with_both_versions(trajectory, tmp_path):
    frame = pd.read_parquet(trajectory)
    frame.attrs["hoopbench_trajectory_format"] = TRAJECTORY_VERSION + 1
    parquet = tmp_path / "new.parquet"
    frame.to_parquet(parquet, index=False)
    csv = Trajectory.read(trajectory).write(tmp_path / "new.csv")
    csv.write_text(csv.read_text().replace("format 1;", f"format {TRAJECTORY_VERSION + 1};", 1))
    for path in (parquet, csv):
        with pytest.raises(FormatVersionError) as caught:
            Trajectory.read(path)
        assert str(caught.value) == newer_message(path, "trajectory file", TRAJECTORY_VERSION)


def test_a_trajectory_version_that_is_not_a_number_is_one_line(trajectory, tmp_path):
    csv = Trajectory.read(trajectory).write(tmp_path / "t.csv")
    csv.write_text(csv.read_text().replace("format 1;", "format 1b;", 1))
    with pytest.raises(FormatVersionError, match=r"must be a whole number, got '1b'$"):
        Trajectory.read(csv)


# --------------------------------------------------------------------------- the mechanism
def test_migrations_run_in_order_from_the_recorded_version():
    calls = []

    def step(k: int):
        def migrate(frame: pd.DataFrame) -> pd.DataFrame:
            calls.append(k)
            return frame.assign(v=k + 1)

        return migrate

    table = FileFormat("t", 4, oldest=1, migrations={k: step(k) for k in (1, 2, 3)})
    start = pd.DataFrame({"v": [2]})
    assert table.upgrade(start, 2, "x")["v"].iloc[0] == 4 and calls == [2, 3]
    calls.clear()
    assert table.upgrade(start, None, "x")["v"].iloc[0] == 4 and calls == [1, 2, 3]
    calls.clear()
    assert table.upgrade(start, 4, "x") is start and calls == []


@pytest.mark.parametrize(
    ("recorded", "message"),
    [
        (True, "x: t format version must be a whole number, got True"),
        ("4", "x: t format version must be a whole number, got '4'"),
        (0, "x: t format version 0 is older than the oldest this hoopbench reads (1)"),
    ],
)
def test_a_recorded_version_this_hoopbench_cannot_read_is_one_line(recorded, message):
    table = FileFormat("t", 2, oldest=1, migrations={1: lambda frame: frame})
    with pytest.raises(FormatVersionError) as caught:
        table.version_of(recorded, "x")
    assert str(caught.value) == message


def test_a_version_without_its_migration_is_caught_where_it_is_declared():
    with pytest.raises(ValueError, match=r"t format 3 lacks migrations from \[2\]"):
        FileFormat("t", 3, oldest=1, migrations={1: lambda frame: frame})
