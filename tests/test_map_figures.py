"""The hop map's figures and report section, on synthetic map frames (no simulation)."""

from __future__ import annotations

import itertools
import re
import shutil
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from hoopbench.engines.judging.verdict import Verdict
from hoopbench.reference.regimes import Regime
from hoopbench.reports.cli import main
from hoopbench.reports.hop_map.spec import MAP_FILE, MapSpec
from hoopbench.reports.hop_map.table import map_frame
from hoopbench.reports.report import map_figures
from hoopbench.reports.report import map_section as map_section_module
from hoopbench.reports.report.map_figures import (
    figure_pixels,
    hop_error_figure,
    hop_ratio_cells,
    map_grid,
    regime_cells,
    regime_figure,
    verdict_cells,
    verdict_figure,
)
from hoopbench.reports.report.map_section import map_findings, map_section, write_map_outputs
from hoopbench.reports.sweep import results

ENGINES = ("mujoco", "pybullet", "pymunk")
_HOPS = (Regime.HOPS, Regime.LIFTS_AT_START)
_NO_ANSWER = (Regime.DEGENERATE, Regime.ERROR)


def synthetic_frame(*args, **kwargs) -> pd.DataFrame:
    """The rows of :func:`synthetic_rows` as a frame."""
    return pd.DataFrame(synthetic_rows(*args, **kwargs))


def synthetic_rows(
    nx: int,
    ny: int,
    engines=ENGINES,
    *,
    xs: np.ndarray | None = None,
    ys: np.ndarray | None = None,
    seed: int = 0,
) -> list[dict]:
    """Map rows over lam x chi (by default lam linear, chi geometric): every regime and
    every verdict appear on a 4x3 grid; hop heights are random over three decades, the
    engines' within a factor 8 of them."""
    rng = np.random.default_rng(seed)
    lams = np.linspace(0.5, 1.0, nx) if xs is None else xs
    chis = (np.geomspace(0.05, 2.0, ny) if ny > 1 else np.array([0.5])) if ys is None else ys
    regimes, verdicts = list(Regime), list(Verdict)
    rows = []
    for ix, lam in enumerate(lams):
        for iy, chi in enumerate(chis):
            regime = regimes[(ix + 3 * iy) % len(regimes)]
            hop = float(10 ** rng.uniform(-3, 0)) if regime in _HOPS else None
            point = {
                "ix": ix,
                "iy": iy,
                "x_axis": "lam",
                "y_axis": "chi",
                "x": lam,
                "y": chi,
                "lam": lam,
                "chi": chi,
                "mu": 0.8,
                "eps": 0.0,
                "theta0_deg": 0.0,
                "t_end": 3.0,
                "regime": str(regime),
                "exact_hop_height": hop,
                "status": "ok",
            }
            rows.append({**point, "run_id": f"reference-{ix}-{iy}", "engine": "reference"})
            for k, engine in enumerate(engines):
                verdict = None
                if regime in _HOPS:  # mostly the hop, so that hop heights can be compared
                    verdict = Verdict.MISSED_HOP if (ix + iy + k) % 3 == 0 else Verdict.AGREES
                elif regime not in _NO_ANSWER:
                    verdict = verdicts[(ix * ny + iy + 3 * k) % len(verdicts)]
                both_hop = hop is not None and verdict in (Verdict.AGREES, Verdict.WRONG_PHASES)
                ratio = 2 ** rng.uniform(-3, 3) if both_hop else None
                rows.append(
                    {
                        **point,
                        "run_id": f"{engine}-{ix}-{iy}",
                        "engine": engine,
                        "timestep": 1e-4,
                        "profile": "tuned",
                        "verdict": None if verdict is None else str(verdict),
                        "outcome_agrees": None
                        if verdict is None
                        else verdict in (Verdict.AGREES, Verdict.WRONG_PHASES),
                        "hop_height": None if ratio is None else hop * ratio,
                        "hop_height_error": None if ratio is None else hop * (ratio - 1.0),
                        "stop_reason": ("impact", "settled", None)[(ix + iy + k) % 3],
                        "n_steps": 1000 * (1 + iy),
                        "sim_time_s": 0.1 * (1 + iy),
                        "wall_time_s": 0.01 * (1 + k),
                    }
                )
    return rows


