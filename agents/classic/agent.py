"""The classic escape agent: perception, a small world model, a state machine and local motion.

Each step: scan -> split-and-merge lines -> features (corners, open ends, exits) -> world model
(scan alignment corrects odometry; exits are tracked) -> state machine -> potential field ->
safety filter. The states:

    START     step away from what is close before turning (the robot cannot see behind itself)
    LOOK      turn in place until an exit is confirmed (at most once round: the LRF sees 229 deg)
    APPROACH  A* to a point in front of the mouth, turning so the robot will cross it sideways
    CORRIDOR  drive along the corridor at full speed, centred between its walls, until the env
              ends the episode (the agent does not know where the finish line is)
    EXPLORE   no exit seen: go to the most open region, then LOOK again
    BACKOFF   stuck or boxed in: move away from the nearest obstacle, then LOOK again

PICO is 0.40 m wide and 0.20 m deep, so it crosses the mouth and drives the corridor sideways
(its x axis across the corridor, travelling along its y axis, which the LRF sees at +-90 deg):
in a 0.5 m corridor that leaves 0.15 m on each side instead of 0.05 m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from pico_gym.agents.base import Agent, RobotSpec
from pico_gym.agents.classic.astar import astar, string_pull
from pico_gym.agents.classic.features import Features
from pico_gym.agents.classic.perception import perceive
from pico_gym.agents.classic.potential_field import (
    MotionConfig,
    attract_and_repel,
    footprint_clearance,
    heading_rate,
    keep_in_view,
    motion_for,
    safety_filter,
)
from pico_gym.agents.classic.split_merge import Lines, Scan
from pico_gym.agents.classic.world_model import CELL_M, ExitTrack, WorldModel
from pico_gym.overlay import Overlay
from pico_gym.types import FloatArray, Pose
from pico_gym.world.geometry import wrap_angle

# In APPROACH the set-point may lie at most this far off the heading [rad] (the LRF sees +-114 deg).
APPROACH_BEARING = 1.5


class EscapeState(Enum):
    """The escape strategy's states (see the module docstring)."""

    START = "start"
    LOOK = "look"
    APPROACH = "approach"
    CORRIDOR = "corridor"
    EXPLORE = "explore"
    BACKOFF = "backoff"


@dataclass(frozen=True)
class ClassicConfig:
    """Parameters of the classic agent (SI units).

    Attributes:
        front_distance: the approach set-point lies this far in front of the mouth [m].
        inflate: obstacles are grown by this for planning [m] (the robot's half width + margin).
        replan_s: re-plan the A* path this often [s].
        lookahead: the path point this far ahead is the potential field's set-point [m].
        look_turn: how far LOOK turns before giving up on this spot [rad].
        stuck_time: no progress for this long means stuck [s].
        memory_s: hits older than this are forgotten for safety and planning [s].
        rotate_clearance: turn in place only when nothing known is closer to the origin [m].
        max_still_time: standing still this long triggers BACKOFF [s].
        align_scans: correct odometry by aligning each scan to the hits seen before.
        start_look_s: START turns to LOOK after this long, once turning is safe [s].
        start_timeout_s: START gives up stepping away and backs off after this long [s].
        explore_timeout_s: EXPLORE looks again after this long [s].
        backoff_s: BACKOFF moves away for this long [s].
        corridor_grace_s: in CORRIDOR, no-progress counts only after this long [s].

    Times are converted to whole control periods once (`round(t / dt)`), so a threshold means
    the same at any `dt_s`.
    """

    front_distance: float = 0.55
    inflate: float = 0.27
    replan_s: float = 1.0
    lookahead: float = 0.5
    look_turn: float = 2.9
    stuck_time: float = 6.0
    memory_s: float = 15.0
    rotate_clearance: float = 0.27
    max_still_time: float = 3.0
    align_scans: bool = True
    start_look_s: float = 0.3
    start_timeout_s: float = 3.0
    explore_timeout_s: float = 8.0
    backoff_s: float = 1.2
    corridor_grace_s: float = 10.0


