"""What a learned agent's shield keeps the footprint off: the scan, and a short memory of it.

The hybrid agent's policy (`pico_gym.agents.hybrid`) commands pass the classic safety filter
(`pico_gym.agents.classic.potential_field.safety_filter`) before they reach the robot: the
footprint is kept off the points the filter is given. The LRF sees about 230 degrees; behind the
robot it is blind, and a robot that turns while it drives sideways swings its rear into what it
saw a moment ago and sees no more. `ScanMemory` keeps the scans' near end points of the last
seconds in the odometry frame (drift over a few seconds is millimetres) and hands them back in
the robot's frame; the filter takes those in its blind sector.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from pico_gym.types import FloatArray, Pose

# Points farther than this from the robot cannot matter to the filter within its horizon [m].
REACH_M = 1.2


class ScanMemory:
    """The near end points of the last `seconds` of scans (odometry frame).

    Args:
        seconds: how long a point is kept.
        dt_s: the control period (one scan per step).
        stride: keep every `stride`-th end point (1,000 beams: 2 cm apart at 1 m with 5).
    """

    def __init__(self, seconds: float, dt_s: float, stride: int = 5) -> None:
        if not (math.isfinite(seconds) and seconds >= 0.0):
            raise ValueError(f"ScanMemory seconds must be >= 0, got {seconds!r}")
        self.steps = int(round(seconds / dt_s))
        self.stride = stride
        self._scans: deque[FloatArray] = deque(maxlen=max(self.steps, 1))

    def reset(self) -> None:
        self._scans.clear()

    def add(self, points: FloatArray, odom: Pose) -> None:
        """Keep a scan's robot-frame end points (those within `REACH_M`), taken at `odom`."""
        if self.steps == 0:
            return
        pts = points[:: self.stride]
        pts = pts[np.hypot(pts[:, 0], pts[:, 1]) < REACH_M]
        c, s = math.cos(odom.theta), math.sin(odom.theta)
        self._scans.append(
            np.column_stack([odom.x + c * pts[:, 0] - s * pts[:, 1], odom.y + s * pts[:, 0] + c * pts[:, 1]])
        )

    def recent(self, odom: Pose) -> FloatArray:
        """The kept points within `REACH_M` (a square) of the robot at `odom`, robot frame."""
        if not self._scans:
            return np.zeros((0, 2))
        d = np.vstack(self._scans) - np.array([odom.x, odom.y])
        d = d[(np.abs(d[:, 0]) < REACH_M) & (np.abs(d[:, 1]) < REACH_M)]
        c, s = math.cos(odom.theta), math.sin(odom.theta)
        return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])
