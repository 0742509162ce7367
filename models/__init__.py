"""The weighted hoop: its scene description, result types and engine translations.

This layer imports nothing from ``reference``, ``engines`` or ``reports``.
"""

from hoopbench.models.events import Events, Outcome, Phase, PhaseKind
from hoopbench.models.scene import DegenerateSceneError, Scene
from hoopbench.models.trajectory import Trajectory

__all__ = ["DegenerateSceneError", "Events", "Outcome", "Phase", "PhaseKind", "Scene", "Trajectory"]
