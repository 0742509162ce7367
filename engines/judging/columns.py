"""The names of a judged run's row: one vocabulary for the suites, the map, the verdict and
the report.

Rows are plain mappings (they travel to worker processes and into Parquet), so a column is
read by name. Reading ``row.get(Col.EXACT_T_SLIP)`` instead of ``row.get("exact_t_slip")``
makes a misspelt name an AttributeError (and a type checker's error) instead of a column that
silently reads as missing. ``Col`` is a StrEnum: its members are the plain strings stored.
"""

from __future__ import annotations

from enum import StrEnum

__all__ = [
    "BATCH_COLUMNS",
    "COST_COLUMNS",
    "CPU_COLUMNS",
    "EVENT_COLUMNS",
    "EXACT_COLUMNS",
    "FLOOR_COLUMNS",
    "FORCE_COLUMNS",
    "KIN_COLUMNS",
    "RENAMED_FROM_CONTACT",
    "RENAMED_TO_KIN",
    "TRANSITION_COLUMNS",
    "Col",
]


class Col(StrEnum):
    """Every column a runs table (a suite's or a map's) may hold, in no particular order;
    each table states its own order (``ROW_COLUMNS``, ``MAP_COLUMNS``)."""

    # What was run.
    RUN_ID = "run_id"
    SCENE = "scene"
    A = "a"
    """Hoop radius, m: with g, carries the verdict's thresholds to the row's hoop."""
    G = "g"
    """m/s^2."""
    ENGINE = "engine"
    PROFILE = "profile"
    VARIANT = "variant"
    TIMESTEP = "timestep"
    """s."""
    GEOMETRY = "geometry"
    OPTIONS = "options"
    """JSON of the options that differ from the profile's values."""
    # A map point's coordinates.
    IX = "ix"
    IY = "iy"
    X_AXIS = "x_axis"
    Y_AXIS = "y_axis"
    X = "x"
    Y = "y"
    LAM = "lam"
    CHI = "chi"
    MU = "mu"
    """The pair's friction coefficient used."""
    EPS = "eps"
    THETA0_DEG = "theta0_deg"
    T_END = "t_end"
    """s."""
    # How the run went.
    STATUS = "status"
    MESSAGE = "message"
    ENGINE_VERSION = "engine_version"
    WALL_TIME_S = "wall_time_s"
    """s: wall time of the run's stepping (model building excluded); a batched run's share
    of its batch's, by steps. Grows with the machine's load."""
    N_STEPS = "n_steps"
    US_PER_STEP = "us_per_step"
    """us: ``wall_time_s`` per step."""
    CPU_TIME_S = "cpu_time_s"
    """s: the process's CPU time over the same stepping (every thread, user and system); a
    batched run's share of its batch's, by steps. Moves far less with the load than the wall
    time: the cost the answer and the findings rank by."""
    CPU_US_PER_STEP = "cpu_us_per_step"
    """us: ``cpu_time_s`` per step."""
    SIM_TIME_S = "sim_time_s"
    STOP_REASON = "stop_reason"
    # The exact solution of the row's scene and mu.
    REGIME = "regime"
    N_SLIPS = "n_slips"
    EXACT_OUTCOME = "exact_outcome"
    """The exact solution's outcome: ``rolls``, ``slips``, ``hops``, ``lifts-at-start``,
    ``painleve``, ``degenerate`` or ``error``."""
    EXACT_T_SLIP = "exact_t_slip"
    """s: the exact first slip onset."""
    EXACT_THETA_SLIP_DEG = "exact_theta_slip_deg"
    """deg: the angle theta at the exact first slip onset."""
    EXACT_T_LIFT = "exact_t_lift"
    """s: the exact lift-off."""
    EXACT_HOP_HEIGHT = "exact_hop_height"
    """m: the exact hop's largest clearance."""
    EXACT_T_IMPACT = "exact_t_impact"
    """s: the exact first impact (the exact solution ends there)."""
    EXACT_T_PAINLEVE = "exact_t_painleve"
    """s: when a ``painleve`` exact solution reaches its Painlevé point (empty otherwise)."""
    EXACT_PHASES = "exact_phases"
    """The exact phases as codes, e.g. ``R S+ R S- F``: R roll, S+ and S- slip (the rim
    sliding towards +x and -x), F flight."""
    EXACT_T_LAST_PHASE = "exact_t_last_phase"
    """s: the start of the exact last phase."""
    EXACT_MAX_SLIP_SPEED = "exact_max_slip_speed"
    """m/s: the largest exact |slip velocity| before any lift-off (empty: no slip). Where it
    stays below the slip threshold the row has no verdict."""
    EXACT_T_SETTLED = "exact_t_settled"
    # The engine's events by the canonical reading (engines/judging/contact.py), and their
    # errors against the exact ones.
    OUTCOME = "outcome"
    """``hops`` with a hop, else ``slips`` with a slip, else ``rolls`` (``painleve``: the
    reference's own row of a Painlevé scene)."""
    T_SLIP = "t_slip"
    """s: the first slip onset (the first slip mode's start)."""
    THETA_SLIP_DEG = "theta_slip_deg"
    """deg: the angle theta at the first slip onset (interpolated)."""
    T_RESTICK = "t_restick"
    """s: the first re-stick, the start of the first roll after the first slip."""
    T_LIFT = "t_lift"
    """s: the lift-off, where the hop's normal force ends."""
    HOP_HEIGHT = "hop_height"
    """m: the hop's largest clearance."""
    T_IMPACT = "t_impact"
    """s: the impact, where the hop's normal force returns."""
    ERR_T_SLIP_MS = "err_t_slip_ms"
    """ms: ``(t_slip - exact_t_slip) * 1000``; positive: the engine slips late."""
    ERR_THETA_SLIP_DEG = "err_theta_slip_deg"
    """deg: ``theta_slip_deg - exact_theta_slip_deg``; positive: the engine slips at a
    larger theta, later in the roll."""
    ERR_T_LIFT_MS = "err_t_lift_ms"
    """ms: ``(t_lift - exact_t_lift) * 1000``; positive: the engine lifts off late."""
    ERR_T_IMPACT_MS = "err_t_impact_ms"
    """ms: ``(t_impact - exact_t_impact) * 1000``; positive: the engine lands late."""
    ERR_HOP_HEIGHT_REL = "err_hop_height_rel"
    """``hop_height / exact_hop_height - 1``; positive: the engine hops higher."""
    PHASES = "phases"
    """The modes as codes, ending at the hop's impact, e.g. ``R S+ R S- F`` (chattering is
    no phase: ``chattering_time_s``)."""
    PHASE_TIMES = "phase_times"
    """s: the start of each of the run's phases (``phases``), space-separated, repr's
    precision: the transition into phase k starts it (engines/judging/transitions.py)."""
    T_LAST_PHASE = "t_last_phase"
    """s: the start of the last mode."""
    PHASES_AGREE = "phases_agree"
    """The phase codes agree with the exact ones as read at the run's timestep
    (``floor_phases``), one last phase at the window's end aside (the verdict's rule)."""
    N_FLIGHTS = "n_flights"
    """Stretches without a normal force (the flights), hops and chatter together."""
    CHATTER_COUNT = "chatter_count"
    """Flights that are not hops (too short or too low)."""
    CHATTER_MAX_CLEARANCE = "chatter_max_clearance"
    """m: the highest clearance inside those flights (negative: the normal force dropped out
    while the hoop stayed in the floor)."""
    CREEP_TIME_S = "creep_time_s"
    """s: the time spent creeping."""
    CREEP_MAX_SPEED = "creep_max_speed"
    """m/s: the largest |slip velocity| while creeping."""
    CREEP_DISTANCE_M = "creep_distance_m"
    """m: how far the rim slides while creeping (verdict ``creeps``)."""
    CONE_STICK_TIME_S = "cone_stick_time_s"
    """s: the longest stick outside the Coulomb cone (verdict ``cone-violation``)."""
    CHATTERING_TIME_S = "chattering_time_s"
    """s: time the contact chatters (friction at the cone on some steps, inside it on
    average) outside the slips: a property of the phases, not a phase."""
    CHATTER_CONE_SHARE = "chatter_cone_share"
    """Share of the chattering samples whose own friction is at the cone."""
    CHATTERS = "chatters"
    """The chattering flag: the contact chatters for at least the reading's ``sustain`` (5 ms
    on the 1 m hoop) in all."""
    MU_EFFECTIVE = "mu_effective"
    """The engine's effective sliding friction coefficient: the median |f| / n over its slip
    phases' samples that slide faster than the slip threshold."""
    MU_EFFECTIVE_RATIO = "mu_effective_ratio"
    """mu_effective over the pair's mu (1 for Coulomb friction at the cone)."""
    # The whole run, whatever the reading.
    ENERGY_RISE_BEFORE_SLIP = "energy_rise_before_slip"
    ENERGY_CHANGE_END = "energy_change_end"
    MAX_PENETRATION_M = "max_penetration_m"
    RMS_POSITION_M = "rms_position_m"
    MAX_CLEARANCE = "max_clearance"
    T_FINAL = "t_final"
    # The same run read by its clearance and slip velocity (engines/judging/detectors.py):
    # the kinematic reading, shown only where the two readings are compared.
    KIN_OUTCOME = "kin_outcome"
    KIN_T_SLIP = "kin_t_slip"
    KIN_T_SLIP_THRESHOLD = "kin_t_slip_threshold"
    KIN_THETA_SLIP_DEG = "kin_theta_slip_deg"
    KIN_T_RESTICK = "kin_t_restick"
    KIN_T_LIFT = "kin_t_lift"
    KIN_HOP_HEIGHT = "kin_hop_height"
    KIN_T_IMPACT = "kin_t_impact"
    KIN_ERR_T_SLIP_MS = "kin_err_t_slip_ms"
    KIN_ERR_THETA_SLIP_DEG = "kin_err_theta_slip_deg"
    KIN_ERR_T_LIFT_MS = "kin_err_t_lift_ms"
    KIN_ERR_T_IMPACT_MS = "kin_err_t_impact_ms"
    KIN_ERR_HOP_HEIGHT_REL = "kin_err_hop_height_rel"
    KIN_PHASES = "kin_phases"
    KIN_T_LAST_PHASE = "kin_t_last_phase"
    CONSISTENT = "consistent"
    """The kinematic events passed the self-consistency checks (event_checks.py)."""
    EVENT_FLAGS = "event_flags"
    # The exact solution read by the canonical reading at the run's timestep: the detection
    # floor, what the reading can see at that step.
    FLOOR_PHASES = "floor_phases"
    """The exact phases as read at the run's timestep: a phase shorter than the reading
    resolves is absorbed. The verdict compares the engine's phases with these."""
    FLOOR_PHASE_TIMES = "floor_phase_times"
    """s: the start of each floor phase (``floor_phases``), as ``phase_times``."""
    EXACT_PHASE_TIMES = "exact_phase_times"
    """s: the exact solver's (true) start of each floor phase, as ``phase_times`` ('nan' where
    the exact solution has no transition of that kind there): the floor's transitions matched
    to the exact ones by kind and nearest time (engines/judging/transitions.py). A floor
    column despite its name: it holds the exact phases after the floor's absorption, so it
    depends on the run's timestep."""
    FLOOR_T_LAST_PHASE = "floor_t_last_phase"
    """s: the start of the last of those phases."""
    FLOOR_ERR_T_SLIP_MS = "floor_err_t_slip_ms"
    """ms: the reading's own error on the exact first slip onset at the run's timestep;
    the verdict adds its size to the slip onset's tolerance."""
    FLOOR_ERR_T_LIFT_MS = "floor_err_t_lift_ms"
    """ms: the reading's own error on the exact lift-off at the run's timestep; the
    verdict adds its size to the lift-off's tolerance."""
    FLOOR_ERR_T_IMPACT_MS = "floor_err_t_impact_ms"
    """ms: the reading's own error on the exact impact at the run's timestep; the
    verdict adds its size to the impact's tolerance."""
    FLOOR_ERR_HOP_HEIGHT_REL = "floor_err_hop_height_rel"
    """The reading's own relative error on the exact hop height at the run's timestep;
    the verdict adds its size to the hop height's tolerance."""
    # The contact force against the exact one (engines/judging/forces.py); suite rows only.
    FORCE_RMS_N_G = "force_rms_n_g"
    """RMS of ``(n - n_exact) / g`` over the window (the exact contact phases the engine's
    phases agree with: engines/judging/forces.py); empty when the window holds no sample."""
    FORCE_RMS_F_G = "force_rms_f_g"
    """RMS of ``(f - f_exact) / g`` over the window; empty when the window holds no
    sample."""
    CONE_VIOLATION = "cone_violation"
    """The largest ``(|f| - mu n) / g`` over the samples with a contact force (the canonical
    reading's: n above its contact level, or a friction above its friction level), whole run;
    0 when never above. Above 0 (beyond round-off, ~1e-14): friction outside the Coulomb cone;
    a friction without a normal force counts whole (DART stock's, up to 6 g)."""
    DISSIPATION_VIOLATION = "dissipation_violation"
    """The fraction of the window's slipping samples (an exact slip phase, the engine's
    samples with a contact force) whose friction does not oppose the slip velocity
    (``f * slip_velocity > 0``): maximum dissipation says it always opposes. Empty without
    such samples."""
    MAX_PENETRATION_IN_CONTACT_M = "max_penetration_in_contact_m"
    """m: the deepest penetration, ``-clearance``, over the samples with a contact force,
    whole run (0 when none penetrates; empty when none has one). Unlike
    ``max_penetration_m``, a sample that sinks without a force does not count."""
    ENERGY_CHANGE_BEFORE_SLIP = "energy_change_before_slip"
    """``(E(t) - E(0)) / E(0)`` at the exact first slip onset (the window's end when the
    exact solution never slips; E interpolated between samples): rolling conserves energy, so
    any change is the engine's. Empty when that time is past the run."""
    # The verdict.
    VERDICT = "verdict"
    OUTCOME_AGREES = "outcome_agrees"
    VERDICT_FLAGS = "verdict_flags"
    """Every check the run failed, space-separated verdict values, the primary one first."""
    VERDICT_REASON = "verdict_reason"
    """The line that says why, for the primary verdict (which way and by how much)."""
    MAX_TRANSITION_ERR_MS = "max_transition_err_ms"
    """ms, signed (run minus exact: negative is early): the error of ``max_transition``."""
    MAX_TRANSITION = "max_transition"
    """The timed transition whose error is largest against its loose tolerance, of every one
    the verdict timed (the first slip onset, the lift-off, the impact and every later
    transition: 're-stick 1'); empty where none was timed."""
    MAX_TRANSITION_RATIO = "max_transition_ratio"
    """|max_transition_err_ms| over that transition's loose tolerance (the row's detection
    floor of it included): above 1 the verdict fails it."""
    HOP_HEIGHT_ERROR = "hop_height_error"
    # Where the run's trajectory is stored.
    TRAJECTORY_FILE = "trajectory_file"
    # What the batch the run was stepped in cost (engines/base.py, Batches); a run stepped
    # alone is a batch of one.
    BATCH_SIZE = "batch_size"
    """Worlds stepped together."""
    US_PER_WORLD_STEP = "us_per_world_step"
    """The batch's wall time over its world-steps (the steps of all its runs), us."""
    WORLD_STEPS_PER_S = "world_steps_per_s"
    """The batch's throughput: world-steps per second of its wall time."""
    CPU_US_PER_WORLD_STEP = "cpu_us_per_world_step"
    """The batch's CPU time over its world-steps, us."""