# --------------------------------------------------------------------------- the cells
@pytest.mark.parametrize(("nx", "ny"), [(4, 3), (1, 5), (5, 1)])
def test_grid_edges_bound_every_centre(nx, ny):
    grid = map_grid(synthetic_frame(nx, ny))
    assert grid.shape == (ny, nx)
    assert len(grid.x_edges) == nx + 1 and len(grid.y_edges) == ny + 1
    assert np.all(grid.x_edges[:-1] < grid.x) and np.all(grid.x < grid.x_edges[1:])
    assert np.all(grid.y_edges[:-1] < grid.y) and np.all(grid.y < grid.y_edges[1:])


def test_a_geometric_axis_is_drawn_in_log_with_geometric_edges():
    grid = map_grid(synthetic_frame(4, 3))
    assert not grid.x_log and grid.y_log  # lam linear, chi geomspace
    np.testing.assert_allclose(grid.x_edges[1:-1], (grid.x[1:] + grid.x[:-1]) / 2)
    np.testing.assert_allclose(grid.y_edges[1:-1], np.sqrt(grid.y[1:] * grid.y[:-1]))


def _expected(frame: pd.DataFrame, engine: str, value) -> dict[tuple[int, int], object]:
    """(iy, ix) -> value(row) for the engine's rows where value is not None, by a plain loop."""
    found = {}
    for _, row in frame[frame["engine"] == engine].iterrows():
        v = value(row)
        if v is not None:
            found[(row["iy"], row["ix"])] = v
    return found


def _drawn(cells: np.ndarray) -> dict[tuple[int, int], float]:
    rows, columns = np.nonzero(np.isfinite(cells))
    return {(int(i), int(j)): cells[i, j] for i, j in zip(rows, columns, strict=True)}


def test_verdict_cells_colour_exactly_the_points_that_differ():
    frame = synthetic_frame(4, 3)
    grid = map_grid(frame)
    order = list(Verdict)
    for engine in ENGINES:
        cells = verdict_cells(frame, engine, grid)
        drawn = _drawn(cells)
        coloured = {k: order[int(v)] for k, v in drawn.items() if order[int(v)] != Verdict.AGREES}
        differs = _expected(
            frame,
            engine,
            lambda r: (
                Verdict(r["verdict"])
                if isinstance(r["verdict"], str) and r["verdict"] != "agrees"
                else None
            ),
        )
        assert coloured == differs
        assert differs  # the frame has disagreements to draw
        agrees = _expected(frame, engine, lambda r: r["verdict"] == "agrees" or None)
        assert {k for k, v in drawn.items() if order[int(v)] == Verdict.AGREES} == set(agrees)
        # Points without an exact answer have no verdict and no colour.
        for _, row in frame[(frame["engine"] == engine) & frame["verdict"].isna()].iterrows():
            assert np.isnan(cells[row["iy"], row["ix"]])


def test_regime_and_hop_ratio_cells_are_the_frames_values():
    frame = synthetic_frame(4, 3)
    grid = map_grid(frame)
    regimes = _drawn(regime_cells(frame, grid))
    assert {k: list(Regime)[int(v)] for k, v in regimes.items()} == _expected(
        frame, "reference", lambda r: Regime(r["regime"])
    )
    for engine in ENGINES:
        ratios = _drawn(hop_ratio_cells(frame, engine, grid))
        expected = _expected(
            frame,
            engine,
            lambda r: (
                r["hop_height"] / r["exact_hop_height"] if pd.notna(r["hop_height_error"]) else None
            ),
        )
        assert set(ratios) == set(expected) and expected
        np.testing.assert_allclose([ratios[k] for k in expected], list(expected.values()))


# --------------------------------------------------------------------------- the files
def _png_size(path) -> tuple[int, int]:
    with Image.open(path) as image:
        assert image.format == "PNG"
        colours = image.convert("RGB").getcolors(maxcolors=1 << 16)
        assert colours is None or len(colours) > 10  # something is drawn
        return image.size


