"""One perception for the classic agents: a scan -> its points, lines and features.

`perceive` runs the pipeline the escape agent steers by (preprocess -> split-and-merge ->
corners, open ends and exits) and returns it as one value, `Percept`, so a strategy reads what was
seen without knowing how it was extracted. The hospital agent reads the same scan points
(`Percept.scan.points`) for its safety filter and keeps its own subsampled points for
localisation (`pico_gym.agents.classic.localisation.scan_points`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pico_gym.agents.classic.features import Features, extract_features
from pico_gym.agents.classic.split_merge import Lines, Scan, preprocess, split_and_merge
from pico_gym.sensors.lrf import LrfConfig
from pico_gym.types import FloatArray


@dataclass(frozen=True)
class Percept:
    """What one scan shows, in the robot frame.

    Attributes:
        ranges: the raw ranges (float64).
        scan: the valid beams and their points (`split_merge.Scan`).
        lines: the wall lines split-and-merge extracted.
        features: corners, open ends and exits (`features.Features`).
    """

    ranges: FloatArray
    scan: Scan
    lines: Lines
    features: Features

    def long_line_directions(self, min_length_m: float = 0.5) -> FloatArray:
        """Unit directions of the lines longer than `min_length_m` (what scan alignment uses)."""
        seg = self.lines.segments
        length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
        long = length > min_length_m
        return (seg[long, 2:] - seg[long, :2]) / length[long, None]


def perceive(ranges: FloatArray, angles: FloatArray, lrf: LrfConfig) -> Percept:
    """The perception pipeline on one scan (ranges in metres, beam angles in radians)."""
    ranges = np.asarray(ranges, dtype=np.float64)
    scan = preprocess(ranges, angles, lrf.range_min_m, lrf.range_max_m)
    lines = split_and_merge(scan)
    features = extract_features(scan, lines, ranges, angles, lrf.range_max_m)
    return Percept(ranges, scan, lines, features)