EXACT_COLUMNS = (
    Col.EXACT_OUTCOME,
    Col.EXACT_T_SLIP,
    Col.EXACT_THETA_SLIP_DEG,
    Col.EXACT_T_LIFT,
    Col.EXACT_HOP_HEIGHT,
    Col.EXACT_T_IMPACT,
    Col.EXACT_T_PAINLEVE,
    Col.EXACT_PHASES,
    Col.EXACT_T_LAST_PHASE,
    Col.EXACT_MAX_SLIP_SPEED,
)
"""The exact columns every judged row carries (:func:`comparison.exact_columns`)."""

EVENT_COLUMNS = (
    Col.OUTCOME,
    Col.T_SLIP,
    Col.THETA_SLIP_DEG,
    Col.T_RESTICK,
    Col.T_LIFT,
    Col.HOP_HEIGHT,
    Col.T_IMPACT,
    Col.ERR_T_SLIP_MS,
    Col.ERR_THETA_SLIP_DEG,
    Col.ERR_T_LIFT_MS,
    Col.ERR_T_IMPACT_MS,
    Col.ERR_HOP_HEIGHT_REL,
    Col.PHASES,
    Col.PHASE_TIMES,
    Col.T_LAST_PHASE,
    Col.PHASES_AGREE,
    Col.N_FLIGHTS,
    Col.CHATTER_COUNT,
    Col.CHATTER_MAX_CLEARANCE,
    Col.CREEP_TIME_S,
    Col.CREEP_MAX_SPEED,
    Col.CREEP_DISTANCE_M,
    Col.CONE_STICK_TIME_S,
    Col.CHATTERING_TIME_S,
    Col.CHATTER_CONE_SHARE,
    Col.CHATTERS,
    Col.MU_EFFECTIVE,
    Col.MU_EFFECTIVE_RATIO,
)
"""The canonical reading's columns (:func:`comparison.event_columns`), in every judged row
of a suite and a map."""

