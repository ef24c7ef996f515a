"""The escape-room task: where PICO starts, when it has escaped, and what each step is worth.

Competition rules (docs/facts/pico-facts.md): finished = the whole robot across the finish line without
bumping; a trial ends on a bump, or after 30 s without sensible movement; 5 minutes in total.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from pico_gym.jit import njit
from pico_gym.robot import RobotConfig
from pico_gym.sensors.lrf import lrf_ranges
from pico_gym.tasks.base import (
    IDLE_TIME_S,
    ConfiguredTask,
    Episode,
    GeodesicProgress,
    IdleRule,
    StepContext,
    StepOutcome,
    in_a_wall,
)
from pico_gym.types import FloatArray, Pose
from pico_gym.validate import flag, number
from pico_gym.world import geometry
from pico_gym.world.escape_room import EscapeRoomConfig, generate_escape_room, sample_start_pose
from pico_gym.world.finish import auto_finish
from pico_gym.world.grid import CostGrid, GeodesicField, Grid, clearance_grid, geodesic_field
from pico_gym.world.map import Map, MapError
from pico_gym.world.movers import Movers
from pico_gym.world.scene import Scene

# Competition rules: 30 s without sensible movement ends a trial; 5 minutes per team.
TIME_LIMIT_S = 300.0

TERMINATION_REASONS = ("escaped", "bump", "idle", "timeout")


# Named families of generated escape rooms (`gym.make("PicoEscape-v0", family=NAME)`), harder
# than the rules' defaults in one way each: "cluttered" (3-5 boxes in the room) and "narrow" (a
# corridor at the rules' narrow end, 0.5-0.6 m).
FAMILIES: dict[str, dict[str, Any]] = {
    "cluttered": {"n_obstacles": (3, 5)},
    "narrow": {"corridor_width_m": (0.5, 0.6)},
}


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the named reward terms; reward = sum of weight * term.

    Attributes:
        progress: per metre of decrease of the geodesic distance to the finish line.
        success: once, on escaping.
        bump: per bump (the term is minus the number of new bumps).
        time: per second of simulated time (the term is minus the step's duration).
        proximity: per second spent closer to a wall than `proximity_m`, scaled by how much closer
            (the term is minus the step's duration times max(0, 1 - clearance / proximity_m)): a
            dense warning before a bump. Off by default.
        proximity_m: the footprint clearance under which the proximity term starts [m].
        approach: per unit of "closeness" gained towards the walls, closeness being
            max(0, 1 - clearance / approach_m) (the term is closeness before the step minus after).
            Potential-based shaping (Ng et al., 1999): over an episode it sums to the closeness at
            the start minus at the end, so it warns while the robot closes in on a wall without
            taxing a narrow corridor it drives along. Off by default.
        approach_m: the footprint clearance under which closeness starts to grow [m].
    """

    progress: float = 1.0
    success: float = 10.0
    bump: float = 10.0
    time: float = 0.1
    proximity: float = 0.0
    proximity_m: float = 0.1
    approach: float = 0.0
    approach_m: float = 0.25

    def __post_init__(self) -> None:
        for name in ("progress", "success", "bump", "time", "proximity", "approach"):
            number(f"RewardWeights.{name}", getattr(self, name))
        for name in ("proximity_m", "approach_m"):
            number(f"RewardWeights.{name}", getattr(self, name), 0.0, lo_open=True, unit=" m")

    def vector(self) -> FloatArray:
        """The weights as `weighted_terms` takes them: the terms' weights in `REWARD_TERMS`' order,
        `proximity_m` after `proximity`'s and `approach_m` after `approach`'s."""
        return np.array(
            [self.progress, self.success, self.bump, self.time, self.proximity, self.proximity_m, self.approach,
             self.approach_m],
            dtype=np.float64,
        )  # fmt: skip


