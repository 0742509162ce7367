"""The reference solvers of the weighted hoop: exact event-driven, and the seed's scheme."""

from hoopbench.reference.exact import ExactSolution, solve_exact
from hoopbench.reference.seed_euler import SeedEulerResult, solve_seed_euler

__all__ = ["ExactSolution", "SeedEulerResult", "solve_exact", "solve_seed_euler"]
