"""The answer in plain words, its ranked table and its files (reports/report/answer_words.py,
answer_files.py): every sentence generated from the rows, never an engine's name by hand.
Rows made by hand, so that each number is known; no engine runs (about 2 s in all)."""

from __future__ import annotations

import json

import pandas as pd
import pytest
from test_answer import front_row, search

from hoopbench.engines.judging.score import CostClock
from hoopbench.engines.judging.verdict import Verdict
from hoopbench.reports.report.answer import RANK_RULE, answer, answer_markdown, ranked
from hoopbench.reports.report.answer_files import (
    ANSWER_COLUMNS,
    answer_frame,
    answer_records,
    write_answer_files,
)
from hoopbench.reports.report.answer_words import answer_section, answer_sentences
from hoopbench.reports.report.verdict_words import PLAIN_VERDICTS

OUTCOMES = {"seed-mu": "slips", "slip-reversal": "slips", "hop-top": "hops", "hop-low": "hops"}


def run(engine, scene, verdict, *, dt=1e-4, profile="tuned", us=10.0):
    return {
        "run_id": f"{engine}-{scene}-{dt}-{profile}",
        "engine": engine,
        "scene": scene,
        "profile": profile,
        "variant": "default",
        "timestep": dt,
        "status": "ok",
        "verdict": verdict,
        "exact_outcome": OUTCOMES[scene],
        "us_per_step": us,
        "cpu_us_per_step": us,
    }


def rows(good: str, hopper: str) -> pd.DataFrame:
    """``good`` agrees on the slip scenes and is close on hop-top; ``hopper`` agrees on both
    hop scenes and slips early on the slip scenes, at 3x the cost; no engine gets hop-low
    within loose but ``hopper``."""
    verdicts = {
        good: {"seed-mu": "agrees", "slip-reversal": "agrees", "hop-top": "close",
               "hop-low": "missed-hop"},
        hopper: {"seed-mu": "early-slip", "slip-reversal": "early-slip", "hop-top": "agrees",
                 "hop-low": "agrees"},
    }  # fmt: skip
    costs = {good: 10.0, hopper: 30.0}
    return pd.DataFrame(
        [run(e, s, v, us=costs[e]) for e, scenes in verdicts.items() for s, v in scenes.items()]
    )


@pytest.mark.parametrize(("good", "hopper"), [("pymunk", "drake"), ("drake", "pymunk")])
def test_the_sentences_name_the_engines_the_rows_say(good, hopper):
    """Swapping the engines' verdicts swaps the names in every sentence: nothing by hand."""
    sentences = answer_sentences(answer(rows(good, hopper)))
    tight, loose, nobody = sentences
    # Tight: 2 scenes each; the cheaper (good) is named, and what it misses, in words.
    assert tight.startswith(
        "Tight (every event within the tight tolerances): no engine meets it on all 4 scenes "
        f"at the suites' settings; the most, 2/4, {good}"
    )
    assert f"the most, 2/4, {good} (tuned, default, dt 0.0001 s) at 0.1 CPU s per" in tight
    assert f"{good} (tuned, default, dt 0.0001 s) at 0.1 CPU s per simulated s" in tight
    assert "short on hop-top (within the loose tolerances only), hop-low (misses the hop)" in tight
    # By exact outcome: the slip scenes go to good, the hop scenes to hopper.
    assert f"on the 2 scenes that slip, {good} (tuned, default, dt 0.0001 s) on all 2" in tight
    assert f"on the 2 scenes that hop, {hopper} (tuned, default, dt 0.0001 s) on all 2" in loose
    assert "at 0.3 CPU s per simulated s" in loose
    assert f"on all 4 scenes at the suites' settings; the most, 3/4, {good}" in loose
    assert f"hop-low by {hopper} alone" in nobody and "seed-mu by" in nobody


