"""Engine releases (compare/releases.py): the version axis, the MuJoCo adapter on releases
without the contact sensor, and the report's "Across engine releases" section.

The end-to-end test installs MuJoCo 3.3.7 and 4.0.0 from the package index into the user's
cache (``$XDG_CACHE_HOME/hoopbench/engines``, or ``HOOPBENCH_ENGINE_CACHE``): the first time
about 20 MB and 10 s of pip a release, reused after.
"""

from __future__ import annotations

import json
import sys

import numpy as np
import pandas as pd
import pytest

from hoopbench.engines import mujoco_engine
from hoopbench.engines.judging.columns import Col
from hoopbench.engines.registry import get_engine
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene
from hoopbench.reports.compare import releases
from hoopbench.reports.compare.suite import batch_key, compare, run_and_row, runs_frame
from hoopbench.reports.compare.suite_file import SuiteError, parse_suite
from hoopbench.reports.report.releases import release_changes, releases_figure, releases_section

SUITE = {"name": "r", "engines": ["mujoco"], "timesteps": [1e-3], "scenes": ["hop-top"]}


# --------------------------------------------------------------------------- the axis
def test_a_release_is_engine_equals_version():
    assert releases.parse_release("mujoco==3.3.7") == releases.Release("mujoco", "3.3.7")
    for bad in ("mujoco", "mujoco==", "nosuch==1.0", "reference==1.0", "mujoco==3.3.7; rm"):
        with pytest.raises(ValueError):
            releases.parse_release(bad)


def test_each_release_is_its_own_run_and_never_batched():
    suite = parse_suite({**SUITE, "engine_versions": {"mujoco": ["3.3.7", "4.0.0"]}})
    tasks = suite.tasks()
    assert [(t.variant, t.release) for t in tasks] == [
        ("release=3.3.7", "3.3.7"),
        ("release=4.0.0", "4.0.0"),
    ]
    plain = parse_suite(SUITE).tasks()
    assert len({t.run_id for t in [*tasks, *plain]}) == 3  # the release is in the run's key
    assert batch_key(plain[0]) is not None and batch_key(tasks[0]) is None
    again = parse_suite(SUITE).with_releases([("mujoco", "3.3.7"), ("mujoco", "4.0.0")])
    assert [t.run_id for t in again.tasks()] == [t.run_id for t in tasks]


@pytest.mark.parametrize(
    ("table", "says"),
    [
        ({"pymunk": ["7.0.0"]}, "not one of the suite's engines"),
        ({"mujoco": []}, "non-empty list"),
        ({"mujoco": ["3.3.7", "3.3.7"]}, "listed twice"),
        ({"mujoco": [3.3]}, "a release is a version"),
    ],
)
def test_a_bad_engine_versions_table_is_refused(table, says):
    with pytest.raises(SuiteError, match=says):
        parse_suite({**SUITE, "engine_versions": table})


