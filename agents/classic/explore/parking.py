"""Parking for the classic explore agent: the parking wall fitted from the scan at the start
(the robot turns round and faces it), refitted to the map before parking, and the place along it
where the way back from the stand-off point is clear; and docking: facing the wall on the way
back, the distance to it and its direction as the scan sees them (`dock`).
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.agents.classic.explore.config import ExploreAgentConfig
from pico_gym.agents.classic.explore.occupancy import OccupancyMap
from pico_gym.agents.classic.localisation import scan_points
from pico_gym.agents.classic.potential_field import MotionConfig
from pico_gym.types import FloatArray, Pose
from pico_gym.world.geometry import wrap_angle

# A wall: a point on it and its unit normal into the building.
Wall = tuple[FloatArray, FloatArray]


def _ahead(ranges: FloatArray, angles: FloatArray) -> FloatArray:
    """The scan's robot-frame points within 2 m and 26 deg of straight ahead."""
    pts = scan_points(ranges, angles, 2.0, len(ranges))
    return pts[np.abs(np.arctan2(pts[:, 1], pts[:, 0])) < 0.45]


def _wall_ahead(ranges: FloatArray, angles: FloatArray) -> FloatArray | None:
    """The robot-frame points of the wall straight ahead (within 2 m and 26 deg of the heading,
    near the depth straight ahead); None when too few are seen."""
    pts = _ahead(ranges, angles)
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
    return pts if len(pts) >= 15 else None


def _line(pts: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The least-squares line through points: its centre and a unit normal."""
    centre = pts.mean(axis=0)
    _, _, vt = np.linalg.svd(pts - centre)
    return centre, np.array([-vt[0][1], vt[0][0]])


def fit_wall(ranges: FloatArray, angles: FloatArray, pose: Pose, start: Pose) -> Wall | None:
    """The parking wall: a line through the nearest points straight ahead (the robot faces back),
    its normal towards the start; None when too few points are seen there."""
    pts = _wall_ahead(ranges, angles)
    if pts is None:
        return None
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    world = np.column_stack([pose.x + c * pts[:, 0] - s * pts[:, 1], pose.y + s * pts[:, 0] + c * pts[:, 1]])
    centre, normal = _line(world)
    if (np.array([start.x, start.y]) - centre) @ normal < 0:
        normal = -normal
    return centre, normal


def dock(
    ranges: FloatArray, angles: FloatArray, pose: Pose, wall: Wall, max_shift_m: float, *, heading: bool
) -> tuple[Pose, FloatArray] | None:
    """Facing the parking wall, the pose put at the distance from it the scan sees, whatever the
    odometry drifted over minutes of exploring, and the wall's normal as seen. `heading`: the
    heading put square to the wall as `wall` has it (else the heading is kept, and the normal
    seen is the scan's wall turned by it: the wall refitted on a drifted map tilted by up to
    20 deg, the reverse went in at that angle). The position along the wall is left alone. None
    when no straight wall is seen ahead, or the one seen is not the parking wall as the pose has
    it (more than 20 deg or `max_shift_m` off: a jamb, a side wall)."""
    pts = _ahead(ranges, angles)
    seed = pts[np.abs(pts[:, 1]) < 0.1]  # the patch straight ahead, then what lies on its line
    if len(seed) < 10:
        return None
    centre, n_robot = _line(seed)
    for _ in range(3):
        on = pts[np.abs((pts - centre) @ n_robot) < 0.02]
        if len(on) < 40:
            return None
        centre, n_robot = _line(on)
    extent = on @ np.array([-n_robot[1], n_robot[0]])
    if extent.max() - extent.min() < 0.3 or float(np.sqrt(np.mean(((on - centre) @ n_robot) ** 2))) > 0.01:
        return None
    if centre @ n_robot > 0:  # the normal towards the robot (the building's side)
        n_robot = -n_robot
    if abs(math.atan2(n_robot[1], -n_robot[0])) > math.radians(30.0):  # not facing it
        return None
    distance = float(-(centre @ n_robot))
    point, normal = wall
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    seen = np.array([c * n_robot[0] - s * n_robot[1], s * n_robot[0] + c * n_robot[1]])
    if float(seen @ normal) < math.cos(math.radians(20.0)):
        return None
    if heading:
        theta = wrap_angle(math.atan2(normal[1], normal[0]) - math.atan2(n_robot[1], n_robot[0]))
        seen = normal
    else:  # the distance only (the heading stays with the map the pose drifted with)
        theta = pose.theta
    here = np.array([pose.x, pose.y])
    shift = distance - float((here - point) @ seen)
    if abs(shift) > max_shift_m:
        return None
    x, y = here + seen * shift
    return Pose(float(x), float(y), theta), seen


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