def test_a_setting_meeting_every_scene_is_the_one_to_use_and_a_scene_no_one_meets_is_said():
    frame = pd.DataFrame(
        [
            *(run("box2d", s, "agrees") for s in ("seed-mu", "hop-top")),
            *(run("rapier", s, "close", us=4.0) for s in ("seed-mu", "hop-top")),
            run("rapier", "hop-low", "missed-hop"),
            run("box2d", "hop-low", "hop-too-low"),
        ]
    )
    tight, loose, nobody = answer_sentences(answer(frame))
    # hop-low, which no run meets, is the timestep's limit: out of the table's scenes.
    assert "use box2d (tuned, default, dt 0.0001 s), the cheapest of the suites' settings" in tight
    assert "use rapier (tuned, default, dt 0.0001 s)" in loose and "at 0.04 CPU" in loose
    assert nobody == (
        "What no engine gets right: no setting of any engine meets the loose tier on hop-low, "
        "at any timestep tried. Met within loose by few engines: seed-mu by box2d and rapier "
        "alone; hop-top by box2d and rapier alone."
    )
    finer = pd.concat([frame, pd.DataFrame([run("box2d", "hop-low", "close", dt=2.5e-5)])])
    nobody = answer_sentences(answer(finer))[-1]
    assert "no engine meets the loose tier on hop-low but at dt 2.5e-05 s, finer" in nobody
    every = pd.DataFrame([run("box2d", s, "agrees") for s in ("seed-mu", "hop-top")])
    tight = answer_sentences(answer(every))[0]
    assert (
        "use box2d (tuned, default, dt 0.0001 s), the cheapest of the suites' settings meeting "
        "it on all 2 scenes, at 0.1 CPU s per simulated s." in tight
    )


def test_a_search_within_the_tier_on_more_of_its_scenes_is_the_one_to_use():
    tuned = front_row("tuned", 1, 2, cost=1.5e6) | {"kind": "baseline"}
    found = search("drake", [front_row("trial-34", 6, 6, cost=7.5e5), tuned])
    tight = answer_sentences(answer(rows("pymunk", "mujoco"), [found]))[0]
    assert tight.startswith(
        "Tight (every event within the tight tolerances): use drake's searched setting trial-34 "
        "(dt 0.0001 s), within it on all 6 of its search's scenes, 4 of them held out, at 0.75 "
        "wall s per simulated s as the search measured it (0.5 times the tuned profile's cost "
        "in the same search). Run it with --settings "
        "'reports/tune/searches/drake/settings.toml#agrees'. No engine meets it on all 4 "
        "scenes at the suites' settings"
    )


def test_a_search_s_cost_is_said_by_its_own_clock_and_against_its_own_tuned():
    """A search costed by CPU time: its cost in CPU s, its ratio to its own tuned baseline;
    the suites' best beside it (0.1 CPU s) is not set against it."""
    tuned = front_row("tuned", 1, 2, cost=1.5e6) | {"kind": "baseline"}
    found = search("drake", [front_row("trial-34", 6, 6, cost=7.5e5), tuned], clock=CostClock.CPU)
    tight = answer_sentences(answer(rows("pymunk", "mujoco"), [found]))[0]
    assert (
        "at 0.75 CPU s per simulated s as the search measured it (0.5 times the tuned "
        "profile's cost in the same search)." in tight
    )
    assert "wall" not in tight


def test_the_table_is_ranked_by_its_stated_rule_and_the_files_hold_its_rows(tmp_path):
    """Loose scenes first (pymunk 3 before drake 2, though dearer here), then the cost."""
    frame = rows("pymunk", "drake")
    frame.loc[frame["engine"] == "pymunk", "cpu_us_per_step"] = 50.0
    frame = pd.concat(  # rapier's rows first: the rank, not the rows' order, orders
        [pd.DataFrame([run("rapier", "seed-mu", "close", us=1.0)]), frame], ignore_index=True
    )
    result = answer(frame)
    assert [line.engine for line in ranked(result)] == ["pymunk", "drake", "rapier"]
    text = answer_markdown(result)
    assert text.index("| 1 | pymunk |") < text.index("| 2 | drake |") < text.index("| 3 | rapier")
    assert RANK_RULE in text
    paths = write_answer_files(result, tmp_path)
    assert [p.name for p in paths] == ["answer.csv", "answer.json"]
    table = pd.read_csv(tmp_path / "answer.csv")
    assert list(table.columns) == [name for name, _ in ANSWER_COLUMNS]
    assert list(table["engine"]) == ["pymunk", "drake", "rapier"] and list(table["rank"]) == [
        1,
        2,
        3,
    ]
    assert list(table["loose_scenes_met"]) == [3, 2, 1]
    assert table.loc[0, "loose_cost_s_per_sim_s"] == pytest.approx(0.5)
    assert table.loc[0, "wrong_everywhere"] == "hop-low: missed-hop"
    assert table.loc[0, "tight_missed"] == "hop-top: close; hop-low: missed-hop"
    data = json.loads((tmp_path / "answer.json").read_text())
    assert data["rows"] == answer_records(result)
    assert len(answer_frame(result)) == len(data["rows"]) == 3
    assert data["sentences"] == answer_sentences(result) and data["rank_rule"] == RANK_RULE
    assert data["clock"] == "CPU" and len(data["scenes"]) == 4


