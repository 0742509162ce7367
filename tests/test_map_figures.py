"""The hop map's figures and report section, on synthetic map frames (no simulation)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from hoopbench.reference.regimes import Regime
from hoopbench.reports import map_figures
from hoopbench.reports.map_figures import (
    figure_pixels,
    hop_error_figure,
    hop_ratio_cells,
    map_grid,
    regime_cells,
    regime_figure,
    verdict_cells,
    verdict_figure,
)
from hoopbench.reports.verdict import Verdict

ENGINES = ("mujoco", "pybullet", "pymunk")
_HOPS = (Regime.HOPS, Regime.LIFTS_AT_START)
_NO_ANSWER = (Regime.DEGENERATE, Regime.ERROR)


def synthetic_frame(nx: int, ny: int, engines=ENGINES, *, seed: int = 0) -> pd.DataFrame:
    """A map frame over lam x chi: every regime and every verdict appear on a 4x3 grid; the
    hop heights are random over three decades, the engines' within a factor 8."""
    rng = np.random.default_rng(seed)
    lams = np.linspace(0.5, 1.0, nx)
    chis = np.geomspace(0.05, 2.0, ny) if ny > 1 else np.array([0.5])
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
                    }
                )
    return pd.DataFrame(rows)


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


def test_a_frame_without_engines_has_no_verdict_figure(tmp_path):
    frame = synthetic_frame(2, 2, engines=())
    assert regime_figure(frame, tmp_path / "r.png").stat().st_size > 0
    with pytest.raises(ValueError, match="no engine rows"):
        verdict_figure(frame, tmp_path / "v.png")