KIN_COLUMNS = (
    Col.KIN_OUTCOME,
    Col.KIN_T_SLIP,
    Col.KIN_T_SLIP_THRESHOLD,
    Col.KIN_THETA_SLIP_DEG,
    Col.KIN_T_RESTICK,
    Col.KIN_T_LIFT,
    Col.KIN_HOP_HEIGHT,
    Col.KIN_T_IMPACT,
    Col.KIN_ERR_T_SLIP_MS,
    Col.KIN_ERR_THETA_SLIP_DEG,
    Col.KIN_ERR_T_LIFT_MS,
    Col.KIN_ERR_T_IMPACT_MS,
    Col.KIN_ERR_HOP_HEIGHT_REL,
    Col.KIN_PHASES,
    Col.KIN_T_LAST_PHASE,
    Col.CONSISTENT,
    Col.EVENT_FLAGS,
)
"""The kinematic reading's columns (:func:`comparison.kin_columns`): only the section that
compares the two readings shows them."""

FLOOR_COLUMNS = (
    Col.FLOOR_PHASES,
    Col.FLOOR_PHASE_TIMES,
    Col.EXACT_PHASE_TIMES,
    Col.FLOOR_T_LAST_PHASE,
    Col.FLOOR_ERR_T_SLIP_MS,
    Col.FLOOR_ERR_T_LIFT_MS,
    Col.FLOOR_ERR_T_IMPACT_MS,
    Col.FLOOR_ERR_HOP_HEIGHT_REL,
)
"""The exact solution read at the run's timestep (:func:`comparison.floor_columns`): what
the verdict absorbs."""

