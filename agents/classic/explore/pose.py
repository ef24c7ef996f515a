"""The classic explore agent's pose: odometry in its odometry frame at reset, optionally
corrected by correlative scan-to-map matching against its own map (`align`) and by the building's
axes (`square`: a 2018 hospital is rectilinear). Both are off by default (`ExploreAgentConfig`):
measured, neither beat the course's odometry.
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.agents.classic.explore.config import ExploreAgentConfig
from pico_gym.agents.classic.explore.occupancy import OccupancyMap
from pico_gym.agents.classic.localisation import scan_points
from pico_gym.jit import njit
from pico_gym.types import FloatArray, Pose
from pico_gym.world.geometry import compose, inverse, wrap_angle

CELL_CAP = 3.0  # the most one end point scores in matching (its cell's log-odds, clipped)


@njit
def _best_pose(
    points: np.ndarray,
    logodds: np.ndarray,
    x0: float,
    y0: float,
    res: float,
    px: float,
    py: float,
    theta: float,
    span_xy: float,
    step_xy: float,
    span_th: float,
    step_th: float,
    cap: float,
) -> tuple[float, float, float, float, float]:
    """Correlative scan matching: of the poses within the spans around (px, py, theta), the one
    whose end points land on the most occupied map (each scores its cell's log-odds, clipped to
    [0, cap]); returns it with its score and the score of the centre pose."""
    rows, cols = logodds.shape
    n_xy = int(round(span_xy / step_xy))
    n_th = int(round(span_th / step_th))
    best = (-1.0, px, py, theta)
    centre = 0.0
    for it in range(-n_th, n_th + 1):
        th = theta + it * step_th
        c, s = math.cos(th), math.sin(th)
        for ix in range(-n_xy, n_xy + 1):
            for iy in range(-n_xy, n_xy + 1):
                x, y = px + ix * step_xy, py + iy * step_xy
                score = 0.0
                for k in range(points.shape[0]):
                    wx = x + c * points[k, 0] - s * points[k, 1]
                    wy = y + s * points[k, 0] + c * points[k, 1]
                    col = int(math.floor((wx - x0) / res))
                    row = int(math.floor((wy - y0) / res))
                    if 0 <= row < rows and 0 <= col < cols:
                        v = logodds[row, col]
                        if v > 0.0:
                            score += min(v, cap)
                # Ties go to the pose nearest the prediction.
                penalty = 1e-6 * (abs(ix) + abs(iy) + abs(it))
                if score - penalty > best[0]:
                    best = (score - penalty, x, y, th)
                if ix == 0 and iy == 0 and it == 0:
                    centre = score
    return best[1], best[2], best[3], best[0], centre


@njit
def wall_directions(
    ranges: FloatArray, angles: FloatArray, gap: int, stride: int, max_r: float
) -> tuple[float, float, int]:
    """The walls' directions in a scan, modulo 90 deg: the sum of (cos 4a, sin 4a) over the
    directions a (robot frame) of straight pieces of wall (three end points, `gap` beams apart,
    8-60 cm end to end, the middle within 1.5 cm of the line through the other two), and how
    many pieces. A rectilinear building's walls all give one 4a; corners and clutter fail the
    straightness test or scatter."""
    c4 = 0.0
    s4 = 0.0
    n = 0
    for k in range(0, ranges.shape[0] - 2 * gap, stride):
        r0, r1, r2 = ranges[k], ranges[k + gap], ranges[k + 2 * gap]
        if r0 < 0.1 or r1 < 0.1 or r2 < 0.1 or r0 > max_r or r1 > max_r or r2 > max_r:
            continue
        x0, y0 = r0 * math.cos(angles[k]), r0 * math.sin(angles[k])
        x1, y1 = r1 * math.cos(angles[k + gap]), r1 * math.sin(angles[k + gap])
        x2, y2 = r2 * math.cos(angles[k + 2 * gap]), r2 * math.sin(angles[k + 2 * gap])
        ex, ey = x2 - x0, y2 - y0
        length = math.hypot(ex, ey)
        if length < 0.08 or length > 0.6:
            continue
        if abs(ex * (y1 - y0) - ey * (x1 - x0)) / length > 0.015:
            continue
        a = 4.0 * math.atan2(ey, ex)
        c4 += math.cos(a)
        s4 += math.sin(a)
        n += 1
    return c4, s4, n


class OdometryPose:
    """The pose in the agent's frame (the odometry frame at reset), and the correction that
    takes odometry into it.

    Attributes:
        pose: the current estimate; start: the pose at reset.
        correction: agent frame <- odometry frame.
        previous_odom: the last step's odometry.
        axes: the walls' (cos 4a, sin 4a) summed in the agent frame while looking round.
        fits: scan matches accepted.
    """

    def __init__(self, config: ExploreAgentConfig, odom: Pose) -> None:
        self.config = config
        self.pose = odom
        self.start = odom
        self.correction = Pose(0.0, 0.0, 0.0)
        self.previous_odom = odom
        self.axes = np.zeros(2)
        self.fits = 0

    def predict(self, odom: Pose) -> Pose:
        """Move the pose by the odometry since the last step; returns that motion (odometry frame)."""
        delta = compose(inverse(self.previous_odom), odom)
        self.pose = compose(compose(self.correction, self.previous_odom), delta)
        return delta

    def settle(self, odom: Pose) -> None:
        """Keep the pose's correction of this step's odometry."""
        self.correction = compose(self.pose, inverse(odom))

    def align(
        self,
        ranges: FloatArray,
        angles: FloatArray,
        occupancy: OccupancyMap,
        range_max: float,
        logodds: np.ndarray | None = None,
        heading_only: bool = False,
        explained: float = 0.0,
    ) -> None:
        """Correlative scan-to-map matching around the prediction (within 3 cm and 0.9 deg:
        odometry drifts far less than that in a step, so a larger jump would be a bad match, e.g.
        a room seen for the first time), against the map (or `logodds` of its grid, e.g. the
        map stored at parking); with `heading_only`, the heading alone (in a hallway the walls
        fix the heading but not the position along it, and a free position slides); a match
        scoring under `explained` of the most the points could score is not taken."""
        cfg = self.config
        points = scan_points(ranges, angles, min(cfg.map_range_m, range_max), 180)
        if len(points) < 40:
            return
        g = occupancy.grid
        p = self.pose
        x, y, th, score, centre = _best_pose(
            points,
            occupancy.logodds if logodds is None else logodds,
            g.x0,
            g.y0,
            g.resolution,
            p.x,
            p.y,
            p.theta,
            0.0 if heading_only else 0.03,
            0.01,
            0.016,
            0.002,
            CELL_CAP,
        )
        if score > 1.02 * centre + 1.0 and score >= explained * CELL_CAP * len(points):
            self.pose = Pose(float(x), float(y), float(th))
            self.fits += 1

    def relocalise(
        self, ranges: FloatArray, angles: FloatArray, logodds: np.ndarray, occupancy: OccupancyMap, range_max: float
    ) -> bool:
        """Correlative matching against a stored map over a wide window (1.2 m, 11 deg, coarse
        then fine); the pose moves to the match when it explains the scan clearly better than
        the prediction. Returns whether it moved."""
        points = scan_points(ranges, angles, min(self.config.map_range_m, range_max), 180)
        if len(points) < 40:
            return False
        g = occupancy.grid
        p = self.pose
        x, y, th, _, centre = _best_pose(
            points, logodds, g.x0, g.y0, g.resolution, p.x, p.y, p.theta, 1.2, 0.1, 0.2, 0.02, CELL_CAP
        )
        x, y, th, score, _ = _best_pose(
            points, logodds, g.x0, g.y0, g.resolution, x, y, th, 0.1, 0.02, 0.02, 0.005, CELL_CAP
        )
        if score < 1.3 * centre + 10.0 or score < 0.4 * CELL_CAP * len(points):
            return False
        self.pose = Pose(float(x), float(y), float(th))
        self.fits += 1
        return True

    def square(self, ranges: FloatArray, angles: FloatArray, looking: bool) -> None:
        """The heading pulled towards the building's axes (`square_gain`); while `looking` round
        at the start, the axes are learnt (summed in the agent frame)."""
        cfg = self.config
        c4, s4, n = wall_directions(ranges, angles, 8, 4, 4.0)
        if n < 20:
            return
        t4 = 4.0 * self.pose.theta
        wc, ws = c4 * math.cos(t4) - s4 * math.sin(t4), c4 * math.sin(t4) + s4 * math.cos(t4)
        if looking:
            self.axes += (wc, ws)
            return
        if not self.axes.any() or math.hypot(c4, s4) < cfg.square_min * n:
            return
        error = wrap_angle(math.atan2(ws, wc) - math.atan2(self.axes[1], self.axes[0])) / 4.0
        if abs(error) < math.radians(cfg.square_window_deg):
            self.pose = Pose(self.pose.x, self.pose.y, wrap_angle(self.pose.theta - cfg.square_gain * error))

    def to_robot(self, p: FloatArray) -> FloatArray:
        """A point (2,) of the agent's frame in the robot frame."""
        dx, dy = p[0] - self.pose.x, p[1] - self.pose.y
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        return np.array([c * dx + s * dy, -s * dx + c * dy])