@dataclass(frozen=True)
class EscapeTaskConfig:
    """Rules of the escape task.

    Attributes:
        collision: "terminate" ends the episode at the first bump (the competition's rule);
            "continue" keeps going and counts bumps.
        idle_time_s: the episode ends after this long without sensible movement [s].
        idle_speed_mps: true translational speed below which the robot is standing still [m/s].
        idle_turn_rate_radps: true turn rate below which the robot is not turning [rad/s].
        time_limit_s: the episode is truncated at this simulated time [s].
        start_clearance_m: minimum distance between the start footprint and any wall [m].
        sample_start: draw the start pose (from the start area, else anywhere enclosed) even on
            a map that fixes one, e.g. to benchmark many starts on one map.
        rewards: weights of the reward terms.
        room: ranges of the escape-room generator.
        geodesic_resolution_m: cell size of the geodesic distance field [m].
        finish: "auto" finds a fixed map's finish line from its walls (`pico_gym.world.finish`:
            across the corridor, 3 m past its mouth as the rules say); None (default) takes the
            map's own `finish`, and finds one for a heightmap map that has none (a course image).
    """

    collision: Literal["terminate", "continue"] = "terminate"
    idle_time_s: float = IDLE_TIME_S
    idle_speed_mps: float = 0.02
    idle_turn_rate_radps: float = 0.05
    time_limit_s: float = TIME_LIMIT_S
    start_clearance_m: float = 0.05
    sample_start: bool = False
    rewards: RewardWeights = field(default_factory=RewardWeights)
    room: EscapeRoomConfig = field(default_factory=EscapeRoomConfig)
    geodesic_resolution_m: float = 0.05
    finish: str | None = None

    def __post_init__(self) -> None:
        if self.finish not in (None, "auto"):
            raise ValueError(f"finish must be 'auto' or None (the map's own), got {self.finish!r}")
        if self.collision not in ("terminate", "continue"):
            raise ValueError(f"collision must be 'terminate' or 'continue', got {self.collision!r}")
        number("EscapeTaskConfig.time_limit_s", self.time_limit_s, 0.0, 1e6, lo_open=True, unit=" s")
        number("EscapeTaskConfig.idle_time_s", self.idle_time_s, 0.0, 1e6, lo_open=True, unit=" s")
        number("EscapeTaskConfig.idle_speed_mps", self.idle_speed_mps, 0.0, unit=" m/s")
        number("EscapeTaskConfig.idle_turn_rate_radps", self.idle_turn_rate_radps, 0.0, unit=" rad/s")
        number("EscapeTaskConfig.start_clearance_m", self.start_clearance_m, 0.0, 1.0, unit=" m")
        number("EscapeTaskConfig.geodesic_resolution_m", self.geodesic_resolution_m, 0.01, 0.5, unit=" m")
        flag("EscapeTaskConfig.sample_start", self.sample_start)

    @property
    def idle_rule(self) -> IdleRule:
        return IdleRule(self.idle_time_s, self.idle_speed_mps, self.idle_turn_rate_radps)


@njit
def _min_signed_distance(
    x: float, y: float, theta: float, outline: FloatArray, px: float, py: float, nx: float, ny: float
) -> float:
    """Smallest signed distance of the footprint's vertices past a line (point p, unit normal n)."""
    c, s = math.cos(theta), math.sin(theta)
    best = math.inf
    for i in range(outline.shape[0]):
        vx = x + c * outline[i, 0] - s * outline[i, 1]
        vy = y + s * outline[i, 0] + c * outline[i, 1]
        d = (vx - px) * nx + (vy - py) * ny
        if d < best:
            best = d
    return best


def _start_side(world: Map) -> FloatArray:
    """A point on the side of the finish line the robot starts on.

    The start pose, else the centre of the start areas, else the mean of the wall points (for an
    escape room, inside the room: the corridor is only one wall's worth of points), else the
    centre of the map's bounds.
    """
    if world.start_pose is not None:
        return np.array(world.start_pose[:2])
    if world.start_area:
        return np.mean([world.polygon(a).mean(axis=0) for a in world.start_area], axis=0)
    if len(world.walls):
        return world.points[np.unique(world.walls)].mean(axis=0)
    x0, y0, x1, y1 = world.bounds
    return np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1)])


# A start drawn anywhere on a map must be enclosed: rays in at least this fraction of directions hit
# a wall (inside an escape room only the corridor's bearing is open; outside, about half is).
ENCLOSED_FRACTION = 0.75
_FAN = np.linspace(-math.pi, math.pi, 72, endpoint=False)


def is_enclosed(x: float, y: float, segments: FloatArray) -> bool:
    """True when walls surround (x, y): a 360-degree fan of rays mostly hits something."""
    hits = np.isfinite(lrf_ranges(Pose(x, y, 0.0), segments, _FAN, max_range=50.0))
    return float(hits.mean()) >= ENCLOSED_FRACTION