@pytest.mark.parametrize(("nx", "ny"), [(4, 3), (1, 5)])
def test_figures_are_pngs_of_their_size(tmp_path, nx, ny):
    frame = synthetic_frame(nx, ny)
    n = len(ENGINES)
    for draw, name, size in (
        (regime_figure, "regimes.png", figure_pixels(2, legend=True)),
        (verdict_figure, "verdicts.png", figure_pixels(n, legend=True)),
        (hop_error_figure, "hop_error.png", figure_pixels(n)),
    ):
        path = draw(frame, tmp_path / name)
        assert path == tmp_path / name
        assert path.stat().st_size > 0
        assert _png_size(path) == size


def test_the_verdict_figure_draws_the_verdict_cells(tmp_path, monkeypatch):
    frame = synthetic_frame(4, 3)
    drawn = []
    real = map_figures._categorical
    monkeypatch.setattr(
        map_figures,
        "_categorical",
        lambda ax, grid, cells, colours: drawn.append(cells) or real(ax, grid, cells, colours),
    )
    verdict_figure(frame, tmp_path / "v.png")
    grid = map_grid(frame)
    assert len(drawn) == len(ENGINES)
    for cells, engine in zip(drawn, ENGINES, strict=True):
        np.testing.assert_array_equal(cells, verdict_cells(frame, engine, grid))


def test_every_verdict_and_regime_has_its_own_colour():
    """Read from the enums, so that a new verdict or regime cannot be left without a colour
    (issue 24 added close, early-impact, late-impact, cone-violation and creeps; creeps
    first came without one)."""
    assert set(map_figures.VERDICT_COLOURS) == set(Verdict)
    assert len(set(map_figures.VERDICT_COLOURS.values())) == len(Verdict)
    assert set(map_figures.REGIME_COLOURS) == set(Regime)
    assert len(set(map_figures.REGIME_COLOURS.values())) == len(Regime)


def _lab(colour: str) -> np.ndarray:
    """CIELAB (D65) of an sRGB hex colour."""
    rgb = np.array([int(colour[i : i + 2], 16) / 255 for i in (1, 3, 5)])
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    to_xyz = np.array(
        [[0.4124564, 0.3575761, 0.1804375],
         [0.2126729, 0.7151522, 0.0721750],
         [0.0193339, 0.1191920, 0.9503041]]
    )  # fmt: skip
    xyz = to_xyz @ linear / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def delta_e(one: str, other: str) -> float:
    """CIE76 colour difference: about 2.3 is just noticeable, 10 and more reads as another
    colour at a glance."""
    return float(np.linalg.norm(_lab(one) - _lab(other)))


def test_the_verdict_colours_are_told_apart():
    """Issue 35: hop-too-low's brown (#8C510A, delta E 32 from it, 8 from late-lift-off) read
    as the regime "hops" vermillion, which the page's key lists beside it. Every two verdicts
    at delta E 15 or more (the two greys of agrees and close: 14, on purpose), hop-too-low 50
    or more from hops."""
    assert delta_e(map_figures.VERDICT_COLOURS[Verdict.HOP_TOO_LOW],
                   map_figures.REGIME_COLOURS[Regime.HOPS]) >= 50  # fmt: skip
    greys = {Verdict.AGREES, Verdict.CLOSE}
    for one, other in itertools.combinations(Verdict, 2):
        if {one, other} == greys:
            continue
        distance = delta_e(map_figures.VERDICT_COLOURS[one], map_figures.VERDICT_COLOURS[other])
        assert distance >= 15, (one, other, distance)


def test_each_verdict_cell_is_drawn_in_its_verdicts_colour(tmp_path, monkeypatch):
    """The cells hold indices into Verdict: the colour list drawn must follow Verdict's
    order, whatever the order of VERDICT_COLOURS."""
    frame = synthetic_frame(4, 3)
    lists = []
    real = map_figures._categorical
    monkeypatch.setattr(
        map_figures,
        "_categorical",
        lambda ax, grid, cells, colours: lists.append(colours) or real(ax, grid, cells, colours),
    )
    shuffled = dict(reversed(map_figures.VERDICT_COLOURS.items()))
    monkeypatch.setattr(map_figures, "VERDICT_COLOURS", shuffled)
    verdict_figure(frame, tmp_path / "v.png")
    assert lists
    for colours in lists:
        assert colours == [shuffled[v] for v in Verdict]


