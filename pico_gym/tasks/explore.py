"""The 2018 explore task: explore an unknown hospital, park backwards, then find the object.

Course rules (docs/facts/hospital-facts.md 1.3, 1.10): PICO starts in the hallway up to 1 m from the "parking
wall", which is behind it; it explores the 3-6 rooms of a building it was not given, parks
backwards against that wall ("I am parked!"), and then finds an object placed in one of the rooms
(the one that needs the most doors to reach from the start, as the teams were told) and stands
still close to it ("I found the object!"). Same bump rule as the other challenges, never 30 s
standing still, 10 minutes in total (S18-1; S18-4 gave 5 minutes per task: `phase_time_limit_s`).

pico-gym's predicates, where the course left them to the tutors:
- parked: the footprint's rear edge within `touch_m` of the parking wall, the heading within
  `park_heading_tolerance_rad` of pointing away from it, the speed when the touch began at most
  `park_speed_mps`; then a dwell of `park_dwell_s` (or an announcement). A gentle touch of the rear
  edge against the parking wall is not a bump.
- found: still for `find_still_s` with the footprint within `find_distance_m` of the object and not
  touching it (or an announcement after that).
- coverage: the fraction of the building's free area (cells of a `coverage_resolution_m` grid
  reachable from the start) that a beam of the LRF has passed through; per room the same.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from pico_gym.jit import njit
from pico_gym.metrics import EpisodeMetrics, max_of, median_of
from pico_gym.robot import RobotConfig
from pico_gym.sensors.lrf import LrfConfig
from pico_gym.tasks.base import IDLE_TIME_S, ConfiguredTask, Episode, IdleRule, StepContext, StepOutcome, in_a_wall
from pico_gym.types import FloatArray, Pose, Segments
from pico_gym.validate import number, span
from pico_gym.world import geometry
from pico_gym.world.grid import CostGrid, Grid, _flood, clearance_grid
from pico_gym.world.hospital2018 import ExploreHospitalConfig, generate_explore_hospital
from pico_gym.world.map import Map, MapError
from pico_gym.world.scene import Scene, box_corners

TIME_LIMIT_S = 600.0  # S18-1: "map the hospital and find the object in 10 minutes"
TERMINATION_REASONS = ("done", "bump", "idle", "false_announcement", "timeout")
PHASES = ("explore", "park", "find", "done")
OBJECT_HINT = "the object is in the room that needs the most doors to reach from the start"
# The geodesic's robot: its centre keeps the footprint's half-depth from walls (as the hospital's).
FIELD_INFLATION_M = 0.1
# Regions smaller than this are slivers (door corners), not rooms [cells].
MIN_REGION_CELLS = 20
# The true free area is rasterised this fine for `belief_iou` (short by 6 mm on average along each
# wall; an exact map drawn at 5 cm scores 0.98, its own cells' rounding being the rest).
IOU_RESOLUTION_M = 0.0125
IOU_MAX_CELLS = 4_000_000  # coarser on a building larger than 25 m x 25 m (memory)


# Named families of generated 2018 hospitals (`gym.make("PicoExplore-v0", family=NAME)`), each
# a layout of the generator that stresses the search (`pico_gym.world.hospital2018`): "comb" (the
# rooms hang off a side corridor, each with its own door), "deep-L" (the rooms at the far end of
# an L hallway's far leg), "nested" (4-6 rooms in rows behind one another, one reached through two).
FAMILIES: dict[str, dict[str, Any]] = {
    "comb": {"layout": "comb", "nested_probability": 0.0},
    "deep-L": {"layout": "deep-L"},
    "nested": {"layout": "nested", "nested_probability": 1.0, "n_rooms": (4, 6)},
}


@dataclass(frozen=True)
class ExploreRewardWeights:
    """Weights of the named reward terms; reward = sum of weight * term.

    Attributes:
        coverage: per square metre of the building's free area seen for the first time.
        park: once, on parking.
        found: once, on finding the object.
        bump: per bump.
        time: per second of simulated time.
        false_announce: per announcement whose predicate did not hold.
    """

    coverage: float = 0.1
    park: float = 10.0
    found: float = 10.0
    bump: float = 10.0
    time: float = 0.1
    false_announce: float = 1.0

    def __post_init__(self) -> None:
        for name in ("coverage", "park", "found", "bump", "time", "false_announce"):
            number(f"ExploreRewardWeights.{name}", getattr(self, name))


@dataclass(frozen=True)
class ExploreTaskConfig:
    """Rules of the explore task and the ranges of its per-episode draws.

    Attributes:
        arrival: "dwell" (parking and finding count after standing still; the action is a twist)
            or "announce" (the action gets a fourth component; a positive value announces).
        park_dwell_s: with "dwell", how long the parked predicate must hold [s].
        find_still_s: how long the robot must stand still near the object [s].
        still_speed_mps, still_turn_rate_radps: true speed and turn rate under which it is still.
        touch_m: the rear edge touches the parking wall within this distance [m] (the physics
            keeps a 0.01 m contact skin).
        park_heading_tolerance_rad: how far from pointing away from the wall the heading may be.
        park_speed_mps: the largest speed at which the rear edge may reach the wall.
        find_distance_m: the footprint within this of the object counts as close [m].
        explore_coverage: a room is explored once this fraction of it has been seen; the phase
            turns from "explore" to "park" once every room (and the hallway) is.
        start_distance_m: range of the start centre's distance from the parking wall [m].
        start_heading_tolerance_rad: the start heading is drawn within this of pointing away.
        start_clearance_m: minimum footprint clearance of a drawn start pose [m].
        object_side_m: range of the object's sides when the env places it [m].
        collision: "terminate" (the first bump ends the episode) or "continue".
        false_announcement: "count" or "terminate".
        idle_time_s, idle_speed_mps, idle_turn_rate_radps: the idle rule.
        time_limit_s: the episode is truncated at this simulated time [s].
        phase_time_limit_s: if set, also truncated this long after a phase began (S18-4: 300 s).
        coverage_resolution_m: cell size of the coverage grid [m].
        coverage_beam_stride: every this-many-th beam marks the coverage grid.
        phase_observation: add an observation key "phase" (0 before parking, 1 while finding).
        rewards: weights of the reward terms.
        hospital: ranges of the 2018 generator (maps drawn when no map is given).
    """

    arrival: Literal["dwell", "announce"] = "dwell"
    park_dwell_s: float = 0.5
    find_still_s: float = 1.0
    still_speed_mps: float = 0.05
    still_turn_rate_radps: float = 0.1
    touch_m: float = 0.02
    park_heading_tolerance_rad: float = math.radians(15.0)
    park_speed_mps: float = 0.1
    find_distance_m: float = 0.5
    explore_coverage: float = 0.95
    start_distance_m: tuple[float, float] = (0.35, 1.0)
    start_heading_tolerance_rad: float = math.radians(15.0)
    start_clearance_m: float = 0.05
    object_side_m: tuple[float, float] = (0.3, 0.5)
    collision: Literal["terminate", "continue"] = "terminate"
    false_announcement: Literal["count", "terminate"] = "count"
    idle_time_s: float = IDLE_TIME_S
    idle_speed_mps: float = 0.02
    idle_turn_rate_radps: float = 0.05
    time_limit_s: float = TIME_LIMIT_S
    phase_time_limit_s: float | None = None
    coverage_resolution_m: float = 0.1
    coverage_beam_stride: int = 2
    phase_observation: bool = False
    rewards: ExploreRewardWeights = field(default_factory=ExploreRewardWeights)
    hospital: ExploreHospitalConfig = field(default_factory=ExploreHospitalConfig)

    def __post_init__(self) -> None:
        for name, allowed in (
            ("arrival", ("dwell", "announce")),
            ("collision", ("terminate", "continue")),
            ("false_announcement", ("count", "terminate")),
        ):
            if getattr(self, name) not in allowed:
                raise ValueError(f"ExploreTaskConfig.{name} must be one of {allowed}, got {getattr(self, name)!r}")
        for name in ("park_dwell_s", "find_still_s", "idle_time_s", "time_limit_s"):
            number(f"ExploreTaskConfig.{name}", getattr(self, name), 0.0, 1e6, lo_open=True, unit=" s")
        if self.phase_time_limit_s is not None:
            number("ExploreTaskConfig.phase_time_limit_s", self.phase_time_limit_s, 0.0, 1e6, lo_open=True, unit=" s")
        for name in ("still_speed_mps", "still_turn_rate_radps", "idle_speed_mps", "idle_turn_rate_radps"):
            number(f"ExploreTaskConfig.{name}", getattr(self, name), 0.0)
        number("ExploreTaskConfig.touch_m", self.touch_m, 0.0, 0.1, lo_open=True, unit=" m")
        number("ExploreTaskConfig.park_speed_mps", self.park_speed_mps, 0.0, lo_open=True, unit=" m/s")
        number("ExploreTaskConfig.find_distance_m", self.find_distance_m, 0.0, 5.0, lo_open=True, unit=" m")
        number("ExploreTaskConfig.explore_coverage", self.explore_coverage, 0.0, 1.0)
        for name in ("park_heading_tolerance_rad", "start_heading_tolerance_rad"):
            number(f"ExploreTaskConfig.{name}", getattr(self, name), 0.0, math.pi, unit=" rad")
        span("ExploreTaskConfig.start_distance_m", self.start_distance_m, 0.15, 5.0)
        span("ExploreTaskConfig.object_side_m", self.object_side_m, 0.05, 2.0)
        number("ExploreTaskConfig.start_clearance_m", self.start_clearance_m, 0.0, 1.0, unit=" m")
        number("ExploreTaskConfig.coverage_resolution_m", self.coverage_resolution_m, 0.02, 0.5, unit=" m")
        number("ExploreTaskConfig.coverage_beam_stride", self.coverage_beam_stride, 1, 1000, integer=True)
        if not isinstance(self.phase_observation, bool):
            raise ValueError(
                f"ExploreTaskConfig.phase_observation must be True or False, got {self.phase_observation!r}"
            )

    @property
    def idle_rule(self) -> IdleRule:
        return IdleRule(self.idle_time_s, self.idle_speed_mps, self.idle_turn_rate_radps)


@dataclass(frozen=True, eq=False)
class ExploreTaskSpec:
    """What the 2018 teams were told, and all an agent may be given (`info["task"]` at reset).

    Attributes:
        phase: the phase the episode starts in ("explore", or "find" with `options={"phase": "find"}`).
        prior_map: None when exploring (nothing is given); when starting in "find", the true
            building (walls and door openings, no object), as the teams' saved map.
        arrival: "dwell" or "announce".
        park_dwell_s, find_still_s: the dwell rules [s].
        park_heading_tolerance_rad, park_speed_mps: the parking rule.
        find_distance_m: how close to the object counts.
        object_hint: where the object is (the course's "high-level hint").
        time_limit_s, phase_time_limit_s, idle_time_s: the limits.
    """

    phase: str
    prior_map: Map | None
    arrival: str
    park_dwell_s: float
    find_still_s: float
    park_heading_tolerance_rad: float
    park_speed_mps: float
    find_distance_m: float
    object_hint: str
    time_limit_s: float
    phase_time_limit_s: float | None
    idle_time_s: float


@dataclass(frozen=True, eq=False)
class OccupancyBelief:
    """An agent's map, as `Agent.belief()` hands it over for scoring.

    Attributes:
        cells: (rows, cols) int8: -1 unknown, 0 free, 1 occupied.
        origin: (x, y) of the lower-left corner of cell (0, 0), in the odometry frame.
        resolution_m: the cells' side [m].
    """

    cells: np.ndarray
    origin: tuple[float, float]
    resolution_m: float

    def __post_init__(self) -> None:
        cells = np.asarray(self.cells)
        if cells.ndim != 2 or cells.size == 0:
            raise ValueError(f"OccupancyBelief.cells must be a non-empty 2-D array, got shape {cells.shape}")
        if not np.isin(cells, (-1, 0, 1)).all():
            raise ValueError("OccupancyBelief.cells must hold only -1 (unknown), 0 (free) and 1 (occupied)")
        if len(self.origin) != 2 or not all(math.isfinite(float(v)) for v in self.origin):
            raise ValueError(f"OccupancyBelief.origin must be a finite (x, y), got {self.origin!r}")
        number("OccupancyBelief.resolution_m", self.resolution_m, 0.0, 10.0, lo_open=True, unit=" m")


# --- the building: free area, rooms, doors --------------------------------------------------


@dataclass(frozen=True, eq=False)
class Building:
    """A building's free area on the coverage grid, split into rooms at its door openings.

    Attributes:
        grid: the coverage grid.
        region: int32 per cell: -2 not free, -1 free but in a door opening, k >= 0 region k
            (region 0 holds the parking wall's side: the hallway).
        region_cells: cells per region.
        depth: doors on the way from region 0 into each region (-1: not reached through doors).
        clearance: each cell's distance to the static geometry (capped at 1.5 m).
        door_clearance: each cell's distance to the door openings (capped at 1.5 m).
        inside: the point the free area was flooded from.
    """

    grid: Grid
    region: np.ndarray
    region_cells: np.ndarray
    depth: np.ndarray
    clearance: FloatArray
    door_clearance: FloatArray
    inside: tuple[float, float]

    @property
    def n_free(self) -> int:
        return int((self.region >= -1).sum())


def free_space_of(world: Map, inside: tuple[float, float], resolution: float) -> tuple[Grid, np.ndarray, FloatArray]:
    """The cells of a `resolution` grid whose centres are reachable from the point `inside`:
    (grid, free mask, each cell's clearance to the static geometry capped at 1.5 m). A cell
    whose centre is within half a cell of a wall counts as wall (so no wall line leaks), so the
    free area comes out half a cell short along every wall on average."""
    grid = Grid.covering(world.bounds, resolution, margin=0.5)
    static = _static_segments(world)
    clearance = clearance_grid(grid, static, cap=1.5)
    block = 0.5 * resolution + 1e-6  # at least one blocked cell across every wall line
    costs = CostGrid.from_clearance(grid, clearance, inflation_m=block)
    free = costs.reachable_from(*inside)
    if free.sum() == 0 or free[0, :].any() or free[-1, :].any() or free[:, 0].any() or free[:, -1].any():
        raise ValueError(f"{world.source or world.name}: the building is not closed around {inside}")
    return grid, free, clearance


def building_of(world: Map, inside: tuple[float, float], resolution: float) -> Building:
    """The free area reachable from the point `inside`, and its rooms (`Building`)."""
    grid, free, clearance = free_space_of(world, inside, resolution)
    doors = [world.polygon(d) for d in world.doors]
    door_clearance, in_door = _door_cells(grid, doors)
    region = np.where(free, -1, -2).astype(np.int32)
    components = _open_components(grid, free & ~in_door, _cell(grid, *inside))
    for k, comp in enumerate(components):
        region[comp] = k
    counts = np.array([int(c.sum()) for c in components], dtype=np.int64)
    depth = _door_depths(grid, region, doors, len(components))
    return Building(grid, region, counts, depth, clearance, door_clearance, inside)


def _door_cells(grid: Grid, doors: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Each cell's clearance to the nearest door, and which cells a doorway covers."""
    if not doors:
        return np.full(grid.shape, 1.5), np.zeros(grid.shape, dtype=bool)
    resolution = grid.resolution
    door_segments = np.vstack([geometry.polygon_to_segments(p) for p in doors])
    door_clearance = clearance_grid(grid, door_segments, cap=1.5)
    xs, ys = grid.centres()
    in_door = door_clearance <= resolution + 1e-6
    for poly in doors:
        lo, hi = poly.min(axis=0), poly.max(axis=0)
        box = (xs >= lo[0]) & (xs <= hi[0]) & (ys >= lo[1]) & (ys <= hi[1])
        for r, c in np.argwhere(box):
            if geometry.point_in_polygon(float(xs[r, c]), float(ys[r, c]), poly):
                in_door[r, c] = True
    return door_clearance, in_door


def _open_components(grid: Grid, open_cells: np.ndarray, start_cell: tuple[int, int]) -> list[np.ndarray]:
    """The rooms: connected open areas, the start's first; specks below MIN_REGION_CELLS dropped."""
    labelled = np.zeros(grid.shape, dtype=bool)
    components: list[np.ndarray] = []
    seeds = [start_cell] if open_cells[start_cell] else []
    while True:
        if not seeds:
            remaining = np.argwhere(open_cells & ~labelled)
            if len(remaining) == 0:
                break
            seeds = [tuple(remaining[0])]
        r0, c0 = seeds.pop()
        comp = _flood(open_cells & ~labelled, int(r0), int(c0))
        labelled |= comp
        if comp.sum() >= MIN_REGION_CELLS or not components:
            components.append(comp)
    return components


def _door_depths(grid: Grid, region: np.ndarray, doors: list[np.ndarray], n: int) -> np.ndarray:
    """Doors join the regions found around their centres; depth = doors from region 0."""
    links: list[set[int]] = [set() for _ in range(n)]
    for poly in doors:
        cx, cy = poly.mean(axis=0)
        reach = 0.5 * float(np.min(poly.max(axis=0) - poly.min(axis=0))) + 0.25
        near = _labels_near(grid, region, float(cx), float(cy), reach)
        for a in near:
            links[a] |= near - {a}
    depth = np.full(n, -1, dtype=np.int64)
    depth[0] = 0
    frontier = [0]
    while frontier:
        nxt = []
        for a in frontier:
            for b in links[a]:
                if depth[b] < 0:
                    depth[b] = depth[a] + 1
                    nxt.append(b)
        frontier = nxt
    return depth


def _labels_near(grid: Grid, region: np.ndarray, x: float, y: float, reach: float) -> set[int]:
    res = grid.resolution
    r0, c0 = _cell(grid, x, y)
    k = int(math.ceil(reach / res))
    out: set[int] = set()
    for r in range(max(0, r0 - k), min(grid.shape[0], r0 + k + 1)):
        for c in range(max(0, c0 - k), min(grid.shape[1], c0 + k + 1)):
            px, py = grid.x0 + (c + 0.5) * res, grid.y0 + (r + 0.5) * res
            if region[r, c] >= 0 and math.hypot(px - x, py - y) <= reach:
                out.add(int(region[r, c]))
    return out


def _cell(grid: Grid, x: float, y: float) -> tuple[int, int]:
    c = int(np.clip((x - grid.x0) / grid.resolution, 0, grid.shape[1] - 1))
    r = int(np.clip((y - grid.y0) / grid.resolution, 0, grid.shape[0] - 1))
    return r, c


def _static_segments(world: Map) -> Segments:
    return np.vstack([world.structure_segments, world.cabinet_segments, world.obstacle_segments, world.low_segments])


@njit
def _mark_seen(
    seen: np.ndarray,
    region: np.ndarray,
    counts: np.ndarray,
    x0: float,
    y0: float,
    res: float,
    px: float,
    py: float,
    theta: float,
    angles: np.ndarray,
    ranges: np.ndarray,
    stride: int,
    range_min: float,
    range_max: float,
    zero_is_no_hit: bool,
) -> int:
    """Mark every cell a beam passed through, up to its reading (a grid walk per beam, Amanatides
    and Woo); returns how many free cells were seen for the first time, and adds each region's
    new cells to `counts`."""
    rows, cols = seen.shape
    fx, fy = (px - x0) / res, (py - y0) / res
    c0, q0 = int(math.floor(fx)), int(math.floor(fy))
    if c0 < 0 or c0 >= cols or q0 < 0 or q0 >= rows:
        return 0
    new = 0
    for k in range(0, angles.shape[0], stride):
        r = ranges[k]
        if r <= range_min:
            if not zero_is_no_hit:
                continue
            r = range_max
        a = theta + angles[k]
        new += _walk_beam(seen, region, counts, fx, fy, c0, q0, math.cos(a), math.sin(a), r / res)
    return new


@njit
def _walk_beam(
    seen: np.ndarray,
    region: np.ndarray,
    counts: np.ndarray,
    fx: float,
    fy: float,
    c0: int,
    q0: int,
    dx: float,
    dy: float,
    length: float,
) -> int:
    """One beam of `_mark_seen`, from cell (q0, c0) (position (fx, fy) in cells) along (dx, dy)
    for `length` cells: marks the cells it passes, returns how many free ones were new."""
    rows, cols = seen.shape
    new = 0
    c, q = c0, q0
    step_c = 1 if dx > 0 else -1
    step_q = 1 if dy > 0 else -1
    # Beam parameter (in cells) at the first vertical / horizontal cell boundary, and per cell.
    inv_x = 1.0 / abs(dx) if dx != 0.0 else math.inf
    inv_y = 1.0 / abs(dy) if dy != 0.0 else math.inf
    t_c = ((c + 1 - fx) if dx > 0 else (fx - c)) * inv_x
    t_q = ((q + 1 - fy) if dy > 0 else (fy - q)) * inv_y
    while True:
        if seen[q, c] == 0:
            seen[q, c] = 1
            g = region[q, c]
            if g >= -1:
                new += 1
                if g >= 0:
                    counts[g] += 1
        if t_c < t_q:
            if t_c > length:
                break
            c += step_c
            t_c += inv_x
        else:
            if t_q > length:
                break
            q += step_q
            t_q += inv_y
        if c < 0 or c >= cols or q < 0 or q >= rows:
            break
    return new


# --- the task -------------------------------------------------------------------------------


class ExploreTask(ConfiguredTask):
    """Spawning, the object, parking and finding, coverage, reward terms and termination (a `Task`).

    Reset options: `phase` ("explore", the default, or "find": start parked with the true map as
    a prior and the object in place), and the template's `start_pose`.
    """

    termination_reasons: tuple[str, ...] = TERMINATION_REASONS
    option_keys: frozenset[str] = frozenset({"phase"})
    goal_name = "the object"

    def __init__(
        self, config: ExploreTaskConfig, robot: RobotConfig, lrf: LrfConfig, fixed_map: Map | None = None
    ) -> None:
        self.config = config
        self.robot = robot
        self._angles = np.ascontiguousarray(lrf.beam_angles, dtype=np.float64)
        self._range_min, self._range_max = float(lrf.range_min_m), float(lrf.range_max_m)
        self._zero_is_no_hit = lrf.no_hit == "zero"
        outline = robot.outline
        back = float(outline[:, 0].min())
        ys = outline[np.isclose(outline[:, 0], back), 1]
        self._rear = np.array([(back, float(ys.min())), (back, float(ys.max()))])
        self._rear_offset = -back  # centre to rear edge [m]
        self.fixed_map = fixed_map
        self._fixed: tuple[FloatArray, FloatArray, Building] | None = None
        if fixed_map is not None:
            wall = parking_wall_of(fixed_map)
            normal, building = parking_side(fixed_map, wall, config.coverage_resolution_m)
            self._fixed = (wall, normal, building)
            _check_parking_wall(fixed_map, wall)
            obj = _object_of(fixed_map)  # refuse a bad `object` key at construction
            if obj is not None:
                _check_object(fixed_map, obj, building, wall, normal, config.find_distance_m)
        self.episode: Episode | None = None
        self._phase_began_s = 0.0

    @property
    def action_extras(self) -> tuple[np.ndarray, np.ndarray]:
        if self.config.arrival == "announce":
            return np.array([-1.0]), np.array([1.0])
        return np.zeros(0), np.zeros(0)

    @property
    def time_limit_s(self) -> float:
        cfg = self.config
        if cfg.phase_time_limit_s is None:
            return cfg.time_limit_s
        return min(cfg.time_limit_s, self._phase_began_s + cfg.phase_time_limit_s)

    # --- reset -------------------------------------------------------------------------------
    def new_episode(self, rng: np.random.Generator, options: dict[str, Any], start: Pose | None) -> Episode:
        cfg = self.config
        phase = options.get("phase", "explore")
        if phase not in ("explore", "find"):
            raise ValueError(f"options['phase'] must be 'explore' or 'find', got {phase!r}")
        if self._fixed is None:
            world = generate_explore_hospital(rng, cfg.hospital).map
            wall = parking_wall_of(world)
            normal, building = parking_side(world, wall, cfg.coverage_resolution_m)
        else:
            assert self.fixed_map is not None  # (`_fixed` is made from it)
            world = self.fixed_map
            wall, normal, building = self._fixed
        where = world.source or world.name
        obj = _object_of(world)
        if obj is None:
            obj = self._place_object(rng, world, building, where)
        static = _static_segments(world)
        if start is None:
            start = self._start(rng, static, wall, normal, where, parked=phase == "find")
        elif not in_a_wall(static, start, self.robot.outline):  # (a wall: the template says so)
            r, c = _cell(building.grid, start.x, start.y)
            if building.region[r, c] < -1:
                raise ValueError(
                    f"options['start_pose'] {tuple(start)} is outside the free space of {where}'s building"
                )
        empty = Scene(world)
        self._object_scene = Scene(world, (), (obj,), empty.movers)  # what the world becomes once parked
        scene = self._object_scene if phase == "find" else empty
        self._object = obj
        self._object_segments = geometry.polygon_to_segments(obj)
        self._wall, self._normal = wall, normal
        self._wall_points = wall.tolist()
        self._away = math.atan2(normal[1], normal[0])
        self._building = building
        self._iou_truth: tuple[FloatArray, FloatArray, float] | None = None  # `belief_iou`'s, built when first asked
        self._static = static
        self._seen = np.zeros(building.grid.shape, dtype=np.uint8)
        self._region_seen = np.zeros(len(building.region_cells), dtype=np.int64)
        self._n_seen = 0
        self._new_seen = 0
        self._room_coverage = (0.0,) * len(building.region_cells)
        self._entered = np.zeros(len(building.region_cells), dtype=bool)
        self._phase = "find" if phase == "find" else "explore"
        self._phase_began_s = 0.0
        self._parked = phase == "find"
        self._explored = False
        self._time_to_park: float | None = None
        self._time_to_find: float | None = None
        self._parking_error: dict[str, float] | None = None
        self._touching = False
        self._touch_speed = math.inf
        self._dwell = 0.0
        self._still = 0.0
        self._false = 0
        self._start_foot = float((np.asarray(start[:2]) - wall[0]) @ _unit(wall[1] - wall[0]))
        self._object_distance = self._footprint_to_object(start)
        shortest = self._oracle_length(building, start)
        public = ExploreTaskSpec(
            phase=self._phase,
            prior_map=world if phase == "find" else None,
            arrival=cfg.arrival,
            park_dwell_s=cfg.park_dwell_s,
            find_still_s=cfg.find_still_s,
            park_heading_tolerance_rad=cfg.park_heading_tolerance_rad,
            park_speed_mps=cfg.park_speed_mps,
            find_distance_m=cfg.find_distance_m,
            object_hint=OBJECT_HINT,
            time_limit_s=cfg.time_limit_s,
            phase_time_limit_s=cfg.phase_time_limit_s,
            idle_time_s=cfg.idle_time_s,
        )
        self.episode = Episode(scene, start, shortest, public, {"object": obj, "building": building})
        self._enter(start)
        return self.episode

    def _start(
        self, rng: np.random.Generator, solid: Segments, wall: FloatArray, normal: FloatArray, where: Any, parked: bool
    ) -> Pose:
        cfg = self.config
        along = wall[1] - wall[0]
        length = float(np.hypot(*along))
        direction = along / length
        away = math.atan2(normal[1], normal[0])
        for _ in range(200):
            lateral = float(rng.uniform(0.3, length - 0.3)) if length > 0.6 else 0.5 * length
            if parked:
                distance, heading = self._rear_offset + 0.5 * cfg.touch_m + 0.005, away
            else:
                distance = float(rng.uniform(*cfg.start_distance_m))
                tol = cfg.start_heading_tolerance_rad
                heading = away + float(rng.uniform(-tol, tol))
            x, y = wall[0] + direction * lateral + normal * distance
            pose = Pose(float(x), float(y), float(math.remainder(heading, 2.0 * math.pi)))
            footprint = geometry.transform_points(pose, self.robot.outline)
            need = 0.003 if parked else cfg.start_clearance_m
            if geometry.polygon_clearance(footprint, solid, need + 0.01) >= need:
                return pose
        raise ValueError(f"{where}: found no start pose in front of the parking wall with the footprint clear")

    def _place_object(self, rng: np.random.Generator, world: Map, b: Building, where: Any) -> FloatArray:
        """A box in a free spot of the room that needs the most doors (ties drawn)."""
        depth = b.depth
        deepest = np.flatnonzero(depth == depth.max())
        target = int(deepest[int(rng.integers(len(deepest)))])
        lo_side, hi_side = self.config.object_side_m
        a, c = (float(v) for v in rng.uniform(lo_side, hi_side, size=2))
        half = 0.5 * math.hypot(a, c)
        in_room = b.region == target
        for room_m, door_m in ((0.45, 0.6), (0.3, 0.45), (0.22, 0.3)):
            spots = np.argwhere(in_room & (b.clearance >= half + room_m) & (b.door_clearance >= half + door_m))
            if len(spots):
                r, col = spots[int(rng.integers(len(spots)))]
                x = b.grid.x0 + (col + 0.5) * b.grid.resolution
                y = b.grid.y0 + (r + 0.5) * b.grid.resolution
                return box_corners(float(x), float(y), 0.0, a, c)
        raise ValueError(f"{where}: no free spot for the object in the room that needs the most doors")

    def _oracle_length(self, b: Building, start: Pose) -> float:
        """The shortest path from the start to a point within `find_distance_m` of the object."""
        to_object = clearance_grid(b.grid, self._object_segments, cap=2.0)
        costs = CostGrid.from_clearance(b.grid, np.minimum(b.clearance, to_object), inflation_m=FIELD_INFLATION_M)
        field = costs.field_from_point(start.x, start.y)
        near = to_object <= self.config.find_distance_m + self._rear_offset
        values = field.distance[near & np.isfinite(field.distance)]
        return float(values.min()) if len(values) else math.inf

    # --- step --------------------------------------------------------------------------------
    def on_scan(self, pose: Pose, ranges: np.ndarray) -> None:
        """Mark the coverage grid along the beams of a scan the robot took at `pose`."""
        g = self._building.grid
        self._new_seen = _mark_seen(
            self._seen,
            self._building.region,
            self._region_seen,
            g.x0,
            g.y0,
            g.resolution,
            pose.x,
            pose.y,
            pose.theta,
            self._angles,
            ranges,
            self.config.coverage_beam_stride,
            self._range_min,
            self._range_max,
            self._zero_is_no_hit,
        )
        self._n_seen += self._new_seen
        if self._new_seen:
            cells = np.maximum(self._building.region_cells, 1)
            self._room_coverage = tuple((self._region_seen / cells).tolist())

    def evaluate(self, ctx: StepContext) -> StepOutcome:
        cfg = self.config
        w = cfg.rewards
        pose = ctx.pose
        self._enter(pose)
        moved = math.hypot(pose.x - ctx.pose_before.x, pose.y - ctx.pose_before.y)
        turned = abs(geometry.wrap_angle(pose.theta - ctx.pose_before.theta))
        still = moved < cfg.still_speed_mps * ctx.dt_s and turned < cfg.still_turn_rate_radps * ctx.dt_s
        self._still = self._still + ctx.dt_s if still else 0.0
        announce = self._n_extras_announce(ctx)
        parked_now = found_now = False
        false_now = 0
        excused: tuple[str, ...] = ()
        new_scene = None
        if self._phase == "explore" and self._new_seen and self._coverage_reached():
            self._explored = True
            self._begin("park", ctx.sim_time_s)
        if self._phase in ("explore", "park"):
            parked_now, false_now, excused = self._parking(ctx, still, announce)
            if parked_now:
                new_scene = self._object_scene
        elif self._phase == "find":
            found_now, false_now = self._finding(ctx, announce)
        elif announce:
            false_now = 1
        self._false += false_now
        bumps = ctx.bumps - len(excused)  # the template's count already leaves earlier excused touches out
        terms = {
            "coverage": w.coverage * self._new_seen * self._building.grid.resolution**2,
            "park": w.park * float(parked_now),
            "found": w.found * float(found_now),
            "bump": -w.bump * (ctx.new_bumps - len(excused)),
            "time": -w.time * ctx.dt_s,
            "false_announce": -w.false_announce * false_now,
        }
        self._new_seen = 0
        reason = None
        if found_now:
            reason = "done"
        elif bumps > 0 and cfg.collision == "terminate":
            reason = "bump"
        elif false_now and cfg.false_announcement == "terminate":
            reason = "false_announcement"
        elif ctx.idle_s >= cfg.idle_time_s:
            reason = "idle"
        return StepOutcome(terms, reason, found_now, new_scene, excused)

    def _parking(self, ctx: StepContext, still: bool, announce: bool) -> tuple[bool, int, tuple[str, ...]]:
        """The explore and park phases: (parked now, false announcement, bump kinds excused)."""
        cfg = self.config
        pose = ctx.pose
        parked_now = False
        false_now = 0
        excused: tuple[str, ...] = ()
        gap = self._rear_gap(pose)
        touching = gap <= cfg.touch_m
        if touching and not self._touching:
            self._touch_speed = math.hypot(ctx.twist[0], ctx.twist[1])
        self._touching = touching
        gentle = touching and self._touch_speed <= cfg.park_speed_mps + 1e-9
        if ctx.new_bumps and gentle and self._only_parking_wall_near(pose):
            excused = ctx.new_bump_kinds[:1]
        heading_error = abs(geometry.wrap_angle(pose.theta - self._away))
        parked = gentle and heading_error <= cfg.park_heading_tolerance_rad + 1e-9
        if cfg.arrival == "dwell":
            self._dwell = self._dwell + ctx.dt_s if (parked and still) else 0.0
            parked_now = self._dwell >= cfg.park_dwell_s - 1e-9
        elif announce:
            parked_now = parked
            false_now = int(not parked)
        if parked_now:
            self._parked = True
            self._time_to_park = ctx.sim_time_s
            direction = _unit(self._wall[1] - self._wall[0])
            lateral = float((np.asarray(pose[:2]) - self._wall[0]) @ direction) - self._start_foot
            self._parking_error = {"heading_rad": heading_error, "lateral_m": abs(lateral)}
            self._begin("find", ctx.sim_time_s)
            self._still = 0.0
        return parked_now, false_now, excused

    def _finding(self, ctx: StepContext, announce: bool) -> tuple[bool, int]:
        """The find phase: (found now, false announcement)."""
        cfg = self.config
        self._object_distance = self._footprint_to_object(ctx.pose)
        close = 0.0 < self._object_distance <= cfg.find_distance_m
        ready = close and self._still >= cfg.find_still_s - 1e-9
        found_now = False
        false_now = 0
        if cfg.arrival == "dwell":
            found_now = ready
        elif announce:
            found_now = ready
            false_now = int(not ready)
        if found_now:
            self._time_to_find = ctx.sim_time_s
            self._begin("done", ctx.sim_time_s)
        return found_now, false_now

    def _n_extras_announce(self, ctx: StepContext) -> bool:
        return self.config.arrival == "announce" and bool(ctx.extras[0] > 0.0)

    def _begin(self, phase: str, sim_time_s: float) -> None:
        self._phase = phase
        self._phase_began_s = sim_time_s

    def _coverage_reached(self) -> bool:
        need = self.config.explore_coverage
        return bool(np.all(self._region_seen >= need * self._building.region_cells))

    def _enter(self, pose: Pose) -> None:
        r, c = _cell(self._building.grid, pose.x, pose.y)
        k = self._building.region[r, c]
        if k >= 0:
            self._entered[k] = True

    def _rear_gap(self, pose: Pose) -> float:
        x, y, th = pose
        c, s = math.cos(th), math.sin(th)
        (ux, uy), (vx, vy) = self._rear.tolist()
        (cx, cy), (dx, dy) = self._wall_points
        return float(
            geometry.segment_segment_distance(
                x + c * ux - s * uy, y + s * ux + c * uy, x + c * vx - s * vy, y + s * vx + c * vy, cx, cy, dx, dy
            )
        )

    def _only_parking_wall_near(self, pose: Pose) -> bool:
        """Whether everything solid within `touch_m` of the footprint lies along the parking wall."""
        footprint = geometry.transform_points(pose, self.robot.outline)
        (cx, cy), (dx, dy) = self._wall
        nx, ny = -(dy - cy), dx - cx
        scale = math.hypot(nx, ny)
        reach = self.config.touch_m + 0.005
        for seg in self._static:
            if geometry.polygon_clearance(footprint, seg[None, :], reach) < reach:
                off = [abs((x - cx) * nx + (y - cy) * ny) / scale for x, y in (seg[:2], seg[2:])]
                if max(off) > 0.01:
                    return False
        return True

    def _footprint_to_object(self, pose: Pose) -> float:
        footprint = geometry.transform_points(pose, self.robot.outline)
        return float(geometry.polygon_clearance(footprint, self._object_segments))

    def info(self) -> dict[str, Any]:
        b = self._building
        return {
            "phase": self._phase,
            "coverage": self._n_seen / max(1, b.n_free),
            "room_coverage": self._room_coverage,
            "rooms_entered": int(self._entered[1:].sum()),
            "explored": self._explored,
            "parked": self._parked,
            "time_to_park": self._time_to_park,
            "parking_error": self._parking_error,
            "time_to_find": self._time_to_find,
            "object_distance": self._object_distance if self._phase in ("find", "done") else None,
            "false_announcements": self._false,
        }

    def phase_code(self) -> int:
        """The phase as the optional observation key gives it: 0 before parking, 1 after."""
        return 0 if self._phase in ("explore", "park") else 1

    def marks(self) -> dict[str, Any]:
        """For the renderer: the parking wall, the object once placed, the phase."""
        cov = self._n_seen / max(1, self._building.n_free)
        return {
            "lines": [(self._wall, "parking wall")],
            "status": f"{self._phase}  coverage {100 * cov:.0f}%",
        }

    def belief_iou(self, belief: OccupancyBelief, odom_from_map: Pose) -> float:
        """IoU of the belief's free space with the building's true free area.

        The true free area is rasterised at `IOU_RESOLUTION_M` (not on the coverage grid: a cell
        there whose centre is within half a cell of a wall counts as wall, 5 cm short along every
        wall, so a perfect map would score 0.92-0.94). Every true free cell's centre is carried
        into the odometry frame (where the agent's map lives) through the true pose of that frame
        at reset, and looked up in the belief; the belief's free area is its free cells' area.
        """
        if self._iou_truth is None:
            assert self.episode is not None  # (the env asks only after a reset)
            world = self.episode.map
            x0, y0, x1, y1 = world.bounds
            res = max(IOU_RESOLUTION_M, math.sqrt((x1 - x0 + 1.0) * (y1 - y0 + 1.0) / IOU_MAX_CELLS))
            grid, free, _ = free_space_of(world, self._building.inside, res)
            xs, ys = grid.centres()
            self._iou_truth = (xs[free], ys[free], grid.resolution**2)
        px, py, cell_area = self._iou_truth
        c, s = math.cos(odom_from_map.theta), math.sin(odom_from_map.theta)
        ox = odom_from_map.x + c * px - s * py
        oy = odom_from_map.y + s * px + c * py
        cells = np.asarray(belief.cells)
        res = float(belief.resolution_m)
        col = np.floor((ox - belief.origin[0]) / res).astype(np.int64)
        row = np.floor((oy - belief.origin[1]) / res).astype(np.int64)
        ok = (row >= 0) & (row < cells.shape[0]) & (col >= 0) & (col < cells.shape[1])
        hit = np.zeros(len(px), dtype=bool)
        hit[ok] = cells[row[ok], col[ok]] == 0
        inter = float(hit.sum()) * cell_area
        truth = float(len(px)) * cell_area
        believed = float((cells == 0).sum()) * res**2
        union = truth + believed - inter
        return inter / union if union > 0 else 0.0


def parking_wall_of(world: Map) -> FloatArray:
    """The map's `parking_wall` ([[x1, y1], [x2, y2]]) as a (2, 2) array; MapError naming the key."""
    where = world.source or world.name
    raw = world.extra.get("parking_wall")
    if raw is None:
        raise MapError(f"{where}: PicoExplore-v0 needs a 'parking_wall' key: [[x1, y1], [x2, y2]]")
    try:
        wall = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError):
        raise MapError(f"{where}: parking_wall: expected [[x1, y1], [x2, y2]], got {raw!r}") from None
    if wall.shape != (2, 2) or not np.isfinite(wall).all():
        raise MapError(f"{where}: parking_wall: expected [[x1, y1], [x2, y2]] of finite numbers, got {raw!r}")
    if np.hypot(*(wall[1] - wall[0])) < 0.45:
        raise MapError(f"{where}: parking_wall: shorter than the robot is wide (0.4 m), got {raw!r}")
    return wall


def _object_of(world: Map) -> FloatArray | None:
    """The map's optional `object` polygon ([[x, y], ...], at least 3 points)."""
    raw = world.extra.get("object")
    if raw is None:
        return None
    where = world.source or world.name
    try:
        poly = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError):
        raise MapError(f"{where}: object: expected a polygon [[x, y], ...], got {raw!r}") from None
    if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3 or not np.isfinite(poly).all():
        raise MapError(f"{where}: object: expected a polygon of at least 3 finite [x, y] points, got {raw!r}")
    return poly


# An object larger than this is not the course's object (a box of 0.3-0.5 m) [m^2].
MAX_OBJECT_AREA_M2 = 4.0


def _check_parking_wall(world: Map, wall: FloatArray) -> None:
    """The parking wall must lie along a wall of the map (within 2 cm over its whole length)."""
    static = np.vstack([world.structure_segments, world.obstacle_segments])
    for t in np.linspace(0.0, 1.0, 9):
        x, y = (wall[0] + t * (wall[1] - wall[0])).tolist()
        if geometry.point_clearance(x, y, static) > 0.02:
            where = world.source or world.name
            raise MapError(
                f"{where}: parking_wall: ({x:.2f}, {y:.2f}) on it is {geometry.point_clearance(x, y, static):.2f} m "
                "from every wall: the parking wall must lie along a wall of the map, not stand in free space"
            )


def _check_object(
    world: Map, obj: FloatArray, building: Building, wall: FloatArray, normal: FloatArray, reach_m: float
) -> None:
    """The map's object must stand on the building's floor (not outside it, not covering it),
    keep clear of where the robot starts, and leave floor within `reach_m` of it to stand on."""
    where = world.source or world.name
    area = 0.5 * abs(float(np.dot(obj[:, 0], np.roll(obj[:, 1], -1)) - np.dot(obj[:, 1], np.roll(obj[:, 0], -1))))
    if area > MAX_OBJECT_AREA_M2:
        raise MapError(f"{where}: object: {area:.1f} m^2; the object is at most {MAX_OBJECT_AREA_M2} m^2 (a box)")
    cx, cy = obj.mean(axis=0).tolist()
    grid = building.grid
    r, c = _cell(grid, cx, cy)
    if not (grid.x0 <= cx <= grid.x0 + grid.shape[1] * grid.resolution) or building.region[r, c] < -1:
        if not _near_free(building, r, c, 0.3):
            raise MapError(f"{where}: object: its centre ({cx:.2f}, {cy:.2f}) is not on the building's floor")
    start_zone = np.array([wall[0], wall[1], wall[1] + 1.3 * normal, wall[0] + 1.3 * normal])
    if geometry.polygon_clearance(obj, geometry.polygon_to_segments(start_zone), 0.01) <= 0.0 or (
        geometry.point_in_polygon(cx, cy, start_zone)
    ):
        raise MapError(f"{where}: object: it stands where the robot starts (within 1.3 m of the parking wall)")
    if not _near_free(building, r, c, reach_m + 0.5):
        raise MapError(f"{where}: object: no floor within {reach_m} m of it for the robot to stand on")


def _near_free(building: Building, r: int, c: int, radius_m: float) -> bool:
    """Whether the building has free floor within `radius_m` of cell (r, c)."""
    k = int(math.ceil(radius_m / building.grid.resolution))
    rows, cols = building.region.shape
    window = building.region[max(0, r - k) : min(rows, r + k + 1), max(0, c - k) : min(cols, c + k + 1)]
    return bool((window >= 0).any())


def _unit(v: FloatArray) -> FloatArray:
    return v / float(np.hypot(*v))


def parking_side(world: Map, wall: FloatArray, resolution: float) -> tuple[FloatArray, Building]:
    """The parking wall's unit normal pointing into the building, and the building on that side
    (its left side, from the first point to the second, is tried first)."""
    d = _unit(wall[1] - wall[0])
    left = np.array([-d[1], d[0]])
    static = _static_segments(world)
    mid = wall.mean(axis=0)
    where = world.source or world.name
    for normal in (left, -left):
        p = mid + 0.5 * normal
        if geometry.point_clearance(float(p[0]), float(p[1]), static) < 0.25:
            continue
        try:
            return normal, building_of(world, (float(p[0]), float(p[1])), resolution)
        except ValueError:
            continue
    raise MapError(f"{where}: parking_wall: neither side of it has room for the robot inside a closed building")


def _percent(rate: float) -> str:
    """A rate as a percentage; "-" when there was nothing to count (NaN: no episode parked)."""
    return "-" if math.isnan(rate) else f"{100 * rate:.1f} %"


class ExploreMetrics(EpisodeMetrics):
    """What an explore episode's record carries beyond the common core: parked, explored (every
    room seen when it parked), coverage, the parking error and time, and the IoU of the agent's
    map (`map_belief()`, if it hands one over) with the true free space."""

    columns = (
        ("parked", lambda s: f"{100 * s.metrics['parked_rate']:.1f} %"),
        ("found, of the parked", lambda s: _percent(s.metrics["found_of_parked_rate"])),
        ("every room seen", lambda s: f"{100 * s.metrics['rooms_covered_rate']:.1f} %"),
        ("timeouts, 95 % seen", lambda s: f"{s.metrics['covered_timeouts']}"),
    )

    def finish(self, env: Any, info: dict[str, Any], agent: Any) -> dict[str, Any]:
        error = info["parking_error"]
        map_belief = getattr(agent, "map_belief", None)
        return {
            "parked": bool(info["parked"]),
            "explored": bool(info["explored"]),
            "coverage": float(info["coverage"]),
            "min_room_coverage": float(min(info["room_coverage"])),
            "time_to_park_s": info["time_to_park"],
            "parking_heading_deg": math.degrees(error["heading_rad"]) if error else None,
            "parking_lateral_m": error["lateral_m"] if error else None,
            "map_iou": float(env.unwrapped.belief_iou(map_belief())) if map_belief is not None else None,
        }

    @classmethod
    def summarize(cls, records: list[Any]) -> dict[str, Any]:
        n = len(records)
        blocks = [r.metrics for r in records]
        parked = [r for r in records if r.metrics["parked"]]
        ious = [b["map_iou"] for b in blocks if b["map_iou"] is not None]
        return {
            "parked_rate": len(parked) / n,
            "explored_and_parked_rate": sum(bool(r.metrics["explored"]) for r in parked) / n,
            "found_of_parked_rate": sum(r.success for r in parked) / len(parked) if parked else math.nan,
            "rooms_covered_rate": sum((b["min_room_coverage"] or 0.0) >= 0.95 for b in blocks) / n,
            "parking_heading_max_deg": max_of(r.metrics["parking_heading_deg"] for r in parked),
            "time_to_park_median_s": median_of(r.metrics["time_to_park_s"] for r in parked),
            "map_iou_median": float(np.median(ious)) if ious else math.nan,
            "map_iou_min": float(min(ious)) if ious else math.nan,
            "map_iou_at_least_0_9_rate": sum(v >= 0.9 for v in ious) / len(ious) if ious else math.nan,
            # episodes that timed out though the robot had seen 95 % of the building
            "covered_timeouts": sum(
                r.termination_reason == "timeout" and r.metrics["coverage"] >= 0.95 for r in records
            ),
        }

    @classmethod
    def summary_rows(cls, block: dict[str, Any]) -> list[tuple[str, str]]:
        rows = [
            (
                "explored and parked",
                f"{100 * block['explored_and_parked_rate']:.1f} % (parked {100 * block['parked_rate']:.1f} %)",
            ),
            ("object found, of the parked", _percent(block["found_of_parked_rate"])),
            ("every room >= 95 % seen", f"{100 * block['rooms_covered_rate']:.1f} % of episodes"),
            ("parking heading error, worst", f"{block['parking_heading_max_deg']:.1f} deg"),
            ("time to park, median", f"{block['time_to_park_median_s']:.1f} s"),
        ]
        if not math.isnan(block["map_iou_median"]):
            rows.append(
                (
                    "map IoU (free space) median / worst",
                    f"{block['map_iou_median']:.3f} / {block['map_iou_min']:.3f} "
                    f"({100 * block['map_iou_at_least_0_9_rate']:.0f} % of episodes >= 0.9)",
                )
            )
        return rows
