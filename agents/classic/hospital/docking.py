"""Docking: a cabinet's front as the LRF sees it, and where the robot should stand before it.

The arrival square lies in front of the cabinet's front; the pose estimate may be a few
centimetres or degrees off, so the last metre is servoed on the front itself: a line fitted to the
scan points near where the front is expected gives the depth and the angle to face it squarely
(`fit_front`); only the position along the front comes from the estimate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pico_gym.types import FloatArray


@dataclass(frozen=True)
class FrontFit:
    """A cabinet's front as the LRF sees it, robot frame.

    Attributes:
        goal: (2,) where the robot's centre should be: on the front's centre line, `depth` in
            front of the fitted line.
        heading_error: how far the robot must turn to face the front squarely [rad].
        depth_m: the robot centre's distance from the fitted line [m].
        n_points: the scan points the line was fitted to.
    """

    goal: FloatArray
    heading_error: float
    depth_m: float
    n_points: int


def fit_front(
    points: FloatArray, front: FloatArray, depth_m: float, within_m: float = 0.08, min_points: int = 8
) -> FrontFit | None:
    """Fit a line to the scan points (robot frame) near where a cabinet's front is expected
    (`front`: its two end points, robot frame, from the pose estimate), and the docking goal it
    gives: depth and angle come from the line itself, so they hold even when the pose estimate
    is a few centimetres or degrees off; only the position along the front comes from the
    estimate (the middle of the expected front, projected onto the line). None when fewer than
    `min_points` points lie within `within_m` of the expected front.

    >>> front = np.array([[0.5, 0.3], [0.5, -0.3]])  # a 0.6 m front 0.5 m straight ahead
    >>> pts = np.column_stack([np.full(31, 0.52), np.linspace(-0.3, 0.3, 31)])  # seen 2 cm deeper
    >>> fit = fit_front(pts, front, 0.33)
    >>> [round(float(v), 3) + 0.0 for v in fit.goal], round(fit.heading_error, 3), round(fit.depth_m, 3)
    ([0.19, 0.0], 0.0, 0.52)
    """
    a, b = np.asarray(front[0], dtype=np.float64), np.asarray(front[1], dtype=np.float64)
    along = b - a
    length = float(np.hypot(*along))
    if length < 1e-9 or len(points) == 0:
        return None
    u = along / length
    rel = points - a
    t = rel @ u
    off = rel @ np.array([-u[1], u[0]])
    near = points[(np.abs(off) <= within_m) & (t >= -0.05) & (t <= length + 0.05)]
    if len(near) < min_points:
        return None
    centre = near.mean(axis=0)
    _, _, vt = np.linalg.svd(near - centre, full_matrices=False)
    direction = vt[0]
    normal = np.array([-direction[1], direction[0]])
    if centre @ normal > 0:  # the normal points from the line towards the robot (the origin)
        normal = -normal
    depth = float(-(centre @ normal))
    middle = 0.5 * (a + b)
    on_line = centre + direction * float((middle - centre) @ direction)
    goal = on_line + normal * depth_m
    heading_error = math.atan2(-normal[1], -normal[0])  # facing the front: x along -normal
    return FrontFit(goal, heading_error, depth, len(near))
