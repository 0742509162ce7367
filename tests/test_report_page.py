"""report.html, opened from file:// in a real headless Chromium (Debian's chromium and its
chromedriver, driven by Selenium; nothing is downloaded): no console errors, the hop map's
cells, hover and click, the hoop's animation, the tables' sorting and filtering, and a scene
name that is a script shown as text.

The page is built once from a small real results folder: the quick suite with its
trajectories, a two-timestep "stability" suite on a scene named like a script, and a 3x2 map.
Screenshots go to the fixture's temporary folder.
"""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import numpy as np
import pytest

from hoopbench.models.catalogue import get_scene
from hoopbench.models.trajectory import COLUMNS, Trajectory
from hoopbench.reports.compare.suite import compare
from hoopbench.reports.compare.suite_file import builtin_suite
from hoopbench.reports.hop_map.display import DISPLAY_SAMPLES, read_display, thinned
from hoopbench.reports.hop_map.spec import MapSpec
from hoopbench.reports.hop_map.stages import run_map
from hoopbench.reports.hop_map.table import map_frame
from hoopbench.reports.report.build import build_report, report_frame
from hoopbench.reports.report.hoop_gif import GIF_FRAMES, hoop_gif
from hoopbench.reports.report.page import PAGE_NAME
from hoopbench.reports.report.page_animation import animation_figure, hoop_motions
from hoopbench.reports.report.page_html import script_json

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
"""Debian's packages (chromium, chromium-driver): .ci/run installs them."""

SCRIPT_NAME = "</script><script>alert(1)</script>"
"""A scene name from anyone: the page must show it, never run it."""

MAP = MapSpec(nx=3, ny=2, engines=("mujoco", "pymunk"), timestep=1e-3, t_end=1.0)
WAIT_S = 20.0
"""How long a browser step may take before the test says it did not happen (no timing is
measured: this bounds a wait on a loaded machine)."""


@pytest.fixture(scope="module")
def page(tmp_path_factory) -> Path:
    """report.html of the quick suite, a stability suite of one script-named scene, a map."""
    root = tmp_path_factory.mktemp("page")
    quick = root / "quick"
    assert compare(
        builtin_suite("quick"), quick, jobs=2, quiet=True, trajectories="default"
    ).completed
    stiff = root / "stability.toml"
    stiff.write_text(
        'name = "stability"\nengines = ["reference", "pymunk"]\ntimesteps = [1e-3, 1e-4]\n'
        f'[[scene]]\nname = "{SCRIPT_NAME}"\nlam = 0.9\nchi = 0.1\nmus = 0.8\nt_end = 0.5\n'
    )
    assert compare(stiff, root / "stability", jobs=2, quiet=True).completed
    run_map(MAP, root / "map", jobs=2, quiet=True)
    build_report([quick, root / "stability", root / "map"], root / "report")
    return root / "report" / PAGE_NAME


@pytest.fixture(scope="module")
def browser(page):
    if not (CHROMIUM.is_file() and CHROMEDRIVER.is_file()):
        pytest.skip(f"no {CHROMIUM} and {CHROMEDRIVER}: apt-get install chromium chromium-driver")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1400,1000"):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=options)
    driver.get(page.as_uri())
    driver.execute_async_script("const done = arguments[0]; hoopDrawAll().then(() => done());")
    yield driver
    driver.quit()


def _until(condition, what: str):
    """Wait for ``condition()`` to be truthy (at most WAIT_S); its value."""
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"not within {WAIT_S:g} s: {what}")


def _shot(driver, page: Path, name: str) -> None:
    driver.save_screenshot(str(page.parent / f"screenshot_{name}.png"))


def _show(driver, element_id: str):
    element = driver.find_element("id", element_id)
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'});", element)
    return element


# --------------------------------------------------------------------------- without a browser
def test_embedded_data_cannot_close_its_script():
    data = {"scene": SCRIPT_NAME, "note": "<!-- & -->"}
    encoded = script_json(data)
    assert "<" not in encoded and ">" not in encoded
    assert json.loads(encoded) == data


