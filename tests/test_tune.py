"""hoopbench tune: a small search end to end (2-3 trials, one short scene, pymunk), its
resume, its settings file in compare and simulate, and its bad inputs."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pandas as pd
import pytest

import hoopbench as hb
from hoopbench.engines.options import Profile
from hoopbench.engines.registry import engine_class
from hoopbench.models.scene import Scene
from hoopbench.reports.cli import main
from hoopbench.reports.compare.settings_file import load_settings
from hoopbench.reports.compare.suite import runs_frame
from hoopbench.reports.tune.heldout import is_overfitted
from hoopbench.reports.tune.search import JOURNAL_NAME, STUDY_NAME, TRIALS_DIR
from hoopbench.reports.tune.tiers import cheapest_by_tier

optuna = pytest.importorskip("optuna")

pytestmark = pytest.mark.slow

ENGINE = "pymunk"


def _scene() -> Scene:
    return hb.scene("hop-bottom", t_end=1.2)


def _study(out: Path) -> optuna.Study:
    backend = optuna.storages.journal.JournalFileBackend(str(out / JOURNAL_NAME))
    return optuna.load_study(study_name=STUDY_NAME, storage=optuna.storages.JournalStorage(backend))


@pytest.fixture(scope="module")
def searched(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, pd.DataFrame]:
    out = tmp_path_factory.mktemp("tune") / "pymunk"
    front = hb.tune(ENGINE, out, scenes=[_scene()], trials=2, quiet=True)
    return out, front


def test_every_trial_is_rows_and_the_first_is_tuned(searched: tuple[Path, pd.DataFrame]) -> None:
    out, _ = searched
    rows = runs_frame(out / TRIALS_DIR)
    variants = sorted(rows["variant"])
    assert variants == ["default", "default", "trial-0", "trial-1"]
    assert set(rows.loc[rows["variant"] == "default", "profile"]) == {"stock", "tuned"}
    assert (rows["status"] == "ok").all()
    first = rows[rows["variant"] == "trial-0"].iloc[0]
    assert first["timestep"] == pytest.approx(1e-4)
    assert json.loads(first["options"]) == {}  # hoopbench's tuned values, nothing changed
    trials = _study(out).trials
    assert [t.state.name for t in trials] == ["COMPLETE", "COMPLETE"]


def test_the_front_has_the_pareto_set_stock_and_tuned(searched: tuple[Path, pd.DataFrame]) -> None:
    out, front = searched
    assert set(front["kind"]) == {"pareto", "baseline"}
    assert {"stock", "tuned"} <= set(front["setting"])
    pareto = front[front["kind"] == "pareto"]
    assert len(pareto) >= 1
    assert pareto["heldout_error"].notna().all()
    assert (out / "front.csv").is_file()
    held = runs_frame(out / "heldout")
    scenes = sorted(set(held["scene"]))
    assert [s for s in scenes if s.startswith("heldout-random-")] == scenes[1:]
    assert scenes[0] == "heldout-near-hop-bottom-1"  # the training scene's neighbour
    assert len(held) == 5 * len(front)  # four regimes and a neighbour, every setting


def test_the_settings_file_is_what_compare_and_simulate_run(
    searched: tuple[Path, pd.DataFrame], tmp_path: Path
) -> None:
    out, front = searched
    loaded = load_settings(out / "settings.toml")
    assert loaded.engine == ENGINE
    assert loaded.engine_version == engine_class(ENGINE)().version()
    assert loaded.provenance["training_scenes"] == ["hop-bottom"]
    assert [s.name for s in loaded.settings] == list(
        front.loc[front["kind"] == "pareto", "setting"]
    )
    suite = tmp_path / "tiny.toml"
    suite.write_text(
        'name = "tiny"\nengines = ["pymunk"]\ntimesteps = [1e-3]\nscenes = ["seed-mu"]\n'
    )
    runs = tmp_path / "runs"
    args = ["compare", "--suite", str(suite), "--out", str(runs), "--quiet"]
    assert main([*args, "--settings", str(out / "settings.toml")]) == 0
    rows = runs_frame(runs)
    first = loaded.settings[0]
    mine = rows[rows["variant"] == first.name].iloc[0]
    assert mine["timestep"] == pytest.approx(first.timestep)
    assert mine["status"] == "ok"
    run = hb.run(ENGINE, "seed-mu", settings=out / "settings.toml")
    assert run.row["variant"] == first.name
    assert run.row["timestep"] == pytest.approx(first.timestep)


def test_each_setting_is_labelled_with_the_tier_every_one_of_its_runs_reaches(
    searched: tuple[Path, pd.DataFrame],
) -> None:
    out, front = searched
    expected = {"agrees": {"agrees"}, "close": {"agrees", "close"}}
    for folder, column in ((TRIALS_DIR, "train_tier"), ("heldout", "heldout_tier")):
        rows = runs_frame(out / folder)
        for line in front[front["kind"] == "pareto"].to_dict("records"):
            verdicts = set(rows.loc[rows["variant"] == line["setting"], "verdict"])
            assert verdicts, (folder, line["setting"])
            within = [t for t, admitted in expected.items() if verdicts <= admitted]
            assert line[column] == (within[0] if within else "none"), (folder, line, verdicts)
    loaded = load_settings(out / "settings.toml")
    assert set(loaded.tiers) == {"agrees", "close"}
    chosen = cheapest_by_tier(front)
    assert loaded.tiers == {t: None if c is None else c.setting for t, c in chosen.items()}
    assert loaded.tier_scenes == {
        t: (c.scenes_within, c.scenes) for t, c in chosen.items() if c is not None
    }
    for setting in loaded.settings:
        line = front[front["setting"] == setting.name].iloc[0]
        assert setting.measured["train_tier"] == line["train_tier"]
        assert setting.measured["heldout_tier"] == line["heldout_tier"]


def test_each_setting_counts_its_scenes_within_each_tier(
    searched: tuple[Path, pd.DataFrame],
) -> None:
    out, front = searched
    rows = pd.concat([runs_frame(out / TRIALS_DIR), runs_frame(out / "heldout")])
    for line in front[front["kind"] == "pareto"].to_dict("records"):
        verdicts = list(rows.loc[rows["variant"] == line["setting"], "verdict"])
        assert line["n_scenes"] == len(verdicts) > 0, line
        assert line["agrees_scenes"] == verdicts.count("agrees"), line
        assert line["close_scenes"] == sum(v in ("agrees", "close") for v in verdicts), line


def _tier_file(out: Path, tmp_path: Path, close: str) -> Path:
    """The search's settings file with its [tiers] saying ``close`` for the loose tier."""
    text = (out / "settings.toml").read_text()
    start = text.index("[tiers]")
    end = text.index("[[settings]]")
    edited = tmp_path / "edited.toml"
    edited.write_text(f'{text[:start]}[tiers]\nclose = "{close}"\n\n{text[end:]}')
    return edited


