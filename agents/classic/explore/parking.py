"""Parking for the classic explore agent: the parking wall fitted from the scan at the start
(the robot turns round and faces it), refitted to the map before parking, and the place along it
where the way back from the stand-off point is clear.
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.agents.classic.explore.config import ExploreAgentConfig
from pico_gym.agents.classic.explore.occupancy import OccupancyMap
from pico_gym.agents.classic.localisation import scan_points
from pico_gym.agents.classic.potential_field import MotionConfig
from pico_gym.types import FloatArray, Pose

# A wall: a point on it and its unit normal into the building.
Wall = tuple[FloatArray, FloatArray]


def fit_wall(ranges: FloatArray, angles: FloatArray, pose: Pose, start: Pose) -> Wall | None:
    """The parking wall: a line through the nearest points straight ahead (the robot faces back),
    its normal towards the start; None when too few points are seen there."""
    pts = scan_points(ranges, angles, 2.0, len(ranges))
    keep = np.abs(np.arctan2(pts[:, 1], pts[:, 0])) < 0.45
    pts = pts[keep]
    if len(pts) < 20:
        return None
    # The wall faces the robot within about 15 deg: keep the points near the depth straight
    # ahead (the side walls' points, nearer, would tilt the line).
    ahead = (
        float(np.median(pts[np.abs(pts[:, 1]) < 0.05, 0]))
        if (np.abs(pts[:, 1]) < 0.05).sum() >= 3
        else float(pts[:, 0].max())
    )
    pts = pts[np.abs(pts[:, 0] - ahead) < 0.15 + 0.3 * np.abs(pts[:, 1])]
    if len(pts) < 15:
        return None
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    world = np.column_stack([pose.x + c * pts[:, 0] - s * pts[:, 1], pose.y + s * pts[:, 0] + c * pts[:, 1]])
    centre = world.mean(axis=0)
    _, _, vt = np.linalg.svd(world - centre)
    direction = vt[0]
    normal = np.array([-direction[1], direction[0]])
    if (np.array([start.x, start.y]) - centre) @ normal < 0:
        normal = -normal
    return centre, normal


def parking_spot(
    occupancy: OccupancyMap,
    wall: Wall,
    start: Pose,
    motion: MotionConfig,
    config: ExploreAgentConfig,
    logodds: np.ndarray | None = None,
) -> tuple[Wall, FloatArray]:
    """The parking wall refitted to the map near the start, and the foot of the stand-off on it:
    behind the start if the way back from the stand-off is clear, else the nearest place along
    the wall that is (a room's wall may meet the parking wall beside the start). The wall fitted
    at the start from one scan, 0.35-1 m away, may be off by 10 deg. `logodds`: the map to fit
    on (default: the occupancy map as it is now)."""
    point, normal = wall
    along = np.array([normal[1], -normal[0]])
    start_xy = np.array([start.x, start.y])
    foot = point + along * float((start_xy - point) @ along)
    g = occupancy.grid
    k = int(2.0 / g.resolution)
    r0 = int((foot[1] - g.y0) / g.resolution)
    c0 = int((foot[0] - g.x0) / g.resolution)
    source = occupancy.logodds if logodds is None else logodds
    window = source[max(r0 - k, 0) : r0 + k + 1, max(c0 - k, 0) : c0 + k + 1]
    rows, cols = np.nonzero(window > config.occupied)
    pts = np.column_stack(
        [
            g.x0 + (cols + max(c0 - k, 0) + 0.5) * g.resolution,
            g.y0 + (rows + max(r0 - k, 0) + 0.5) * g.resolution,
        ]
    )
    for _ in range(2):  # the wall's cells near the foot, refitted
        rel = pts - foot
        on = (np.abs(rel @ normal) < 0.12) & (np.abs(rel @ along) < 1.0)
        if on.sum() < 10:
            break
        centre = pts[on].mean(axis=0)
        _, _, vt = np.linalg.svd(pts[on] - centre)
        fitted = np.array([-vt[0][1], vt[0][0]])
        fitted = fitted if fitted @ normal > 0 else -fitted
        if fitted @ wall[1] < math.cos(math.radians(20.0)):
            break
        normal = fitted
        along = np.array([normal[1], -normal[0]])
        foot = centre + along * float((start_xy - centre) @ along)
    refitted = (foot.copy(), normal)
    rel = pts - foot
    u, n = rel @ along, rel @ normal
    half = motion.half_width + 0.05
    depth = config.park_standoff_m + motion.half_depth + 0.05
    beside = (n > 0.07) & (n < depth)
    # Room to turn round at the stand-off point (it arrives facing the wall and turns to face
    # away): nothing mapped within the footprint's circumradius and a margin (a start near a
    # side wall of a narrow hallway put the stand-off where the turn was cut forever).
    turn_room = math.hypot(motion.half_width, motion.half_depth) + config.park_turn_margin_m
    for t in sorted(np.arange(-0.6, 0.61, 0.05), key=abs):
        if np.any(beside & (np.abs(u - t) < half)):
            continue
        if config.park_turn_margin_m > 0.0 and np.any(np.hypot(u - t, n - config.park_standoff_m) < turn_room):
            continue
        return refitted, foot + along * t
    return refitted, foot
