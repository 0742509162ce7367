"""The truth test (issue 24, item 6): on scenes drawn at random, which nobody tuned the
reading on, no label of any engine's row contradicts the run's own trajectory and contact
force.

Nine scenes are drawn with a seed of their own (reference/random_scenes.py: two rolls, two
slips, a slip reversal, three hops, and a hoop the floor cannot hold at t = 0, which hops
from there: lifts-at-start, added 2026-11-30). Each is run by the reference and the seven engines,
stock and tuned, at dt 1e-3 and 1e-4, through ``hb.run`` as a user runs one, and every row
is checked by the independent checker of tests/truth_checker.py, which reads the canonical
events from their definitions and does not call the judging code. Both profiles and both
timesteps, because the issue's three kinds of false slip do not all show in one (creep read
as a slip is MuJoCo stock's, chattering read as a slip shows at dt 1e-4 tuned) and the four
cost about 30 s of CPU together (the draw 3 s; a minute of wall time on a busy machine).

Before issue 24's canonical reading, the row's labels read with today's names (the contact
reading's contact_* columns), this test found 35 contradictions in 20 of the 256 rows: see
the commit that introduced it.

Issue 33 (item 7) adds a second draw, with a seed of its own, of the scenes where the
reading's slip and creep rules decide: two near-slip rolls (exact rolls whose friction peaks
above 0.9 of the cone: random_scenes.near_slip), two slip reversals, a slip that re-sticks
and a hop, 0.9 s each. All ten engines and the reference run them stock and tuned at dt
1e-3 through ``hb.run``, and the checker, with issue 33's definitions, times every
transition of the agreeing rows. DART stock, whose friction saturates below mu (0.65-0.83
mu n), slides on both near-slip rolls (a test says so). Cost on this 2-core CPU (measured
under another job's load): 5 s for the draw, 95-107 s for MuJoCo Warp (its tuned RK4 steps
at 14 ms), 20-27 s MJX, 14 s Newton, 4 s the eight others together: 2.5-2.8 min of CPU for
every near-slip test with the compile caches warm, 3.9 min cold (MJX, MuJoCo Warp and
Newton compile for 20-35 s each). Against main before issue 33's reading it finds 24
contradictions in 17 of the 132 rows (see the commit that introduced it).
"""

from __future__ import annotations

import ast
import dataclasses
import itertools
from importlib.resources import files
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import engine_unavailable
from truth_checker import (
    CANONICAL_NAMES,
    DOCS_LOOSE,
    FAST_SLIDE,
    Exact,
    Hoop,
    Kind,
    Labels,
    LooseTolerances,
    contradictions,
)

import hoopbench as hb
from hoopbench.engines.registry import engine_names
from hoopbench.engines.run import RunStatus
from hoopbench.models.scene import Scene
from hoopbench.reference.random_scenes import Draw, draw, near_slip, peak_rolling_share
from hoopbench.reference.regimes import Regime

SEED = 2_411_026
"""Not a seed the project used before: the scenes are new to every reading."""
QUOTA = {
    Regime.ROLLS: 2,
    Regime.SLIPS: 2,
    Regime.SLIP_REVERSAL: 1,
    Regime.HOPS: 3,
    Regime.LIFTS_AT_START: 1,
}
ENGINES = ("reference", "mujoco", "pybullet", "pymunk", "drake", "box2d", "rapier", "dart")
PROFILES = ("tuned", "stock")
TIMESTEPS = (1e-3, 1e-4)
TIMESTEP = 1e-4
"""s: the checker's own tests run the reference at this one."""
T_END = 1.5
"""s: each scene's window."""
TABLE = files("hoopbench.engines.judging").joinpath("tolerances.toml")
"""The one tolerance table of issue 24 (its [loose] tier), read as data from the installed
package."""


def loose() -> LooseTolerances:
    """The table's loose tier; before the table existed, the tolerances docs/report.md
    stated (wider: a looser check, never a stricter one)."""
    return LooseTolerances.from_table(TABLE) if TABLE.is_file() else DOCS_LOOSE


@pytest.fixture(scope="module")
def drawn() -> Draw:
    return draw(SEED, QUOTA, t_end=T_END)


@pytest.fixture(scope="module")
def exact(drawn: Draw) -> dict[str, Exact]:
    return {s.name: Exact.from_solution(hb.exact(s), Hoop(s.a, s.g)) for s in drawn.scenes}


