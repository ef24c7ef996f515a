"""What an agent asks the renderer to draw on top of the world (its own view of things).

An agent thinks in its odometry frame; the renderer places an overlay given in that frame where the
agent believes it is, so odometry drift shows as a drift of the overlay against the map.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from pico_gym.types import FloatArray


@dataclass
class Overlay:
    """Shapes to draw, all in one frame.

    Attributes:
        frame: "odom" (the agent's odometry frame), "robot" (the robot's body frame) or "map".
        segments: (N, 4) line segments, e.g. extracted walls.
        points: (M, 2) points, e.g. corners or exit candidates.
        path: (K, 2) a planned path, drawn as a polyline.
        target: (2,) the current set-point, or None.
        text: a short status line (e.g. the agent's state).
    """

    frame: Literal["odom", "robot", "map"] = "odom"
    segments: FloatArray = field(default_factory=lambda: np.zeros((0, 4)))
    points: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    path: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    target: FloatArray | None = None
    text: str = ""