def test_a_release_folder_is_keyed_by_engine_version_and_python(monkeypatch, tmp_path):
    monkeypatch.setenv(releases.CACHE_ENV, str(tmp_path))
    folder = releases.env_dir(releases.Release("pymunk", "6.11.1"))
    assert folder == tmp_path / f"pymunk-6.11.1-{releases.PYTHON_TAG}"
    monkeypatch.delenv(releases.CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert releases.cache_root() == tmp_path / "xdg" / "hoopbench" / "engines"


@pytest.mark.slow
def test_releases_side_by_side_and_a_missing_one_in_one_line(tmp_path, capfd):
    """The issue's "done when": MuJoCo 3.3.7 and 4.0.0 in one folder (and 3.1.3, before the
    contact sensor), rows marked by the version imported; mujoco==0.0.1 one line on stderr,
    and the rest completes."""
    suite_file = tmp_path / "one.toml"
    suite_file.write_text(
        'name = "one"\nengines = ["mujoco"]\ntimesteps = [1e-3]\nscenes = ["hop-top"]\n'
        '[engine_versions]\nmujoco = ["3.1.3", "3.3.7", "4.0.0", "0.0.1"]\n'
    )
    out = tmp_path / "out"
    summary = compare(suite_file, out, jobs=2, quiet=True)
    assert summary.exit_code == 0
    err = capfd.readouterr().err
    missing = [line for line in err.splitlines() if "0.0.1" in line]
    assert missing == [
        "hoopbench: mujoco==0.0.1: cannot be installed: "
        "No matching distribution found for mujoco==0.0.1"
    ]
    assert "Traceback" not in err
    rows = runs_frame(out)
    assert sorted(
        zip(rows[Col.VARIANT], rows[Col.ENGINE_VERSION], rows[Col.STATUS], strict=True)
    ) == [
        ("release=3.1.3", "3.1.3", "ok"),
        ("release=3.3.7", "3.3.7", "ok"),
        ("release=4.0.0", "4.0.0", "ok"),
    ]
    # 3.1.3 has no contact sensor: the adapter reads the force itself, and the events are
    # 4.0.0's (the releases' states are the same; a force read as none made a false lift-off).
    by_release = rows.set_index(Col.VARIANT.value)
    for column in (Col.ERR_T_SLIP_MS, Col.ERR_T_LIFT_MS, Col.ERR_HOP_HEIGHT_REL):
        old, new = by_release.loc["release=3.1.3", column], by_release.loc["release=4.0.0", column]
        assert pd.notna(new), column  # hop-top has each of these events
        assert float(old) == pytest.approx(float(new), rel=1e-6), column
    meta = json.loads((out / "meta.json").read_text())["engine_releases"]
    assert meta["mujoco==0.0.1"]["status"] == "unusable"
    section = releases_section(rows)  # from the stored rows
    assert "## Across engine releases" in section and "| 3.1.3 | 3.3.7 | 4.0.0 |" in section


# --------------------------------------------------------------------------- MuJoCo before 3.3.5
def test_mujoco_without_the_contact_sensor_steps_as_the_rollout(monkeypatch):
    """A release before 3.3.5 has no contact sensor: the adapter steps from Python and reads
    the force itself. On 4.0.0, forced onto that path, every state and force is the same."""
    scene, settings = get_scene("hop-top"), RunSettings(timestep=1e-3)
    sensor = get_engine("mujoco").simulate(scene, settings).trajectory
    monkeypatch.setattr(mujoco_engine, "has_contact_sensor", lambda mujoco: False)
    own = get_engine("mujoco").simulate(scene, settings).trajectory
    assert sensor is not None and own is not None
    for key in ("X", "Y", "theta", "thetadot", "normal_force", "friction_force"):
        mine, theirs = np.asarray(getattr(own, key)), np.asarray(getattr(sensor, key))
        assert np.array_equal(mine, theirs), key


# --------------------------------------------------------------------------- the report section
def _rows() -> pd.DataFrame:
    """Two releases' rows of one run: the 4.0.0 adapter's row, stored as two releases."""
    (task,) = parse_suite({**SUITE, "engine_versions": {"mujoco": ["3.3.7"]}}).tasks()
    _, row = run_and_row(task)
    newer = {**row, Col.VARIANT.value: "release=4.0.0", Col.ENGINE_VERSION.value: "4.0.0"}
    return pd.DataFrame([row, newer])


def test_the_section_says_no_change_between_identical_releases():
    section = releases_section(_rows())
    assert "No change between consecutive releases" in section
    assert "**" not in section.split("### What changed")[0].split("| 4.0.0 |")[1]


def test_the_section_names_each_change_and_the_release_that_made_it(tmp_path):
    rows = _rows()
    newer = rows.index[1]
    rows.loc[newer, Col.VERDICT.value] = "missed-hop"
    rows.loc[newer, Col.ERR_HOP_HEIGHT_REL.value] = rows.loc[newer, Col.ERR_HOP_HEIGHT_REL] + 0.5
    rows.loc[newer, Col.CPU_US_PER_STEP.value] = 3 * rows.loc[newer, Col.CPU_US_PER_STEP]
    changes = release_changes(rows)
    assert {(c.before, c.after, c.what) for c in changes} == {
        ("3.3.7", "4.0.0", "verdict"),
        ("3.3.7", "4.0.0", "hop height"),
        ("3.3.7", "4.0.0", "cost"),
    }
    section = releases_section(rows)
    assert "- mujoco 4.0.0 (from 3.3.7): hop-top dt 0.001 s tuned: verdict " in section
    assert "→ missed-hop" in section
    assert "**missed-hop" in section  # the changed cell in bold
    (figure,) = releases_figure(rows, tmp_path)
    assert figure.name == "releases-mujoco.png" and figure.stat().st_size > 0


def test_releases_are_ordered_by_version_not_text():
    rows = _rows()
    third = rows.iloc[[0]].assign(**{Col.VARIANT.value: "release=3.10.0"})
    section = releases_section(pd.concat([rows, third]))
    assert "| 3.3.7 | 3.10.0 | 4.0.0 |" in section


def test_no_release_rows_no_section():
    rows = _rows().assign(**{Col.VARIANT.value: "default"})
    assert releases_section(rows) == ""
    assert releases_section(pd.DataFrame(columns=[Col.VARIANT.value, Col.ENGINE.value])) == ""


def test_the_child_refuses_an_engine_imported_before_its_folder(tmp_path):
    """The release's folder must come first on sys.path before the engine is imported: a
    process that imported it already would run the main environment's release."""
    import mujoco  # noqa: F401

    from hoopbench.reports.compare import release_child

    with pytest.raises(RuntimeError, match="imported before"):
        release_child.use_release(tmp_path, "mujoco")


@pytest.mark.slow
def test_a_report_of_release_runs_alone_has_their_section(tmp_path):
    """A suite whose runs are all on named releases (the releases suite) has no default
    runs: the other sections are of none, and the report still writes its own."""
    from hoopbench.reports.report.markdown import write_markdown

    path = write_markdown(_rows(), tmp_path, generated="now")
    text = path.read_text()
    assert "## Across engine releases" in text and "Runs: 2;" in text
    assert (tmp_path / "releases-mujoco.png").is_file()


def test_an_engines_version_is_read_once_per_search_path(monkeypatch, tmp_path):
    """Engine.version() reads the package's metadata once per sys.path (it cost up to 2 ms a
    run), and again when the path changes, as a release run puts its folder first."""
    from hoopbench.engines import base

    reads: list[str] = []

    def counted(distribution: str) -> str:
        reads.append(distribution)
        return f"1.{len(reads)}"

    base._installed_version.cache_clear()
    monkeypatch.setattr(base, "version", counted)
    engine = get_engine("mujoco")
    assert engine.version() == engine.version() == "1.1"
    monkeypatch.setattr("sys.path", [str(tmp_path), *sys.path])
    assert engine.version() == "1.2"
    assert reads == ["mujoco", "mujoco"]
    base._installed_version.cache_clear()
