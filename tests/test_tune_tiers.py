"""A search's settings labelled by accuracy tier (reports/tune/tiers.py) and a settings
file's [tiers] (``--settings FILE#close``), without running a search: a front table and a
settings file written by hand."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hoopbench.engines.judging.columns import Col
from hoopbench.reports.compare.settings_file import (
    SettingsFileError,
    TunedSetting,
    load_choice,
    load_settings,
    pick_setting,
    settings_identity,
    settings_mismatch,
    settings_text,
)
from hoopbench.reports.tune.tiers import NO_TIER, cheapest_by_tier, tier_columns

ENGINE = "pymunk"


def _front(*lines: tuple[str, str, float, str, str]) -> pd.DataFrame:
    return pd.DataFrame(
        [
            {
                "setting": name,
                "kind": kind,
                "train_cost_us_per_s": cost,
                "train_tier": train,
                "heldout_tier": heldout,
            }
            for name, kind, cost, train, heldout in lines
        ]
    )


def test_the_cheapest_of_a_tier_reaches_it_on_training_and_held_out_scenes() -> None:
    front = _front(
        ("trial-1", "pareto", 100.0, "agrees", "agrees"),
        ("trial-2", "pareto", 10.0, "agrees", "close"),  # cheaper, but only close held out
        ("trial-3", "pareto", 5.0, "agrees", NO_TIER),  # overfitted: within no tier held out
        ("tuned", "baseline", 1.0, "agrees", "agrees"),  # a baseline is no setting of the file
    )
    assert cheapest_by_tier(front) == {"agrees": "trial-1", "close": "trial-2"}


def test_a_tier_no_setting_reaches_is_none() -> None:
    front = _front(("trial-1", "pareto", 1.0, "close", "close"))
    assert cheapest_by_tier(front) == {"agrees": None, "close": "trial-1"}
    old = front.drop(columns=["train_tier", "heldout_tier"])  # a front.csv from before
    assert cheapest_by_tier(old) == {"agrees": None, "close": None}


def test_a_settings_tier_is_what_every_one_of_its_runs_reaches() -> None:
    agrees, close, late = ({Col.VERDICT: v} for v in ("agrees", "close", "late-slip"))
    assert tier_columns([agrees, agrees], [agrees, close]) == {
        "train_tier": "agrees",
        "heldout_tier": "close",
    }
    assert tier_columns([agrees, late], []) == {"train_tier": NO_TIER, "heldout_tier": NO_TIER}


def _file(tmp_path: Path, tiers: dict[str, str | None] | None) -> Path:
    settings = [
        TunedSetting("trial-4", 2e-4, {"iterations": 20}, measured={"cost_us_per_s": 9.0}),
        TunedSetting("trial-7", 1e-4, {"iterations": 80}, measured={"cost_us_per_s": 30.0}),
    ]
    path = tmp_path / "settings.toml"
    path.write_text(settings_text(ENGINE, None, {"seed": 0}, settings, tiers))
    return path


def test_file_hash_close_picks_the_setting_its_tiers_name(tmp_path: Path) -> None:
    path = _file(tmp_path, {"agrees": "trial-7", "close": "trial-4"})
    loaded = load_settings(path)
    assert loaded.tiers == {"agrees": "trial-7", "close": "trial-4"}
    assert pick_setting(loaded, "close").name == "trial-4"
    assert pick_setting(loaded, "agrees").name == "trial-7"
    assert load_choice(f"{path}#close") == (loaded, "close")


def test_a_tier_no_setting_reaches_is_said_when_asked_for(tmp_path: Path) -> None:
    loaded = load_settings(_file(tmp_path, {"agrees": None, "close": "trial-4"}))
    assert 'agrees = "none"' in (tmp_path / "settings.toml").read_text()
    with pytest.raises(SettingsFileError, match="no setting of the settings file reaches"):
        pick_setting(loaded, "agrees")


def test_a_file_from_before_the_tiers_still_reads(tmp_path: Path) -> None:
    loaded = load_settings(_file(tmp_path, None))
    assert loaded.tiers == {}
    assert pick_setting(loaded, "trial-7").timestep == 1e-4
    with pytest.raises(SettingsFileError, match="names no setting for the tier 'close'"):
        pick_setting(loaded, "close")


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace('close = "trial-4"', 'close = "trial-9"'), "tiers.close must name"),
        (lambda t: t.replace('close = "trial-4"', 'loose = "trial-4"'), "unknown tier"),
        (lambda t: t.replace('name = "trial-4"', 'name = "close"'), "other than"),
    ],
)
def test_a_bad_tiers_table_is_refused(tmp_path: Path, edit: object, message: str) -> None:
    path = _file(tmp_path, {"agrees": "trial-7", "close": "trial-4"})
    path.write_text(edit(path.read_text()))  # type: ignore[operator]
    with pytest.raises(SettingsFileError, match=message):
        load_settings(path)


def test_a_folders_settings_identity_is_the_files_content_and_choice(tmp_path: Path) -> None:
    path = _file(tmp_path, {"agrees": "trial-7", "close": "trial-4"})
    loaded = load_settings(path)
    copy = tmp_path / "renamed.toml"
    copy.write_bytes(path.read_bytes())
    made = settings_identity(loaded)
    assert settings_mismatch(made, settings_identity(load_settings(copy))) is None
    assert "without --settings" in str(settings_mismatch(made, settings_identity(None)))
    assert "#close" in str(settings_mismatch(made, settings_identity(loaded, "close")))
    path.write_text(path.read_text().replace("iterations = 80", "iterations = 81"))
    assert settings_mismatch(made, settings_identity(load_settings(path))) is not None
    assert settings_mismatch({"kind": "suite"}, made) is None  # a folder from before says nothing
