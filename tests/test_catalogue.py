"""The scene catalogue: valid scenes, and each one does what its ``why`` says (exact solver)."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import re

import pytest

from hoopbench.models.catalogue import SCENES, get_scene, scene_names
from hoopbench.models.events import Outcome, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.reference import dynamics
from hoopbench.reference.exact import ExactSolution, solve_exact
from hoopbench.reference.find_scenes import perturbations

# Numbers each scene's `why` quotes, as the text written there: the test checks that the text is
# in the `why` and that the exact solver's value rounds to it. Keys are Events fields, or
# "theta_*_deg" (degrees, mod 360), "extra:<key>", "phases[i].t_start".
QUOTED: dict[str, dict[str, str]] = {
    "seed": {
        "t_slip": "0.98708",
        "theta_slip_deg": "88.504",
        "t_restick": "1.23075",
        "phases[4].t_start": "1.72642",
    },
    "seed-pi": {
        "t_slip": "0.03712",
        "theta_slip_deg": "210.731",
        "thetadot_slip": "10.109",
        "t_restick": "0.54334",
    },
    "seed-mu": {"t_slip": "0.98708", "t_restick": "1.22833"},
    "massless": {"t_slip": "0.91526", "theta_slip_deg": "77.3196"},
    "hop-top": {
        "t_slip": "0.44203",
        "t_restick": "0.77635",
        "phases[3].t_start": "0.81092",
        "t_lift": "1.17108",
        "theta_lift_deg": "315.3",
        "hop_height": "0.3800",
        "t_impact": "2.03055",
    },
    "hop-low": {
        "t_slip": "0.46591",
        "t_lift": "1.30077",
        "hop_height": "0.03297",
        "t_impact": "1.79990",
    },
    "hop-bottom": {
        "t_slip": "0.11353",
        "theta_slip_deg": "234.34",
        "t_lift": "0.31084",
        "theta_lift_deg": "305.5",
        "hop_height": "0.4340",
        "t_impact": "1.02034",
    },
    "slip-reversal": {
        "t_slip": "0.56263",
        "phases[2].t_start": "1.24580",
        "t_restick": "1.33527",
        "phases[5].t_start": "1.86570",
    },
    "painleve": {"extra:theta_painleve_deg": "311.357", "extra:t_painleve": "0.18418"},
    "high-spin": {
        "t_slip": "0.09635",
        "theta_slip_deg": "17.41",
        "t_restick": "0.64562",
        "t_lift": "0.91960",
        "hop_height": "1.4840",
        "t_impact": "1.96628",
    },
    "low-friction": {
        "t_slip": "0.21000",
        "theta_slip_deg": "12.14",
        "phases[2].t_start": "0.90747",
        "phases[3].t_start": "0.98288",
        "phases[4].t_start": "1.62579",
        "t_restick": "1.89823",
        "phases[6].t_start": "2.45604",
    },
}

OUTCOMES = {
    "seed": Outcome.SLIPS,
    "seed-pi": Outcome.SLIPS,
    "seed-mu": Outcome.SLIPS,
    "massless": Outcome.DEGENERATE,
    "hop-top": Outcome.HOPS,
    "hop-low": Outcome.HOPS,
    "hop-bottom": Outcome.HOPS,
    "slip-reversal": Outcome.SLIPS,
    "painleve": Outcome.PAINLEVE,
    "high-spin": Outcome.HOPS,
    "low-friction": Outcome.SLIPS,
}
HOP_SCENES = [name for name, outcome in OUTCOMES.items() if outcome is Outcome.HOPS]


@pytest.fixture(scope="module")
def solutions() -> dict[str, ExactSolution]:
    return {name: solve_exact(scene) for name, scene in SCENES.items()}


def _value(solution: ExactSolution, key: str) -> float:
    events = solution.events
    if match := re.fullmatch(r"phases\[(\d+)\]\.t_start", key):
        return events.phases[int(match[1])].t_start
    if key.startswith("extra:"):
        return float(events.extra[key.removeprefix("extra:")])
    if key == "theta_slip_deg":
        return math.degrees(events.theta_slip) % 360.0
    if key == "theta_lift_deg":
        return math.degrees(solution.state(events.t_lift)[2, 0]) % 360.0
    return float(getattr(events, key))


# --------------------------------------------------------------------------- the mapping
def test_names_and_mapping_agree() -> None:
    assert scene_names() == tuple(SCENES)
    assert set(scene_names()) == set(OUTCOMES) == set(QUOTED)
    for name, scene in SCENES.items():
        assert scene.name == name
        assert scene.why.strip()
        assert get_scene(name) is scene


def test_mapping_is_read_only() -> None:
    with pytest.raises(TypeError):
        SCENES["seed"] = SCENES["seed-mu"]  # type: ignore[index]


def test_unknown_name_lists_valid_names() -> None:
    with pytest.raises(ValueError, match=r"^name must be a catalogue scene \(seed, seed-pi, ") as e:
        get_scene("nope")
    message = str(e.value)
    assert message.endswith("got 'nope'")
    for name in SCENES:
        assert name in message


def test_non_string_name_is_a_value_error() -> None:
    with pytest.raises(ValueError, match="name must be a catalogue scene"):
        get_scene(3)  # type: ignore[arg-type]


# Every field that counts in a Scene's equality, with a value the Scene must reject.
INVALID = {
    "lam": 1.5,
    "thetadot0": math.nan,
    "mus": -0.1,
    "muk": -0.1,
    "eps": -0.01,
    "theta0": math.inf,
    "g": 0.0,
    "a": -1.0,
    "M": 0.0,
    "t_end": 0.0,
    "xdot0": math.nan,
}


def test_invalid_lists_every_compared_field() -> None:
    assert set(INVALID) == {f.name for f in dataclasses.fields(Scene) if f.compare}


@pytest.mark.parametrize("name", list(SCENES))
def test_scene_round_trips_through_to_dict(name: str) -> None:
    """The catalogue scene, written out as plain JSON and built again (validated), is itself."""
    scene = SCENES[name]
    fields = json.loads(json.dumps(scene.to_dict(), allow_nan=False))
    assert fields.pop("chi") == scene.chi
    assert set(fields) == set(INVALID) | {"name"}
    rebuilt = Scene(**fields)
    assert rebuilt == scene
    assert rebuilt.name == name


@pytest.mark.parametrize("field", list(INVALID))
def test_one_bad_field_is_named(field: str) -> None:
    """In any catalogue scene, one invalid field raises a ValueError that names it first."""
    for name, scene in SCENES.items():
        with pytest.raises(ValueError, match=rf"^{field}\b"):
            scene.with_(**{field: INVALID[field]})
            pytest.fail(f"{name}: {field} = {INVALID[field]} accepted")


# --------------------------------------------------------------------------- required parameters
def test_seed_parameters() -> None:
    seed = get_scene("seed")
    assert (seed.g, seed.a, seed.lam, seed.eps, seed.theta0) == (9.8, 1.0, 0.95, 0.01, 0.0)
    assert (seed.mus, seed.muk, seed.t_end, seed.xdot0) == (0.8, 0.7, 3.0, None)
    assert seed.chi == pytest.approx(0.1, rel=1e-12)


def test_seed_variants() -> None:
    seed, seed_pi, seed_mu = get_scene("seed"), get_scene("seed-pi"), get_scene("seed-mu")
    assert seed_pi.theta0 == math.pi
    assert seed_pi.thetadot0 == pytest.approx(19.36699, abs=1e-5)
    assert seed_pi.energy_per_mass == pytest.approx(seed.energy_per_mass, rel=1e-12)
    assert (seed_pi.mus, seed_pi.muk) == (1.0, 0.7)
    assert seed_mu == seed.with_(mus=0.8, muk=0.8)


def test_massless_and_painleve_parameters() -> None:
    massless = get_scene("massless")
    assert (massless.lam, massless.eps, massless.mus, massless.muk) == (1.0, 0.0, 0.8, 0.8)
    assert massless.chi == pytest.approx(0.1, rel=1e-12)
    painleve = get_scene("painleve")
    assert (painleve.lam, painleve.eps, painleve.mus, painleve.muk) == (0.9, 0.0, 0.6, 0.6)
    assert math.degrees(painleve.theta0) == pytest.approx(300.0)
    assert (painleve.thetadot0, painleve.xdot0) == (0.0, 10.0)
    assert painleve.muk > math.sqrt(1 - painleve.lam**2) / painleve.lam


def test_extreme_scenes_are_extreme() -> None:
    assert get_scene("high-spin").chi == pytest.approx(1.0, rel=1e-12)
    low = get_scene("low-friction")
    assert (low.mus, low.muk) == (0.1, 0.1)


# --------------------------------------------------------------------------- exact outcomes
@pytest.mark.parametrize("name", list(SCENES))
def test_outcome(name: str, solutions: dict[str, ExactSolution]) -> None:
    assert solutions[name].events.outcome is OUTCOMES[name]


@pytest.mark.parametrize("name", list(SCENES))
def test_quoted_numbers(name: str, solutions: dict[str, ExactSolution]) -> None:
    why = SCENES[name].why
    for key, text in QUOTED[name].items():
        assert text in why, f"{name}: why does not quote {text} ({key})"
        decimals = len(text.partition(".")[2])
        value = _value(solutions[name], key)
        assert abs(value - float(text)) <= 0.5 * 10.0**-decimals + 1e-12, (name, key, value)


@pytest.mark.parametrize("name", HOP_SCENES)
def test_hop_scenes_really_hop(name: str, solutions: dict[str, ExactSolution]) -> None:
    scene, events = SCENES[name], solutions[name].events
    assert scene.xdot0 is None and scene.mus == scene.muk
    assert events.t_lift is not None and events.t_impact is not None
    assert 0.0 < events.t_lift <= 2.0
    assert events.hop_height > 1e-3
    assert events.t_impact - events.t_lift > 0.01
    # A lift-off from slipping far from D = 0 is a clean one, not the Painlevé point.
    before = events.phases[-2]
    assert before.kind is PhaseKind.SLIP
    theta = solutions[name].state(events.t_lift)[2, 0]
    assert dynamics.slip_denominator(scene, theta, before.sigma) > 0.5


def test_hop_scenes_cover_two_regimes() -> None:
    regimes = {(SCENES[n].theta0, SCENES[n].lam) for n in HOP_SCENES}
    assert len({theta0 for theta0, _ in regimes}) >= 2
    assert len({lam for _, lam in regimes}) >= 2


@pytest.mark.parametrize("name", HOP_SCENES)
def test_hops_survive_small_changes(name: str) -> None:
    changed = perturbations(SCENES[name], 1e-3)
    assert len(changed) >= 8
    for label, scene in changed:
        events = solve_exact(scene).events
        assert events.outcome is Outcome.HOPS, label
        assert events.hop_height > 1e-3, label


def test_seed_resticks(solutions: dict[str, ExactSolution]) -> None:
    kinds = [p.kind for p in solutions["seed"].events.phases]
    assert kinds[:3] == [PhaseKind.ROLL, PhaseKind.SLIP, PhaseKind.ROLL]
    assert solutions["seed"].events.t_restick is not None


@pytest.mark.parametrize("name", ["slip-reversal", "low-friction"])
def test_slip_reverses_without_resticking(name: str, solutions: dict[str, ExactSolution]) -> None:
    phases = solutions[name].events.phases
    reversals = [
        (p, q)
        for p, q in itertools.pairwise(phases)
        if p.kind is q.kind is PhaseKind.SLIP and p.sigma == -q.sigma != 0
    ]
    assert reversals
    for p, q in reversals:
        assert p.t_end == q.t_start


def test_massless_slips_at_the_closed_form_angle(solutions: dict[str, ExactSolution]) -> None:
    scene, events = get_scene("massless"), solutions["massless"].events
    expected = min(math.acos(scene.chi), 2.0 * math.atan(scene.mus))
    assert events.theta_slip == pytest.approx(expected, abs=1e-8)