def test_a_frame_without_engines_has_no_verdict_figure(tmp_path):
    frame = synthetic_frame(2, 2, engines=())
    assert regime_figure(frame, tmp_path / "r.png").stat().st_size > 0
    with pytest.raises(ValueError, match="no engine rows"):
        verdict_figure(frame, tmp_path / "v.png")


# --------------------------------------------------------------------------- the report
@pytest.fixture(scope="module")
def map_dir(tmp_path_factory) -> Path:
    """A map folder as `hoopbench map` leaves it (map.toml, runs/), from synthetic rows
    written with the results writer."""
    out = tmp_path_factory.mktemp("map")
    spec = MapSpec(nx=4, ny=3, engines=ENGINES)
    (out / MAP_FILE).write_text(spec.to_toml(), encoding="utf-8")
    rows = synthetic_rows(
        spec.nx, spec.ny, spec.engines, xs=spec.axis_values(spec.x), ys=spec.axis_values(spec.y)
    )
    writer = results.RunsWriter(out / results.RUNS_NAME)
    for row in rows:
        writer.add(row)
    writer.flush()
    return out


def _fractions(text: str) -> list[tuple[int, int]]:
    return [(int(a), int(b)) for a, b in re.findall(r"(\d+)/(\d+)", text)]


def _counts_by_hand(frame: pd.DataFrame) -> dict[str, dict[str, int]]:
    """Per engine: judged points, outcome agreements, verdict agreements (a plain loop)."""
    counts = {e: {"judged": 0, "outcome": 0, "agrees": 0} for e in ENGINES}
    for _, row in frame[frame["engine"] != "reference"].iterrows():
        if isinstance(row["verdict"], str):
            c = counts[row["engine"]]
            c["judged"] += 1
            c["outcome"] += row["outcome_agrees"] == True  # noqa: E712
            c["agrees"] += row["verdict"] == "agrees"
    return counts


def _sentence(findings: list[str], start: str) -> str:
    found = [s for s in findings if s.startswith(start)]
    assert len(found) == 1, (start, findings)
    return found[0]


def test_map_findings_carry_the_frames_numbers(map_dir):
    frame = map_frame(map_dir)
    findings = map_findings(frame)
    refs = frame[frame["engine"] == "reference"]
    regimes = _sentence(findings, "The exact reference classifies")
    for regime, n in Counter(refs["regime"]).items():
        assert f" {n} {regime} (" in regimes
    counts = _counts_by_hand(frame)
    key = {e: (c["outcome"] / c["judged"], c["agrees"] / c["judged"]) for e, c in counts.items()}
    best = max(ENGINES, key=key.__getitem__)
    worst = min(reversed(ENGINES), key=key.__getitem__)
    top = [e for e in ENGINES if key[e] == key[best]]  # ties are said as ties
    bottom = [e for e in ENGINES if key[e] == key[worst]]
    names = {1: "{}", 2: "{} and {}", 3: "{}, {} and {}"}
    if len(top) == len(ENGINES):
        ranking = _sentence(findings, names[len(top)].format(*top) + " agree with the reference")
        assert "alike" in ranking and "least" not in ranking
        tied = (best,)
    else:
        verb = "agrees" if len(top) == 1 else "agree"
        ranking = _sentence(findings, f"{names[len(top)].format(*top)} {verb} most")
        assert f"; {names[len(bottom)].format(*bottom)} least" in ranking
        tied = (best, worst)
    expected = []
    for engine in tied:
        c = counts[engine]
        expected += [(c["outcome"], c["judged"]), (c["agrees"], c["judged"])]
    assert _fractions(ranking) == expected
    for engine in ENGINES:
        mine = frame[frame["engine"] == engine]
        both = mine[mine["hop_height_error"].notna()]
        ratio = both["hop_height"] / both["exact_hop_height"]
        within = int(((ratio - 1.0).abs() <= 0.05).sum())  # the loose tolerance, 5 %
        if both.empty:
            assert not any(s.startswith(f"Where both hop, {engine}'s") for s in findings)
        else:
            hops = _sentence(findings, f"Where both hop, {engine}'s")
            assert _fractions(hops) == [(within, len(both))]
            assert f"median ratio {ratio.median():.3g}" in hops
        # The regime with the largest share of verdicts other than agrees.
        judged = mine[mine["verdict"].notna()]
        shares = {
            r: ((g["verdict"] != "agrees").sum(), len(g)) for r, g in judged.groupby("regime")
        }
        top = max(w / n for w, n in shares.values())
        worst_regimes = {r: wn for r, wn in shares.items() if wn[0] / wn[1] == top}
        text = _sentence(findings, f"{engine} disagrees most in regime")
        regime = text.removeprefix(f"{engine} disagrees most in regime ").split(":")[0]
        assert regime in worst_regimes
        assert _fractions(text) == [tuple(int(v) for v in worst_regimes[regime])]