def test_file_hash_close_runs_the_cheapest_close_setting_and_says_when_there_is_none(
    searched: tuple[Path, pd.DataFrame], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out, front = searched
    last = str(front.loc[front["kind"] == "pareto", "setting"].iloc[-1])
    named = _tier_file(out, tmp_path, last)
    run = hb.run(ENGINE, "seed-mu", settings=f"{named}#close")
    assert run.row["variant"] == last
    none = _tier_file(out, tmp_path, "none")
    args = ["simulate", "--engine", ENGINE, "--scene", "seed-mu", "--settings"]
    assert main([*args, f"{none}#close"]) == 2
    assert main([*args, f"{none}#agrees"]) == 2  # the edited file names no tight setting
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 2, lines
    assert "no setting of the settings file is within the tier 'close'" in lines[0]
    assert "names no setting for the tier 'agrees'" in lines[1]


def test_a_results_folder_resumes_only_with_its_own_settings_file(
    searched: tuple[Path, pd.DataFrame], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out, front = searched
    suite = tmp_path / "tiny.toml"
    suite.write_text(
        'name = "tiny"\nengines = ["pymunk"]\ntimesteps = [1e-3]\nscenes = ["seed-mu"]\n'
    )
    mine = tmp_path / "mine.toml"
    mine.write_bytes((out / "settings.toml").read_bytes())
    other = tmp_path / "other.toml"
    other.write_text(mine.read_text().replace("heldout_seed =", "# edited\nheldout_seed ="))
    runs = tmp_path / "runs"
    args = ["compare", "--suite", str(suite), "--out", str(runs), "--quiet"]
    last = str(front.loc[front["kind"] == "pareto", "setting"].iloc[-1])
    assert main([*args, "--settings", f"{mine}#{last}"]) == 0
    assert set(runs_frame(runs)["variant"]) == {"default", last}  # the one setting named
    capsys.readouterr()
    for refused in ([], ["--settings", str(other)], ["--settings", str(mine)]):
        assert main([*args, "--resume", *refused]) == 2, refused
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "resume it with the same --settings" in err, err
    copy = tmp_path / "copy.toml"  # the same content under another name is the same file
    copy.write_bytes(mine.read_bytes())
    assert main([*args, "--resume", "--settings", f"{copy}#{last}"]) == 0
    meta = json.loads((runs / "meta.json").read_text())  # the file the folder was made with
    assert meta["settings_file"] == f"mine.toml#{last}"
    assert meta["settings_sha256"] == load_settings(mine).sha256


def _per_simulated_s(rows: pd.DataFrame, column: str) -> float:
    """us of ``column`` (a time, s) per simulated second of the rows."""
    return 1e6 * rows[column].sum() / (rows["n_steps"] * rows["timestep"]).sum()


def test_a_trial_s_cost_is_the_cpu_time_of_its_runs_per_simulated_second(
    searched: tuple[Path, pd.DataFrame],
) -> None:
    """The objective's cost is the runs' CPU time; the wall time's is kept beside it, in
    trials.csv, front.csv and the settings file, and tune.json says which clock."""
    out, front = searched
    assert json.loads((out / "tune.json").read_text())["cost_clock"] == "cpu"
    rows = runs_frame(out / TRIALS_DIR)
    trials = pd.read_csv(out / "trials.csv").set_index("trial")
    for trial in _study(out).trials:
        mine = rows[rows["variant"] == f"trial-{trial.number}"]
        cpu, wall = _per_simulated_s(mine, "cpu_time_s"), _per_simulated_s(mine, "wall_time_s")
        assert trial.values[1] == pytest.approx(cpu, rel=1e-9)
        assert trials.loc[trial.number, "train_cost_us_per_s"] == pytest.approx(cpu, rel=1e-9)
        assert trials.loc[trial.number, "train_wall_us_per_s"] == pytest.approx(wall, rel=1e-9)
        assert cpu != pytest.approx(wall, rel=1e-9)  # two clocks, not one number twice
    held = runs_frame(out / "heldout")
    for line in front.to_dict("records"):
        variant = "default" if line["kind"] == "baseline" else line["setting"]
        mine = held[held["variant"] == variant]
        if line["kind"] == "baseline":
            mine = mine[mine["profile"] == line["setting"]]
        assert line["heldout_cost_us_per_s"] == pytest.approx(_per_simulated_s(mine, "cpu_time_s"))
        assert line["heldout_wall_us_per_s"] == pytest.approx(_per_simulated_s(mine, "wall_time_s"))
    loaded = load_settings(out / "settings.toml")
    assert loaded.provenance["cost_clock"] == "cpu"
    first = loaded.settings[0]
    line = front[front["setting"] == first.name].iloc[0]
    assert first.measured["wall_us_per_s"] == pytest.approx(line["train_wall_us_per_s"])


def test_a_search_made_before_the_clock_was_recorded_resumes_by_wall_time(
    tmp_path: Path,
) -> None:
    """A search whose tune.json has no cost_clock (every shipped one) was scored by wall time:
    a resume scores its new trials, its baselines and its held-out runs by wall time too, and
    leaves tune.json without the key. (The older search is made here by removing the key
    after a first session; that session's trial 0 keeps its CPU cost and is not checked.)"""
    out = tmp_path / "older"
    hb.tune(ENGINE, out, scenes=[_scene()], trials=1, quiet=True)
    spec = json.loads((out / "tune.json").read_text())
    del spec["cost_clock"]
    (out / "tune.json").write_text(json.dumps(spec, indent=2) + "\n")
    front = hb.tune(ENGINE, out, scenes=[_scene()], trials=2, resume=True, quiet=True)
    assert "cost_clock" not in json.loads((out / "tune.json").read_text())
    rows = runs_frame(out / TRIALS_DIR)
    new = _study(out).trials[1]
    mine = rows[rows["variant"] == f"trial-{new.number}"]
    assert new.values[1] == pytest.approx(_per_simulated_s(mine, "wall_time_s"), rel=1e-9)
    assert new.values[1] != pytest.approx(_per_simulated_s(mine, "cpu_time_s"), rel=1e-9)
    baselines = front[front["kind"] == "baseline"]
    assert (baselines["train_cost_us_per_s"] == baselines["train_wall_us_per_s"]).all()
    assert (front["heldout_cost_us_per_s"] == front["heldout_wall_us_per_s"]).all()
    assert load_settings(out / "settings.toml").provenance["cost_clock"] == "wall"


def test_a_search_goes_on_after_an_interruption(tmp_path: Path) -> None:
    out = tmp_path / "search"
    hb.tune(ENGINE, out, scenes=[_scene()], trials=2, quiet=True)
    stale = _study(out).ask()  # a trial a Ctrl-C left running: failed on resume, not counted
    hb.tune(ENGINE, out, scenes=[_scene()], trials=3, resume=True, quiet=True)
    trials = _study(out).trials
    states = [t.state.name for t in trials]
    assert states[stale.number] == "FAIL"
    assert states.count("COMPLETE") == 3
    rows = runs_frame(out / TRIALS_DIR)
    assert sorted(v for v in rows["variant"] if v != "default") == ["trial-0", "trial-1", "trial-3"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--engine", "nosuch", "--trials", "2"], "--engine"),
        (["--engine", "pymunk"], "a search needs a budget: --trials"),
        (["--engine", "pymunk", "--trials", "0"], "--trials"),
        (["--engine", "pymunk", "--trials", "2", "--scenes", "nosuch"], "--scenes"),
        (["--engine", "pymunk", "--trials", "2", "--heldout-seed", "0"], "--heldout-seed"),
        (["--engine", "pymunk", "--trials", "2", "--seed", "-1"], "--seed"),
        (["--engine", "pymunk", "--trials", "2", "--seed", str(2**32)], "--seed"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    args: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["tune", "--out", str(tmp_path / "x"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert not (tmp_path / "x").exists()


def test_a_folder_of_another_search_is_refused(
    searched: tuple[Path, pd.DataFrame], capsys: pytest.CaptureFixture[str]
) -> None:
    out, _ = searched
    assert main(["tune", "--engine", "pymunk", "--out", str(out), "--trials", "3"]) == 2
    assert main(["tune", "--engine", "mujoco", "--out", str(out), "--trials", "3", "--resume"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 2, lines


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace("iterations =", "iteratons ="), "unknown pymunk setting"),
        (lambda t: t.replace('engine = "pymunk"', 'engine = "mujoco"'), "unknown mujoco setting"),
        (lambda t: "foo = 1\n" + t, "unknown key"),
        # Its tables too: a front of several settings with options stays TOML, one key
        # unknown, whatever the search found (a front of two made it "not TOML").
        (
            lambda t: t.replace("[[settings]]", "[[setting]]").replace("[settings.", "[setting."),
            "unknown key",
        ),
    ],
)
def test_a_bad_settings_file_is_one_line_and_exit_2(
    searched: tuple[Path, pd.DataFrame],
    edit: object,
    message: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out, _ = searched
    bad = tmp_path / "bad.toml"
    bad.write_text(edit((out / "settings.toml").read_text()))  # type: ignore[operator]
    code = main(["simulate", "--engine", "pymunk", "--scene", "seed-mu", "--settings", str(bad)])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err


def test_simulate_refuses_a_settings_file_of_another_engine(
    searched: tuple[Path, pd.DataFrame], capsys: pytest.CaptureFixture[str]
) -> None:
    out, _ = searched
    path = str(out / "settings.toml")
    assert main(["simulate", "--engine", "mujoco", "--scene", "seed-mu", "--settings", path]) == 2
    assert "is for pymunk, not mujoco" in capsys.readouterr().err


def test_overfitted_means_much_worse_on_held_out_scenes() -> None:
    assert not is_overfitted(0.1, 0.6)
    assert is_overfitted(0.1, 0.8)
    assert is_overfitted(0.0, 0.6)
    assert not is_overfitted(None, 10.0)


def test_stock_and_tuned_profiles_exist() -> None:
    assert {str(p) for p in Profile} == {"stock", "tuned"}


def test_the_report_has_a_best_settings_section(
    searched: tuple[Path, pd.DataFrame], tmp_path: Path
) -> None:
    out, front = searched
    report = hb.report([out], tmp_path / "report")
    text = report.read_text()
    section = text[text.index("## Best settings") :]
    assert "### pymunk" in section
    for name in front["setting"]:
        assert f"| {name} |" in section
    assert "Held-out error of tuned" in section
    assert (tmp_path / "report" / "best-settings-pymunk.png").is_file()


CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
"""Debian's packages, as tests/test_report_page.py drives them (.ci/run installs both)."""

COMPACT_FILES = ("tune.json", "front.csv", "trials.csv", "settings.toml")
"""What a shipped search keeps (the Makefile's SEARCH_FILES): no runs, no journal."""


def _compact(out: Path, folder: Path) -> Path:
    folder.mkdir(parents=True)
    for name in COMPACT_FILES:
        (folder / name).write_bytes((out / name).read_bytes())
    return folder


def test_the_section_reads_a_compact_search_and_the_page_shows_it(
    searched: tuple[Path, pd.DataFrame], tmp_path: Path
) -> None:
    out, front = searched
    compact = _compact(out, tmp_path / "searches" / "pymunk")
    report = hb.report([compact], tmp_path / "report")
    text = report.read_text()
    section = text[text.index("## Best settings") :]
    loaded = load_settings(compact / "settings.toml")
    line = next(s for s in section.splitlines() if s.startswith("The cheapest setting"))
    for tier, name in loaded.tiers.items():
        assert f"{tier}: {name or 'none'}" in line, line
        if name is not None:
            within, scenes = loaded.tier_scenes[tier]
            assert f"{within}/{scenes} scenes" in line, line
    for row in front.to_dict("records"):
        assert f"| {row['train_tier']} | {row['heldout_tier']} |" in section
    page = (tmp_path / "report" / "report.html").read_text()
    body = page[page.index('id="section-1">Best settings') :]
    assert "Held-out error of tuned" in body and "The cheapest setting" in body
    for name in front["setting"]:
        assert f"<td>{name}</td>" in body
    # the figure is the interactive one, its points named by setting, not the PNG
    assert 'id="best-settings-0"' in body and "data:image/png" not in body
    data = body[body.index('id="best-settings-0-data">') :]
    data = json.loads(data[data.index(">") + 1 : data.index("</script>")])
    named = {point[0] for trace in data["data"] for point in trace.get("customdata", [])}
    assert set(front["setting"]) <= named
    settings = [
        p for trace in data["data"] for p in trace.get("customdata", []) if isinstance(p, list)
    ]
    counts = {p[0]: p[11] for p in settings}  # a trial's customdata is its number alone
    for row in front.to_dict("records"):
        scenes = row["n_scenes"]
        said = f"agrees {row['agrees_scenes']}/{scenes}, close {row['close_scenes']}/{scenes}"
        assert counts[row["setting"]] == said, counts


def test_hovering_a_point_of_the_front_names_its_setting(
    searched: tuple[Path, pd.DataFrame], tmp_path: Path
) -> None:
    """In headless Chromium (Debian's, as tests/test_report_page.py drives it): the page's
    front draws without a console error, and tuned's held-out point names it and its tier."""
    from selenium.webdriver.common.action_chains import ActionChains

    if not (CHROMIUM.is_file() and CHROMEDRIVER.is_file()):
        pytest.skip(f"no {CHROMIUM} and {CHROMEDRIVER}: apt-get install chromium chromium-driver")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    out, front = searched
    hb.report([_compact(out, tmp_path / "pymunk")], tmp_path / "report")
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1400,1000"):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=options)
    try:
        driver.get((tmp_path / "report" / "report.html").as_uri())
        driver.execute_async_script("const done = arguments[0]; hoopDrawAll().then(() => done());")
        figure = driver.find_element("id", "best-settings-0")
        driver.execute_script("arguments[0].scrollIntoView({block: 'center'});", figure)
        dx, dy = driver.execute_script(
            """const gd = document.getElementById('best-settings-0'), L = gd._fullLayout;
            const t = gd.data.find(d => d.name === 'tuned' && d.xaxis === 'x2');
            const r = gd.getBoundingClientRect();
            const x = L.xaxis2._offset + L.xaxis2.c2p(t.x[0]);
            const y = L.yaxis2._offset + L.yaxis2.c2p(t.y[0]);
            return [Math.round(x - r.width / 2), Math.round(y - r.height / 2)];"""
        )
        ActionChains(driver).move_to_element_with_offset(figure, dx, dy).perform()
        script = (
            "const h = document.querySelector('#best-settings-0 .hoverlayer .hovertext');"
            "return h ? h.textContent : '';"
        )
        hover = ""
        for _ in range(100):  # at most 10 s on a loaded machine
            hover = driver.execute_script(script)
            if hover:
                break
            time.sleep(0.1)
        driver.save_screenshot(str(tmp_path / "best_settings_hover.png"))
        severe = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
    finally:
        driver.quit()
    assert not severe, severe
    tuned = front[front["setting"] == "tuned"].iloc[0]
    assert "tuned (baseline)" in hover, hover
    assert f"tier {tuned['heldout_tier']}" in hover, hover


def test_make_report_passes_every_shipped_search(
    searched: tuple[Path, pd.DataFrame], tmp_path: Path
) -> None:
    import subprocess

    out, _ = searched
    shipped = tmp_path / "searches"
    for engine in ("pymunk", "mujoco"):  # two engines' compact searches (one search copied)
        _compact(out, shipped / engine)
    (shipped / "empty").mkdir()  # not a search: left out
    root = Path(__file__).resolve().parent.parent
    command = ["make", "-n", "report", f"SEARCHES={shipped}", f"OUT={tmp_path / 'out'}"]
    dry = subprocess.run(command, cwd=root, capture_output=True, text=True, check=True)
    line = dry.stdout.replace("\\\n", " ")
    # make report's report is written by report-runs itself (--report and the searches).
    report = next(s for s in line.splitlines() if "hoopbench report-runs" in s)
    searches = " ".join(report.split()).split(" --report ", 1)[1]
    assert searches.startswith(f"{shipped / 'mujoco'} {shipped / 'pymunk'} ")
    assert str(shipped / "empty") not in report


def test_the_front_figure_labels_its_log_axis_in_plain_numbers(
    searched: tuple[Path, pd.DataFrame], tmp_path: Path
) -> None:
    from hoopbench.reports.report.best_settings import _panel, best_settings
    from hoopbench.reports.report.plotting import pyplot

    out, _ = searched
    (best,) = best_settings([out])
    plt = pyplot()
    fig, ax = plt.subplots()
    _panel(ax, best, "heldout")
    fig.canvas.draw()
    labels = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
    plt.close(fig)
    assert labels and not any("$" in label for label in labels), labels


def test_ctrl_c_keeps_every_finished_trial(tmp_path: Path) -> None:
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "search"
    command = [sys.executable, "-m", "hoopbench.reports.cli", "tune", "--engine", ENGINE]
    command += ["--out", str(out), "--scenes", "hop-bottom", "--trials", "500", "--jobs", "1"]
    process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            time.sleep(0.5)
            if (out / JOURNAL_NAME).exists() and sum(
                t.state.name == "COMPLETE" for t in _study(out).trials
            ) >= 2:
                break
        process.send_signal(signal.SIGINT)
        # A signal lets the runs in flight finish (the runner's clean stop): a drawn trial may
        # be a fine timestep with many iterations, tens of seconds on a loaded machine (it
        # took over 60 s once in CI while a report ran beside it). Its time limit bounds it.
        _, err = process.communicate(timeout=300)
    finally:
        process.kill()
    assert process.returncode == 130, err
    assert err.strip().splitlines()[-1].startswith("hoopbench: interrupted"), err
    done = [t.number for t in _study(out).trials if t.state.name == "COMPLETE"]
    assert len(done) >= 2
    assert not (out / "settings.toml").exists()  # the search did not end: no front yet
    trials = len(done) + 1
    again = ["tune", "--engine", ENGINE, "--out", str(out), "--scenes", "hop-bottom"]
    again += ["--trials", str(trials), "--jobs", "1", "--resume", "--quiet"]
    code = main(again)
    assert code == 0
    after = _study(out).trials
    assert [t.number for t in after if t.state.name == "COMPLETE"][: len(done)] == done
    assert sum(t.state.name == "COMPLETE" for t in after) == trials
    assert (out / "settings.toml").is_file()


@pytest.mark.parametrize("name", ["tune.json", "front.csv", "trials.csv"])
def test_a_tune_folder_file_leading_out_of_it_is_not_read(
    searched: tuple[Path, pd.DataFrame],
    name: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A tune folder is read as any results folder is (folder_files): a file that is a link
    to one outside the folder is refused in one line, never read as the folder's."""
    import shutil

    out, _ = searched
    copy = tmp_path / "search"
    shutil.copytree(out, copy)
    outside = tmp_path / f"elsewhere-{name}"
    shutil.move(copy / name, outside)
    (copy / name).symlink_to(outside)
    code = main(["report", "--results", str(copy), "--out", str(tmp_path / "report")])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "leads out of the results folder" in err, err


def test_a_settings_file_that_is_a_fifo_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import os

    fifo = tmp_path / "settings.toml"
    os.mkfifo(fifo)  # read as a file it would never end
    code = main(["simulate", "--engine", ENGINE, "--scene", "seed-mu", "--settings", str(fifo)])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "FIFO" in err, err