def _finish_of(world: Map) -> FloatArray:
    """An escape map's finish line, (2, 2) float64 (the task refuses a map without one)."""
    if world.finish is None:
        raise MapError(f"{world.source or world.name}: an escape map needs a 'finish' line")
    return np.asarray(world.finish, dtype=np.float64)


# The escape task's reward terms: their names, in the order `weighted_terms` computes them and
# `RewardWeights.vector` lists their weights. The single env's step (`EscapeTask.reward_terms`)
# and the vector env's compiled batch (`pico_gym.batched`) both compute them with `weighted_terms`.
REWARD_TERMS = ("progress", "success", "bump", "time", "proximity", "approach")


@njit
def closeness(clearance_m: float, within_m: float) -> float:
    """0 at `within_m` or more from the walls, rising to 1 at contact: max(0, 1 - clearance / within_m)."""
    c = 1.0 - clearance_m / within_m
    return c if c > 0.0 else 0.0


@njit
def weighted_terms(
    weights: FloatArray,
    progress_m: float,
    escaped: bool,
    new_bumps: int,
    dt_s: float,
    clearance_m: float,
    previous_clearance_m: float,
) -> tuple[float, float, float, float, float, float]:
    """The weighted reward terms of one step, in `REWARD_TERMS`' order (`weights`:
    `RewardWeights.vector()`; the clearances: the footprint's after and before the step)."""
    w_progress, w_success, w_bump, w_time = weights[0], weights[1], weights[2], weights[3]
    w_proximity, proximity_m, w_approach, approach_m = weights[4], weights[5], weights[6], weights[7]
    return (
        w_progress * progress_m,
        w_success * (1.0 if escaped else 0.0),
        -w_bump * new_bumps,
        -w_time * dt_s,
        -w_proximity * dt_s * closeness(clearance_m, proximity_m),
        w_approach * (closeness(previous_clearance_m, approach_m) - closeness(clearance_m, approach_m)),
    )


