"""The comparison suite and its report, on the quick suite."""

from __future__ import annotations

import json
import re
import sys

import numpy as np
import pandas as pd
import pytest

from hoopbench.engines.options import Profile
from hoopbench.engines.registry import engine_class, engine_names
from hoopbench.engines.run import RunStatus
from hoopbench.reports.compare.suite import ROW_COLUMNS, compare, run_task
from hoopbench.reports.compare.suite_file import builtin_suite, load_suite, parse_suite
from hoopbench.reports.report.build import build_report, report_frame
from hoopbench.reports.report.markdown import write_markdown


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("results")
    summary = compare(builtin_suite("quick"), out, jobs=2, quiet=True, trajectories="default")
    assert summary.completed
    return out, build_report(out)


@pytest.mark.slow  # the quick suite, about 10 s once per module
def test_quick_report_writes_its_files(quick_report):
    out, report = quick_report
    assert report == out / "report.md"
    for name in ("runs.csv", "meta.json", "suite.toml", "error_vs_time.png", "hoop_seed.png"):
        assert (out / name).stat().st_size > 0
    assert any((out / "trajectories").glob("*.parquet"))


@pytest.mark.slow  # the quick suite, about 10 s once per module
def test_runs_table_is_tidy_and_complete(quick_report):
    out, _ = quick_report
    runs = pd.read_parquet(out / "runs")
    tasks = load_suite(builtin_suite("quick")).tasks()
    assert len(runs) == len(tasks)
    assert sorted(runs["run_id"]) == sorted(t.run_id for t in tasks)
    assert not runs.duplicated(["scene", "engine", "variant", "timestep"]).any()
    assert set(runs["status"]) == {"ok"}
    assert set(ROW_COLUMNS) - {"trajectory_file"} <= set(runs.columns)
    csv = pd.read_csv(out / "runs.csv")  # a plain CSV: header on line 1
    assert set(csv.columns) == set(runs.columns)
    ref = runs[(runs["engine"] == "reference") & (runs["scene"] == "seed-mu")].iloc[0]
    # The reference row measures the detectors' own bias: it must be small.
    assert abs(ref["err_t_slip_ms"]) < 0.1


@pytest.mark.slow  # the quick suite, about 10 s once per module
def test_report_has_the_tables(quick_report):
    _, report = quick_report
    text = report.read_text()
    for heading in (
        "## Seed reproduction",
        "## Events per scene",
        "### seed-mu",
        "### hop-bottom",
        "## Error against run time",
        "## Stability",
    ):
        assert heading in text
    assert "| reference |" in text


@pytest.mark.slow  # the quick suite, about 10 s once per module
def test_write_markdown_leaves_its_input_alone(quick_report, tmp_path):
    """The report derives its columns locally: the caller's frame comes back unchanged, here one
    that lacks the optional columns which the report fills with blanks."""
    out, _ = quick_report
    optional = ["phases", "phases_agree", "exact_phases", "outcome_agrees", "max_penetration_m"]
    frame = report_frame(out).drop(columns=optional)
    before, columns = frame.copy(), list(frame.columns)
    assert write_markdown(frame, tmp_path, generated="now") == tmp_path / "report.md"
    assert list(frame.columns) == columns
    pd.testing.assert_frame_equal(frame, before)
    assert "## Stability" in (tmp_path / "report.md").read_text()


def test_a_broken_run_becomes_an_error_row():
    suite = parse_suite(
        {"name": "t", "engines": ["pymunk"], "timesteps": [1e-3], "scenes": ["seed-mu"]}
    )
    (task,) = suite.tasks()
    # An option value no check would let through, as a stale task from an old file might hold.
    broken = task.__class__(**{**task.__dict__, "options": (("iterations", "x"),)})
    row = run_task(broken)
    assert row["status"] == str(RunStatus.ERROR)
    assert "iterations" in row["message"]
    assert row["run_id"] == task.run_id and row["scene"] == "seed-mu"


LEFT_OUT = re.compile(r"^# left out: (\S+) (\S+): (.{10,})$", re.MULTILINE)
"""A line of a suite file naming an engine's variant or knob it leaves out, with the reason."""


def _left_out(name: str) -> set[tuple[str, str]]:
    return {(m[1], m[2]) for m in LEFT_OUT.finditer(builtin_suite(name).read_text())}


def _declared(engine: str) -> set[tuple]:
    return {
        (v.name, v.geometry, tuple(sorted(v.options.items())))
        for v in engine_class(engine).variants
    }


