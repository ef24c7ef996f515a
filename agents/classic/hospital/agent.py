"""The classic hospital agent: localise on the given map, plan around what the map does not show,
dock at every cabinet in order.

It knows what the course gave the teams (`info["task"]` at reset: the given map and the cabinet
order, the arrival rule) and senses with the LRF and odometry; nothing else. Each step:

    scan -> pose (odometry prediction, then scan-to-map registration, with a health check: `pose`)
         -> evidence grid (end points the map does not explain accumulate: `evidence`)
         -> state machine (`states`) -> A* on the inflated map + evidence (`route`)
         -> potential field -> safety filter (`pico_gym.agents.classic.potential_field`)

People: clusters of what the map does not explain are tracked (`tracking.PeopleTracker`); the
points of one seen walking are kept out of the registration and the cells it walked through are
cleared. Tried and measured worse, so not used: planning around a moving track's predicted disc
(the hallway closes, the robot waits: timeouts), and its predicted points in the safety filter
(more bumps). YIELD reacts to what it sees.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from pico_gym.agents.base import Agent, RobotSpec
from pico_gym.agents.classic.hospital.config import HospitalAgentConfig
from pico_gym.agents.classic.hospital.docking import FrontFit
from pico_gym.agents.classic.hospital.evidence import EvidenceMap, to_map, to_robot
from pico_gym.agents.classic.hospital.ghosts import Ghosts
from pico_gym.agents.classic.hospital.given import GivenMap
from pico_gym.agents.classic.hospital.pose import MapPose
from pico_gym.agents.classic.hospital.route import RoutePlanner
from pico_gym.agents.classic.hospital.states import HANDLERS, Command, State
from pico_gym.agents.classic.localisation import scan_points
from pico_gym.agents.classic.potential_field import MotionConfig, keep_in_view, motion_for, safe_turn, safety_filter
from pico_gym.agents.shield import ScanMemory, SeenFree, behind_seen_free, blind_translation, blind_turn
from pico_gym.overlay import Overlay
from pico_gym.types import FloatArray, Pose
from pico_gym.world.hospital import Cabinet

# How long the scans that vouch for the strip behind the robot are kept (`back_guard_mps`) [s].
_BACK_MEMORY_S = 4.0


class HospitalAgent(Agent):
    """The classic hospital strategy (see the module docstring).

    Its parts, made anew for every task (the given map) or episode: `given` (the map prepared),
    `localisation` (the pose on it), `world` (what the map does not show), `route` (the plan).
    """

    name = "classic"

    def __init__(
        self, spec: RobotSpec, config: HospitalAgentConfig | None = None, motion: MotionConfig | None = None
    ) -> None:
        super().__init__(spec)
        self.config = config or HospitalAgentConfig()
        self.motion = motion or dataclasses.replace(
            motion_for(spec), floor=self.config.safety_floor_m + 2.0 * spec.lrf.noise_m, drop_turn=True
        )
        # Following a planned path, the plan keeps the clearance: a weak, short-range repulsion only
        # (a strong one fights the path in narrow ways, the deadlock a course team met), and the
        # safety filter keeps the margin.
        self.follow = dataclasses.replace(self.motion, repulsion_range=0.12, repulsion_gain=0.004)
        self.angles = spec.beam_angles
        self._view = (spec.lrf.angle_min_rad, spec.lrf.angle_max_rad)  # the LRF's bearings
        self._task: Any = None

    def _steps(self, seconds: float) -> int:
        return max(1, round(seconds / self.spec.dt_s))

    # --- episode ----------------------------------------------------------------------------
    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:
        """Start an episode: needs `info["task"]` (the given map and the cabinet order)."""
        task = (info or {}).get("task")
        if task is None:
            raise ValueError("the classic hospital agent needs info['task'] from reset (the given map and order)")
        cfg = self.config
        if task is not self._task:
            self._task = task
            self.given = GivenMap(task.map, cfg)
        self.localisation = MapPose(self.given, cfg, self.spec.dt_s, 0.8 * self.motion.max_turn)
        self.world = EvidenceMap(self.given, cfg)
        self.route = RoutePlanner(self.given, self.world, cfg)
        self.order = list(task.cabinet_order)
        self.dwell_s = float(task.dwell_s)
        self.announce = getattr(task, "arrival", "dwell") == "announce"
        self._announcing = False  # this step's action announces an arrival
        self.state = State.LOCALISE
        self.state_steps = 0
        self.steps = 0
        self.done = 0  # cabinets of the order visited
        self.still_steps = 0
        self.best_distance = math.inf
        self.progress_step = 0
        self.side = 0.0  # the side kept towards the way when driving sideways
        self.target: FloatArray | None = None
        self.front_fit: FrontFit | None = None
        self._odom = Pose(0.0, 0.0, 0.0)
        self._scan_robot = np.zeros((0, 2))  # every valid end point of the last scan, robot frame
        self._fixed = np.zeros((0, 2))  # the last scan's points the registration used
        self._last_points = np.zeros((0, 2))
        self._memory = ScanMemory(cfg.blind_memory_s, self.spec.dt_s)
        lrf = self.spec.lrf
        self._people_free = self.seen_free(cfg.blind_memory_s) if cfg.people_cuts_m > 0.0 else None
        self._back_free = (
            self.seen_free(_BACK_MEMORY_S, walk_in_mps=cfg.back_guard_mps) if cfg.back_guard_mps > 0.0 else None
        )
        self._ghosts = (
            Ghosts(
                cfg.ghost_people_s,
                self.spec.dt_s,
                lrf.angle_min_rad,
                lrf.angle_max_rad,
                self.motion.half_depth,
                self.motion.half_width,
            )
            if cfg.ghost_people_s > 0.0 and cfg.track_people
            else None
        )
        self._static_until = 0  # no YIELD before this step (a blocker was seen not to move)
        self._anchor: tuple[FloatArray, int] | None = None  # (spot, step) of `states.going_nowhere`
        self._blocked_spots: list[FloatArray] = []  # escape spots the robot could not move towards
        self._yield_seen = np.zeros((0, 2))
        self._moved_step = -(10**9)

    def seen_free(self, seconds: float, walk_in_mps: float = 0.0) -> SeenFree:
        """A memory of where this robot's last `seconds` of scans saw free space (`SeenFree`)."""
        lrf = self.spec.lrf
        return SeenFree(
            seconds, self.spec.dt_s, lrf.angle_min_rad, lrf.angle_max_rad, lrf.range_min_m, lrf.range_max_m,
            self.motion.half_depth, self.motion.half_width, walk_in_mps=walk_in_mps,
        )  # fmt: skip

    @property
    def pose(self) -> Pose:
        """The pose estimate, map frame."""
        return self.localisation.pose

    @pose.setter
    def pose(self, value: Pose) -> None:
        self.localisation.pose = value

    @property
    def localised(self) -> bool:
        return self.localisation.localised

    def belief(self) -> Pose | None:
        """The agent's estimate of its pose in the map frame (None before it has localised)."""
        return self.pose if self.localised else None

    def _go(self, state: State) -> None:
        self.state = state
        self.state_steps = 0
        self.route.clear()
        self.best_distance = math.inf
        self.progress_step = self.steps
        self._yield_seen = np.zeros((0, 2))
        self._moved_step = -(10**9)
        self._anchor = None
        self._blocked_spots = []

    def _lost(self) -> None:
        """The pose is lost: search the whole map."""
        self.localisation.lose()
        self._go(State.RELOCALISE)

    # --- the step -----------------------------------------------------------------------------
    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        near = self._sense(obs)
        return self._finish(near, self._decide(near))

    def _sense(self, obs: dict[str, np.ndarray]) -> FloatArray:
        """Take in one observation: track the pose, update the evidence; returns the robot-frame
        points the safety filter keeps the footprint off (`near`)."""
        cfg, lrf = self.config, self.spec.lrf
        ranges = np.asarray(obs["lrf"], dtype=np.float64)
        odom = Pose(*(float(v) for v in obs["odom"]))
        self.steps += 1
        self.state_steps += 1
        points = scan_points(ranges, self.angles, lrf.range_max_m, cfg.beams)
        self._last_points = points
        loc = self.localisation
        if loc.odom0 is None:
            loc.odom0 = odom
        if self.localised:
            self._track(odom, points)
            if cfg.track_people:
                self.world.track_people(self.pose, ranges, self.angles, lrf.range_max_m, self.steps * self.spec.dt_s)
        self._odom = odom
        loc.odom_prev = odom
        near = scan_points(ranges, self.angles, lrf.range_max_m, len(ranges))
        self._scan_robot = near  # every valid end point, robot frame (docking fits the front to it)
        near = near[np.hypot(near[:, 0], near[:, 1]) < 1.2]
        if self.localised:
            # The blind sector behind the robot: the map's walls and what the evidence holds there.
            behind = self.world.remembered(self.pose, self._memory, self._odom)
            near = np.vstack([near, behind[np.abs(np.arctan2(behind[:, 1], behind[:, 0])) > lrf.angle_max_rad - 0.05]])
            if self._ghosts is not None:  # people who walked out of the view near the robot
                self._ghosts.update(self.pose, self.world.walking(), self.steps * self.spec.dt_s, ranges, self.angles)
                near = np.vstack([near, self._ghosts.points(self.pose)])
            near = self.world.wary(self.pose, near, self.motion, self.route.squeeze)
        self._memory.add(self._scan_robot, odom)  # (after `near`: this step's scan is in it already)
        if self._people_free is not None:
            self._people_free.add(ranges, odom)
        if self._back_free is not None:
            self._back_free.add(ranges, odom)
        return near

    def _track(self, odom: Pose, points: FloatArray) -> None:
        """Odometry prediction, registration against the map (people left out), the evidence."""
        loc = self.localisation
        predicted = loc.predict(odom)
        fixed = self.world.without_people(points, predicted, self.steps * self.spec.dt_s)
        self._fixed = fixed
        if loc.track(odom, predicted, points, fixed, self.steps, self.state is State.RELOCALISE):
            self._go(State.RELOCALISE)
        self.world.update(self.pose, points)

    def _localise(self, odom: Pose, points: FloatArray) -> Command:
        """LOCALISE and RELOCALISE: turn in place until the pose is found (`MapPose.search`)."""
        found = self.localisation.search(odom, points, self.state is State.RELOCALISE, self.steps)
        if found is None:
            return 0.0, 0.0, self.localisation.turn_radps
        if found.moved_far:
            self.world.fade()  # built on the lost pose (passing beams clear the rest)
        self.world.update(self.pose, points)
        self._go(State.NAVIGATE)
        return 0.0, 0.0, 0.0

    def _decide(self, near: FloatArray) -> Command:
        """The state machine's command for this step (before the safety filter)."""
        if self.state in (State.LOCALISE, State.RELOCALISE):
            return self._localise(self._odom, self._last_points)
        if self.state is State.DONE:
            return 0.0, 0.0, 0.0
        return HANDLERS[self.state](self, near)

    def _max_still_s(self) -> float:
        """How long the robot may stand still (not dwelling) before it recovers, in this state [s]."""
        return self.config.max_still_s

    def _finish(self, near: FloatArray, command: Command) -> np.ndarray:
        """The command through the safety filter (kept in the LRF's view, turns cut near corners,
        scaled down until the footprint keeps its margin), and the never-stand-still rule."""
        if self._people_free is not None and self._person_near():
            free = self._people_free
            command = self._blind_cuts(command, lambda pts: free.free(pts, self._odom, aged=False))
        vx, vy, w = command
        if vx < 0.0 and self._back_free is not None and self.state in (State.RECOVER, State.YIELD):
            back_free = self._back_free
            if not behind_seen_free(self.motion, lambda pts: back_free.free(pts, self._odom)):
                vx = 0.0  # no backing into the strip behind that no recent scan saw free
        v = keep_in_view(np.array([vx, vy]), self.motion)
        if self.config.turn_keep_m > 0.0:
            w = safe_turn(near, float(w), self.motion, keep_m=self.config.turn_keep_m)
        vx, vy, w = safety_filter(near, (float(v[0]), float(v[1]), float(w)), self.motion)
        # Never stand still long: the challenge ends a run after 30 s without movement (a dwell
        # or a wait is short; a robot boxed in by its own safety filter is not).
        moving = math.hypot(vx, vy) > 0.03 or abs(w) > 0.08
        self.still_steps = 0 if moving or self.state in (State.DWELL, State.DONE) else self.still_steps + 1
        if self.still_steps >= self._steps(self._max_still_s()):
            self.still_steps = 0
            self._go(State.RECOVER)
        if self.announce:  # the fourth component: > 0 announces (the course's io.speak)
            said, self._announcing = self._announcing, False
            return np.array([vx, vy, w, 1.0 if said else -1.0], dtype=np.float32)
        return np.array([vx, vy, w], dtype=np.float32)

    def _person_near(self) -> bool:
        """Whether a person tracked walking, or remembered after it left the view, is within
        `people_cuts_m` of the pose estimate (before localisation: always)."""
        if not self.localised:
            return True
        here = np.array([self.pose.x, self.pose.y])
        reach = self.config.people_cuts_m
        tracker = self.world.tracker
        return any(t.moving and math.hypot(*(t.position - here)) < reach for t in (*tracker.tracks, *tracker.dropped))

    def _blind_cuts(
        self, command: Command, seen_free: Callable[[FloatArray], FloatArray], translate: bool = True
    ) -> Command:
        """The command with no translation (while navigating, with `translate`) and no turn that
        sweeps the footprint's rear into space `seen_free` does not vouch for (`_translate`,
        `blind_turn`); recovering or yielding, a robot boxed in must be free to edge out. (First,
        so that a turn in place is left to the safety filter.)"""
        vx, vy = keep_in_view(np.array(command[:2]), self.motion)
        if translate and self.state is State.NAVIGATE:
            vx, vy = self._translate((vx, vy, command[2]), seen_free)
        twist = (float(vx), float(vy), command[2])
        return (twist[0], twist[1], blind_turn(twist, self.motion, *self._view, seen_free=seen_free))

    def _translate(self, twist: Command, seen_free: Callable[[FloatArray], FloatArray]) -> tuple[float, float]:
        """`_blind_cuts`' translation: no part of the footprint's rear into unvouched space."""
        return blind_translation(twist, self.motion, *self._view, seen_free=seen_free)

    # --- what the states ask --------------------------------------------------------------------
    def cabinet(self) -> Cabinet:
        """The next cabinet of the order."""
        return self.given.cabinets[self.order[self.done]]

    def dock_point(self) -> FloatArray:
        """Where the robot's centre docks at the next cabinet."""
        return self.cabinet().dock_point(self.config.dock_depth_m)

    def _to_map(self, points: FloatArray) -> FloatArray:
        """Robot-frame points (N, 2) in the map frame, at the pose estimate."""
        return to_map(self.pose, points)

    def _to_robot(self, p: FloatArray) -> FloatArray:
        """Map-frame points (N, 2), or one point (2,), in the robot frame, at the pose estimate."""
        return to_robot(self.pose, p)

    def _unexplained_near(self, within_m: float = 1.5) -> FloatArray:
        """Robot-frame points within `within_m` of the last scan that the map does not explain,
        and with `escape_people` the people tracked walking within `within_m`."""
        pts = self._last_points
        if len(pts):
            seen = self._to_map(pts)
            odd = self.world.unexplained(np.ascontiguousarray(seen[:, 0]), np.ascontiguousarray(seen[:, 1]))
            pts = pts[odd & (np.hypot(pts[:, 0], pts[:, 1]) < within_m)]
        if not (self._escapes_people() and self.localised and self.config.track_people):
            return pts
        walking = [t.position for t in self.world.tracker.moving()]
        if not walking:
            return pts
        people = self._to_robot(np.array(walking))
        people = people[np.hypot(people[:, 0], people[:, 1]) < within_m]
        return np.vstack([pts, people]) if len(people) else pts

    def _escapes_people(self) -> bool:
        """Whether `_unexplained_near` holds the people tracked walking (`escape_people`)."""
        return self.config.escape_people

    # --- drawing ---------------------------------------------------------------------------------
    def overlay(self) -> Overlay:
        """The pose estimate's path and set-point, the evidence cells, the tracks of people seen
        walking with their pause circles, the target's arrival square and the front the LRF fitted
        (map frame)."""
        g = self.given.grid
        rows, cols = np.nonzero(self.world.seen())
        evidence = np.column_stack([g.x0 + (cols + 0.5) * g.resolution, g.y0 + (rows + 0.5) * g.resolution])
        pose = self.pose
        here = np.array([pose.x, pose.y])
        path = np.array([here, *self.route.path]) if self.route.path else np.zeros((0, 2))
        target = f" -> cabinet {self.order[self.done]}" if self.done < len(self.order) else ""
        segments = []
        ring = np.linspace(0.0, 2.0 * math.pi, 17)
        for t in self.world.tracker.moving() if self.localised else ():
            xs = t.position[0] + t.pause_radius_m * np.cos(ring)
            ys = t.position[1] + t.pause_radius_m * np.sin(ring)
            segments.append(np.column_stack([xs[:-1], ys[:-1], xs[1:], ys[1:]]))
        if self.done < len(self.order) and self.localised:
            sq = self.cabinet().square
            segments.append(np.column_stack([sq, np.roll(sq, -1, axis=0)]))
        if self.state is State.DOCK and self.front_fit is not None:
            gx, gy = to_map(pose, self.front_fit.goal[None, :])[0]
            segments.append(np.array([[pose.x, pose.y, gx, gy]]))
        health = self.localisation.health
        return Overlay(
            frame="map",
            segments=np.vstack(segments) if segments else np.zeros((0, 4)),
            points=evidence.reshape(-1, 2),
            path=path.reshape(-1, 2),
            target=self.target,
            text=f"classic: {self.state.value}{target} ({self.done}/{len(self.order)}), fit {health:.2f}",
        )