TRANSITION_COLUMNS = (Col.MAX_TRANSITION_ERR_MS, Col.MAX_TRANSITION, Col.MAX_TRANSITION_RATIO)
"""The verdict's largest transition error (:func:`verdict.verdict_columns`), in every judged
row of a suite and a map."""

RENAMED_TO_KIN = {
    "outcome": Col.KIN_OUTCOME,
    "t_slip": Col.KIN_T_SLIP,
    "t_slip_threshold": Col.KIN_T_SLIP_THRESHOLD,
    "theta_slip_deg": Col.KIN_THETA_SLIP_DEG,
    "t_restick": Col.KIN_T_RESTICK,
    "t_lift": Col.KIN_T_LIFT,
    "hop_height": Col.KIN_HOP_HEIGHT,
    "t_impact": Col.KIN_T_IMPACT,
    "err_t_slip_ms": Col.KIN_ERR_T_SLIP_MS,
    "err_theta_slip_deg": Col.KIN_ERR_THETA_SLIP_DEG,
    "err_t_lift_ms": Col.KIN_ERR_T_LIFT_MS,
    "err_t_impact_ms": Col.KIN_ERR_T_IMPACT_MS,
    "err_hop_height_rel": Col.KIN_ERR_HOP_HEIGHT_REL,
    "phases": Col.KIN_PHASES,
    "t_last_phase": Col.KIN_T_LAST_PHASE,
}
"""Issue 24's migration, step 1: the unprefixed event columns of a table stored before it
held the kinematic reading."""