def _in_file(suite, engine: str) -> set[tuple]:
    return {
        (v.name, v.geometry, tuple(sorted(v.options.items())))
        for v in suite.variants
        if v.engine == engine
    }


def _stock_knobs(engine: str) -> dict[str, object]:
    """Option name -> stock value, for the options whose stock value is not the tuned one."""
    cls = engine_class(engine)
    stock, tuned = cls.defaults(Profile.STOCK), cls.defaults(Profile.TUNED)
    return {k: v for k, v in stock.items() if v != tuned[k]}


def test_the_full_suite_runs_every_engine_and_every_declared_variant():
    full = load_suite(builtin_suite("full"))
    assert set(full.engines) == set(engine_names())
    assert set(full.profiles) == set(Profile)
    for engine in full.engines:
        assert _declared(engine) <= _in_file(full, engine), engine


def test_the_default_suite_runs_each_declared_variant_or_says_why_not():
    suite = load_suite(builtin_suite("default"))
    assert set(suite.engines) == set(engine_names())  # every registered engine
    assert set(suite.profiles) == set(Profile)  # stock beside tuned
    assert {"seed-mu", "hop-top", "hop-low", "hop-bottom"} <= {s.name for s in suite.scenes}
    left_out = _left_out("default")
    for engine in suite.engines:
        missing = {name for name, _, _ in _declared(engine) - _in_file(suite, engine)}
        assert missing <= {name for e, name in left_out if e == engine}, (engine, missing)


def test_the_default_suite_runs_each_stock_knob_alone_or_says_why_not():
    """Every knob whose stock value differs from the tuned one runs alone at its stock value
    on the tuned settings, on a slip scene and a hop scene (the contact-settings tables), or
    the file says why not. Every left-out line names a real variant or knob."""
    suite = load_suite(builtin_suite("default"))
    left_out = _left_out("default")
    for engine in suite.engines:
        tuned = engine_class(engine).defaults(Profile.TUNED)
        scenes_by_knob: dict[str, set[str]] = {}
        for task in suite.tasks():
            if task.engine != engine or task.variant == "default" or task.geometry != "sphere":
                continue
            off = {k: v for k, v in task.options if v != tuned[k]}
            if len(off) == 1:
                scenes_by_knob.setdefault(next(iter(off)), set()).add(task.scene.name)
        for knob, value in _stock_knobs(engine).items():
            if (engine, knob) in left_out:
                continue
            ran = scenes_by_knob.get(knob, set())
            assert {"seed-mu", "hop-top"} <= ran, (engine, knob, value, ran)
        real = {name for name, _, _ in _declared(engine)} | set(_stock_knobs(engine))
        stale = {name for e, name in left_out if e == engine} - real
        assert not stale, (engine, stale)


def test_the_stability_suite_file_holds_every_engine():
    assert set(load_suite(builtin_suite("stability")).engines) == set(engine_names())


def test_seed_section_sets_the_ports_numbers_beside_the_printed_ones():
    from hoopbench.reports.report import seed_reproduction

    steps = seed_reproduction.timestep_table().set_index("dt")
    assert steps.loc[0.002, "steps"] == steps.loc[0.002, "seed steps"] == 14
    deltas = seed_reproduction.delta_table().set_index("delta")
    hop = deltas.loc[1e-3, "hop"]
    assert hop == pytest.approx(deltas.loc[1e-3, "seed hop"], rel=0.1)
    onset = seed_reproduction.onset_table().set_index("source")
    assert onset.loc["exact reference", "outcome"] == "slips"  # no lift-off: the hop is delta's


@pytest.mark.slow  # the quick suite, about 10 s once per module
def test_a_scene_table_leaves_out_the_events_its_scene_lacks(quick_report):
    _, report = quick_report
    text = report.read_text()
    seed = text.split("### seed-mu")[1].split("###")[0]
    hop = text.split("### hop-bottom")[1].split("##")[0]
    assert "t_slip s" in seed and "hop m" not in seed and "impact error" not in seed
    assert "hop m" in hop and "impact error ms" in hop
    assert "s solve" in seed  # the reference's cost is its solve time, not us per step


def _knob_row(engine, profile, variant, options, scene, **values):
    hops = scene == "hop-top"
    return {
        "engine": engine,
        "profile": profile,
        "variant": variant,
        "options": options,
        "geometry": values.pop("geometry", "sphere"),
        "scene": scene,
        "timestep": 1e-4,
        "status": "ok",
        "exact_t_lift": 1.17 if hops else None,
        "exact_t_slip": 0.44 if hops else 0.987,
        "err_t_slip_ms": values.pop("slip", None),
        "err_hop_height_rel": values.pop("hop", None),
        "verdict": values.pop("verdict", "agrees"),
        "us_per_step": 20.0,
    }