def test_the_draw_covers_every_regime(drawn):
    assert sorted(drawn.regimes) == sorted(r for r, k in QUOTA.items() for _ in range(k))
    assert set(ENGINES) <= set(engine_names())


@pytest.mark.slow
@pytest.mark.parametrize("timestep", TIMESTEPS)
@pytest.mark.parametrize("profile", PROFILES)
def test_no_label_contradicts_its_run(drawn, exact, profile, timestep):
    found, tolerances = [], loose()
    for scene in drawn.scenes:
        for engine in ENGINES:
            run = hb.run(engine, scene, timestep=timestep, profile=profile)
            if run.status is RunStatus.UNAVAILABLE:
                engine_unavailable(engine, run.row.get("message"))
            labels = Labels.from_row(run.row, CANONICAL_NAMES)
            hoop = Hoop(scene.a, scene.g, scene)
            for c in contradictions(
                run.trajectory,
                labels,
                exact[scene.name],
                mu=run.row["mu"],
                hoop=hoop,
                loose=tolerances,
            ):
                found.append(f"{scene.name} {engine} [{labels.verdict}]: {c.kind}: {c.text}")
    head = f"{len(found)} contradictions (loose tolerances: {tolerances.source}):"
    assert not found, "\n".join([head, *found])


# ------------------------------------------------------------ near slips, every engine
NEAR_SEED = 3_311_207
"""Issue 33's draw: a seed no test, search or held-out set used before."""
NEAR_QUOTA = {Regime.ROLLS: 2, Regime.SLIP_REVERSAL: 2, Regime.SLIPS: 1, Regime.HOPS: 1}
NEAR_SHARE = 0.9
"""The rolls drawn are near slips: their friction peaks above this share of the cone."""
NEAR_T_END = 0.9
"""s: each scene's window (MuJoCo Warp's tuned RK4 steps at 14 ms on this CPU)."""
NEAR_TIMESTEP = 1e-3
"""s: every engine's, MJX and MuJoCo Warp included (1e-4 would cost them ten times)."""
ALL_ENGINES = (
    "reference",
    "mujoco",
    "mjx",
    "mjwarp",
    "pybullet",
    "pymunk",
    "drake",
    "box2d",
    "rapier",
    "dart",
    "newton",
)


@pytest.fixture(scope="module")
def near_drawn() -> Draw:
    return draw(
        NEAR_SEED, NEAR_QUOTA, t_end=NEAR_T_END, conditions={Regime.ROLLS: near_slip(NEAR_SHARE)}
    )


@pytest.fixture(scope="module")
def near_exact(near_drawn: Draw) -> dict[str, Exact]:
    return {s.name: Exact.from_solution(hb.exact(s), Hoop(s.a, s.g)) for s in near_drawn.scenes}


def test_the_near_slip_draw_has_near_slips_reversals_and_every_engine(near_drawn, near_exact):
    assert sorted(near_drawn.regimes) == sorted(r for r, k in NEAR_QUOTA.items() for _ in range(k))
    assert set(ALL_ENGINES) == set(engine_names())
    for scene, regime in zip(near_drawn.scenes, near_drawn.regimes, strict=True):
        codes = near_exact[scene.name].codes()
        if regime is Regime.ROLLS:
            assert NEAR_SHARE < peak_rolling_share(hb.exact(scene)) < 1.0, scene.name
        if regime is Regime.SLIP_REVERSAL:  # a reversal a reading sees, inside the record
            assert any({a, b} == {"S+", "S-"} for a, b in itertools.pairwise(codes)), codes


def _near_rows(drawn: Draw, exact: dict[str, Exact], engine: str) -> list[str]:
    found, tolerances = [], loose()
    for scene in drawn.scenes:
        for profile in PROFILES:
            run = hb.run(engine, scene, timestep=NEAR_TIMESTEP, profile=profile)
            if run.status is RunStatus.UNAVAILABLE:  # CI installs every engine: never a skip
                pytest.fail(f"{engine} unavailable: {run.row.get('message')}")
            labels = Labels.from_row(run.row, CANONICAL_NAMES)
            for c in contradictions(
                run.trajectory,
                labels,
                exact[scene.name],
                mu=run.row["mu"],
                hoop=Hoop(scene.a, scene.g, scene),
                loose=tolerances,
            ):
                found.append(f"{scene.name} {profile} [{labels.verdict}]: {c.kind}: {c.text}")
    return found