class ClassicAgent(Agent):
    """The hand-written escape strategy (see the module docstring)."""

    name = "classic"

    def __init__(
        self, spec: RobotSpec, config: ClassicConfig | None = None, motion: MotionConfig | None = None
    ) -> None:
        super().__init__(spec)
        self.config = config or ClassicConfig()
        self.motion = motion or motion_for(spec)
        self.angles = spec.beam_angles
        cfg = self.config
        steps = self._steps
        self._replan, self._memory = max(steps(cfg.replan_s), 1), steps(cfg.memory_s)
        self._start_look, self._start_timeout = steps(cfg.start_look_s), steps(cfg.start_timeout_s)
        self._explore_timeout, self._backoff_steps = steps(cfg.explore_timeout_s), steps(cfg.backoff_s)
        self._corridor_grace = steps(cfg.corridor_grace_s)
        self._handlers = {
            EscapeState.START: self._start,
            EscapeState.LOOK: self._look,
            EscapeState.APPROACH: self._approach,
            EscapeState.CORRIDOR: self._corridor,
            EscapeState.EXPLORE: self._explore,
            EscapeState.BACKOFF: self._backoff,
        }
        self.reset({"lrf": np.zeros(spec.lrf.n_beams), "odom": np.zeros(3)})

    def _steps(self, seconds: float) -> int:
        """A duration in whole control periods."""
        return int(round(seconds / self.spec.dt_s))

    # --- episode ---------------------------------------------------------------------------
    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:
        self.model = WorldModel()
        self.state = EscapeState.START
        self.state_steps = 0
        self.still_steps = 0
        self.turned = 0.0
        self.side = 0.0  # +1: the corridor runs along the robot's +y; -1: along -y
        self.chosen: ExitTrack | None = None
        self.path: list[FloatArray] = []
        self.target: FloatArray | None = None  # model frame
        self.goal: FloatArray | None = None
        self.best_progress = math.inf
        self.progress_step = 0
        self.pose = Pose(0.0, 0.0, 0.0)
        self.scan: Scan | None = None
        self.lines: Lines | None = None
        self.features: Features | None = None
        self.corridor_width = 0.5  # last measured width [m]
        self.corridor_step = 0

    def _go(self, state: EscapeState) -> None:
        self.state = state
        self.state_steps = 0
        self.turned = 0.0
        self.path = []
        self.best_progress = math.inf
        self.progress_step = self.model.step

    # --- the step --------------------------------------------------------------------------
    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        lrf = self.spec.lrf
        odom = Pose(*(float(v) for v in obs["odom"]))
        percept = perceive(obs["lrf"], self.angles, lrf)
        self.scan, self.lines, self.features = scan, _, features = percept.scan, percept.lines, percept.features
        model = self.model
        if self.config.align_scans:
            model.align(odom, scan.points, percept.long_line_directions(0.5))
        self.pose = pose = model.pose(odom)
        model.add_hits(pose, scan.points)
        model.update_exits(pose, features.exits)
        model.step += 1
        self.state_steps += 1

        near = scan.points[np.hypot(scan.points[:, 0], scan.points[:, 1]) < 1.2]
        # Remembered hits fill in the blind sector behind the robot; where the LRF looks now,
        # the current scan is the truth (old hits there may be stale after odometry drift).
        memory = model.hits_near(pose, 1.0, self._memory)
        memory = memory[np.abs(np.arctan2(memory[:, 1], memory[:, 0])) > lrf.angle_max_rad - 0.05]
        obstacles = np.vstack([near, memory]) if len(memory) else near

        vx, vy, w = self._handlers[self.state](pose, obstacles)
        v = keep_in_view(np.array([vx, vy]), self.motion)
        vx, vy, w = safety_filter(obstacles, (float(v[0]), float(v[1]), float(w)), self.motion)
        self.turned += abs(w) * self.spec.dt_s
        # Never freeze: the challenge ends a run after 30 s without sensible movement.
        moving = math.hypot(vx, vy) > 0.02 or abs(w) > 0.05
        self.still_steps = 0 if moving else self.still_steps + 1
        if self.still_steps * self.spec.dt_s > self.config.max_still_time and self.state != EscapeState.BACKOFF:
            self.still_steps = 0
            self._go(EscapeState.BACKOFF)
        return np.array([vx, vy, w], dtype=np.float32)

    # --- helpers ---------------------------------------------------------------------------
    def _to_robot(self, p: FloatArray) -> FloatArray:
        d = np.asarray(p) - np.array([self.pose.x, self.pose.y])
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])

    def _can_rotate(self, obstacles: FloatArray) -> bool:
        """True when turning in place sweeps no known obstacle (points inside the footprint are
        stale memory, not obstacles)."""
        if len(obstacles) == 0:
            return True
        real = obstacles[footprint_clearance(obstacles, self.motion) > 0.0]
        return len(real) == 0 or float(np.hypot(real[:, 0], real[:, 1]).min()) > self.config.rotate_clearance

    def _away(self, obstacles: FloatArray) -> tuple[float, float, float]:
        """Translate away from the nearest obstacles (no turning)."""
        target = np.zeros(2)
        v = attract_and_repel(obstacles, target, self.motion, speed=0.25)
        if np.hypot(*v) < 0.02:  # nothing pushes: creep towards the most open visible direction
            v = 0.15 * self._open_direction()
        return float(v[0]), float(v[1]), 0.0

    def _open_direction(self, max_bearing: float = 1.6) -> FloatArray:
        """Unit vector (robot frame) towards the most open visible direction."""
        r = np.asarray(self._ranges_filled(), dtype=float)
        window = max(1, len(r) // 25)
        smooth = np.convolve(r, np.ones(window) / window, mode="same")
        smooth[np.abs(self.angles) > max_bearing] = -1.0
        a = float(self.angles[int(np.argmax(smooth))])
        return np.array([math.cos(a), math.sin(a)])

    def _ranges_filled(self) -> FloatArray:
        r = np.full(len(self.angles), self.spec.lrf.range_max_m)
        if self.scan is not None:
            r[self.scan.beams] = self.scan.ranges
        return r

    def _check_progress(self, distance: float) -> bool:
        """Track progress towards a goal; True when stuck for too long."""
        if distance < self.best_progress - 0.1:
            self.best_progress = distance
            self.progress_step = self.model.step
        return (self.model.step - self.progress_step) * self.spec.dt_s > self.config.stuck_time

    # --- states ----------------------------------------------------------------------------
    def _start(self, pose: Pose, obstacles: FloatArray) -> tuple[float, float, float]:
        if self.model.best_exit() is not None:
            self._go(EscapeState.APPROACH)
            return 0.0, 0.0, 0.0
        if self._can_rotate(obstacles) and self.state_steps > self._start_look:
            self._go(EscapeState.LOOK)
            return 0.0, 0.0, 0.0
        if self.state_steps > self._start_timeout:
            self._go(EscapeState.BACKOFF)
        # Move a little towards open space: what is behind the robot is unknown, and turning
        # in place sweeps a circle of 0.22 m radius.
        v = attract_and_repel(obstacles, 0.2 * self._open_direction(), self.motion, speed=0.2)
        return float(v[0]), float(v[1]), 0.0

    def _look(self, pose: Pose, obstacles: FloatArray) -> tuple[float, float, float]:
        if self.model.best_exit() is not None:
            self._go(EscapeState.APPROACH)
            return 0.0, 0.0, 0.0
        if self.turned >= self.config.look_turn:
            self._go(EscapeState.EXPLORE)
            return 0.0, 0.0, 0.0
        if not self._can_rotate(obstacles):
            return self._away(obstacles)
        return 0.0, 0.0, self.motion.max_turn

    def _corridor_frame(self, track: ExitTrack) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The mouth centre, the corridor direction and the approach set-point (model frame)."""
        direction = track.outward / np.linalg.norm(track.outward)
        centre = track.centre
        front = centre - self.config.front_distance * direction
        return centre, direction, front

    def _sideways_heading(self, direction: FloatArray) -> float:
        """Heading that puts the corridor direction at the robot's +y or -y (the nearer turn)."""
        along = math.atan2(direction[1], direction[0])
        if self.side == 0.0:
            left = wrap_angle(along - math.pi / 2 - self.pose.theta)
            right = wrap_angle(along + math.pi / 2 - self.pose.theta)
            self.side = 1.0 if abs(left) <= abs(right) else -1.0
        return float(wrap_angle(along - self.side * math.pi / 2))

    def _approach(self, pose: Pose, obstacles: FloatArray) -> tuple[float, float, float]:
        # Stick to the exit chosen first (switching between two sightings of one mouth zigzags).
        if self.chosen is None or self.chosen not in self.model.tracks:
            self.chosen = self.model.best_exit()
        track = self.chosen
        if track is None:
            self._go(EscapeState.LOOK)
            return 0.0, 0.0, 0.0
        centre, direction, front = self._corridor_frame(track)
        heading = self._sideways_heading(direction)
        here = np.array([pose.x, pose.y])
        rel = here - centre
        along = float(rel @ direction)
        lateral = float(rel @ np.array([-direction[1], direction[0]]))
        heading_error = abs(wrap_angle(heading - pose.theta))
        # In line with the mouth and turned: go through.
        lined_up = along > -self.config.front_distance - 0.15 and abs(lateral) < 0.12 and heading_error < 0.1
        inside = along > 0.05 and abs(lateral) < 0.5 * track.width
        if lined_up or inside:
            self.corridor_width = track.width
            self.corridor_step = self.model.step
            self._go(EscapeState.CORRIDOR)
            return 0.0, 0.0, 0.0
        distance = float(np.linalg.norm(front - here))
        if self._check_progress(distance):
            # Could not get in front of it: forget this exit and look again.
            self.model.tracks = [t for t in self.model.tracks if t is not track]
            self._go(EscapeState.BACKOFF)
            return 0.0, 0.0, 0.0
        self.goal = front
        if not self.path or self.state_steps % self._replan == 1:
            self._plan(here, front)
        target = self._lookahead(here, front)
        self.target = target
        # Keep the way ahead in view: turn towards the corridor's sideways heading only as far as
        # the set-point stays within APPROACH_BEARING of the heading (a set-point behind the robot
        # would leave it zigzagging along the edge of the LRF's view).
        to_target = target - here
        if float(np.hypot(*to_target)) > 0.2:
            travel = math.atan2(to_target[1], to_target[0])
            heading = travel + float(np.clip(wrap_angle(heading - travel), -APPROACH_BEARING, APPROACH_BEARING))
            heading_error = abs(wrap_angle(heading - pose.theta))
        v = attract_and_repel(obstacles, self._to_robot(target), self.motion)
        w = (
            heading_rate(heading - pose.theta, self.motion)
            if self._can_rotate(obstacles) or heading_error < 0.3
            else 0.0
        )
        return float(v[0]), float(v[1]), w

    def _plan(self, here: FloatArray, goal: FloatArray) -> None:
        model = self.model
        blocked = model.blocked(self.config.inflate, self._memory)
        start, end = model.cell(here), model.cell(goal)
        # The robot's own cell (and the goal's) may touch the inflated zone: clear a small disc.
        for cell in (start, end):
            r, c = cell
            k = int(self.config.inflate / CELL_M)
            blocked[max(r - k, 0) : r + k + 1, max(c - k, 0) : c + k + 1] = False
        path = astar(blocked, start, end)
        if path is None:
            self.path = [goal]
            return
        cells = string_pull(blocked, path.cells)
        self.path = [model.centre_of(c) for c in cells[1:]] + [goal]

    def _lookahead(self, here: FloatArray, goal: FloatArray) -> FloatArray:
        while len(self.path) > 1 and np.linalg.norm(self.path[0] - here) < self.config.lookahead:
            self.path.pop(0)
        return self.path[0] if self.path else goal

    def _corridor_walls(self) -> tuple[FloatArray | None, float | None, float | None]:
        """The corridor as the current scan shows it, in the robot frame.

        Walls are the extracted lines running along the travel direction (+-y) within 1 m to
        either side. Returns the corridor direction (unit, pointing the way the robot travels)
        and the distances from the origin to the wall in front (+x) and behind (-x).
        """
        if self.lines is None or len(self.lines) == 0:
            return None, None, None
        seg = self.lines.segments
        d = seg[:, 2:] - seg[:, :2]
        length = np.hypot(d[:, 0], d[:, 1])
        u = d / np.maximum(length, 1e-9)[:, None]
        u = np.where((u[:, 1:2] * self.side) < 0, -u, u)  # orient along the travel direction
        # offset of each line from the origin, measured along x (across the corridor)
        mid = 0.5 * (seg[:, :2] + seg[:, 2:])
        along_travel = np.abs(u[:, 1]) > math.cos(math.radians(25.0))
        ahead = (mid[:, 1] * self.side) > -0.3
        wall = along_travel & ahead & (length > 0.3) & (np.abs(mid[:, 0]) < 1.0)
        if not wall.any():
            return None, None, None
        direction = (u[wall] * length[wall, None]).sum(axis=0)
        direction /= np.linalg.norm(direction)
        normal = np.array([direction[1], -direction[0]]) * self.side  # points to +x side
        offsets = mid[wall] @ normal
        lengths = length[wall]
        # On each side, the longest wall line is the corridor's wall.
        front = offsets > 0
        return (
            direction,
            float(offsets[front][np.argmax(lengths[front])]) if front.any() else None,
            float(-offsets[~front][np.argmax(lengths[~front])]) if (~front).any() else None,
        )

    def _corridor(self, pose: Pose, obstacles: FloatArray) -> tuple[float, float, float]:
        """Drive along the corridor centred between its walls, steering by the current scan only."""
        direction, front, back = self._corridor_walls()
        if direction is None:
            direction = np.array([0.0, self.side])  # past the walls: straight on
        if front is not None and back is not None:
            self.corridor_width = front + back
            lateral = 0.5 * (front - back)  # > 0: the centre lies towards +x
        elif front is not None:
            lateral = front - 0.5 * self.corridor_width
        elif back is not None:
            lateral = 0.5 * self.corridor_width - back
        else:
            lateral = 0.0
        across = np.array([direction[1], -direction[0]]) * self.side
        v = direction * self.motion.max_speed + across * float(np.clip(2.0 * lateral, -0.25, 0.25))
        norm = float(np.hypot(*v))
        if norm > self.motion.max_speed:
            v *= self.motion.max_speed / norm
        # Turn so the corridor runs along the robot's y axis.
        heading_error = math.atan2(direction[1], direction[0]) - self.side * math.pi / 2
        self.target = self._to_model(0.6 * direction)
        self.goal = None
        moved = self.model.step - self.corridor_step
        if self._check_progress(-moved * self.spec.dt_s * float(np.hypot(*v))) and moved > self._corridor_grace:
            self._go(EscapeState.BACKOFF)
        return float(v[0]), float(v[1]), heading_rate(heading_error, self.motion)

    def _to_model(self, p: FloatArray) -> FloatArray:
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        return np.array([self.pose.x + c * p[0] - s * p[1], self.pose.y + s * p[0] + c * p[1]])

    def _explore(self, pose: Pose, obstacles: FloatArray) -> tuple[float, float, float]:
        if self.model.best_exit() is not None:
            self._go(EscapeState.APPROACH)
            return 0.0, 0.0, 0.0
        here = np.array([pose.x, pose.y])
        if self.goal is None or self.state_steps == 1:
            d = self._open_direction()
            r = self._ranges_filled()
            reach = min(1.5, float(np.interp(math.atan2(d[1], d[0]), self.angles, r)) - 0.6)
            c, s = math.cos(pose.theta), math.sin(pose.theta)
            self.goal = here + max(reach, 0.3) * np.array([c * d[0] - s * d[1], s * d[0] + c * d[1]])
        distance = float(np.linalg.norm(self.goal - here))
        if distance < 0.15 or self._check_progress(distance) or self.state_steps > self._explore_timeout:
            self.goal = None
            self._go(EscapeState.LOOK)
            return 0.0, 0.0, 0.0
        self.target = self.goal
        v = attract_and_repel(obstacles, self._to_robot(self.goal), self.motion)
        bearing = math.atan2(v[1], v[0]) if np.hypot(*v) > 0.05 else 0.0
        return float(v[0]), float(v[1]), heading_rate(bearing, self.motion) if self._can_rotate(obstacles) else 0.0

    def _backoff(self, pose: Pose, obstacles: FloatArray) -> tuple[float, float, float]:
        if self.state_steps > self._backoff_steps:
            self.side = 0.0
            self.chosen = None
            self._go(EscapeState.LOOK)
            return 0.0, 0.0, 0.0
        return self._away(obstacles)

    # --- drawing ---------------------------------------------------------------------------
    def overlay(self) -> Overlay:
        """Extracted lines, corners, open ends, exits, the plan and the set-point (robot frame)."""
        points = []
        segments = np.zeros((0, 4)) if self.lines is None else self.lines.segments
        if self.features is not None:
            points += [c.point for c in self.features.corners]
            points += [p for e in self.features.exits for p in (e.a, e.b)]
        path = [self._to_robot(p) for p in self.path] if self.path else []
        track = self.model.best_exit()
        exits = []
        if track is not None:
            a, b = self._to_robot(track.a), self._to_robot(track.b)
            exits = [np.concatenate([a, b])]
        return Overlay(
            frame="robot",
            segments=np.vstack([segments] + exits) if exits else segments,
            points=np.array(points).reshape(-1, 2),
            path=np.array(path).reshape(-1, 2),
            target=None if self.target is None else self._to_robot(self.target),
            text=f"classic: {self.state.name}",
        )


def build(env: Any, **kwargs: Any) -> ClassicAgent:
    """The classic escape agent for an env's robot (`make_agent("classic", env)`)."""
    return ClassicAgent(RobotSpec.of(env), **kwargs)