def test_the_contact_settings_table_names_each_knob_its_values_and_what_it_moves():
    """Synthetic rows: each line names the knob off its tuned value (from the run's full
    option values, whatever the profile it started from), marks a stock value, and shows the
    slip-onset error on the slip scene and the hop-height error on the hop scene."""
    from hoopbench.reports.report.markdown import _settings_section, with_optional_columns

    rows = [
        _knob_row("mujoco", "tuned", "default", "{}", "seed-mu", slip=2.4),
        _knob_row("mujoco", "tuned", "default", "{}", "hop-top", hop=-0.011),
        _knob_row("mujoco", "stock", "default", "{}", "seed-mu", slip=-914.0),
        _knob_row("mujoco", "stock", "default", "{}", "hop-top", verdict="missed-hop"),
        _knob_row(
            "mujoco", "tuned", "cone=pyramidal", '{"cone": "pyramidal"}', "seed-mu", slip=-1.17
        ),
        _knob_row(
            "mujoco",
            "tuned",
            "cone=pyramidal",
            '{"cone": "pyramidal"}',
            "hop-top",
            hop=-0.997,
            verdict="missed-hop",
        ),
        _knob_row("mujoco", "tuned", "geometry=ring", "{}", "seed-mu", slip=1.0, geometry="ring"),
        _knob_row(
            "pymunk",
            "stock",
            "collision_bias=None",
            '{"collision_slop": 1e-05, "iterations": 50}',
            "seed-mu",
            slip=3.9,
        ),
    ]
    text = _settings_section(with_optional_columns(pd.DataFrame(rows)))
    mujoco = text.split("### mujoco")[1].split("###")[0]
    assert "| knob | tuned value | this run | seed-mu slip onset | hop-top hop height |" in mujoco
    assert "| (all tuned) |  |  | +2.4 ms | -1.1 % |" in mujoco
    assert "| (all stock) |  |  | -914 ms | missed-hop |" in mujoco
    assert "| cone | elliptic | pyramidal (stock) | -1.17 ms | -99.7 % (missed-hop) |" in mujoco
    assert "| geometry | sphere | ring | +1 ms | not run |" in mujoco
    pymunk = text.split("### pymunk")[1]
    assert "| collision_bias | 1e-40 | None (stock) | +3.9 ms |" in pymunk


def test_the_contact_settings_table_shows_every_verdict_but_agrees_beside_its_number():
    """As its caption says: a close or a creeping run (the outcome right, some event off)
    shows its verdict after the number, not the number alone (issue 35)."""
    from hoopbench.reports.report.markdown import _settings_section, with_optional_columns

    rows = [
        _knob_row("mujoco", "tuned", "default", "{}", "seed-mu", slip=2.4),
        _knob_row("mujoco", "tuned", "default", "{}", "hop-top", hop=-0.011, verdict="close"),
        _knob_row("mujoco", "stock", "default", "{}", "seed-mu", slip=1.32, verdict="creeps"),
        _knob_row("mujoco", "stock", "default", "{}", "hop-top", hop=-0.02),
        _knob_row(
            "mujoco", "tuned", "cone=pyramidal", '{"cone": "pyramidal"}', "seed-mu", slip=-1.17
        ),
        _knob_row(
            "mujoco",
            "tuned",
            "cone=pyramidal",
            '{"cone": "pyramidal"}',
            "hop-top",
            hop=-0.05,
            verdict="close",
        ),
    ]
    mujoco = _settings_section(with_optional_columns(pd.DataFrame(rows)))
    assert "| (all tuned) |  |  | +2.4 ms | -1.1 % (close) |" in mujoco
    assert "| (all stock) |  |  | +1.32 ms (creeps) | -2 % |" in mujoco
    assert "| cone | elliptic | pyramidal (stock) | -1.17 ms | -5 % (close) |" in mujoco


