"""The classic explore agent (2018): map an unknown hospital, park backwards, find the object.

It is given nothing of the building (`info["task"]` holds the rules only) and senses with the LRF
and odometry. It thinks in its odometry frame at reset. Each step:

    scan -> pose (odometry; optionally corrected against its own map: `pose`)
         -> occupancy grid (log-odds along every beam: `occupancy`)
         -> state machine (`states`) -> Dijkstra on the planning grid (`frontiers`)
         -> potential field -> safety filters (`motion`)

Hand-written in numpy and numba: this is the course's subject. Not built: a scan matcher that
beats the odometry (the correlative one here random-walks the heading), loop closure, reading the
prior map of a start in "find" (it maps again from the parked start, and searches nearest-first).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from pico_gym.agents.base import Agent, RobotSpec
from pico_gym.agents.classic.explore.config import ExploreAgentConfig
from pico_gym.agents.classic.explore.frontiers import FrontierPlanner
from pico_gym.agents.classic.explore.motion import Command, Follower, filtered, wary
from pico_gym.agents.classic.explore.occupancy import OccupancyMap
from pico_gym.agents.classic.explore.parking import Wall
from pico_gym.agents.classic.explore.pose import OdometryPose
from pico_gym.agents.classic.explore.search import ObjectFinder
from pico_gym.agents.classic.explore.states import HANDLERS, State
from pico_gym.agents.classic.localisation import scan_points
from pico_gym.agents.classic.potential_field import motion_for, safety_filter
from pico_gym.overlay import Overlay
from pico_gym.tasks.explore import OccupancyBelief
from pico_gym.types import FloatArray, Pose


class ExploreAgent(Agent):
    """The classic explore strategy (see the module docstring).

    Its parts, made anew every episode: `occupancy` (its map), `odometry` (its pose), `planner`
    (frontiers and paths), `follower` (the path as commands), `finder` (the object).
    """

    name = "classic"

    def __init__(self, spec: RobotSpec, config: ExploreAgentConfig | None = None) -> None:
        super().__init__(spec)
        self.config = config or ExploreAgentConfig()
        floor = self.config.safety_floor_m
        self.motion = dataclasses.replace(
            motion_for(spec), floor=floor + 2.0 * spec.lrf.noise_m if floor > 0 else 0.0, drop_turn=floor > 0
        )
        self.follow = dataclasses.replace(self.motion, repulsion_range=0.15, repulsion_gain=0.004)
        self.angles = np.ascontiguousarray(spec.beam_angles, dtype=np.float64)
        # The beams straight ahead: backing up along the heading lengthens them by exactly the
        # distance moved, whatever the wall they hit (beams to the side may hit walls parallel to
        # the motion, which do not move at all).
        self._front = np.flatnonzero(np.abs(self.angles) < 0.02)

    def _steps(self, seconds: float) -> int:
        return max(1, round(seconds / self.spec.dt_s))

    # --- episode ----------------------------------------------------------------------------
    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:
        cfg = self.config
        task = (info or {}).get("task")
        self.phase = getattr(task, "phase", "explore")
        odom = Pose(*(float(v) for v in obs["odom"]))
        # The agent's frame is the odometry frame at reset; the grid is centred on the start.
        self.occupancy = OccupancyMap(cfg, odom)
        self.odometry = OdometryPose(cfg, odom)
        self.planner = FrontierPlanner(cfg, self.occupancy, self.spec.dt_s)
        self.follower = Follower(cfg, self.motion, self.follow, self.spec.dt_s)
        self.finder = ObjectFinder(cfg, self.occupancy)
        self.steps = 0
        self.state_steps = 0
        self.state = State.LOOK
        self.turned = 0.0  # how far it has turned looking round at the start [rad]
        self.wall: Wall | None = None  # the parking wall: (point, unit normal into the building)
        self.park_foot = np.zeros(2)  # where on the parking wall it parks
        self.at_standoff = False
        self.standoff_extra = 0.0  # how much farther from the wall it stands off (`park_more_m`)
        self.turn_blocked = 0  # steps the turn at the stand-off point was cut
        self.stuck = 0  # reversing: the seconds in a row it looked touched
        self.reversed_m = 0.0
        self.reverse_log: list[tuple[float, FloatArray]] = []
        self.still_steps = 0
        self.start_map: np.ndarray | None = None  # the map after the first look round (`relocalise_park_m`)
        self.unstick_until = 0
        self.unsticks = 0
        self._lrf_points = 0
        # The blind sector's memory starts here: the pose was moved (`park_dock_m`), and the hits
        # before stand where the drifted pose put them.
        self.blind_from = 0
        self.wall_seen: FloatArray | None = None  # the parking wall's normal as seen, docking
        self.round_from = 0.0  # approaching: the distance at which the final creep was held (0: none)

    @property
    def pose(self) -> Pose:
        """The pose estimate, in the agent's frame."""
        return self.odometry.pose

    def parking_wall(self) -> Wall:
        """The parking wall (fitted, or assumed, by the end of the first look round)."""
        assert self.wall is not None
        return self.wall

    def belief(self) -> None:
        """No pose on a given map to report (the explore agent has no map frame to localise in)."""
        return None

    def map_belief(self) -> OccupancyBelief:
        """The agent's occupancy grid in its odometry frame at reset (for `env.belief_iou`)."""
        return self.occupancy.belief()

    def _go(self, state: State) -> None:
        self.state = state
        self.state_steps = 0
        self.planner.clear(self.steps)
        self.round_from = 0.0

    # --- the step -------------------------------------------------------------------------------
    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        ranges = np.asarray(obs["lrf"], dtype=np.float64)
        odom = Pose(*(float(v) for v in obs["odom"]))
        self.steps += 1
        self.state_steps += 1
        delta, near = self._sense(ranges, odom)
        if self.steps < self.unstick_until:
            command = self._unstick(ranges, near)
        else:
            vx, vy, w = HANDLERS[self.state](self, ranges, near, odom, delta)
            if self.state is not State.REVERSE:
                vx, vy, w = filtered(near, vx, vy, w, self.motion)
            command = (vx, vy, w)
        self.odometry.previous_odom = odom
        return np.array(command, dtype=np.float32)

    def _sense(self, ranges: FloatArray, odom: Pose) -> tuple[Pose, FloatArray]:
        """The pose, the map and the object's evidence from one scan, and the still-standing
        count; returns the odometry's motion since the last step and the robot-frame points the
        filters keep the footprint off (the scan within 1.2 m, and the map in the blind sector)."""
        cfg, lrf = self.config, self.spec.lrf
        pose = self.odometry
        delta = pose.predict(odom)
        if self.steps >= 3 and cfg.scan_matching:
            pose.align(ranges, self.angles, self.occupancy, lrf.range_max_m)
        elif cfg.search_align and self.finder.stored is not None:  # against the map stored at parking
            pose.align(
                ranges,
                self.angles,
                self.occupancy,
                lrf.range_max_m,
                self.finder.stored,
                heading_only=True,
                explained=cfg.search_align_explained,
            )
        if cfg.square_gain > 0.0:
            pose.square(ranges, self.angles, looking=self.state is State.LOOK)
        pose.settle(odom)
        self.occupancy.integrate(self.pose, self.angles, ranges, lrf.range_max_m, self.steps)
        near = scan_points(ranges, self.angles, lrf.range_max_m, len(ranges))
        near = near[np.hypot(near[:, 0], near[:, 1]) < 1.2]
        behind = self.occupancy.mapped_near(self.pose, 0.7, self._blind_since())
        blind = np.abs(np.arctan2(behind[:, 1], behind[:, 0])) > lrf.angle_max_rad - 0.05
        # The map covers the LRF's blind sector, its points pulled towards the footprint (`wary`:
        # a cell centre may lie beyond its wall). The potential field and the safety filters see
        # the same points; the field's local minimum they make in a doorway is escaped in
        # `Follower.follow`.
        self._lrf_points = len(near)
        near = np.vstack([near, wary(behind[blind], self.motion)])
        if self.finder.stored is not None:
            self.finder.look(ranges, self.angles, self.pose, lrf.range_max_m, self.planner.given_up)
        moving = math.hypot(delta.x, delta.y) > 0.003 or abs(delta.theta) > 0.01
        waiting = self.state in (State.PARKED, State.FOUND, State.REVERSE)
        self.still_steps = 0 if moving or waiting else self.still_steps + 1
        if moving:
            self.unsticks = 0
        if self.still_steps > self._steps(8.0):
            self.unstick_until = self.steps + self._steps(1.5)
            self.unsticks += 1
            self.still_steps = 0
            self.planner.path = []
        return delta, near

    def _blind_since(self) -> int | None:
        """The first step whose hits the blind sector holds (`blind_memory_s`; None: every hit)."""
        memory = self.config.blind_memory_s
        since = self.steps - self._steps(memory) if memory > 0.0 else None
        if self.blind_from:
            since = self.blind_from if since is None else max(since, self.blind_from)
        return since

    def _unstick(self, ranges: FloatArray, near: FloatArray) -> Command:
        """Boxed in (the filters stop every way the plan wants): towards the most open direction
        in view, whatever the plan, then plan again (the 30 s idle rule). Wedged for 16 s, every
        way refused within the filters' margins (a jamb 2 cm beside it), it edges out with the
        margins cut to 1 cm and what the LRF sees now."""
        view = np.abs(self.angles) < 1.6
        k = int(np.argmax(np.where(view, ranges, -1.0)))
        a = float(self.angles[k])
        command = (0.12 * math.cos(a), 0.12 * math.sin(a), 0.0)
        vx, vy, w = safety_filter(near, command, self.motion)
        if vx == vy == 0.0 and self.unsticks >= 2:
            tight = dataclasses.replace(self.motion, margin=0.01, floor=0.01, slack=0.005)
            vx, vy, w = safety_filter(near[: self._lrf_points], command, tight)
        return vx, vy, w

    def overlay(self) -> Overlay:
        """The occupied cells, the path and target, in the agent's (odometry) frame."""
        pts = self.occupancy.occupied_points()
        here = np.array([self.pose.x, self.pose.y])
        planner = self.planner
        path = np.array([here, *planner.path]) if planner.path else np.zeros((0, 2))
        crosses = [(f[0] - d, f[1] - d, f[0] + d, f[1] + d) for f in planner.frontiers for d in (0.1,)] + [
            (f[0] - d, f[1] + d, f[0] + d, f[1] - d) for f in planner.frontiers for d in (0.1,)
        ]
        return Overlay(
            frame="odom",
            segments=np.array(crosses, dtype=float).reshape(-1, 4),
            points=pts.reshape(-1, 2),
            path=path.reshape(-1, 2),
            target=planner.goal if self.finder.object is None else self.finder.object,
            text=f"classic explore: {self.state.value}",
        )


def build(env: Any, **kwargs: Any) -> ExploreAgent:
    """The classic explore agent for an env's robot (`make_agent("classic", env)`)."""
    return ExploreAgent(RobotSpec.of(env), **kwargs)
