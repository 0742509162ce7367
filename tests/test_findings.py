"""Findings are generated from the rows: each sentence follows the numbers it quotes."""

from __future__ import annotations

import pandas as pd
import pytest

from hoopbench.reports.report.findings import README_BEGIN, README_END, findings, update_readme


def row(engine, scene="seed-mu", **values):
    base = {
        "engine": engine,
        "scene": scene,
        "variant": "default",
        "profile": "tuned",
        "timestep": 1e-4,
        "suite": "default",
        "status": "ok",
        "us_per_step": 10.0,
        "err_t_slip_ms": None,
        "err_hop_height_rel": None,
        "verdict": "agrees",
        "outcome_agrees": True,
        "message": "",
    }
    return {**base, **values}


def frame(*rows) -> pd.DataFrame:
    return pd.DataFrame(list(rows))


def test_the_closest_engine_is_the_one_with_the_smallest_error():
    runs = frame(
        row("reference", err_t_slip_ms=0.01),
        row("mujoco", err_t_slip_ms=2.4, us_per_step=37.0),
        row("pybullet", err_t_slip_ms=-0.14, us_per_step=80.0),
    )
    text = findings(runs)[0]
    assert text.startswith(
        "Slip onset on seed-mu (dt 0.0001, tuned): closest is pybullet, -0.14 ms"
    )
    assert "at 80 us/step" in text and "then mujoco +2.4 ms" in text
    assert "reference" not in text  # the reference is what the engines are measured against


def test_agreement_names_every_scene_that_went_wrong():
    runs = frame(
        row("pymunk", err_t_slip_ms=1.0, verdict="wrong-phases", outcome_agrees=True),
        row("pymunk", scene="hop-top", verdict="false-hop", outcome_agrees=False),
        row("pymunk", scene="hop-low", verdict="wrong-phases", outcome_agrees=True),
        row("pymunk", scene="hop-bottom", verdict="agrees", outcome_agrees=True),
    )
    sentence = next(s for s in findings(runs) if s.startswith("pymunk (dt"))
    assert sentence == (
        "pymunk (dt 0.0001, tuned) gets the outcome right on 3 of 4 scenes and the whole "
        "phase sequence on 1 (false-hop on hop-top; wrong-phases on seed-mu, hop-low)."
    )


def test_stock_and_tuned_each_get_their_own_sentences():
    runs = frame(
        row("mujoco", err_t_slip_ms=2.4),
        row("mujoco", profile="stock", err_t_slip_ms=-900.0, verdict="false-hop"),
    )
    text = findings(runs)
    assert any("(dt 0.0001, tuned)" in s and "+2.4 ms" in s for s in text)
    assert any("(dt 0.0001, stock)" in s and "-900 ms" in s for s in text)


def test_the_readme_block_is_replaced_between_its_markers(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text(f"# x\n\n{README_BEGIN}\nold\n{README_END}\n\nafter\n")
    update_readme(readme, "- new")
    assert readme.read_text() == f"# x\n\n{README_BEGIN}\n- new\n{README_END}\n\nafter\n"
    (tmp_path / "bare.md").write_text("no markers")
    with pytest.raises(ValueError, match="has no findings markers"):
        update_readme(tmp_path / "bare.md", "- new")


def test_the_stock_knobs_that_break_a_tuned_outcome_are_named():
    """A knob at its stock value alone (cone: pyramidal) that loses the tuned run's hop is
    named with its verdict and error; one that changes no outcome (tolerance) is listed apart;
    a variant that is not a stock value (noslip_iterations = 10) is not a stock knob."""
    hop = {"exact_t_lift": 1.17, "geometry": "sphere"}
    runs = frame(
        row("mujoco", "hop-top", options="{}", err_hop_height_rel=-0.011, **hop),
        row(
            "mujoco",
            "hop-top",
            variant="cone=pyramidal",
            options='{"cone": "pyramidal"}',
            err_hop_height_rel=-0.997,
            verdict="missed-hop",
            outcome_agrees=False,
            **hop,
        ),
        row(
            "mujoco",
            "hop-top",
            variant="tolerance=1e-8",
            options='{"tolerance": 1e-08}',
            err_hop_height_rel=-0.011,
            **hop,
        ),
        row(
            "mujoco",
            "hop-top",
            variant="noslip",
            options='{"noslip_iterations": 10}',
            verdict="missed-hop",
            outcome_agrees=False,
            **hop,
        ),
    )
    (text,) = [s for s in findings(runs) if "stock knob" in s]
    assert "cone = pyramidal on hop-top (missed-hop, -99.7 %)" in text
    assert text.endswith("tolerance = 1e-08 keeps every outcome.")
    assert "noslip" not in text
