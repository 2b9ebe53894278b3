"""Design criteria of the cable and of the whole robot: the cable's strength against its
winch, and the lowest natural frequency (the one criterion differentiated numerically).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from tension_opt import CableRobot

from ..errors import InvalidDesignError
from ..materials import breaking_load
from ..response import natural_frequencies
from .base import Criterion, CriterionValue, checked_poses, positive, soft_max
from .space import RobotGradient

__all__ = ["CableStrength", "LowestFrequency"]


class CableStrength(Criterion):
    """The load of the most loaded winch's cable over its breaking load,
    ``safety * max_i t_max_i / breaking_load(d)``: bound it by 1 to size the cable for
    its winch (:func:`catenary.breaking_load`, the rope's strength on its nominal
    section).

    Parameters
    ----------
    safety : float
        The safety factor (default 3).
    material : str, optional
        The catalogue material; default: the design space's (set by the optimiser).
    """

    name = "cable strength use"
    unit = ""

    def __init__(self, safety: float = 3.0, material: str | None = None) -> None:
        self.safety = positive(safety, "safety")
        self.material = material

    def with_material(self, material: str | None) -> Criterion:
        """Bound to the space's ``material`` unless a material was given here."""
        if material is None or self.material is not None:
            return self
        return CableStrength(self.safety, material)

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        if self.material is None or robot.cable is None:
            raise InvalidDesignError("CableStrength needs a catalogue material (material= "
                                     "here or on the DesignSpace) and a robot with a cable")
        d = robot.cable.diameter
        strength = float(breaking_load(self.material, d))
        if not np.isfinite(strength):
            raise InvalidDesignError(f"the catalogue knows no rope strength of "
                                     f"{self.material!r}: choose another material")
        t_max = np.broadcast_to(np.asarray(robot.t_max, dtype=float), (robot.m,))
        if not np.isfinite(t_max).all():
            raise InvalidDesignError("CableStrength needs finite t_max on every winch: "
                                     "robot.with_(t_max=...)")
        top = int(np.argmax(t_max))
        value = self.safety * float(t_max[top]) / strength
        d_t = np.zeros(robot.m)
        d_t[top] = self.safety / strength
        grad = RobotGradient(np.zeros((robot.m, 3)), np.zeros((robot.m, 3)),
                             -2.0 * value / d, d_t)
        return CriterionValue(value, value, grad)


class LowestFrequency(Criterion):
    """The lowest natural frequency (Hz) over poses (:func:`catenary.natural_frequencies`),
    made smooth by a soft minimum; differentiated numerically by the optimiser.

    Parameters
    ----------
    poses : array_like, shape (N, n)
    model : {"coupled", "straight"}
        The stiffness model (default ``"coupled"``).
    temperature : float
        Of the soft minimum (Hz), default 0.01.
    """

    name = "lowest frequency"
    unit = "Hz"
    numeric = True

    def __init__(self, poses: ArrayLike, model: str = "coupled",
                 temperature: float = 0.01) -> None:
        self.poses = checked_poses(poses, "poses")
        if model not in ("coupled", "straight"):
            raise InvalidDesignError(f"model must be 'coupled' or 'straight', got {model!r}")
        self.model = model
        self.temperature = positive(temperature, "temperature")

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        f = natural_frequencies(robot, robot.as_poses(self.poses), model=self.model)  # type: ignore[arg-type]
        lowest = f[:, 0]
        bad = ~np.isfinite(lowest)
        if bad.any():
            return CriterionValue(np.nan, np.nan, None, 0, int(bad.sum()))
        value, _ = soft_max(-lowest, self.temperature)
        return CriterionValue(-value, float(lowest.min()), None)
