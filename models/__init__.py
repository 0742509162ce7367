"""The weighted hoop: its scene description, result types and engine translations.

This layer imports nothing from ``reference``, ``engines`` or ``reports``.
"""

from models.events import Events, Outcome, Phase, PhaseKind
from models.scene import DegenerateSceneError, Scene
from models.trajectory import Trajectory

__all__ = ["DegenerateSceneError", "Events", "Outcome", "Phase", "PhaseKind", "Scene", "Trajectory"]