class OraclePoseAgent(HospitalAgent):
    """The classic hospital agent handed the true pose every step: privileged, for benchmarks only.

    It is the same agent with localisation replaced by the truth (read from the env it was built
    for), so comparing it with `classic` on the same episodes separates localisation failures from
    planning and motion failures. Its `belief()` is the truth, so its localisation figures are 0.
    """

    name = "classic-oracle"

    def __init__(self, spec: RobotSpec, env: Any, config: HospitalAgentConfig | None = None) -> None:
        super().__init__(spec, config)
        self._env = env.unwrapped  # privileged: the true pose

    def _truth(self) -> Pose:
        pose = self._env.pose
        return Pose(float(pose.x), float(pose.y), float(pose.theta))

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        if not self.localised:
            self.pose = self._truth()
            self.localisation.localised = True
            self.localisation.localise_s = 0.0
            self._go(State.NAVIGATE)
        return super().act(obs)

    def _track(self, odom: Pose, points: FloatArray) -> None:
        self.pose = self._truth()
        self.localisation.health = 1.0
        self.world.update(self.pose, points)


def build(env: Any, **kwargs: Any) -> HospitalAgent:
    """The classic hospital agent for an env's robot (`make_agent("classic", env)`)."""
    return HospitalAgent(RobotSpec.of(env), **kwargs)


def build_oracle(env: Any, **kwargs: Any) -> OraclePoseAgent:
    """The classic hospital agent handed the true pose (`make_agent("classic-oracle", env)`)."""
    return OraclePoseAgent(RobotSpec.of(env), env, **kwargs)
