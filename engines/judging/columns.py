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
    N_STEPS = "n_steps"
    US_PER_STEP = "us_per_step"
    SIM_TIME_S = "sim_time_s"
    STOP_REASON = "stop_reason"
    # The exact solution of the row's scene and mu.
    REGIME = "regime"
    N_SLIPS = "n_slips"
    EXACT_OUTCOME = "exact_outcome"
    EXACT_T_SLIP = "exact_t_slip"
    EXACT_THETA_SLIP_DEG = "exact_theta_slip_deg"
    EXACT_T_LIFT = "exact_t_lift"
    EXACT_HOP_HEIGHT = "exact_hop_height"
    EXACT_T_IMPACT = "exact_t_impact"
    EXACT_T_PAINLEVE = "exact_t_painleve"
    EXACT_PHASES = "exact_phases"
    EXACT_T_LAST_PHASE = "exact_t_last_phase"
    EXACT_MAX_SLIP_SPEED = "exact_max_slip_speed"
    EXACT_T_SETTLED = "exact_t_settled"
    # The engine's events by the canonical reading (engines/judging/contact.py), and their
    # errors against the exact ones.
    OUTCOME = "outcome"
    T_SLIP = "t_slip"
    THETA_SLIP_DEG = "theta_slip_deg"
    T_RESTICK = "t_restick"
    T_LIFT = "t_lift"
    HOP_HEIGHT = "hop_height"
    T_IMPACT = "t_impact"
    ERR_T_SLIP_MS = "err_t_slip_ms"
    ERR_THETA_SLIP_DEG = "err_theta_slip_deg"
    ERR_T_LIFT_MS = "err_t_lift_ms"
    ERR_T_IMPACT_MS = "err_t_impact_ms"
    ERR_HOP_HEIGHT_REL = "err_hop_height_rel"
    PHASES = "phases"
    PHASE_TIMES = "phase_times"
    """s: the start of each of the run's phases (``phases``), space-separated, repr's
    precision: the transition into phase k starts it (engines/judging/transitions.py)."""
    T_LAST_PHASE = "t_last_phase"
    PHASES_AGREE = "phases_agree"
    N_FLIGHTS = "n_flights"
    """Stretches without contact force, hops and chatter together."""
    CHATTER_COUNT = "chatter_count"
    CHATTER_MAX_CLEARANCE = "chatter_max_clearance"
    """m."""
    CREEP_TIME_S = "creep_time_s"
    CREEP_MAX_SPEED = "creep_max_speed"
    """m/s."""
    CREEP_DISTANCE_M = "creep_distance_m"
    """m: how far the rim slides while creeping (verdict creeps)."""
    CONE_STICK_TIME_S = "cone_stick_time_s"
    """s: the longest stick outside the Coulomb cone (verdict cone-violation)."""
    CHATTERING_TIME_S = "chattering_time_s"
    """s: time in chattering modes (phase code C)."""
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
    """The exact phases as read at the run's timestep (shorter ones absorbed)."""
    FLOOR_PHASE_TIMES = "floor_phase_times"
    """s: the start of each floor phase (``floor_phases``), as ``phase_times``."""
    EXACT_PHASE_TIMES = "exact_phase_times"
    """s: the exact solver's (true) start of each floor phase, as ``phase_times`` ('nan' where
    the exact solution has no transition of that kind there): the floor's transitions matched
    to the exact ones by kind and nearest time (engines/judging/transitions.py). A floor
    column despite its name: it holds the exact phases after the floor's absorption, so it
    depends on the run's timestep."""
    FLOOR_T_LAST_PHASE = "floor_t_last_phase"
    FLOOR_ERR_T_SLIP_MS = "floor_err_t_slip_ms"
    FLOOR_ERR_T_LIFT_MS = "floor_err_t_lift_ms"
    FLOOR_ERR_T_IMPACT_MS = "floor_err_t_impact_ms"
    FLOOR_ERR_HOP_HEIGHT_REL = "floor_err_hop_height_rel"
    # The contact force against the exact one (engines/judging/forces.py); suite rows only.
    FORCE_RMS_N_G = "force_rms_n_g"
    FORCE_RMS_F_G = "force_rms_f_g"
    CONE_VIOLATION = "cone_violation"
    """(|f| - mu n)/g at its largest over the samples with a contact force; 0 if never above."""
    DISSIPATION_VIOLATION = "dissipation_violation"
    """Fraction of the slipping samples whose friction does not oppose the slip."""
    MAX_PENETRATION_IN_CONTACT_M = "max_penetration_in_contact_m"
    ENERGY_CHANGE_BEFORE_SLIP = "energy_change_before_slip"
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

COST_COLUMNS = (
    Col.WALL_TIME_S,
    Col.US_PER_STEP,
    Col.BATCH_SIZE,
    Col.US_PER_WORLD_STEP,
    Col.WORLD_STEPS_PER_S,
)
"""What a run cost, and the batch it was stepped in: the only columns that differ between two
runs of the same task (alone or in a batch, on one machine or a cluster)."""