def test_the_timestep_table_keeps_stock_and_tuned_apart():
    from hoopbench.reports.report.markdown import _timestep_section, with_optional_columns

    rows = [
        {**_knob_row("pymunk", p, "default", "{}", "seed-mu", slip=s), "outcome_agrees": a}
        | {"wall_time_s": w}
        for p, s, a, w in (("tuned", 3.9, True, 0.2), ("stock", 4.9, False, 0.1))
    ]
    text = _timestep_section(with_optional_columns(pd.DataFrame(rows)))
    assert "| pymunk | tuned | 0.0001 | 0.2 | 3.9 | 1/1 |" in text
    assert "| pymunk | stock | 0.0001 | 0.1 | 4.9 | 0/1 |" in text


def test_figures_drawn_side_by_side_come_back_in_order():
    from hoopbench.reports.report.markdown import _drawn

    assert _drawn([(pow, (2, k)) for k in range(6)]) == [1, 2, 4, 8, 16, 32]
    assert _drawn([(pow, (3, 2))]) == [9]  # one call: drawn here


@pytest.mark.slow  # the quick suite, about 10 s once per module
def test_the_platform_section_names_the_machine_and_its_load(quick_report):
    """Issue 34: the CPU model, the cores, and the load average at the suite's start and end
    (meta.json's session), and every run that stepped carries its CPU time beside its wall
    time."""
    out, report = quick_report
    meta = json.loads((out / "meta.json").read_text())
    session = meta["session"]
    platform = report.read_text().split("## Platform and runs")[1]
    start = "/".join(f"{x:g}" for x in session["load_average_start"])
    end = "/".join(f"{x:g}" for x in session["load_average_end"])
    assert f"Machine: {meta['cpu_model']}, {meta['cpu_count']} cores." in platform
    assert f"quick {start} to {end}." in platform
    runs = pd.read_parquet(out / "runs")
    stepped = runs[runs["n_steps"] > 0]
    assert (stepped["cpu_time_s"] > 0).all()
    per_step = 1e6 * stepped["cpu_time_s"] / stepped["n_steps"]
    assert np.allclose(stepped["cpu_us_per_step"], per_step)


@pytest.mark.slow  # the quick suite, about 10 s once per module; the report drawn again
def test_the_report_says_what_it_is_doing(quick_report, tmp_path, capsys, monkeypatch):
    """A line a step, on stderr from the command line: the folders read, each figure group
    as it is drawn (k of n, every one of them), the tables, the page."""
    from hoopbench.reports.cli import main

    out, _ = quick_report
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)  # the lines are a terminal's
    assert main(["report", "--results", str(out), "--out", str(tmp_path)]) == 0
    lines = capsys.readouterr().err.splitlines()
    monkeypatch.undo()
    assert main(["report", "--results", str(out), "--out", str(tmp_path / "log")]) == 0
    assert not capsys.readouterr().err  # not a terminal: nothing between a script's lines
    assert lines and all(re.fullmatch(r"report: .+; elapsed (\d+m)?\d+s", line) for line in lines)
    assert lines[0].startswith("report: read 1 results folder(s)")
    drawing = re.fullmatch(r"report: drawing (\d+) figure groups in \d process\(es\).*", lines[1])
    assert drawing, lines[1]
    groups = int(drawing[1])
    counted = [re.match(r"report: figures (\d+)/(\d+): (.+);", line) for line in lines[2:]]
    counted = [m for m in counted if m]
    assert [int(m[1]) for m in counted] == list(range(1, groups + 1))
    named = {m[3] for m in counted}
    assert {"contact forces", "seed reproduction", "paths and events of seed-mu"} <= named
    assert any(line.startswith("report: tables:") for line in lines)
    assert any(line.startswith("report: report.html:") for line in lines)


def test_figures_drawn_say_each_group_as_it_ends():
    from hoopbench.reports.report.markdown import _drawn

    said: list[str] = []
    assert _drawn([(pow, (2, k)) for k in range(3)], said.append) == [1, 2, 4]
    assert said[0] == "drawing 3 figure groups in 2 process(es)"
    assert sorted(said[1:]) == ["figures 1/3: pow", "figures 2/3: pow", "figures 3/3: pow"]


@pytest.mark.slow  # the quick suite, about 10 s once per module
def test_the_files_section_links_every_file_the_report_folder_holds(quick_report):
    """Written last, report.html included: every link of the Files section leads to a file,
    and every file of the folder (here the results folder itself) has its link."""
    out, report = quick_report
    files = report.read_text().split("\n## Files\n", 1)[1]
    targets = {m.rstrip("/") for m in re.findall(r"\]\(([^)]+)\)", files)}
    assert all((out / t).exists() for t in targets), targets
    present = {p.name for p in out.iterdir() if not p.name.startswith(".")}
    assert present <= targets