def test_the_map_section_has_the_tables_and_figures(map_dir, tmp_path):
    text = map_section(map_dir, tmp_path)
    assert text.startswith("## Hop map: lam x chi")
    for figure in re.findall(r"\]\((map_\w+\.png)\)", text):
        assert (tmp_path / figure).stat().st_size > 0
    assert len(re.findall(r"\]\((map_\w+\.png)\)", text)) == 3
    counts = _counts_by_hand(map_frame(map_dir))
    outcome_all, verdict_all = re.findall(r"^\| all \|.*$", text, flags=re.MULTILINE)
    assert _fractions(outcome_all) == [(counts[e]["outcome"], counts[e]["judged"]) for e in ENGINES]
    assert _fractions(verdict_all) == [(counts[e]["agrees"], counts[e]["judged"]) for e in ENGINES]
    assert "4 x 3 grid" in text and "dt = 0.0001 s" in text


def test_write_map_outputs_writes_the_figures_and_map_md(map_dir):
    paths = write_map_outputs(map_dir)
    assert paths[-1] == map_dir / "map.md"
    assert [p.name for p in paths[:-1]] == [
        "map_regimes.png",
        "map_verdicts.png",
        "map_hop_error.png",
    ]
    text = paths[-1].read_text()
    assert text.startswith("# Hop map") and "## Agreement with the exact reference" in text


class _Recording(ThreadPoolExecutor):
    """One thread that draws each call submitted to it, and names it (report-runs lends the
    report's drawing processes; a thread stands in for them here)."""

    def __init__(self) -> None:
        super().__init__(max_workers=1)
        self.drawn: list[str] = []

    def submit(self, fn, /, *args, **kwargs):  # type: ignore[override]
        self.drawn.append(fn.__name__)
        return super().submit(fn, *args, **kwargs)


def test_write_map_outputs_draws_the_same_figures_where_it_is_told(map_dir, tmp_path):
    """Given the report's drawing processes (report-runs --report), the map's figures are
    drawn there, the same bytes as drawn here, map.md written once they are."""
    here, there = tmp_path / "a" / "map", tmp_path / "b" / "map"  # map.md names its folder
    for folder in (here, there):
        shutil.copytree(map_dir, folder, ignore=shutil.ignore_patterns("*.png", "map.md"))
    drawn_here = write_map_outputs(here)
    with _Recording() as processes:
        drawn_there = write_map_outputs(there, processes)
    assert processes.drawn == ["regime_figure", "verdict_figure", "hop_error_figure"]
    assert [p.name for p in drawn_there] == [p.name for p in drawn_here]
    for a, b in zip(drawn_here, drawn_there, strict=True):
        assert a.read_bytes() == b.read_bytes(), a.name