def test_the_section_puts_the_words_above_the_table_and_every_verdict_has_words():
    section = answer_section(answer(rows("pymunk", "drake")))
    assert section.index("- **Tight (") < section.index("- **Loose (") < section.index("| rank")
    assert "\n  - Run it with" not in section  # no search: no setting of one to run
    assert "| hop-low (misses the hop) |" in section  # the last column in words
    assert set(PLAIN_VERDICTS) == {str(v) for v in Verdict}
    assert answer_section(answer(pd.DataFrame([run("x", "seed-mu", "agrees")]).iloc[:0])) == ""


def test_best_settings_say_their_costs_in_the_one_unit_and_that_they_were_shipped(tmp_path):
    """A shipped search (reports/tune/searches/pymunk) read back: its costs in seconds per
    simulated second, and when it ran, from its own files (one figure drawn, about 1 s)."""
    from pathlib import Path

    from hoopbench.reports.report.best_settings import best_settings, best_settings_section

    folder = Path(__file__).parents[1] / "reports" / "tune" / "searches" / "pymunk"
    (found,) = best_settings([folder])
    text = best_settings_section([found], tmp_path)
    assert "shipped with the repository" in text and "measures nothing of them again" in text
    assert f"Search started {json.loads((folder / 'tune.json').read_text())['created']}." in text
    assert "| training cost (wall s per simulated s) |" in text
    tuned = found.front.set_index("setting").loc["tuned", "train_cost_us_per_s"]
    row = next(line for line in text.splitlines() if line.startswith("| tuned |"))
    assert f" | {tuned * 1e-6:.3g} | " in row
    assert "wall s per simulated s)" in text and "us per simulated s" not in text


def test_a_report_never_replaces_answer_files_unasked(tmp_path):
    """answer.csv and answer.json are the report's files: refused without --force, as
    report.md is (build.files_to_replace), in the order the report writes them."""
    from hoopbench.reports.report.build import files_to_replace

    for name in ("answer.json", "answer.csv", "report.md", "mine.txt"):
        (tmp_path / name).write_text("")
    names = [path.name for path in files_to_replace(tmp_path, [])]
    assert names == ["report.md", "answer.csv", "answer.json"]


def test_a_setting_s_runs_are_read_once_and_the_worst_transition_of_the_chosen_alone(
    monkeypatch,
):
    """answer() weighs some 100 settings on 2 tiers for every engine and every exact outcome
    (seconds of the report step, issue 34): each setting's runs are read once for the
    engines' lines and once for the regimes (their rows on the answer's scenes), not once a
    tier and regime, and the worst transition and missed scenes only of the settings chosen."""
    from hoopbench.reports.report import answer as answer_module

    read: list[str] = []
    worst: list[str] = []
    setting_runs, worst_transition = answer_module._setting_runs, answer_module._worst_transition

    def counted_runs(judged, key, at):
        read.append(str(key))
        return setting_runs(judged, key, at)

    def counted_worst(judged, at, scenes, tier):
        worst.append(str(tier))
        return worst_transition(judged, at, scenes, tier)

    monkeypatch.setattr(answer_module, "_setting_runs", counted_runs)
    monkeypatch.setattr(answer_module, "_worst_transition", counted_worst)
    frame = rows("pymunk", "drake")
    coarse = rows("pymunk", "drake").assign(timestep=1e-3, max_transition_ratio=0.5)
    result = answer(pd.concat([frame.assign(max_transition_ratio=0.2), coarse]))
    assert len(result.regimes) == 2 and len(result.engines) == 2
    assert len(read) == 2 * 4  # 4 settings, each once a group of rows
    chosen = [c for line in result.engines for c in line.cheapest if c is not None]
    chosen += [c for regime in result.regimes for c in regime.best if c is not None]
    assert len(worst) == len(chosen) == 8
    assert all(c.worst is not None and c.worst.ratio == 0.5 for c in chosen)  # dt 1e-3's