@pytest.mark.slow
@pytest.mark.parametrize("engine", ALL_ENGINES)
def test_no_label_contradicts_its_run_near_slips(near_drawn, near_exact, engine):
    """Issue 33, item 7: six scenes never seen (two near-slip rolls, two slip reversals, a
    slip, a hop), every engine stock and tuned at dt 1e-3 through ``hb.run``, every row
    checked, every transition timed on the agreeing ones."""
    found = _near_rows(near_drawn, near_exact, engine)
    head = f"{engine}: {len(found)} contradictions on {len(near_drawn.scenes)} scenes x 2:"
    assert not found, "\n".join([head, *found])


@pytest.mark.slow
def test_dart_stock_slides_on_the_near_slip_rolls(near_drawn):
    """The draw holds an engine whose friction saturates below mu: on each near-slip roll
    DART stock (Dantzig) slides faster than FAST_SLIDE where the exact hoop rolls, its
    friction there 0.9 mu n at most on nine samples in ten (0.65 and 0.79 mu n at the median
    on the two rolls): the rows' slip and creep labels are then what the checker tests."""
    rolls = [
        s for s, r in zip(near_drawn.scenes, near_drawn.regimes, strict=True) if r is Regime.ROLLS
    ]
    slides = []
    for scene in rolls:
        frame = hb.run("dart", scene, timestep=NEAR_TIMESTEP, profile="stock").trajectory
        fast = np.abs(frame["slip_velocity"]) > FAST_SLIDE
        ratio = np.abs(frame["friction_force"] / (frame["normal_force"] * scene.mus))
        slides.append(bool(fast.any()) and float(np.percentile(ratio[fast], 90)) < 0.9)
    assert all(slides), slides