def test_write_map_outputs_starts_the_figures_before_the_text(map_dir, tmp_path, monkeypatch):
    """report-runs --report: the map's figures are submitted to the drawing processes before
    the section's text is made (drawn while it is made, not after), and the agreement table
    and the frame's CSV (the figures' keys) are made once, not once a use."""
    folder = tmp_path / "map"  # no figures drawn yet
    shutil.copytree(map_dir, folder, ignore=shutil.ignore_patterns("*.png", "map.md"))
    made: Counter[str] = Counter()
    drawn_by_then: list[list[str]] = []
    findings, table, to_csv = (
        map_section_module.map_findings,
        map_section_module.agreement_table,
        pd.DataFrame.to_csv,
    )

    def counted(name, function):
        def call(*args, **kwargs):
            made[name] += 1
            return function(*args, **kwargs)

        return call

    def findings_seen(*args, **kwargs):
        drawn_by_then.append(list(processes.drawn))
        return findings(*args, **kwargs)

    monkeypatch.setattr(map_section_module, "map_findings", findings_seen)
    monkeypatch.setattr(map_section_module, "agreement_table", counted("table", table))
    monkeypatch.setattr(pd.DataFrame, "to_csv", counted("csv", to_csv))
    with _Recording() as processes:
        write_map_outputs(folder, processes)
    assert drawn_by_then == [["regime_figure", "verdict_figure", "hop_error_figure"]]
    assert made == {"table": 1, "csv": 1}


def test_report_of_a_map_folder(map_dir, tmp_path, capsys):
    out = tmp_path / "report"
    assert main(["report", "--results", str(map_dir), "--out", str(out)]) == 0
    text = (out / "report.md").read_text()
    assert text.startswith("# hoopbench report")
    assert "## Hop map: lam x chi" in text and "### Findings" in text
    for figure in ("map_regimes.png", "map_verdicts.png", "map_hop_error.png"):
        assert f"]({figure})" in text and (out / figure).stat().st_size > 0
    # Two map folders in one report: a section each, figures apart (one folder named twice
    # is refused: tests/test_bad_inputs.py).
    both, other = tmp_path / "both", shutil.copytree(map_dir, tmp_path / "other")
    assert main(["report", "--results", str(map_dir), str(other), "--out", str(both)]) == 0
    text = (both / "report.md").read_text()
    assert text.count("## Hop map:") == 2
    assert "](map1_regimes.png)" in text and "](map2_regimes.png)" in text


def _agreement(*lines: tuple[str, int, int, int]) -> pd.DataFrame:
    """An agreement table's overall rows: (engine, judged, outcome agreements, agreements)."""
    from hoopbench.reports.hop_map.table import ALL_REGIMES

    return pd.DataFrame(
        [
            {"engine": e, "regime": ALL_REGIMES, "judged": n, "outcome_agrees": o,
             "agrees": a, "outcome_agrees_pct": 100 * o / n, "agrees_pct": 100 * a / n}
            for e, n, o, a in lines
        ]
    )  # fmt: skip


def test_engines_that_agree_alike_are_a_tie_not_a_ranking():
    """All at 100 %: no 'agrees most' beside 'least' with the same numbers."""
    from hoopbench.reports.report.map_section import _ranking_sentence

    text = _ranking_sentence(_agreement(("mujoco", 4, 4, 4), ("pymunk", 4, 4, 4)))
    assert text.startswith("mujoco and pymunk agree with the reference alike: each the outcome")
    assert "most" not in text and "least" not in text
    text = _ranking_sentence(
        _agreement(("mujoco", 4, 4, 4), ("drake", 4, 4, 4), ("pymunk", 4, 2, 1))
    )
    assert text.startswith("mujoco and drake agree most with the reference")
    assert "; pymunk least: the outcome on 2/4" in text


def test_engines_at_their_own_step_are_named_with_it(tmp_path):
    """A map whose engines run at different steps (the batched engines' own, 1e-3 s) says
    each engine's step in its text and in its panels' titles; one step for all: no label."""
    spec = MapSpec(nx=2, ny=2, engines=("mujoco", "mjx", "newton"))
    assert map_section_module._engines_text(spec) == (
        "mujoco at dt = 0.0001 s; mjx, newton at dt = 0.001 s (their own step)"
    )
    same = MapSpec(nx=2, ny=2, engines=("mujoco", "mjx"), engine_timesteps={})
    assert map_section_module._engines_text(same) == "mujoco, mjx at dt = 0.0001 s"
    frame = synthetic_frame(2, 2, ("mujoco", "mjx"))
    engines = frame["engine"] != "reference"
    frame.loc[engines, "timestep"] = np.where(frame.loc[engines, "engine"] == "mjx", 1e-3, 1e-4)
    assert map_figures._engine_label(frame, "mjx") == "mjx (dt 0.001 s)"
    assert map_figures._engine_label(frame, "mujoco") == "mujoco (dt 0.0001 s)"
    frame.loc[engines, "timestep"] = 1e-4
    assert map_figures._engine_label(frame, "mjx") == "mjx"