class EscapeTask(ConfiguredTask):
    """Spawning, success, reward terms and termination for the escape room (a `Task`)."""

    termination_reasons: tuple[str, ...] = TERMINATION_REASONS
    option_keys: frozenset[str] = frozenset()
    goal_name = "the finish line"

    def __init__(self, config: EscapeTaskConfig, robot: RobotConfig, fixed_map: Map | None = None) -> None:
        if fixed_map is not None and (config.finish == "auto" or fixed_map.finish is None):
            fixed_map = _with_finish(fixed_map, config.finish == "auto")
        self.config = config
        self.robot = robot
        self.fixed_map = fixed_map
        self._field_cache: tuple[Map, GeodesicField] | None = None
        self._room_cache: tuple[Map, Grid, np.ndarray] | None = None
        self._finish_point = np.zeros(2)
        self._finish_normal = np.zeros(2)
        self._progress: GeodesicProgress = None  # type: ignore[assignment]  # made by new_episode
        self._line = (0.0,) * 8  # the finish segment, its point and outward normal
        self._out = False  # the centre went out through the finish segment (and not back)
        self._weights = config.rewards.vector()
        if fixed_map is not None:
            self._check_map(fixed_map)

    # --- reset -------------------------------------------------------------------------
    def new_episode(
        self, rng: np.random.Generator, options: dict[str, Any] | None = None, start: Pose | None = None
    ) -> Episode:
        """Draw (or take) the world and the start pose, and prepare the progress field."""
        room = None
        given = start
        if self.fixed_map is None:
            room = generate_escape_room(rng, self.config.room, self.robot)
            world = room.map
            self._set_finish(world, room.route[0])
            if start is None:
                start = sample_start_pose(room, rng, self.robot, self.config.start_clearance_m)
        else:
            world = self.fixed_map
            self._set_finish(world, _start_side(world))
            if start is None:
                fixed = world.start_pose is not None and not self.config.sample_start
                start = world.start_pose if fixed else self._sample_fixed_start(world, rng)
        assert start is not None  # (a fixed start is the map's start_pose, else one was drawn)
        # A drawn room's field covers only what the robot can reach before the line (a fixed
        # map's, kept for every episode, covers the whole map).
        field = self._field(world, None if world is self.fixed_map else (start.x, start.y))
        if self._centre_past_line(start):
            raise ValueError(f"options['start_pose'] {tuple(start)} is past the finish line")
        if given is not None and not in_a_wall(world.solid_segments(), given, self.robot.outline):
            inside = room.route[0] if room is not None else _start_side(world)
            if not self._in_room(world, given, (float(inside[0]), float(inside[1]))):
                raise ValueError(
                    f"options['start_pose'] {tuple(given)} is outside the walls: not in the room the finish line closes"
                )
        # Every door of an escape map is closed (a door leaf is part of the room).
        # (a map's movers walk here too: a course config's objects, `sim_config=`)
        movers = Movers(list(world.movers)) if world.movers else Movers(())
        scene = Scene(world, closed_doors=tuple(range(len(world.door_segments))), movers=movers)
        return self._begin(world, scene, field, start, room)

    def join_episode(
        self, first: Episode, rng: np.random.Generator, options: dict[str, Any], start: Pose | None, others: list[Pose]
    ) -> Episode:
        """A second robot's episode in `first`'s room (the same walls, finish line and movers): a
        start of its own, given, or drawn clear of the robots at `others`."""
        world, scene, field, room = first.scene.map, first.scene, first.extra["field"], first.extra["room"]
        self._set_finish(world, room.route[0] if room is not None else _start_side(world))
        if start is None:
            start = self._start_clear_of(world, room, rng, others)
        elif self._centre_past_line(start):
            raise ValueError(f"options['start_pose'] {tuple(start)} is past the finish line")
        return self._begin(world, scene, field, start, room)

    def _start_clear_of(self, world: Map, room: Any, rng: np.random.Generator, others: list[Pose]) -> Pose:
        """A start drawn as the first robot's was, its footprint clear of the robots at `others`."""
        outline = self.robot.outline
        walls = [geometry.transform_points(p, outline) for p in others]
        edges = np.vstack([np.hstack([w, np.roll(w, -1, axis=0)]) for w in walls]) if walls else np.zeros((0, 4))
        for _ in range(200):
            if room is not None:
                pose = sample_start_pose(room, rng, self.robot, self.config.start_clearance_m)
            else:
                pose = self._sample_fixed_start(world, rng)
            footprint = geometry.transform_points(pose, outline)
            if not len(edges) or geometry.polygon_clearance(footprint, edges, 0.2) >= 0.1:
                return pose
        raise ValueError(f"{world.source or world.name}: no start for a second robot clear of the first (200 draws)")

    def _begin(self, world: Map, scene: Scene, field: GeodesicField, start: Pose, room: Any) -> Episode:
        """The episode from its scene, field and start: the oracle path and the task's state."""
        # The oracle path: the origin's geodesic to the line, plus the footprint's rear half so
        # the whole robot is across.
        rear = float(-self.robot.outline[:, 0].min())
        shortest = field.lookup(start.x, start.y) + rear
        self._progress = GeodesicProgress(field, start)
        (ax, ay), (bx, by) = _finish_of(world).tolist()
        p, n = self._finish_point.tolist(), self._finish_normal.tolist()
        self._line = (ax, ay, bx, by, p[0], p[1], n[0], n[1])  # plain floats for the step
        self._out = False
        return Episode(scene, start, shortest, extra={"field": field, "room": room})

    def _check_map(self, world: Map) -> None:
        """What a fixed map must give, checked at load: a start pose (if it has one) inside the
        walls, off every obstacle, before the finish line and with a path to it for the footprint;
        otherwise a start area (or the whole map) with such a pose in it.

        Raises:
            MapError: naming the file and the key.
        """
        where = world.source or world.name
        self._set_finish(world, _start_side(world))
        if world.start_pose is not None:
            pose = world.start_pose
            at = f"start_pose ({pose.x:.3f}, {pose.y:.3f})"
            if not is_enclosed(pose.x, pose.y, world.solid_segments()):
                raise MapError(f"{where}: {at} is not inside the walls")
            if self.start_problem(world, pose) is not None:
                raise MapError(f"{where}: {at} {self.start_problem(world, pose)}")
        if world.start_pose is None or self.config.sample_start:
            try:  # a fixed generator: a check, not a draw of any episode
                self._sample_fixed_start(world, np.random.default_rng(0), tries=2000)
            except ValueError:
                key = "start_area" if world.start_area else "start_area (none given: anywhere inside the walls)"
                raise MapError(
                    f"{where}: {key}: found no free start pose in it with a path to the finish line"
                ) from None

    def _centre_past_line(self, pose: Pose) -> bool:
        p, n = self._finish_point, self._finish_normal
        return bool((pose.x - p[0]) * n[0] + (pose.y - p[1]) * n[1] >= 0.0)

    def start_problem(self, world: Map, pose: Pose) -> str | None:
        """Why `pose` cannot start an escape on `world` (None when it can)."""
        if self._centre_past_line(pose):
            return "is past the finish line"
        if not math.isfinite(self._field(world).lookup(pose.x, pose.y)):
            return "is inside an obstacle or has no path to the finish line for the robot's footprint"
        return None

    def _in_room(self, world: Map, pose: Pose, inside: tuple[float, float]) -> bool:
        """Whether the robot's centre at `pose` is in the room (with its corridor) that holds
        `inside`, the finish line closing it (a fixed map's room is kept for every episode)."""
        if self._room_cache is not None and self._room_cache[0] is world:
            grid, mask = self._room_cache[1], self._room_cache[2]
        else:
            grid = Grid.covering(world.bounds, self.config.geodesic_resolution_m, margin=1.0)
            closed = np.vstack([world.solid_segments(), _finish_of(world).reshape(1, 4)])
            costs = CostGrid.from_clearance(grid, clearance_grid(grid, closed, cap=0.5))
            mask = costs.reachable_from(*inside)
            if world is self.fixed_map:
                self._room_cache = (world, grid, mask)
        c = int((pose.x - grid.x0) / grid.resolution)
        r = int((pose.y - grid.y0) / grid.resolution)
        return 0 <= r < grid.shape[0] and 0 <= c < grid.shape[1] and bool(mask[r, c])

    def _field(self, world: Map, start: tuple[float, float] | None = None) -> GeodesicField:
        """The geodesic field to the finish line (with `start`: only where a robot from there can be)."""
        if self._field_cache is not None and self._field_cache[0] is world:
            return self._field_cache[1]
        grid = Grid.covering(world.bounds, self.config.geodesic_resolution_m, margin=1.0)
        side = self._finish_point - self._finish_normal
        field = geodesic_field(
            grid, world.solid_segments(), _finish_of(world), (float(side[0]), float(side[1])), start=start
        )
        if world is self.fixed_map:
            self._field_cache = (world, field)
        return field

    def _set_finish(self, world: Map, start_side: FloatArray) -> None:
        a, b = _finish_of(world)
        d = (b - a) / np.linalg.norm(b - a)
        normal = np.array([-d[1], d[0]])
        if (np.asarray(start_side) - a) @ normal > 0:
            normal = -normal  # point away from the start side
        self._finish_point = a
        self._finish_normal = normal

    def _sample_fixed_start(self, world: Map, rng: np.random.Generator, tries: int = 10000) -> Pose:
        """A start pose on a fixed map without start_pose: in its start area, else anywhere free
        and enclosed by walls."""
        segments = world.solid_segments()
        areas = [world.polygon(a) for a in world.start_area]
        if areas:
            region = areas[int(rng.integers(len(areas)))]
        else:
            x0, y0, x1, y1 = world.bounds
            region = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
        lo, hi = region.min(axis=0), region.max(axis=0)
        for _ in range(tries):
            x, y = rng.uniform(lo, hi)
            pose = Pose(float(x), float(y), float(rng.uniform(-math.pi, math.pi)))
            if not geometry.point_in_polygon(pose.x, pose.y, region):
                continue
            if not areas and not is_enclosed(pose.x, pose.y, segments):
                continue
            footprint = geometry.transform_points(pose, self.robot.outline)
            if geometry.polygon_clearance(footprint, segments) < self.config.start_clearance_m:
                continue
            if self.past_finish(pose) < 0 and math.isfinite(self._field(world).lookup(pose.x, pose.y)):
                return pose
        where = world.source or world.name
        raise ValueError(f"{where}: found no free start pose with a path to the finish line")

    # --- step --------------------------------------------------------------------------
    def past_finish(self, pose: Pose) -> float:
        """How far the whole footprint is past the finish line (negative: not yet across)."""
        p, n = self._finish_point, self._finish_normal
        return _min_signed_distance(pose.x, pose.y, pose.theta, self.robot.outline, p[0], p[1], n[0], n[1])

    def _crossing(self, before: Pose, after: Pose) -> int:
        """+1 when the robot's centre went out through the finish line segment in this step, -1
        when it came back in through it, 0 otherwise (crossing the line's extension beside the
        corridor is no crossing)."""
        ax, ay, bx, by, px, py, nx, ny = self._line
        d0 = (before.x - px) * nx + (before.y - py) * ny
        d1 = (after.x - px) * nx + (after.y - py) * ny
        if (d0 <= 0.0) == (d1 <= 0.0):
            return 0  # the centre stayed on one side of the line (the common case: no kernel call)
        if not geometry.segments_intersect(before.x, before.y, after.x, after.y, ax, ay, bx, by):
            return 0
        return 1 if d1 > 0.0 else -1

    def evaluate(self, ctx: StepContext) -> StepOutcome:
        """Judge one step: its reward terms, and why the episode ends now (or None).

        Escaped: the robot's centre has gone out through the finish line segment (inside the
        corridor, not round it) and the whole footprint is past the line."""
        progress = self._progress.update(ctx.pose)
        crossing = self._crossing(ctx.pose_before, ctx.pose)
        if crossing:
            self._out = crossing > 0
        escaped = self._out and self.past_finish(ctx.pose) > 0.0
        return StepOutcome(
            self.reward_terms(progress, escaped, ctx.new_bumps, ctx.dt_s, ctx.clearance_m, ctx.previous_clearance_m),
            self.termination(escaped, ctx.bumps, ctx.idle_s),
            escaped,
        )

    # --- what a compiled batch of robots reads and writes (`pico_gym.batched`) ---------------
    @property
    def finish_line(self) -> tuple[float, float, float, float, float, float, float, float]:
        """The finish segment's ends, a point on it and its outward normal, as plain floats."""
        return self._line

    @property
    def progress_field(self) -> GeodesicField:
        """The episode's geodesic field to the finish (the progress term's)."""
        return self._progress.field

    @property
    def weights(self) -> FloatArray:
        """The reward weights as `weighted_terms` takes them (`RewardWeights.vector`)."""
        return self._weights

    def progress_state(self) -> tuple[float, bool]:
        """(the geodesic distance at the last pose, whether the centre went out through the line)."""
        return self._progress.value, self._out

    def set_progress_state(self, value: float, out: bool) -> None:
        """Put back a progress state a batch stepped on."""
        self._progress.value = value
        self._out = out

    def info(self) -> dict[str, Any]:
        """`geodesic_to_finish`: the oracle's remaining path length to the finish line [m]."""
        return {"geodesic_to_finish": self._progress.value}

    def reward_terms(
        self,
        progress_m: float,
        escaped: bool,
        new_bumps: int,
        dt_s: float,
        clearance_m: float = math.inf,
        previous_clearance_m: float = math.inf,
    ) -> dict[str, float]:
        """The weighted reward terms of one step (clearance_m and previous_clearance_m: the
        footprint's, after and before the step)."""
        terms = weighted_terms(
            self._weights, progress_m, bool(escaped), int(new_bumps), dt_s, clearance_m, previous_clearance_m
        )
        return dict(zip(REWARD_TERMS, terms, strict=True))

    def termination(self, escaped: bool, bumps: int, idle_s: float) -> str | None:
        """Why the episode ends now (one of TERMINATION_REASONS but timeout), or None."""
        if escaped:
            return "escaped"
        if bumps > 0 and self.config.collision == "terminate":
            return "bump"
        if idle_s >= self.config.idle_time_s:
            return "idle"
        return None


def _with_finish(world: Map, asked: bool) -> Map:
    """The map with its finish line found from its walls (`finish="auto"`, or a heightmap map
    without one: a course image); a drawn map without one is refused, saying how to get one."""
    where = str(world.source or world.name)
    if not asked and world.heightmap is None:
        raise ValueError(
            f"{where}: an escape map needs a 'finish' line ([[x1, y1], [x2, y2]] across the corridor), "
            'or finish="auto" to find it from the walls'
        )
    if world.start_pose is not None:
        start = (world.start_pose.x, world.start_pose.y)
    elif world.start_area:
        cx, cy = world.polygon(world.start_area[0]).mean(axis=0)
        start = (float(cx), float(cy))
    else:
        x0, y0, x1, y1 = world.bounds
        start = (0.5 * (x0 + x1), 0.5 * (y0 + y1))
    line, warning = auto_finish(world.solid_segments(), start, where)
    if warning is not None:
        warnings.warn(warning, stacklevel=4)
    return dataclasses.replace(world, finish=line)
