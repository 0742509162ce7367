"""The reference solvers of the weighted hoop: exact event-driven, and the seed's scheme."""

from hoopbench.reference.exact import (
    DEFAULT_ATOL,
    DEFAULT_MAX_PHASES,
    DEFAULT_MAX_SAMPLES,
    DEFAULT_MAX_STEPS,
    DEFAULT_RTOL,
    ExactSolution,
    WorkBudgetError,
    solve_exact,
)
from hoopbench.reference.seed_euler import SeedEulerResult, min_step, solve_seed_euler

__all__ = [
    "DEFAULT_ATOL",
    "DEFAULT_MAX_PHASES",
    "DEFAULT_MAX_SAMPLES",
    "DEFAULT_MAX_STEPS",
    "DEFAULT_RTOL",
    "ExactSolution",
    "SeedEulerResult",
    "WorkBudgetError",
    "min_step",
    "solve_exact",
    "solve_seed_euler",
]