# --------------------------------------------------------------------------- the checker
def test_the_checker_and_the_draw_do_not_call_the_judging_code():
    """An independent check: sharing the judging code would share its mistakes."""
    judging = ("hoopbench.engines", "hoopbench.reports")
    here = Path(__file__).parent
    for path in (here / "truth_checker.py", here.parent / "reference" / "random_scenes.py"):
        name = path.name
        tree = ast.parse(path.read_text())
        modules = {n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
        modules |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        assert not {m for m in modules if m.startswith(judging)}, name


# It must accept the truth and catch a lie: the exact events on the reference's own
# trajectory are no contradiction, and each label made false is one, of its kind.
def _first(drawn: Draw, regime: Regime) -> Scene:
    return next(s for s, r in zip(drawn.scenes, drawn.regimes, strict=True) if r is regime)


def _truth(scene: Scene, exact: Exact, timestep: float = TIMESTEP) -> tuple:
    """The reference's run of ``scene`` with the exact events as its labels (agrees)."""
    run = hb.run("reference", scene, timestep=timestep)
    labels = Labels(
        engine="reference",
        status="ok",
        verdict="agrees",
        flags=frozenset(),
        t_slip=exact.t_slip,
        t_lift=exact.t_lift,
        t_impact=exact.t_impact,
        hop_height=exact.hop_height,
        phases=exact.codes(),
    )
    return run.trajectory, labels, run.row["mu"], Hoop(scene.a, scene.g, scene)


def _kinds(frame, labels, exact, mu, hoop) -> set[Kind]:
    return {c.kind for c in contradictions(frame, labels, exact, mu=mu, hoop=hoop)}


@pytest.mark.parametrize(
    "regime", [Regime.HOPS, Regime.ROLLS, Regime.SLIP_REVERSAL, Regime.LIFTS_AT_START]
)
def test_the_checker_accepts_the_exact_events(drawn, exact, regime):
    scene = _first(drawn, regime)
    frame, labels, mu, hoop = _truth(scene, exact[scene.name])
    assert contradictions(frame, labels, exact[scene.name], mu=mu, hoop=hoop) == []


def _hop_lies(e: Exact) -> dict[str, tuple[dict, dict, Kind]]:
    """Each lie: the labels changed, the exact events changed (to make the reference's own
    run early or late), the kind of contradiction it is."""
    assert e.t_lift is not None and e.hop_height is not None and e.t_slip is not None
    missed = dict(verdict="missed-hop", flags=frozenset({"missed-hop"}))
    hop = Kind.HOP_VERDICT
    return {
        "missed-hop": (missed, {}, Kind.HOP_VERDICT),
        "late lift-off": (dict(verdict="late-lift-off"), dict(t_lift=e.t_lift + 0.1), hop),
        "hop too low": (dict(verdict="hop-too-low"), {}, Kind.HOP_VERDICT),
        "lift-off 50 ms off": (dict(t_lift=e.t_lift - 0.05), {}, Kind.HOP_LABEL),
        "twice the height": (dict(hop_height=2 * e.hop_height), {}, Kind.HOP_LABEL),
        "no impact": (dict(t_impact=None), {}, Kind.HOP_LABEL),
        "no slip": (dict(t_slip=None), {}, Kind.SLIP_LABEL),
        "slip 40 ms early": (dict(t_slip=e.t_slip - 0.04), {}, Kind.NO_SLIP_AS_SLIP),
        "early slip": (dict(verdict="early-slip"), dict(t_slip=e.t_slip - 0.05), Kind.SLIP_VERDICT),
        "late slip": (dict(verdict="late-slip"), dict(t_slip=e.t_slip + 0.05), Kind.SLIP_VERDICT),
        "missed slip": (dict(verdict="missed-slip"), {}, Kind.SLIP_VERDICT),
        "agrees, slip 50 ms off": ({}, dict(t_slip=e.t_slip - 0.05), Kind.TOLERANCE),
        "agrees, lift-off 100 ms off": ({}, dict(t_lift=e.t_lift + 0.1), Kind.TOLERANCE),
        "flags without the late slip": (
            dict(verdict="hop-too-low", flags=frozenset({"hop-too-low"})),
            dict(t_slip=e.t_slip - 0.05),
            Kind.MISSING_FLAG,
        ),
        "diverged": (dict(verdict="diverged"), {}, Kind.DIVERGED),
        "a reference failing": (dict(verdict="wrong-phases"), {}, Kind.REFERENCE),
        "an unfounded cone flag": (dict(flags=frozenset({"cone-violation"})), {}, Kind.CONE_FLAG),
    }


@pytest.mark.parametrize("lie", list(_hop_lies(Exact(1.0, True, 0.5, 0.6, 0.9, 0.1))))
def test_the_checker_catches_each_false_hop_scene_label(drawn, exact, lie):
    scene = _first(drawn, Regime.HOPS)
    e = exact[scene.name]
    frame, labels, mu, hoop = _truth(scene, e)
    change, exact_change, kind = _hop_lies(e)[lie]
    lied = dataclasses.replace(labels, **change)
    assert kind in _kinds(frame, lied, dataclasses.replace(e, **exact_change), mu, hoop)


def test_the_checker_catches_a_false_slip_and_agreeing_on_a_missed_hop(drawn, exact):
    rolls, hops = _first(drawn, Regime.ROLLS), _first(drawn, Regime.HOPS)
    frame, labels, mu, hoop = _truth(rolls, exact[rolls.name])
    false_slip = dataclasses.replace(labels, verdict="false-slip")
    assert Kind.SLIP_VERDICT in _kinds(frame, false_slip, exact[rolls.name], mu, hoop)
    # A roll judged against the hop scene's exact events: agrees would be a lie.
    roll_as_hop = dataclasses.replace(labels, t_slip=None)
    assert Kind.TOLERANCE in _kinds(frame, roll_as_hop, exact[hops.name], mu, hoop)


def test_the_checker_tells_creep_and_a_stick_outside_the_cone_from_a_slip(drawn, exact):
    """Edited exact runs. A roll made to slide at 5 mm/s against its friction, which stays at
    the rolling demand inside the cone, is creep, not a slip; a slip whose friction is held
    at 1.3 of the cone with the rim still is a stick outside the cone (and needs the
    cone-violation flag)."""
    rolls = _first(drawn, Regime.ROLLS)
    frame, labels, mu, hoop = _truth(rolls, exact[rolls.name])
    t = frame["t"].to_numpy()
    middle = (t > 0.3 * t[-1]) & (t < 0.6 * t[-1])
    creep = frame.copy()
    creep.loc[middle, "slip_velocity"] = -np.sign(creep.loc[middle, "friction_force"]) * 5e-3
    said_slip = dataclasses.replace(labels, t_slip=float(t[middle][0]))
    assert Kind.CREEP_AS_SLIP in _kinds(creep, said_slip, exact[rolls.name], mu, hoop)
    scene = _first(drawn, Regime.SLIPS)
    e = exact[scene.name]
    frame, labels, mu, hoop = _truth(scene, e)
    assert e.t_slip is not None
    after = frame["t"].to_numpy() >= e.t_slip
    stick = frame.copy()
    stick.loc[after, "friction_force"] *= 1.3
    stick.loc[after, "slip_velocity"] = 0.0
    kinds = _kinds(stick, labels, e, mu, hoop)
    assert {Kind.STICK_AS_SLIP, Kind.CONE_FLAG} <= kinds
    assert np.all(np.isfinite(stick["friction_force"]))


def test_the_loose_tier_is_read_from_the_table(tmp_path):
    table = tmp_path / "tolerances.toml"
    table.write_text(
        "[tight]\nt_slip_s = 0.002\n[loose]\nt_slip_s = 0.01\nt_lift_s = 0.02\n"
        "t_impact_s = 0.005\nhop_height_rel = 0.05\nsteps = 1\n"
    )
    read = LooseTolerances.from_table(table)
    assert (read.slip_s, read.lift_s, read.impact_s, read.steps) == (0.01, 0.02, 0.005, 1.0)
    assert (read.height_low, read.height_high) == pytest.approx((0.95, 1.05))


def test_a_hop_the_record_cuts_short_is_left_out(drawn, exact):
    """A hop that lifts off just before the window's end cannot show in a run's record (nor
    in the reference's): its checks are left out rather than asked of every engine."""
    scene = _first(drawn, Regime.HOPS)
    assert not exact[scene.name].hop_unresolved
    t_lift = exact[scene.name].t_lift
    assert t_lift is not None
    cut = Exact.from_solution(hb.exact(scene.with_(t_end=t_lift + 0.003)), Hoop())
    assert cut.hop_unresolved and cut.t_lift is None


# Issue 33's definitions: every transition timed, fast sliding never creep, creep at the
# rolling demand never a slip. On the near-slip draw's scenes at the near-slip timestep.
@pytest.mark.parametrize("timestep", [NEAR_TIMESTEP, TIMESTEP])
def test_the_checker_accepts_the_exact_events_of_every_near_slip_scene(
    near_drawn, near_exact, timestep
):
    for scene in near_drawn.scenes:
        e = near_exact[scene.name]
        frame, labels, mu, hoop = _truth(scene, e, timestep)
        found = contradictions(frame, labels, e, mu=mu, hoop=hoop, loose=loose())
        assert found == [], scene.name


def _moved(exact: Exact, k: int, shift: float) -> Exact:
    """``exact`` with its transition into phase k moved by ``shift`` (s)."""
    phases = list(exact.phases)
    phases[k - 1] = dataclasses.replace(phases[k - 1], t_end=phases[k - 1].t_end + shift)
    phases[k] = dataclasses.replace(phases[k], t_start=phases[k].t_start + shift)
    return dataclasses.replace(exact, phases=tuple(phases))


def _later_transition(exact: Exact, regime: Regime) -> int:
    """The phase a later transition leads into: a slip scene's re-stick, a reversal scene's
    first reversal."""
    codes = [p.code for p in exact.phases]
    pairs = list(enumerate(itertools.pairwise(codes), start=1))
    if regime is Regime.SLIPS:
        return next(k for k, (a, b) in pairs if a.startswith("S") and b == "R")
    return next(k for k, (a, b) in pairs if {a, b} == {"S+", "S-"})


def _timed(drawn: Draw, exact: dict[str, Exact], regime: Regime) -> Scene:
    """The first scene of ``regime`` whose later transition lies 0.1 s before the record's
    end at least (one at its very end is not timed: the phase rule)."""
    return next(
        s
        for s, r in zip(drawn.scenes, drawn.regimes, strict=True)
        if r is regime
        and exact[s.name].phases[_later_transition(exact[s.name], regime)].t_start < s.t_end - 0.1
    )


@pytest.mark.parametrize(
    ("regime", "shift"),
    [(Regime.SLIPS, 0.1), (Regime.SLIPS, -0.1), (Regime.SLIP_REVERSAL, 0.1), (Regime.SLIPS, 0.012)],
)
def test_the_checker_times_every_transition(near_drawn, near_exact, regime, shift):
    """An agrees row whose run re-sticks (or reverses) 100 ms from the exact solution's
    (the exact event moved, as the lies above move it) is contradicted; 12 ms, about the
    loose tolerance at dt 1e-3 (10 ms, a step and the floor), is not. The first slip onset
    is left where it is."""
    scene = _timed(near_drawn, near_exact, regime)
    e = near_exact[scene.name]
    frame, labels, mu, hoop = _truth(scene, e, NEAR_TIMESTEP)
    moved = _moved(e, _later_transition(e, regime), shift)
    assert moved.t_slip == e.t_slip
    kinds = _kinds(frame, labels, moved, mu, hoop)
    assert (Kind.TRANSITION in kinds) is (abs(shift) > 0.05), kinds


def _longest(mask: np.ndarray) -> np.ndarray:
    """The longest stretch of ``mask`` (a mask of it)."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts, stops = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
    k = int(np.argmax(stops - starts))
    out = np.zeros(len(mask), dtype=bool)
    out[starts[k] : stops[k]] = True
    return out


def _near_slip_roll(drawn: Draw, exact: dict[str, Exact], low: float, high: float) -> tuple:
    """The reference's run of the first near-slip roll whose friction stays between ``low``
    and ``high`` of the cone for 20 ms at least, and that stretch."""
    for scene, regime in zip(drawn.scenes, drawn.regimes, strict=True):
        if regime is not Regime.ROLLS:
            continue
        frame, labels, mu, hoop = _truth(scene, exact[scene.name], NEAR_TIMESTEP)
        ratio = np.abs(frame["friction_force"] / (mu * frame["normal_force"])).to_numpy()
        stretch = _longest((ratio >= low) & (ratio <= high))
        if np.ptp(frame["t"].to_numpy()[stretch]) >= 0.02:
            return scene, frame, labels, mu, hoop, stretch
    raise AssertionError(f"no near-slip roll holds its friction within {low}-{high} of the cone")


def test_the_checker_reads_a_fast_slide_at_the_demand_as_a_slip(near_drawn, near_exact):
    """A near-slip roll made to slide at 0.6 m/s against its friction where that friction,
    the rolling demand, is 0.77-0.83 mu n: a slip (fast sliding is never creep), so a row that
    reads a roll there, or creep at that speed, is contradicted."""
    scene, frame, labels, mu, hoop, stretch = _near_slip_roll(near_drawn, near_exact, 0.77, 0.83)
    slide = frame.copy()
    slide.loc[stretch, "slip_velocity"] = -np.sign(slide.loc[stretch, "friction_force"]) * 0.6
    e = near_exact[scene.name]
    assert labels.t_slip is None
    assert Kind.SLIDE_AS_ROLL in _kinds(slide, labels, e, mu, hoop)
    creep = dataclasses.replace(labels, creep_max_speed=0.6, creep_distance=0.012)
    assert Kind.CREEP_LABEL in _kinds(slide, creep, e, mu, hoop)


def test_the_checker_reads_a_slow_slide_at_the_demand_as_creep(near_drawn, near_exact):
    """A near-slip roll made to slide at 14 mm/s against its friction, held 1.5 % of the cone
    above the rolling demand where that demand is 0.90-0.96 of the cone (nearer the cone
    than the demand, as MuJoCo stock's creep in the issue): creep, so a row that reads a
    slip there is contradicted."""
    scene, frame, labels, mu, hoop, stretch = _near_slip_roll(near_drawn, near_exact, 0.9, 0.96)
    creep = frame.copy()
    sign = np.sign(creep.loc[stretch, "friction_force"])
    creep.loc[stretch, "friction_force"] += sign * 0.015 * mu * creep.loc[stretch, "normal_force"]
    creep.loc[stretch, "slip_velocity"] = -sign * 0.014
    t0 = float(creep["t"][stretch].iloc[0])
    code = "S+" if sign.iloc[0] < 0 else "S-"
    said_slip = dataclasses.replace(
        labels, t_slip=t0, phases=("R", code, "R"), verdict="false-slip", flags=frozenset()
    )
    assert Kind.CREEP_AS_SLIP in _kinds(creep, said_slip, near_exact[scene.name], mu, hoop)


def test_the_checker_counts_creep_only_before_the_exact_lift_off(near_drawn, near_exact):
    """A near-slip roll made to slide 10 mm (0.1 m/s for 0.1 s) after an exact lift-off put
    at 0.3 s: a row that counts those 10 mm as creep is contradicted (the exact hoop has no
    contact to creep on), one that counts none is not."""
    scene = _first(near_drawn, Regime.ROLLS)
    e = dataclasses.replace(near_exact[scene.name], contact_end=0.3)
    frame, labels, mu, hoop = _truth(scene, e, NEAR_TIMESTEP)
    t = frame["t"].to_numpy()
    later = (t >= 0.4) & (t < 0.5)
    slide = frame.copy()
    slide.loc[later, "slip_velocity"] = -np.sign(slide.loc[later, "friction_force"]) * 0.1
    crept = dataclasses.replace(labels, creep_distance=0.01, creep_max_speed=0.1)
    assert Kind.CREEP_LABEL in _kinds(slide, crept, e, mu, hoop)
    assert Kind.CREEP_LABEL not in _kinds(slide, labels, e, mu, hoop)


@pytest.mark.parametrize(
    ("regime", "phases", "kind"),
    [
        (Regime.SLIPS, ("R", "S+", "C", "R"), Kind.CHATTER_PHASE),
        (Regime.SLIPS, ("R", "S+", "R", "S+", "R", "S+", "R", "S+", "R"), Kind.SLIP_PHASES),
        (Regime.SLIP_REVERSAL, ("R", "S-", "R", "S-"), Kind.SLIP_LABEL),
    ],
    ids=["chattering as a phase", "rolls inside one slip", "a reversal read as a roll"],
)
def test_the_checker_reads_the_phase_codes(near_drawn, near_exact, regime, phases, kind):
    """The row's phase codes against the exact run: no C; no more slips one way than the
    run can hold; no fewer than it clearly has (the reversal scene's clear S+ read as none)."""
    scene = _timed(near_drawn, near_exact, regime)
    e = near_exact[scene.name]
    frame, labels, mu, hoop = _truth(scene, e, NEAR_TIMESTEP)
    assert kind not in _kinds(frame, labels, e, mu, hoop)
    lied = dataclasses.replace(labels, phases=phases, verdict="wrong-phases")
    assert kind in _kinds(frame, lied, e, mu, hoop)


BRAKED = Scene(
    lam=0.8933763038492488,
    thetadot0=2.570064666465523,
    mus=0.3423239219300248,
    muk=0.3423239219300248,
    eps=0.03245061302574129,
    theta0=5.689820109105772,
    t_end=T_END,
    name="random-27",
)
"""A hop drawn at random (seed 7,301,130, a draw of this test's QUOTA), on which DART stock
creeps and then brakes before its slip (below)."""


@pytest.mark.slow
def test_the_checker_reads_a_friction_lagging_the_demand_over_a_creep_as_no_slip(
    near_drawn, near_exact
):
    """A near-slip roll whose friction is made to fall 8 % of the cone short of the rolling
    demand for 20 ms while the rim creeps on at 4 mm/s (Box2D stock's lag on a ramping
    demand, seed 6,301,130's random-37): the slide does not grow, so it is no clear slip and
    a row that reads a roll there stands. Where the slide grows from 4 to 8 mm/s over the
    stretch, it is a slip, and the roll is contradicted."""
    scene, frame, labels, mu, hoop, stretch = _near_slip_roll(near_drawn, near_exact, 0.5, 0.8)
    lag = frame.copy()
    sign = np.sign(lag.loc[stretch, "friction_force"])
    lag.loc[stretch, "friction_force"] -= sign * 0.08 * mu * lag.loc[stretch, "normal_force"]
    lag.loc[stretch, "slip_velocity"] = -sign * 4e-3
    e = near_exact[scene.name]
    assert labels.t_slip is None
    assert Kind.SLIDE_AS_ROLL not in _kinds(lag, labels, e, mu, hoop)
    grows = lag.copy()
    t = grows.loc[stretch, "t"]
    grows.loc[stretch, "slip_velocity"] = -sign * (4e-3 + 4e-3 * (t - t.iloc[0]) / np.ptp(t))
    assert Kind.SLIDE_AS_ROLL in _kinds(grows, labels, e, mu, hoop)


def test_a_friction_above_the_demand_starts_no_slip_in_the_checker():
    """The canonical reading: a friction above the rolling demand brakes a slide already
    going but starts none. DART stock creeps on this hop from 0.52 s, its friction saturated
    1-2 % of the cone short of the demand (the tolerance is 3 %) and the rim reaching
    6.5 mm/s, then up to 7 % above the demand as it falls, braking the rim to rest at
    0.60 s, 0.3 mm in all; its first slip, at the cone, is read at 0.687 s (exact 0.674 s).
    The checker called the braking a clear slip (3 contradictions at dt 1e-3); it still
    contradicts a row that reads no slip at all."""
    frame, labels, exact, mu, hoop = _checked_run(BRAKED)
    assert contradictions(frame, labels, exact, mu=mu, hoop=hoop, loose=loose()) == []
    none = dataclasses.replace(labels, t_slip=None, phases=("R",), verdict="missed-slip")
    assert Kind.SLIP_LABEL in _kinds(frame, none, exact, mu, hoop)


def _checked_run(
    scene: Scene, engine: str = "dart", profile: str = "stock"
) -> tuple[pd.DataFrame, Labels, Exact, float, Hoop]:
    """The engine's run of ``scene`` at dt 1e-3 (DART stock's by default) as the checker
    reads it: its trajectory, its row's labels, the exact solution, mu and the hoop."""
    run = hb.run(engine, scene, timestep=1e-3, profile=profile)
    if run.status is RunStatus.UNAVAILABLE:
        engine_unavailable(engine, run.row.get("message"))
    labels = Labels.from_row(run.row, CANONICAL_NAMES)
    exact = Exact.from_solution(hb.exact(scene), Hoop(scene.a, scene.g))
    return run.trajectory, labels, exact, run.row["mu"], Hoop(scene.a, scene.g, scene)


SLID_WITHOUT_N = Scene(
    lam=0.888109903621521,
    thetadot0=3.1645455094508557,
    mus=0.776546447881074,
    muk=0.776546447881074,
    eps=0.022687785446562053,
    theta0=6.227654241689828,
    t_end=T_END,
    name="random-10",
)
"""A hop drawn at random (seed 9,301,130, a draw of this test's QUOTA), on which DART stock
slides without a normal force (below)."""


def test_a_slide_with_friction_and_no_normal_force_is_a_slip_in_the_checker():
    """DART stock on this hop: from 0.18 s its normal force is round-off (1e-17) while its
    friction, 0.3-1.2 m/s^2, brakes the rim sliding up to 430 mm/s on the floor. The reading
    took those samples as without force (a roll) and read the slip at 0.342 s; a friction is
    a contact force, and both the reading and the checker now read the slide as the slip
    (from 0.183 s; exact 0.148 s). The old reading's row is contradicted."""
    frame, labels, exact, mu, hoop = _checked_run(SLID_WITHOUT_N)
    assert labels.t_slip is not None and labels.t_slip < 0.2
    assert contradictions(frame, labels, exact, mu=mu, hoop=hoop, loose=loose()) == []
    late = dataclasses.replace(labels, t_slip=0.342)
    assert Kind.SLIP_LABEL in _kinds(frame, late, exact, mu, hoop)


SLIPS_WITHOUT_IMPULSE = Scene(
    lam=0.9457652976868376,
    thetadot0=3.211316587212609,
    mus=0.5404252451257464,
    muk=0.5404252451257464,
    eps=0.0385097884643903,
    theta0=0.05339669473021462,
    t_end=T_END,
    name="random-58",
)
"""A hop drawn at random (seed 6,701,130, a draw of this test's QUOTA) whose rolling normal
force starts at 0.005 g: the exact hoop slips at 0.004 s."""


def test_a_slide_the_checker_cannot_read_is_not_clearly_no_slip():
    """pymunk tuned on this hop (dt 1e-3) gives no impulse at all for 0.23 s while its rim
    slides from rest to 0.93 m/s and the hoop sinks 2.2 mm (its solver returns none for such
    a slipping contact: the adapter's docstring), then a load below the checker's LOADED
    level. The row reads a slip from 0 s (a sample without force takes the mode it
    borders): the checker, which cannot read a friction law there, called that a slip read
    without a slip, and the slip late (2 contradictions). With the hoop 5 mm up over those
    samples they are a flight, which no slip may be read in."""
    frame, labels, exact, mu, hoop = _checked_run(SLIPS_WITHOUT_IMPULSE, "pymunk", "tuned")
    free = (frame["t"] < 0.23).to_numpy()
    assert labels.t_slip == 0.0 and np.all(frame.loc[free, "normal_force"].abs() < 1e-9)
    assert contradictions(frame, labels, exact, mu=mu, hoop=hoop, loose=loose()) == []
    up = frame.copy()
    up.loc[free, "clearance"] = 5e-3
    assert Kind.NO_SLIP_AS_SLIP in _kinds(up, labels, exact, mu, hoop)