def test_the_map_keeps_a_thinned_copy_of_each_run(page):
    folder = page.parent.parent / "map"
    frame = map_frame(folder)
    for run_id in frame[frame["status"] == "ok"]["run_id"]:  # a degenerate point is not run
        trajectory = read_display(folder, run_id)
        assert trajectory is not None, run_id
        assert 2 <= len(trajectory) <= DISPLAY_SAMPLES
    engine = frame[frame["engine"] == "pymunk"].iloc[0]
    stored = read_display(folder, engine["run_id"])
    assert stored is not None
    # the run stops at its first impact or after settling: its copy spans what it simulated
    assert stored.t[-1] == pytest.approx(engine["sim_time_s"], abs=2 * MAP.timestep)


def test_a_display_file_keeps_only_what_the_page_draws(page):
    """A 40x40 map's display/ took 267 MB when each file held the whole thinned trajectory
    in double precision; it keeps the four drawn curves in single precision now."""
    import pyarrow.parquet as pq

    from hoopbench.reports.hop_map.display import DISPLAY_COLUMNS, display_path

    folder = page.parent.parent / "map"
    run_id = map_frame(folder).query("engine == 'pymunk'").iloc[0]["run_id"]
    schema = pq.read_schema(display_path(folder, run_id))
    assert schema.names == list(DISPLAY_COLUMNS)
    assert all(str(schema.field(name).type) == "float" for name in DISPLAY_COLUMNS)
    assert display_path(folder, run_id).stat().st_size < 12_000


def test_thinning_keeps_the_ends():
    n = 1001
    columns = {c: np.linspace(0.0, 1.0, n) for c in COLUMNS}
    columns["contact"] = np.ones(n, dtype=bool)
    kept = thinned(Trajectory(**columns), 50)
    assert len(kept) == 50 and kept.t[0] == 0.0 and kept.t[-1] == 1.0


def test_a_large_map_embeds_fewer_samples_per_run():
    """A 40x40 map of three engines (6,400 runs) would embed 400 samples of every run, about
    75 MB; the page's budget keeps the total bounded and never below a readable curve."""
    from hoopbench.reports.report.page_map import MIN_RUN_SAMPLES, PAGE_SAMPLES, run_samples

    assert run_samples(6 * 6 * 4) == DISPLAY_SAMPLES  # a small map keeps every stored sample
    assert run_samples(40 * 40 * 4) * 40 * 40 * 4 <= PAGE_SAMPLES
    assert run_samples(10**7) == MIN_RUN_SAMPLES


def test_the_page_shows_the_script_named_scene_as_text(page):
    html = page.read_text(encoding="utf-8")
    assert SCRIPT_NAME not in html
    assert "&lt;/script&gt;&lt;script&gt;alert(1)&lt;/script&gt;" in html


# --------------------------------------------------------------------------- in Chromium
def test_no_errors_in_the_console(browser, page):
    _shot(browser, page, "top")
    severe = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert not severe, severe
    drawn = browser.execute_script(
        "return [...document.querySelectorAll('.hoop-figure')].map(d => d.dataset.drawn)"
    )
    assert drawn and all(d == "1" for d in drawn)


def test_no_script_from_a_scene_name_runs(browser):
    from selenium.common.exceptions import NoAlertPresentException

    with pytest.raises(NoAlertPresentException):
        browser.switch_to.alert.text  # noqa: B018 - reading it is what raises
    assert SCRIPT_NAME in browser.find_element("tag name", "body").text


def test_the_map_has_a_cell_per_grid_point(browser):
    keys = browser.execute_script(
        "return document.getElementById('map-0').data[0].customdata.flat().filter(k => k)"
    )
    assert sorted(keys) == sorted(f"{ix},{iy}" for ix in range(MAP.nx) for iy in range(MAP.ny))
    z = browser.execute_script("return document.getElementById('map-0').data[0].z")
    assert len(z) == MAP.ny and all(len(row) == MAP.nx for row in z)


