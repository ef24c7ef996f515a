"""Local motion: a potential field under a proportional controller, plus a safety filter.

Khatib, "Real-time obstacle avoidance for manipulators and mobile robots" (IJRR 1986): the
set-point attracts (proportionally, saturated at the speed limit), obstacle points within a radius
repel. Distances are measured to the robot's footprint, not its centre, because PICO is twice as
wide as it is deep. Two rules the course teams learned the hard way are enforced on top:
- never translate towards space the LRF cannot see (the 131 deg behind the robot);
- the safety filter predicts the footprint a short horizon ahead and scales the command down
  until no known obstacle point comes closer than a margin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from pico_gym.types import FloatArray

if TYPE_CHECKING:
    from pico_gym.agents.base import RobotSpec


@dataclass(frozen=True)
class MotionConfig:
    """Gains and limits of the local controller (SI units).

    Attributes:
        max_speed: translational speed limit [m/s] (the competition's 0.5).
        max_turn: turn-rate limit [rad/s].
        attraction_gain: speed per metre of distance to the set-point [1/s].
        repulsion_range: obstacle points closer than this to the footprint repel [m].
        repulsion_gain: strength of the repulsion [m^2/s].
        half_depth, half_width: the footprint as a rectangle around the origin [m].
        visible_bearing: translation is allowed only towards bearings within this [rad].
        horizon: the safety filter looks this far ahead [s].
        margin: the safety filter keeps obstacle points at least this far from the footprint [m].
        slack: a point already inside the margin may come this much closer [m] (LRF noise).
        floor: ... but never closer than this, and one already closer not closer at all [m]
            (0: no floor). The slack is allowed afresh at every step, so without a floor a slow
            command creeps into a wall a few millimetres a step; what a point's reading does
            over the horizon depends on the motion, not on its noise.
        drop_turn: before scaling a command down, try it without its turn (PICO is twice as
            wide as deep: backing away from something beside a corner while turning to watch
            it swings the corner into it).
        turn_gain: turn rate per radian of heading error [1/s].
    """

    max_speed: float = 0.5
    max_turn: float = 1.2
    attraction_gain: float = 1.5
    repulsion_range: float = 0.35
    repulsion_gain: float = 0.02
    half_depth: float = 0.1
    half_width: float = 0.2
    visible_bearing: float = 1.85
    horizon: float = 0.35
    margin: float = 0.04
    slack: float = 0.005
    floor: float = 0.0
    drop_turn: bool = False
    turn_gain: float = 2.0


def motion_for(spec: RobotSpec) -> MotionConfig:
    """The motion config of a robot: its limits, and a safety margin and slack for points
    already inside it that grow with the LRF's noise (a wall 5 cm away can read as 3 cm with
    +-2 cm noise)."""
    noise = spec.lrf.noise_m
    return MotionConfig(
        max_speed=spec.robot.max_speed_mps, max_turn=spec.robot.max_turn_rate_radps, margin=0.03 + noise, slack=noise
    )


def footprint_clearance(points: FloatArray, cfg: MotionConfig) -> FloatArray:
    """Distance from robot-frame points to the footprint rectangle (`footprint_distance` without
    the directions: the safety checks run it several times a step)."""
    dx = np.maximum(np.abs(points[:, 0]) - cfg.half_depth, 0.0)
    dy = np.maximum(np.abs(points[:, 1]) - cfg.half_width, 0.0)
    return np.hypot(dx, dy)


def footprint_distance(points: FloatArray, cfg: MotionConfig) -> tuple[FloatArray, FloatArray]:
    """Distance from robot-frame points to the footprint rectangle, and unit directions away from it."""
    ax, ay = np.abs(points[:, 0]), np.abs(points[:, 1])
    dx = np.maximum(ax - cfg.half_depth, 0.0)
    dy = np.maximum(ay - cfg.half_width, 0.0)
    d = np.hypot(dx, dy)
    away = np.column_stack([np.sign(points[:, 0]) * dx, np.sign(points[:, 1]) * dy])
    with np.errstate(invalid="ignore", divide="ignore"):
        away = np.where(d[:, None] > 1e-9, away / d[:, None], 0.0)
    return d, away


def attract_and_repel(
    points: FloatArray, target: FloatArray, cfg: MotionConfig, speed: float | None = None
) -> FloatArray:
    """Translational velocity (robot frame) towards `target` (robot frame), away from `points`."""
    vmax = cfg.max_speed if speed is None else speed
    dist = float(np.hypot(*target))
    v = np.zeros(2) if dist < 1e-9 else target / dist * min(vmax, cfg.attraction_gain * dist)
    if len(points):
        d, away = footprint_distance(points, cfg)
        near = d < cfg.repulsion_range
        if near.any():
            dn = np.maximum(d[near], 0.005)
            strength = cfg.repulsion_gain * (1.0 / dn - 1.0 / cfg.repulsion_range) / dn
            # Push away from obstacles (the footprint moves away from each point).
            v = v - (strength[:, None] * away[near]).sum(axis=0) / max(1.0, near.sum() / 10.0)
    norm = float(np.hypot(*v))
    if norm > vmax:
        v *= vmax / norm
    return v


def keep_in_view(v: FloatArray, cfg: MotionConfig) -> FloatArray:
    """Drop the part of a translation that points into the LRF's blind sector."""
    speed = float(np.hypot(*v))
    if speed < 1e-9:
        return v
    bearing = math.atan2(v[1], v[0])
    if abs(bearing) <= cfg.visible_bearing:
        return v
    # Project onto the edge of the visible sector (or stop if that is backwards).
    edge = math.copysign(cfg.visible_bearing, bearing)
    u = np.array([math.cos(edge), math.sin(edge)])
    along = float(v @ u)
    return u * max(along, 0.0)


