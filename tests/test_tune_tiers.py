"""A search's settings labelled by accuracy tier (reports/tune/tiers.py) and a settings
file's [tiers] (``--settings FILE#close``), without running a search: a front table and a
settings file written by hand."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pytest

from hoopbench.engines.judging.columns import Col
from hoopbench.reports.cli import main
from hoopbench.reports.compare.settings_file import (
    SettingsFileError,
    TierChoice,
    TunedSetting,
    load_choice,
    load_settings,
    pick_setting,
    settings_identity,
    settings_mismatch,
    settings_text,
    tier_note,
)
from hoopbench.reports.tune.tiers import NO_TIER, cheapest_by_tier, count_columns, tier_columns

ENGINE = "pymunk"


def _front(*lines: tuple[str, str, float, int, int]) -> pd.DataFrame:
    """A front table: (setting, kind, training cost, scenes within agrees, within close),
    every setting on 22 scenes."""
    return pd.DataFrame(
        [
            {
                "setting": name,
                "kind": kind,
                "train_cost_us_per_s": cost,
                "agrees_scenes": agrees,
                "close_scenes": close,
                "n_scenes": 22,
            }
            for name, kind, cost, agrees, close in lines
        ]
    )


def _names(chosen: dict[str, TierChoice | None]) -> dict[str, str | None]:
    return {tier: None if c is None else c.setting for tier, c in chosen.items()}


def test_the_cheapest_of_a_tier_is_the_cheapest_within_it_on_the_most_scenes() -> None:
    front = _front(
        ("trial-1", "pareto", 100.0, 4, 13),
        ("trial-2", "pareto", 10.0, 4, 13),  # as many scenes, cheaper
        ("trial-3", "pareto", 5.0, 3, 12),  # cheaper still, one scene fewer
        ("trial-4", "pareto", math.nan, 9, 9),  # most agree, its cost not measured
        ("tuned", "baseline", 1.0, 22, 22),  # a baseline is no setting of the file
    )
    chosen = cheapest_by_tier(front)
    assert _names(chosen) == {"agrees": "trial-4", "close": "trial-2"}
    assert chosen["close"] == TierChoice("trial-2", 13, 22)


def test_a_setting_within_a_tier_on_every_scene_is_named_however_costly() -> None:
    front = _front(("trial-1", "pareto", 1e6, 22, 22), ("trial-2", "pareto", 1.0, 21, 21))
    assert _names(cheapest_by_tier(front)) == {"agrees": "trial-1", "close": "trial-1"}


def test_a_tier_no_setting_has_a_scene_within_is_none() -> None:
    front = _front(("trial-1", "pareto", 1.0, 0, 3))
    assert _names(cheapest_by_tier(front)) == {"agrees": None, "close": "trial-1"}
    old = front.drop(columns=["agrees_scenes", "close_scenes", "n_scenes"])  # from before
    assert cheapest_by_tier(old) == {"agrees": None, "close": None}


def test_a_settings_scene_counts_are_its_runs_within_each_tier() -> None:
    agrees, close, late = ({Col.VERDICT: v} for v in ("agrees", "close", "late-slip"))
    failed = {Col.VERDICT: None}
    assert count_columns([agrees, late, close], [close, agrees, failed]) == {
        "agrees_scenes": 2,
        "close_scenes": 4,
        "n_scenes": 6,
    }


def test_a_settings_tier_is_what_every_one_of_its_runs_reaches() -> None:
    agrees, close, late = ({Col.VERDICT: v} for v in ("agrees", "close", "late-slip"))
    assert tier_columns([agrees, agrees], [agrees, close]) == {
        "train_tier": "agrees",
        "heldout_tier": "close",
    }
    assert tier_columns([agrees, late], []) == {"train_tier": NO_TIER, "heldout_tier": NO_TIER}


def _settings() -> list[TunedSetting]:
    return [
        TunedSetting("trial-4", 2e-4, {"iterations": 20}, measured={"cost_us_per_s": 9.0}),
        TunedSetting("trial-7", 1e-4, {"iterations": 80}, measured={"cost_us_per_s": 30.0}),
    ]


def _file(tmp_path: Path, tiers: dict[str, TierChoice | None] | None) -> Path:
    path = tmp_path / "settings.toml"
    path.write_text(settings_text(ENGINE, None, {"seed": 0}, _settings(), tiers))
    return path


_TIERS = {"agrees": TierChoice("trial-7", 3, 22), "close": TierChoice("trial-4", 13, 22)}


def test_file_hash_close_picks_the_setting_its_tiers_name(tmp_path: Path) -> None:
    path = _file(tmp_path, _TIERS)
    assert 'close_scenes = "13/22"' in path.read_text()
    loaded = load_settings(path)
    assert loaded.tiers == {"agrees": "trial-7", "close": "trial-4"}
    assert loaded.tier_scenes == {"agrees": (3, 22), "close": (13, 22)}
    assert pick_setting(loaded, "close").name == "trial-4"
    assert pick_setting(loaded, "agrees").name == "trial-7"
    assert load_choice(f"{path}#close") == (loaded, "close")


def test_file_hash_close_picks_the_most_scenes_then_the_cheapest_of_a_front(
    tmp_path: Path,
) -> None:
    front = _front(
        ("trial-7", "pareto", 30.0, 0, 13),
        ("trial-4", "pareto", 9.0, 0, 12),  # cheaper, within close on a scene fewer
    )
    path = _file(tmp_path, cheapest_by_tier(front))
    assert 'agrees = "none"' in path.read_text()
    loaded = load_settings(path)
    assert pick_setting(loaded, "close").name == "trial-7"
    assert loaded.tier_scenes == {"close": (13, 22)}
    with pytest.raises(SettingsFileError, match="on any training or held-out scene"):
        pick_setting(loaded, "agrees")


def test_a_file_from_before_the_counts_still_reads(tmp_path: Path) -> None:
    path = _file(tmp_path, _TIERS)
    old = [line for line in path.read_text().splitlines() if "_scenes =" not in line]
    path.write_text("\n".join(old).replace('agrees = "trial-7"', 'agrees = "none"') + "\n")
    loaded = load_settings(path)
    assert loaded.tiers == {"agrees": None, "close": "trial-4"}
    assert loaded.tier_scenes == {}
    assert pick_setting(loaded, "close").name == "trial-4"
    with pytest.raises(SettingsFileError, match="on every training and held-out scene"):
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
        (lambda t: t.replace('"13/22"', '"23/22"'), "close_scenes must be 'k/n'"),
        (lambda t: t.replace('"13/22"', '"13/0"'), "close_scenes must be 'k/n'"),
        (lambda t: t.replace('"13/22"', '"-1/22"'), "close_scenes must be 'k/n'"),
        (lambda t: t.replace('"13/22"', "13"), "close_scenes must be 'k/n'"),
        (lambda t: t.replace('"13/22"', '"0/22"'), "close_scenes counts the scenes"),
        (lambda t: t.replace('close = "trial-4"', 'close = "none"'), "close_scenes counts"),
        (lambda t: t.replace('"13/22"', '"13/22"\nclose_scenes = "1/2"'), "not TOML"),
    ],
)
def test_a_bad_tiers_table_is_refused(tmp_path: Path, edit: object, message: str) -> None:
    path = _file(tmp_path, _TIERS)
    path.write_text(edit(path.read_text()))  # type: ignore[operator]
    with pytest.raises(SettingsFileError, match=message):
        load_settings(path)


def test_a_folders_settings_identity_is_the_files_content_and_choice(tmp_path: Path) -> None:
    path = _file(tmp_path, _TIERS)
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


def test_file_hash_tier_says_when_its_setting_is_within_the_tier_on_some_scenes_only(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    all_of_them = {"agrees": None, "close": TierChoice("trial-4", 22, 22)}
    assert tier_note(load_settings(_file(tmp_path, all_of_them)), "close") is None
    path = _file(tmp_path, _TIERS)
    loaded = load_settings(path)
    assert tier_note(loaded, "trial-4") is None  # a setting by name: nothing to say
    assert "trial-4, within the tier on only 13/22" in str(tier_note(loaded, "close"))
    args = ["simulate", "--engine", ENGINE, "--scene", "seed-mu", "--settings"]
    assert main([*args, f"{path}#close"]) == 0
    assert "#close is trial-4, within the tier on only 13/22" in capsys.readouterr().err