def test_a_report_copies_the_maps_own_figures_of_the_same_data(tmp_path):
    """`hoopbench map` draws its figures, and the report's are the same pictures of the same
    rows: copied, not drawn again; rows that changed since (a resumed map) are drawn anew,
    and so is a figure whose file lost its key. Cost: about 2 s (three figures drawn twice)."""
    from hoopbench.reports.report.map_section import write_map_figures

    frame = synthetic_frame(4, 3)
    drawn: list[str] = []

    def draw(function, *args):
        drawn.append(Path(args[1]).name)
        return function(*args)

    own, report = tmp_path / "map", tmp_path / "report"
    names = ["map_regimes.png", "map_verdicts.png", "map_hop_error.png"]
    assert [p.name for p in write_map_figures(frame, own, draw=draw)] == names
    assert drawn == names
    drawn.clear()
    paths = write_map_figures(frame, report, draw=draw, drawn_in=own)
    assert drawn == [] and [p.read_bytes() for p in paths] == [
        (own / n).read_bytes() for n in names
    ]
    write_map_figures(frame, report, draw=draw, drawn_in=own)
    assert drawn == []  # already there, of the same data
    changed = frame.copy()
    changed.loc[changed.index[-1], "verdict"] = str(Verdict.FALSE_HOP)
    write_map_figures(changed, report, draw=draw, drawn_in=own)
    assert drawn == names
    drawn.clear()
    with Image.open(own / names[0]) as image:
        image.save(own / names[0])  # the pixels alone, no key
    (report / names[0]).unlink()
    write_map_figures(frame, report, draw=draw, drawn_in=own)
    assert drawn == [names[0]]


def test_a_figure_key_is_the_same_for_the_same_map_run_again():
    """What a run cost and when it finished differ between two runs of one map and no figure
    draws them: the keys (and so the PNGs' bytes) are the same; a drawn value is not."""
    from hoopbench.reports.report.map_section import UNDRAWN_COLUMNS, figure_keys

    frame = synthetic_frame(4, 3)
    names = ["map_regimes.png", "map_verdicts.png"]
    again = frame.copy()
    for column in UNDRAWN_COLUMNS:
        again[column] = np.arange(len(again), dtype=float) + 0.5
    assert figure_keys(again, names) == figure_keys(frame, names)
    changed = frame.copy()
    changed.loc[changed.index[-1], "verdict"] = str(Verdict.FALSE_HOP)
    assert figure_keys(changed, names)[names[1]] != figure_keys(frame, names)[names[1]]


def test_every_text_of_the_hop_error_figure_lies_within_it(tmp_path, monkeypatch):
    """The colour bar's label was clipped at the figure's edge (its one line was longer than
    the bar): every title and axis label, the bar's included, lies within the figure."""
    figures = []
    real = map_figures._save
    monkeypatch.setattr(
        map_figures, "_save", lambda fig, path, key: figures.append(fig) or real(fig, path, key)
    )
    hop_error_figure(synthetic_frame(10, 10), tmp_path / "hop_error.png")
    (fig,) = figures
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    fig.set_dpi(map_figures.DPI)  # as saved
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    inside = fig.bbox
    # Titles and axis labels (tick labels outside an axis's limits are never drawn).
    named = [t for ax in fig.axes for t in (ax.title, ax.xaxis.label, ax.yaxis.label)]
    texts = [t for t in named if isinstance(t, Text) and t.get_visible() and t.get_text()]
    assert any("exact hop height" in t.get_text() for t in texts)
    for text in texts:
        box = text.get_window_extent(renderer)
        assert inside.x0 - 0.5 <= box.x0 and box.x1 <= inside.x1 + 0.5, text.get_text()
        assert inside.y0 - 0.5 <= box.y0 and box.y1 <= inside.y1 + 0.5, text.get_text()