RENAMED_FROM_CONTACT = {
    "contact_phases": Col.PHASES,
    "contact_t_slip": Col.T_SLIP,
    "contact_t_restick": Col.T_RESTICK,
    "contact_t_lift": Col.T_LIFT,
    "contact_t_impact": Col.T_IMPACT,
    "contact_hop_height": Col.HOP_HEIGHT,
    "contact_t_last_phase": Col.T_LAST_PHASE,
    "err_contact_t_slip_ms": Col.ERR_T_SLIP_MS,
    "err_contact_t_lift_ms": Col.ERR_T_LIFT_MS,
    "err_contact_t_impact_ms": Col.ERR_T_IMPACT_MS,
}
"""Step 2: its ``contact_*`` columns held the contact reading, now the unprefixed ones."""

FORCE_COLUMNS = (
    Col.FORCE_RMS_N_G,
    Col.FORCE_RMS_F_G,
    Col.CONE_VIOLATION,
    Col.DISSIPATION_VIOLATION,
    Col.MAX_PENETRATION_IN_CONTACT_M,
    Col.ENERGY_CHANGE_BEFORE_SLIP,
)
"""The contact-force columns against the exact solution (engines/judging/forces.py), in a
suite's rows (judged with the exact solution); a map's rows have none."""

BATCH_COLUMNS = (Col.BATCH_SIZE, Col.US_PER_WORLD_STEP, Col.WORLD_STEPS_PER_S)
"""A run's batch cost (:func:`comparison.cost_columns`), in every row of a suite and a map
beside the run's own cost (wall_time_s, us_per_step)."""

CPU_COLUMNS = (Col.CPU_TIME_S, Col.CPU_US_PER_STEP, Col.CPU_US_PER_WORLD_STEP)
"""The process's CPU time over a run's stepping, and over its batch's (issue 34): in every
row of a suite and a map beside the wall-time ones."""

COST_COLUMNS = (
    Col.WALL_TIME_S,
    Col.US_PER_STEP,
    Col.BATCH_SIZE,
    Col.US_PER_WORLD_STEP,
    Col.WORLD_STEPS_PER_S,
    *CPU_COLUMNS,
)
"""What a run cost, and the batch it was stepped in: the only columns that differ between two
runs of the same task (alone or in a batch, on one machine or a cluster)."""