def _cell_offset(driver, ix: int, iy: int) -> tuple[int, int]:
    """The offset of a map cell's centre from the figure's centre, px (Selenium's origin)."""
    return tuple(
        driver.execute_script(
            """const gd = document.getElementById('map-0'), L = gd._fullLayout;
            const t = gd.data[0], r = gd.getBoundingClientRect();
            const x = L.xaxis._offset + L.xaxis.c2p(t.x[arguments[0]]);
            const y = L.yaxis._offset + L.yaxis.c2p(t.y[arguments[1]]);
            return [Math.round(x - r.width / 2), Math.round(y - r.height / 2)];""",
            ix,
            iy,
        )
    )


def _pymunk_row(page: Path, ix: int, iy: int):
    frame = map_frame(page.parent.parent / "map")
    hit = frame[(frame["engine"] == "pymunk") & (frame["ix"] == ix) & (frame["iy"] == iy)]
    return hit.iloc[0]


@pytest.mark.parametrize("cell", [(0, 1), (1, 0)])
def test_hovering_a_cell_shows_its_verdict(browser, page, cell):
    from selenium.webdriver.common.action_chains import ActionChains

    figure = _show(browser, "map-0")
    dx, dy = _cell_offset(browser, *cell)
    ActionChains(browser).move_to_element_with_offset(figure, dx, dy).perform()
    hover = _until(
        lambda: browser.execute_script(
            "const h = document.querySelector('#map-0 .hoverlayer .hovertext');"
            "return h ? h.textContent : '';"
        ),
        "a hover label on the map",
    )
    _shot(browser, page, f"map_hover_{cell[0]}_{cell[1]}")
    row = _pymunk_row(page, *cell)
    assert f"pymunk: {row['verdict']}" in hover
    assert f"chi {row['chi']:.4g}" in hover


def test_clicking_a_cell_shows_its_runs(browser, page):
    from selenium.webdriver.common.action_chains import ActionChains

    figure = _show(browser, "map-0")
    dx, dy = _cell_offset(browser, 1, 1)
    ActionChains(browser).move_to_element_with_offset(figure, dx, dy).click().perform()
    key = _until(
        lambda: browser.execute_script("return document.getElementById('map-0-runs').dataset.key"),
        "the clicked cell's runs drawn",
    )
    assert key == "1,1"
    names = browser.execute_script(
        "return document.getElementById('map-0-runs').data.map(t => t.name)"
    )
    # three panels (clearance, slip velocity, n/g) for each engine and the exact solution
    assert sorted(set(names)) == ["exact", "mujoco", "pymunk"] and len(names) == 9
    _show(browser, "map-0-runs")
    _shot(browser, page, "map_click")


def _hoop_x(driver, figure_id: str) -> list[float]:
    """The first panel's hoop outline as drawn now (its first moving trace)."""
    return driver.execute_script(
        "const gd = document.getElementById(arguments[0]);"
        "return gd.data.find(t => t.mode === 'lines' && t.line && t.line.width === 2).x;",
        figure_id,
    )


def test_the_animation_advances_when_played(browser, page):
    figure = _show(browser, "motion-0")
    before = _hoop_x(browser, "motion-0")
    play = figure.find_element("xpath", ".//*[contains(@class,'updatemenu-button')][1]")
    play.click()
    _until(lambda: _hoop_x(browser, "motion-0") != before, "the hoop moves")
    _until(
        lambda: browser.execute_script(
            "return document.getElementById('motion-0')._fullLayout.sliders[0].active > 0"
        ),
        "the time slider moves",
    )
    _shot(browser, page, "animation")


def _column(driver, table, index: int) -> list[str]:
    return [
        row.find_elements("tag name", "td")[index].text
        for row in table.find_elements("css selector", "tbody tr")
        if row.is_displayed()
    ]


def test_the_tables_sort_and_filter(browser, page):
    from selenium.webdriver.support.ui import Select

    heading = browser.find_element("xpath", "//h3[text()='seed-mu']")
    table = heading.find_element("xpath", "following-sibling::table[1]")
    headers = [th.text for th in table.find_elements("css selector", "thead th")]
    engine = headers.index("engine")
    th = table.find_elements("css selector", "thead th")[engine]
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'});", th)
    th.click()
    assert th.get_attribute("aria-sort") == "ascending"
    values = _column(browser, table, engine)
    assert values == sorted(values) and len(set(values)) > 1
    th.click()
    assert _column(browser, table, engine) == sorted(values, reverse=True)
    bar = table.find_element("xpath", "preceding-sibling::div[@class='tablebar'][1]")
    Select(bar.find_element("tag name", "select")).select_by_value("pymunk")
    assert set(_column(browser, table, engine)) == {"pymunk"}
    _shot(browser, page, "table")


