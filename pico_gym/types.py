"""Shared type aliases and small value types used across pico_gym."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
"""A float64 array."""

Segments = npt.NDArray[np.float64]
"""Line segments as an (N, 4) float64 array of rows (x1, y1, x2, y2), metres."""


class Pose(NamedTuple):
    """A planar pose: position in metres, heading in radians (counter-clockwise from +x)."""

    x: float
    y: float
    theta: float
