"""The classic explore agent's motion and safety: following the planned path with the potential
field, forward where there is room and sideways through narrow doors, and the filters every
command passes (kept in the LRF's view, clear of what is near, no creep into a wall).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from pico_gym.agents.classic.explore.config import ExploreAgentConfig
from pico_gym.agents.classic.explore.frontiers import FrontierPlanner
from pico_gym.agents.classic.potential_field import (
    MotionConfig,
    attract_and_repel,
    distances_after,
    footprint_clearance,
    footprint_distance,
    heading_rate,
    keep_in_view,
    safe_turn,
    safety_filter,
)
from pico_gym.types import FloatArray, Pose
from pico_gym.world.geometry import wrap_angle

Command = tuple[float, float, float]


def wary(points: FloatArray, motion: MotionConfig, pull_m: float = 0.08) -> FloatArray:
    """Mapped points pulled `pull_m` towards the footprint (never into it): a cell centre may lie
    a few centimetres beyond the wall it stands for, and the pose may be off as much."""
    if len(points) == 0:
        return points
    d, away = footprint_distance(points, motion)
    return points - away * np.minimum(pull_m, np.maximum(d - 0.005, 0.0))[:, None]


def no_creep(near: FloatArray, vx: float, vy: float, w: float, motion: MotionConfig) -> Command:
    """Stop a command that brings anything within 2.5 cm of the footprint closer still (the
    shared safety filter lets a point already inside its margin come a little closer per
    step, which, step after step, is a slow drive into the wall)."""
    if len(near) == 0:
        return vx, vy, w
    d_now = footprint_clearance(near, motion)
    close = d_now < 0.05
    if not close.any():
        return vx, vy, w
    pts = near[close]
    a = -w * 0.3
    c, s = math.cos(a), math.sin(a)
    moved = (pts - np.array([vx, vy]) * 0.3) @ np.array([[c, -s], [s, c]]).T
    d_after = footprint_clearance(moved, motion)
    if np.any((d_after < 0.025) & (d_after < d_now[close] - 1e-4)):
        return 0.0, 0.0, 0.0
    return vx, vy, w


def filtered(near: FloatArray, vx: float, vy: float, w: float, motion: MotionConfig) -> Command:
    """A command as the safety filters let it through (in view, clear of `near`)."""
    v = keep_in_view(np.array([vx, vy]), motion)
    vx, vy, w = safety_filter(near, (float(v[0]), float(v[1]), float(w)), motion)
    w = safe_turn(near, w, motion)
    return no_creep(near, vx, vy, w, motion)


class Follower:
    """Follows the planner's path, gives up a goal approached too slowly (backing off first), and
    steps out ahead where the way on lies in the blind sector.

    Attributes:
        backoff_until: the step until which it backs away from what is nearest.
        step_out, step_out_until: the command it steps out ahead with, and until when.
    """

    def __init__(self, config: ExploreAgentConfig, motion: MotionConfig, follow: MotionConfig, dt_s: float) -> None:
        self.config, self.motion, self.follow_cfg, self.dt_s = config, motion, follow, dt_s
        self.backoff_until = 0
        self.step_out_until = 0
        self.step_out: Command = (0.0, 0.0, 0.0)
        self.wedge_turn_until = 0
        self.wedge_turn = 0.0

    def _steps(self, seconds: float) -> int:
        return max(1, round(seconds / self.dt_s))

    def _progress(self, planner: FrontierPlanner, here: FloatArray, step: int) -> bool:
        """Track progress along the path (not towards the goal: a way round a wall first leads
        away from it); False when the goal is given up (no progress for `give_up_s`)."""
        remaining = planner.remaining(here)
        if remaining < planner.best - 0.2:
            planner.best, planner.best_step = remaining, step
        elif step - planner.best_step > self._steps(self.config.give_up_s):
            assert planner.goal is not None  # (progress is tracked towards a goal)
            planner.given_up.append(planner.goal.copy())
            planner.goal = None
            planner.path = []
            self.backoff_until = step + self._steps(1.5)
            return False
        return True

    def follow(self, planner: FrontierPlanner, pose: Pose, near: FloatArray, step: int, still_steps: int) -> Command:
        """The command that takes the robot along the path (`near`: what the filters keep it off)."""
        cfg = self.config
        here = np.array([pose.x, pose.y])
        while len(planner.path) > 1 and np.linalg.norm(planner.path[0] - here) < 0.3:
            planner.path.pop(0)
        if not planner.path:
            return 0.0, 0.0, 0.0
        if planner.goal is not None and not self._progress(planner, here, step):
            return 0.0, 0.0, 0.0
        if step < self.backoff_until:
            # Away from what is nearest (the way it came, as the LRF sees it), then plan anew.
            away = dataclasses.replace(self.follow_cfg, repulsion_range=0.4, repulsion_gain=0.02)
            v = attract_and_repel(near, np.zeros(2), away, speed=0.2)
            return float(v[0]), float(v[1]), 0.0
        target = planner.path[0]
        travel = math.atan2(target[1] - here[1], target[0] - here[0])
        tight = planner.tight_ahead(here, 1.2)
        # Slower the closer anything is (the map behind the robot may be a few centimetres off).
        closest = float(footprint_clearance(near, self.motion).min()) if len(near) else 1.0
        speed = min(0.2 if tight else cfg.cruise_mps, max(0.08, 0.08 + 1.5 * (closest - 0.05)))
        dx, dy = target[0] - pose.x, target[1] - pose.y
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        goal = np.array([c * dx + s * dy, -s * dx + c * dy])
        v = attract_and_repel(near, goal, self.follow_cfg, speed=speed)
        u = goal / max(float(np.hypot(*goal)), 1e-9)
        if float(v @ u) < 0.25 * speed:
            # A local minimum of the field (a doorway's jambs push back as hard as the path
            # pulls on): keep the push across the way, drop the push against it; the safety
            # filter still guards the footprint.
            v = v - float(v @ u) * u + 0.25 * speed * u
        heading = travel - math.pi / 2 if tight else travel
        error = wrap_angle(heading - pose.theta)
        if step < self.step_out_until:
            return self.step_out
        if still_steps >= self._steps(1.0) and abs(math.atan2(goal[1], goal[0])) > self.motion.visible_bearing:
            stepped = self._step_out(near, step)
            if stepped is not None:
                return stepped
        r, c_ = planner.occupancy.plan_cell(here)
        if planner.clearance[r, c_] < cfg.narrow_m:
            return self._through_door(near, v, error, step, still_steps)
        if abs(error) > 1.0:
            v = v * 0.2  # turn first
        return float(v[0]), float(v[1]), safe_turn(near, heading_rate(error, self.motion), self.motion)

    def _through_door(self, near: FloatArray, v: FloatArray, error: float, step: int, still_steps: int) -> Command:
        """In the doorway itself: no turning (the jamb's far corners have not been seen), the
        holonomic base translates through at the heading it came in with; unless that is wedged
        across the door (the filters have stopped it for a second), then it turns
        (`wedge_turn_s`; `error`: the heading's from the one the follower wants)."""
        cfg = self.config
        if step < self.wedge_turn_until:
            w = filtered(near, 0.0, 0.0, self.wedge_turn, self.motion)[2]
            if w != 0.0:
                return 0.0, 0.0, w
            self.wedge_turn_until = 0
        if still_steps < self._steps(1.0):
            return float(v[0]), float(v[1]), 0.0
        w = min(max(heading_rate(error, self.motion), -0.3), 0.3)  # slowly: the map is built as it turns
        if cfg.wedge_turn_s > 0.0:
            # Held: turn in place, towards the way or else the way that frees the corners pressed
            # against the jambs, as the filters let it, for `wedge_turn_s` (a turn of one step a
            # second, the still count starting again with it, turned nothing).
            w = filtered(near, 0.0, 0.0, w, self.motion)[2]
            w = w if abs(w) >= 0.05 else self._freeing_turn(near)
            if w != 0.0:
                self.wedge_turn, self.wedge_turn_until = w, step + self._steps(cfg.wedge_turn_s)
                return 0.0, 0.0, w
        return float(v[0]), float(v[1]), safe_turn(near, w, self.motion)

    def _freeing_turn(self, near: FloatArray, rate: float = 0.3) -> float:
        """The turn in place (+-`rate`, as the filters let it) that moves the points nearest the
        footprint farthest off it, or 0 where neither does: wedged askew between two jambs, a
        corner against each, one sense of turn frees both."""
        close = near[np.hypot(near[:, 0], near[:, 1]) < 0.5]
        if len(close) == 0:
            return 0.0
        d_now = float(footprint_clearance(close, self.motion).min())
        best, best_gain = 0.0, 0.005
        for w in (rate, -rate):
            w = filtered(near, 0.0, 0.0, w, self.motion)[2]
            if w == 0.0:
                continue
            gain = float(distances_after(close, 0.0, 0.0, w, 0.5, self.motion).min()) - d_now
            if gain > best_gain:
                best, best_gain = w, gain
        return best

    def _step_out(self, near: FloatArray, step: int) -> Command | None:
        """Stuck with the way on behind (a new plan turned it round in or by a door): the blind
        sector lets it neither back out nor turn past the jamb, so it steps out ahead, where the
        LRF sees, and turns there; edging off a jamb beside it if straight on is too close."""
        for side in (0.0, 0.06, -0.06):
            if filtered(near, 0.15, side, 0.0, self.motion)[0] > 0.05:
                self.step_out = (0.15, side, 0.0)
                self.step_out_until = step + self._steps(2.0)
                return self.step_out
        return None