def test_the_readme_animation_is_a_small_gif(page, tmp_path):
    from PIL import Image

    runs = report_frame(page.parent.parent / "quick")
    scene = "hop-bottom"  # the quick suite's hop: the README's hop-top is drawn the same way
    trajectories = {
        row["engine"]: Trajectory.read(row["trajectory_file"])
        for _, row in runs[runs["scene"] == scene].iterrows()
    }
    motions = hoop_motions(get_scene(scene), trajectories, runs[runs["scene"] == scene])
    assert motions[0].name == "exact" and len(motions) == len(trajectories)
    path = hoop_gif(get_scene(scene), motions, tmp_path / "hop.gif")
    with Image.open(path) as image:
        assert image.format == "GIF" and image.n_frames == GIF_FRAMES
    assert path.stat().st_size < 2e6


def _figure_data(fragment: str, figure_id: str) -> dict:
    found = re.search(
        rf'<script type="application/json" id="{figure_id}-data">(.*?)</script>', fragment, re.S
    )
    assert found
    return json.loads(found[1])


def test_the_map_has_a_key_for_every_colour_it_draws(page):
    """The cells carry no colour scale: the legend names each regime and verdict present."""
    from hoopbench.reports.report.page_map import map_fragment

    folder = page.parent.parent / "map"
    frame = map_frame(folder)
    figure = _figure_data(map_fragment(folder, "m"), "m")
    names = {trace.get("name") for trace in figure["data"][1:]}
    regimes = set(frame[frame["engine"] == "reference"]["regime"].dropna())
    verdicts = set(frame[frame["engine"] != "reference"]["verdict"].dropna())
    assert regimes and verdicts
    assert regimes | verdicts | {"no verdict"} == names
    assert figure["data"][0]["showscale"] is False


def test_the_map_cells_read_from_their_columns_as_from_the_whole_table(page, monkeypatch):
    """page_map._cells groups the columns a cell reads (_CELL_COLUMNS), not the table's
    hundred: its hovers, keys and runs are those of the whole table's groups."""
    from hoopbench.reports.report import page_map

    folder = page.parent.parent / "map"
    frame = map_frame(folder)
    grid = page_map.map_grid(frame)
    assert len(frame.columns) > len(page_map._CELL_COLUMNS)
    read = page_map._cells(frame, grid, folder)
    monkeypatch.setattr(page_map, "_CELL_COLUMNS", tuple(frame.columns))
    assert script_json(read) == script_json(page_map._cells(frame, grid, folder))


def test_the_animation_is_a_grid_with_its_controls_on_top_and_says_when_a_run_ended(page):
    from hoopbench.reports.report.page_animation import GRID_COLUMNS

    runs = report_frame(page.parent.parent / "quick")
    rows = runs[runs["scene"] == "hop-bottom"]
    trajectories = {r["engine"]: Trajectory.read(r["trajectory_file"]) for _, r in rows.iterrows()}
    motions = hoop_motions(get_scene("hop-bottom"), trajectories, rows)
    figure = animation_figure(get_scene("hop-bottom"), motions)
    layout = figure["layout"]
    assert layout["sliders"][0]["y"] >= 1 and layout["updatemenus"][0]["y"] >= 1
    columns = {tuple(layout[f"xaxis{k + 1 if k else ''}"]["domain"]) for k in range(len(motions))}
    assert len(columns) == min(GRID_COLUMNS, len(motions)) > 1
    exact_end = float(motions[0].t[-1])
    labels = [frame["data"][4]["text"][0] for frame in figure["frames"]]  # the exact panel's
    times = [float(frame["name"]) for frame in figure["frames"]]
    ended = [t > exact_end + 1e-3 for t in times]  # frame names are rounded to 1 ms
    assert ["ended" in label for label in labels] == ended
    assert any("ended" in label for label in labels)  # the engines run past the exact impact