def heading_rate(error: float, cfg: MotionConfig) -> float:
    """Proportional turn rate for a heading error, saturated."""
    error = (error + math.pi) % (2 * math.pi) - math.pi
    return float(np.clip(cfg.turn_gain * error, -cfg.max_turn, cfg.max_turn))


def distances_after(points: FloatArray, vx: float, vy: float, w: float, t: float, cfg: MotionConfig) -> FloatArray:
    """Footprint distance of each point after moving with (vx, vy, w) for t seconds."""
    # In the robot frame the points move by the inverse motion.
    a = -w * t
    c, s = math.cos(a), math.sin(a)
    shifted = points - np.array([vx, vy]) * t
    moved = shifted @ np.array([[c, -s], [s, c]]).T
    return footprint_clearance(moved, cfg)


def safety_filter(
    points: FloatArray, command: tuple[float, float, float], cfg: MotionConfig
) -> tuple[float, float, float]:
    """Scale a command down until the predicted footprint stays `margin` away from the points.

    Checks the motion at several times within the horizon. Each point must stay outside the
    margin or, if it is already inside, come no more than `slack` closer (so a point that is
    already too close, perhaps a noisy one, blocks only the motions towards it). Points inside
    the footprint cannot be real obstacles (stale memory after drift) and are ignored.
    """
    vx, vy, w = command
    if len(points) == 0:
        return command
    near = points[np.hypot(points[:, 0], points[:, 1]) < 1.0]
    if len(near) == 0:
        return command
    d_now = footprint_clearance(near, cfg)
    near, d_now = near[d_now > 0.0], d_now[d_now > 0.0]
    if len(near) == 0:
        return command
    floor = np.minimum(cfg.margin, d_now - cfg.slack)
    if cfg.floor > 0.0:
        floor = np.minimum(cfg.margin, np.maximum(d_now - cfg.slack, np.minimum(d_now, cfg.floor)))

    def safe(cvx: float, cvy: float, cw: float) -> bool:
        return all(
            bool(np.all(distances_after(near, cvx, cvy, cw, cfg.horizon * f, cfg) >= floor)) for f in (0.34, 0.67, 1.0)
        )

    if safe(vx, vy, w):
        return command
    if safe(0.7 * vx, 0.7 * vy, 0.7 * w):
        return 0.7 * vx, 0.7 * vy, 0.7 * w
    # Before slowing down further, try sliding along the point in the way.
    slid = _slide(near, floor, (vx, vy, w), cfg)
    if slid is not None and safe(*slid):
        return slid
    if cfg.drop_turn and w != 0.0 and (vx != 0.0 or vy != 0.0) and safe(vx, vy, 0.0):
        return vx, vy, 0.0  # the turn swung a corner into something: translate only
    for scale in (0.45, 0.25, 0.1, 0.0):
        if safe(vx * scale, vy * scale, w * scale):
            return vx * scale, vy * scale, w * scale
    return 0.0, 0.0, 0.0


def _slide(
    points: FloatArray, floor: FloatArray, command: tuple[float, float, float], cfg: MotionConfig
) -> tuple[float, float, float] | None:
    """The command without its translation towards the point it would hit worst, or None.

    Scaling a command down keeps its direction: at a corridor's mouth, where the corner ahead
    blocks the way on and a step sideways would clear it, that only creeps into the corner.
    Sliding keeps moving past it. None when too little of the command would be left.
    """
    vx, vy, w = command
    deficit = floor - distances_after(points, vx, vy, w, cfg.horizon, cfg)
    worst = int(np.argmax(deficit))
    n = footprint_distance(points[worst : worst + 1], cfg)[1][0]  # from the footprint to the point
    v = np.array([vx, vy])
    towards = float(v @ n)
    if towards <= 0.0:
        return None
    slid = v - towards * n
    if float(np.hypot(*slid)) < 0.1 * float(np.hypot(*v)):
        return None
    return float(slid[0]), float(slid[1]), w


def safe_turn(near: FloatArray, w: float, cfg: MotionConfig, horizon_s: float = 0.5, keep_m: float = 0.05) -> float:
    """The turn rate, cut so that turning for `horizon_s` keeps every point `keep_m` off the
    footprint or no closer than it is (PICO is twice as wide as deep: turning in place next to a
    wall or a cabinet swings a corner into it, a motion `safety_filter`'s slack lets creep)."""
    if len(near) == 0 or w == 0.0:
        return w
    close = near[np.hypot(near[:, 0], near[:, 1]) < 0.5]
    if len(close) == 0:
        return w
    d_now = footprint_clearance(close, cfg)
    for scale in (1.0, 0.5, 0.25, 0.0):
        a = -w * scale * horizon_s
        c, s = math.cos(a), math.sin(a)
        turned = close @ np.array([[c, -s], [s, c]]).T
        d_after = footprint_clearance(turned, cfg)
        if np.all((d_after >= keep_m) | (d_after >= d_now)):
            return w * scale
    return 0.0
