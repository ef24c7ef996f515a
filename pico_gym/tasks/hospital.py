"""The hospital task (2019-2021): visit cabinets in a given order on a given map.

Course rules (docs/facts/hospital-facts.md): PICO is given the map and starts in a 1 x 1 m start area with an
arbitrary heading; it visits cabinets in the order announced before the start, standing with its
centre in the square in front of each cabinet's front (side = the front's length) and facing it,
and announces arrival; some doors turn out to be closed, boxes that are not on the map stand in
the way and people walk about. A trial ends on a bump or after 30 s without sensible movement.
No official time limit was found (docs/facts/hospital-facts.md 1.9, 5): pico-gym's default is the 10 minutes
of a 2019 team's requirement table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from pico_gym.jit import njit
from pico_gym.metrics import EpisodeMetrics
from pico_gym.robot import RobotConfig
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
from pico_gym.types import FloatArray, Pose, Segments
from pico_gym.validate import index_list, number
from pico_gym.world import geometry
from pico_gym.world.grid import CostGrid, GeodesicField, Grid, clearance_grid
from pico_gym.world.hospital import Cabinet, HospitalConfig, cabinets_of, generate_hospital
from pico_gym.world.map import Map, MapError
from pico_gym.world.movers import box_corner_list
from pico_gym.world.scene import MoverRecord, Movers, Scene, box_corners

TIME_LIMIT_S = 600.0
TERMINATION_REASONS = ("done", "bump", "idle", "false_announcement", "timeout")
# The geodesic fields' robot: its centre keeps the footprint's half-depth (0.1 m) from walls, so a
# 0.5 m door is crossed sideways (docs/facts/hospital-facts.md 3, "Checks on every episode").
FIELD_INFLATION_M = 0.1
# Placement margins (docs/facts/hospital-facts.md 3): boxes keep this far from squares, the start area, doors.
BOX_MARGIN_M = 0.3
# Draws of an episode's people, boxes and closed doors (a generated world: of the world too)
# before a count the options ask for is refused as one that cannot be met.
POPULATE_TRIES = 20


@dataclass(frozen=True)
class HospitalRewardWeights:
    """Weights of the named reward terms; reward = sum of weight * term.

    Attributes:
        progress: per metre of decrease of the geodesic distance to the next arrival square.
        cabinet: once per cabinet counted (in order).
        bump: per bump.
        time: per second of simulated time.
        false_announce: per announcement that did not satisfy the arrival rule.
        facing: potential-based shaping of facing the cabinet (0 by default): the potential is
            minus the heading error [rad] while the robot's centre is in the arrival square and
            -pi outside it, so turning to face in the square pays, and the term sums to a
            constant over an episode's legs (Ng et al., 1999: it leaves the optimal policy alone).
    """

    progress: float = 1.0
    cabinet: float = 10.0
    bump: float = 10.0
    time: float = 0.1
    false_announce: float = 1.0
    facing: float = 0.0

    def __post_init__(self) -> None:
        for name in ("progress", "cabinet", "bump", "time", "false_announce", "facing"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"HospitalRewardWeights.{name} must be a finite number, got {value!r}")


def _pair(name: str, value: object) -> tuple:
    """`value` as a (lo, hi) pair, or a ValueError naming the option."""
    if isinstance(value, str) or not hasattr(value, "__len__") or len(value) != 2:
        raise ValueError(f"{name} must be a range (lo, hi) or a single integer, got {value!r}")
    return tuple(value)  # type: ignore[arg-type]


def _count_range(name: str, value: object) -> tuple[int, int]:
    """A count option as a range (lo, hi) of integers, 0 <= lo <= hi (n alone means (n, n))."""
    if isinstance(value, int) and not isinstance(value, bool):
        return value, value
    lo, hi = _pair(name, value)
    if not (isinstance(lo, int) and isinstance(hi, int) and 0 <= lo <= hi):
        raise ValueError(f"{name} must be a range (lo, hi) of integers with 0 <= lo <= hi, got {(lo, hi)}")
    return lo, hi


@dataclass(frozen=True)
class HospitalTaskConfig:
    """Rules of the hospital task and the ranges of its per-episode draws.

    Attributes:
        n_cabinets: cabinets in a drawn order (at most the map's number of cabinets).
        n_closed_doors: range of the number of doors drawn closed (never one that cuts the start
            or a target off); the reset option `closed_doors` names the doors instead.
        n_boxes: range of the number of unknown boxes.
        box_side_m: range of a box's sides [m].
        n_movers: range of the number of walking people drawn when the map has no movers.
        people_towards_start: drawn people walk the hallway of a generated hospital, starting at
            the end of their lane farther from the start area (they come towards the robot);
            otherwise anywhere in the building, either way.
        arrival: "dwell" (a cabinet counts once the robot has stood in its square facing it,
            nearly still, for `dwell_s`; the action is a twist) or "announce" (the action gets a
            fourth component; a positive value announces, as the course's io.speak).
        dwell_s: how long the robot must stand in the square [s].
        dwell_speed_mps: true speed under which the robot is nearly still [m/s].
        dwell_turn_rate_radps: true turn rate under which it is nearly still [rad/s].
        facing_tolerance_rad: how far the heading may be from facing the front [rad].
        false_announcement: "count" (counted and penalised) or "terminate" (also ends the episode).
        collision: "terminate" (the first bump ends the episode) or "continue".
        idle_time_s, idle_speed_mps, idle_turn_rate_radps: the idle rule.
        time_limit_s: the episode is truncated at this simulated time [s].
        start_clearance_m: minimum footprint clearance of a drawn start pose [m].
        rewards: weights of the reward terms.
        hospital: ranges of the hospital generator (maps drawn when no map is given).
        geodesic_resolution_m: cell size of the geodesic fields [m]; 0.1 m gives the oracle chains
            of the 2019 and 2021 maps within 1 % of 0.05 m at well under half the reset time.
    """

    n_cabinets: int = 3
    n_closed_doors: tuple[int, int] = (0, 1)
    n_boxes: tuple[int, int] = (0, 2)
    box_side_m: tuple[float, float] = (0.2, 0.6)
    n_movers: tuple[int, int] = (0, 1)
    people_towards_start: bool = False
    arrival: Literal["dwell", "announce"] = "dwell"
    dwell_s: float = 0.5
    dwell_speed_mps: float = 0.05
    dwell_turn_rate_radps: float = 0.1
    facing_tolerance_rad: float = 0.26
    false_announcement: Literal["count", "terminate"] = "count"
    collision: Literal["terminate", "continue"] = "terminate"
    idle_time_s: float = IDLE_TIME_S
    idle_speed_mps: float = 0.02
    idle_turn_rate_radps: float = 0.05
    time_limit_s: float = TIME_LIMIT_S
    start_clearance_m: float = 0.05
    rewards: HospitalRewardWeights = field(default_factory=HospitalRewardWeights)
    hospital: HospitalConfig = field(default_factory=HospitalConfig)
    geodesic_resolution_m: float = 0.1

    def __post_init__(self) -> None:
        for name, allowed in (
            ("arrival", ("dwell", "announce")),
            ("false_announcement", ("count", "terminate")),
            ("collision", ("terminate", "continue")),
        ):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name} must be {' or '.join(map(repr, allowed))}, got {getattr(self, name)!r}")
        if not isinstance(self.people_towards_start, bool):
            raise ValueError(f"people_towards_start must be true or false, got {self.people_towards_start!r}")
        if not (isinstance(self.n_cabinets, int) and self.n_cabinets >= 1):
            raise ValueError(f"n_cabinets must be an integer >= 1, got {self.n_cabinets!r}")
        for name in ("n_closed_doors", "n_boxes", "n_movers"):
            object.__setattr__(self, name, _count_range(name, getattr(self, name)))
        lo, hi = _pair("box_side_m", self.box_side_m)
        if not 0 < lo <= hi:
            raise ValueError(f"box_side_m must be a range (lo, hi) with 0 < lo <= hi, got {self.box_side_m}")
        for name in ("dwell_s", "time_limit_s", "idle_time_s"):
            number(f"HospitalTaskConfig.{name}", getattr(self, name), 0.0, 1e6, lo_open=True, unit=" s")
        number("HospitalTaskConfig.geodesic_resolution_m", self.geodesic_resolution_m, 0.02, 0.5, unit=" m")
        for name in ("dwell_speed_mps", "dwell_turn_rate_radps", "idle_speed_mps", "idle_turn_rate_radps"):
            number(f"HospitalTaskConfig.{name}", getattr(self, name), 0.0)
        number("HospitalTaskConfig.start_clearance_m", self.start_clearance_m, 0.0, 1.0, unit=" m")
        number("HospitalTaskConfig.n_boxes[1]", self.n_boxes[1], 0, 20, integer=True)
        number("HospitalTaskConfig.n_movers[1]", self.n_movers[1], 0, 20, integer=True)
        if not 0 < self.facing_tolerance_rad < math.pi:
            raise ValueError(f"facing_tolerance_rad must be in (0, pi), got {self.facing_tolerance_rad}")

    @property
    def idle_rule(self) -> IdleRule:
        return IdleRule(self.idle_time_s, self.idle_speed_mps, self.idle_turn_rate_radps)


# Named families of generated hospitals (`gym.make("PicoHospital-v0", family=NAME)`), harder than
# the 2019 rules' defaults in one way each: "narrow" at the rules' narrow end (hallway 1.0-1.2 m,
# doors 0.55-0.7 m) with 1-2 people walking the hallway towards the start; "crowded" with 2-3
# people and 2-3 boxes.
FAMILIES: dict[str, dict[str, Any]] = {
    "narrow": {
        "hallway_width_m": (1.0, 1.2),
        "door_width_m": (0.55, 0.7),
        "n_movers": (1, 2),
        "people_towards_start": True,
    },
    "crowded": {"n_movers": (2, 3), "n_boxes": (2, 3)},
}


@dataclass(frozen=True, eq=False)
class HospitalTaskSpec:
    """What the course gave the teams, and all an agent may be given (`info["task"]` at reset).

    Attributes:
        map: the given map: walls, cabinets (fronts first, numbered by index), the start area
            and `doors`, the door openings (indexed as `closed_doors` indexes them). It never holds
            the episode's closed doors, boxes or movers, nor the world's unknown static obstacles.
        cabinet_order: the cabinets to visit, in order.
        arrival: "dwell" or "announce".
        dwell_s: with "dwell", how long to stand still in the square.
        facing_tolerance_rad: how far from facing the front the heading may be.
        time_limit_s: the episode's time limit.
        idle_time_s: the longest the robot may stand still.
    """

    map: Map
    cabinet_order: tuple[int, ...]
    arrival: str
    dwell_s: float
    facing_tolerance_rad: float
    time_limit_s: float
    idle_time_s: float


def given_map(world: Map) -> Map:
    """The map an agent is given: the world without its unknown static obstacles and movers."""
    return replace(world, obstacles=(), movers=(), extra={k: v for k, v in world.extra.items() if k != "movers"})


class HospitalTask(ConfiguredTask):
    """Spawning, arrivals, reward terms and termination for the hospital (a `Task`).

    Reset options: `cabinet_order` (cabinet indices), `closed_doors` (door indices; [] = all
    open), and the template's `start_pose`.
    """

    termination_reasons: tuple[str, ...] = TERMINATION_REASONS
    option_keys: frozenset[str] = frozenset({"cabinet_order", "closed_doors"})
    goal_name = "every cabinet of the order"

    def __init__(self, config: HospitalTaskConfig, robot: RobotConfig, fixed_map: Map | None = None) -> None:
        self.config = config
        self.robot = robot
        self.fixed_map = fixed_map
        if fixed_map is not None:
            where = fixed_map.source or fixed_map.name
            if not fixed_map.cabinets:
                raise ValueError(f"{where}: a hospital map needs 'cabinets'")
            self._fixed_cabinets = cabinets_of(fixed_map)
            self._fixed_grid = Grid.covering(fixed_map.bounds, config.geodesic_resolution_m, margin=0.5)
            self._fixed_clearance: FloatArray | None = None
            self._person_lanes: _PersonLanes | None = None
            self._regions: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # cabinet -> its square's cells
            self._check_map(fixed_map)
            n_doors = len(fixed_map.door_segments)
            if config.n_closed_doors[0] > n_doors:
                raise ValueError(
                    f"n_closed_doors={config.n_closed_doors}: {where} has {n_doors} door(s); ask for at most that"
                )
        self._arrival_cost = 0.0
        self.episode: Episode | None = None

    @property
    def action_extras(self) -> tuple[np.ndarray, np.ndarray]:
        if self.config.arrival == "announce":
            return np.array([-1.0]), np.array([1.0])
        return np.zeros(0), np.zeros(0)

    # --- reset -------------------------------------------------------------------------------
    def new_episode(self, rng: np.random.Generator, options: dict[str, Any], start: Pose | None) -> Episode:
        shortfall: dict[str, tuple[int, int]] = {}
        for _ in range(POPULATE_TRIES):
            # A generated world is drawn again, a fixed map's people, boxes and doors are, until
            # every count drawn from the ranges is met (never silently fewer).
            world, cabinets, grid, base_clearance, hallway = self._world(rng)
            where = world.source or world.name
            order = self._order(rng, options.get("cabinet_order"), len(cabinets), where)
            targets = [cabinets[i] for i in order]
            area = self._start_region(world)
            squares = [c.square for c in targets]
            reachable = _Reachable(grid, base_clearance, area.mean(axis=0), targets)
            closed, n_closed = self._closed_doors(rng, options.get("closed_doors"), world, reachable, where)
            movers, n_movers = self._movers(rng, world, grid, base_clearance, area, squares, hallway)
            boxes, n_boxes = self._boxes(rng, world, grid, base_clearance, closed, area, squares, movers, reachable)
            placed = {"n_closed_doors": (n_closed, len(closed)), "n_movers": (n_movers, len(movers))}
            placed["n_boxes"] = (n_boxes, len(boxes))
            shortfall = {k: v for k, v in placed.items() if v[1] < v[0]}
            if not shortfall:
                break
        else:
            raise ValueError(_shortfall_message(shortfall, where, self.fixed_map is None))
        scene = Scene(world, closed, tuple(boxes), Movers(movers))
        return self._begin(rng, world, cabinets, grid, base_clearance, area, scene, order, start, where)

    def join_episode(
        self, first: Episode, rng: np.random.Generator, options: dict[str, Any], start: Pose | None, others: list[Pose]
    ) -> Episode:
        """A second robot's episode in `first`'s hospital: the same walls, closed doors, boxes and
        people (the same `Movers`), an order of its own (given or drawn) and a start of its own
        (given, or drawn in the start area clear of the robots at `others`)."""
        world, scene = first.scene.map, first.scene
        grid, base_clearance, cabinets = first.extra["grid"], first.extra["clearance"], first.extra["cabinets"]
        where = world.source or world.name
        order = self._order(rng, options.get("cabinet_order"), len(cabinets), where)
        area = self._start_region(world)
        return self._begin(rng, world, cabinets, grid, base_clearance, area, scene, order, start, where, others)

    def _begin(
        self,
        rng: np.random.Generator,
        world: Map,
        cabinets: Any,
        grid: Grid,
        base_clearance: FloatArray,
        area: FloatArray,
        scene: Scene,
        order: list[int],
        start: Pose | None,
        where: Any,
        others: list[Pose] | None = None,
    ) -> Episode:
        """The episode in a scene: the start (drawn, or checked), the cabinets' fields and legs,
        what the agent is given, and the task's state."""
        cfg = self.config
        targets = [cabinets[i] for i in order]
        closed, boxes = scene.closed_doors, scene.boxes
        door_segments = [world.door_segments[d] for d in closed]
        extra_segments = door_segments + [geometry.polygon_to_segments(b) for b in boxes]
        costs = _costs(grid, base_clearance, np.vstack(extra_segments) if extra_segments else np.zeros((0, 4)))
        if start is None:
            start = self._sample_start(rng, area, scene, where, others or [])
        elif not in_a_wall(scene.solid_segments(), start, self.robot.outline):  # (a wall: the template says so)
            inside = _costs(grid, base_clearance, np.zeros((0, 4))).reachable_from(*area.mean(axis=0).tolist())
            r, c = _cell(grid, start.x, start.y)
            if not inside[r, c]:
                raise ValueError(
                    f"options['start_pose'] {tuple(start)} is outside the walls of {where}: not in the building "
                    "the start area is in"
                )
        cells = [self._region_cells(costs, c, world) for c in targets]
        fields = _Fields(costs, cells)
        # The legs after the first need only the distance at the previous cabinet's dock point; the
        # progress field of a leg is computed when the leg begins (`_Fields`).
        legs = [fields[0].lookup(start.x, start.y)]
        for k in range(1, len(targets)):
            legs.append(costs.distance_at(*cells[k], *targets[k - 1].dock_point()))
        shortest = float(sum(legs))
        public = HospitalTaskSpec(
            map=given_map(world),
            cabinet_order=tuple(order),
            arrival=cfg.arrival,
            dwell_s=cfg.dwell_s,
            facing_tolerance_rad=cfg.facing_tolerance_rad,
            time_limit_s=cfg.time_limit_s,
            idle_time_s=cfg.idle_time_s,
        )
        self._targets = targets
        self._fields = fields
        self._done = 0
        self._dwell = 0.0
        self._false = 0
        self._progress = GeodesicProgress(fields[0], start)
        self._arrival_parts = targets[0].arrival(start, cfg.facing_tolerance_rad)
        self._scene = scene
        extra = {"legs": legs, "fields": fields, "grid": grid, "clearance": base_clearance, "cabinets": cabinets}
        self.episode = Episode(scene, start, shortest, public, extra)
        return self.episode

    def _world(
        self, rng: np.random.Generator
    ) -> tuple[Map, tuple[Cabinet, ...], Grid, FloatArray, tuple[tuple[float, float, float, float], ...]]:
        """The episode's building: drawn (a generated one), or the fixed map; its cabinets, grid,
        clearance and (generated) hallway legs."""
        if self.fixed_map is None:
            built = generate_hospital(rng, self.config.hospital, self.robot)
            world = built.map
            grid = Grid.covering(world.bounds, self.config.geodesic_resolution_m, margin=0.5)
            return world, cabinets_of(world), grid, _clearance(grid, world), built.hallway
        if self._fixed_clearance is None:
            self._fixed_clearance = _clearance(self._fixed_grid, self.fixed_map)
        return self.fixed_map, self._fixed_cabinets, self._fixed_grid, self._fixed_clearance, ()

    def _order(self, rng: np.random.Generator, given: Any, n: int, where: Any) -> list[int]:
        if given is None:
            k = min(self.config.n_cabinets, n)
            return [int(i) for i in rng.permutation(n)[:k]]
        order = index_list("options['cabinet_order']", given, n, "cabinet", where)
        if not order:
            raise ValueError("options['cabinet_order'] is empty: give at least one cabinet index")
        return order

    def _closed_doors(
        self, rng: np.random.Generator, given: Any, world: Map, reachable: Any, where: Any
    ) -> tuple[tuple[int, ...], int]:
        """The doors closed this episode, and how many were asked for (given, or drawn from
        `n_closed_doors`): a draw keeps every cabinet of the order reachable from the start area."""
        n = len(world.door_segments)
        if given is not None:
            closed = tuple(index_list("options['closed_doors']", given, n, "door", where))
            for d in closed:
                if not reachable(world.door_segments[d]):
                    raise ValueError(
                        f"options['closed_doors']: closing door {d} of {where} cuts the start area off from a "
                        "cabinet of the order"
                    )
            if closed and not reachable(np.vstack([world.door_segments[d] for d in closed])):
                raise ValueError(
                    f"options['closed_doors']: closing doors {list(closed)} together cuts the start area off "
                    "from a cabinet of the order"
                )
            return closed, len(closed)
        lo, hi = self.config.n_closed_doors
        # (a draw above the doors the map has asks for all of them, unless the range's low end
        # is above it: a fixed map is refused that at load, a generated one drawn again)
        k = min(int(rng.integers(lo, hi + 1)), n)
        if k > 0:
            for _ in range(20):
                closed = tuple(sorted(int(d) for d in rng.permutation(n)[:k]))
                if reachable(np.vstack([world.door_segments[d] for d in closed])):
                    return closed, k
        return (), max(k, lo)

    def _region_cells(self, costs: CostGrid, cabinet: Cabinet, world: Map) -> tuple[np.ndarray, np.ndarray]:
        """The free cells of a cabinet's arrival square (its cells cached on a fixed map)."""
        if world is self.fixed_map:
            cells = self._regions.get(cabinet.index)
            if cells is None:
                cells = self._regions[cabinet.index] = costs.region_cells(cabinet.square)
        else:
            cells = costs.region_cells(cabinet.square)
        rows, cols = cells
        free = np.isfinite(costs.cost[rows, cols])
        return rows[free], cols[free]

    def _check_map(self, world: Map) -> None:
        """What a fixed hospital map must give, checked at load (every door open, no box): a start
        area whose centre is free for the robot's footprint and enclosed by the walls, and from
        there a path to every cabinet's arrival square.

        Raises:
            MapError: naming the file and the key.
        """
        where = world.source or world.name
        _check_cabinets_apart(world, where)
        _check_doors_in_openings(world, where)
        grid = self._fixed_grid
        self._fixed_clearance = _clearance(grid, world)
        costs = _costs(grid, self._fixed_clearance, np.zeros((0, 4)))
        area = self._start_region(world)
        key = "start_area" if world.start_area else "start_pose"
        cx, cy = (float(v) for v in area.mean(axis=0))
        r, c = _cell(grid, cx, cy)
        mask = costs.reachable_from(cx, cy)
        if not mask[r, c]:
            raise MapError(f"{where}: {key}: ({cx:.2f}, {cy:.2f}) is inside a wall or an obstacle for the robot")
        if mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any():
            raise MapError(f"{where}: {key}: ({cx:.2f}, {cy:.2f}) is not inside the walls (it reaches the map's edge)")
        for i, cab in enumerate(self._fixed_cabinets):
            rows, cols = costs.region_cells(cab.square)
            if not mask[rows, cols].any():
                raise MapError(
                    f"{where}: cabinets[{i}]: its arrival square cannot be reached from the {key} by the robot "
                    "(with every door open)"
                )

    def _start_region(self, world: Map) -> FloatArray:
        if world.start_area:
            return world.polygon(world.start_area[0])
        if world.start_pose is not None:
            x, y, _ = world.start_pose
            return np.array([(x - 0.01, y - 0.01), (x + 0.01, y - 0.01), (x + 0.01, y + 0.01), (x - 0.01, y + 0.01)])
        raise ValueError(f"{world.source or world.name}: a hospital map needs a 'start_area' (or 'start_pose')")

    def _sample_start(
        self, rng: np.random.Generator, area: FloatArray, scene: Scene, where: Any, others: list[Pose] | None = None
    ) -> Pose:
        world = scene.map
        if world.start_pose is not None and not world.start_area:
            return world.start_pose
        solid = scene.solid_segments()
        if others:  # (other robots in the world: a start clear of them too)
            solid = np.vstack([solid, *(_footprint_edges(p, self.robot.outline) for p in others)])
        lo, hi = area.min(axis=0), area.max(axis=0)
        for _ in range(2000):
            x, y = rng.uniform(lo, hi)
            pose = Pose(float(x), float(y), float(rng.uniform(-math.pi, math.pi)))
            if not geometry.point_in_polygon(pose.x, pose.y, area):
                continue
            footprint = geometry.transform_points(pose, self.robot.outline)
            if geometry.polygon_clearance(footprint, solid, self.config.start_clearance_m + 0.01) >= (
                self.config.start_clearance_m
            ):
                return pose
        raise ValueError(
            f"{where}: found no start pose in the start area with {self.config.start_clearance_m} m clearance"
        )

    def _movers(
        self,
        rng: np.random.Generator,
        world: Map,
        grid: Grid,
        clearance: FloatArray,
        area: FloatArray,
        squares: list[FloatArray],
        hallway: tuple[tuple[float, float, float, float], ...] = (),
    ) -> tuple[list[MoverRecord], int]:
        """The walking people of the episode (a map's own, or drawn), and how many were asked for."""
        if world.movers:
            return list(world.movers), len(world.movers)  # the map loader made them MoverRecords
        lo, hi = self.config.n_movers
        n = int(rng.integers(lo, hi + 1))
        out: list[MoverRecord] = []
        if n == 0:
            return out, 0
        lanes = self._person_lanes if world is self.fixed_map else None
        if lanes is None:
            centre = area.mean(axis=0)
            inside = _costs(grid, clearance, np.zeros((0, 4))).reachable_from(float(centre[0]), float(centre[1]))
            lanes = _PersonLanes.of(grid, np.where(inside, clearance, 0.0))
            if world is self.fixed_map:
                self._person_lanes = lanes  # the same every episode of a fixed map
        towards = hallway if self.config.people_towards_start else ()
        for _ in range(n):
            record = _draw_person(rng, grid, lanes, area, squares, out, towards)
            if record is not None:
                out.append(record)
        return out, n

    def _boxes(
        self,
        rng: np.random.Generator,
        world: Map,
        grid: Grid,
        clearance: FloatArray,
        closed: tuple[int, ...],
        area: FloatArray,
        squares: list[FloatArray],
        movers: list[MoverRecord],
        reachable: Any,
    ) -> tuple[list[FloatArray], int]:
        """The unknown boxes of the episode, and how many were asked for (drawn from `n_boxes`)."""
        lo, hi = self.config.n_boxes
        n = int(rng.integers(lo, hi + 1))
        if n == 0:
            return [], 0
        keep_out = _Keepout([area] + squares + [world.polygon(d) for d in world.doors])
        for m in movers:
            keep_out.add(_mover_lane(m))
        static = np.vstack(
            [world.structure_segments, world.cabinet_segments, world.obstacle_segments, world.low_segments]
        )
        door_segs = [world.door_segments[d] for d in closed]
        xs, ys = grid.centres()
        # Candidate centres: inside the building (reachable from the start area), off the walls.
        centre = area.mean(axis=0)
        door_extra = np.vstack(door_segs) if door_segs else np.zeros((0, 4))
        inside = _costs(grid, clearance, door_extra).reachable_from(float(centre[0]), float(centre[1]))
        free = np.argwhere(inside & (clearance > 0.2))
        boxes: list[FloatArray] = []
        for _ in range(60):
            if len(boxes) == n:
                break
            r, c = free[int(rng.integers(len(free)))]
            cx, cy = float(xs[r, c]), float(ys[r, c])
            lo_side, hi_side = self.config.box_side_m
            a, b = rng.uniform(lo_side, hi_side, size=2)
            yaw = float(rng.uniform(0, math.pi)) if rng.random() < 0.5 else 0.0
            poly = box_corners(cx, cy, yaw, float(a), float(b))
            if geometry.polygon_clearance(poly, static, 0.06) < 0.05:
                continue
            if keep_out.near(poly, BOX_MARGIN_M, boxes):
                continue
            candidate = boxes + [poly]
            segs = door_segs + [geometry.polygon_to_segments(p) for p in candidate]
            if not reachable(np.vstack(segs)):
                continue
            boxes.append(poly)
        return boxes, n

    # --- step --------------------------------------------------------------------------------
    def evaluate(self, ctx: StepContext) -> StepOutcome:
        cfg = self.config
        w = cfg.rewards
        target = self._targets[self._done] if self._done < len(self._targets) else None
        arrived_now, false_now, progress, facing = False, 0, 0.0, 0.0
        if target is not None:
            arrived_now, false_now, progress, facing = self._toward(target, ctx)
        elif cfg.arrival == "announce" and ctx.extras[0] > 0.0:
            false_now = 1
            self._false += 1
        done = self._done == len(self._targets)
        terms = {
            "progress": w.progress * progress,
            "cabinet": w.cabinet * float(arrived_now),
            "bump": -w.bump * ctx.new_bumps,
            "time": -w.time * ctx.dt_s,
            "false_announce": -w.false_announce * false_now,
            "facing": w.facing * facing,
        }
        return StepOutcome(terms, self._ending(ctx, done, false_now), done)

    def _toward(self, target: Cabinet, ctx: StepContext) -> tuple[bool, int, float, float]:
        """One step toward the next cabinet: (arrived now, false announcement, progress, facing)."""
        cfg = self.config
        pose = ctx.pose
        progress = self._progress.update(pose)
        arrived, distance, error = target.arrival(pose, cfg.facing_tolerance_rad)
        facing = 0.0
        if cfg.rewards.facing:
            _, distance_before, error_before = self._arrival_parts
            facing = _facing_potential(distance, error) - _facing_potential(distance_before, error_before)
        self._arrival_parts = (arrived, distance, error)
        arrived_now = False
        false_now = 0
        if cfg.arrival == "dwell":
            still = arrived and self._held_still(ctx)  # (how far it moved matters only there)
            self._dwell = self._dwell + ctx.dt_s if still else 0.0
            arrived_now = self._dwell >= cfg.dwell_s - 1e-9
        elif ctx.extras[0] > 0.0:
            if arrived:
                arrived_now = True
            else:
                false_now = 1
                self._false += 1
        if arrived_now:
            self._done += 1
            self._dwell = 0.0
            if self._done < len(self._targets):
                self._progress = GeodesicProgress(self._fields[self._done], pose)
                self._arrival_parts = self._targets[self._done].arrival(pose, cfg.facing_tolerance_rad)
        return arrived_now, false_now, progress, facing

    def _held_still(self, ctx: StepContext) -> bool:
        cfg = self.config
        pose, before = ctx.pose, ctx.pose_before
        moved = math.hypot(pose.x - before.x, pose.y - before.y)
        turned = abs(geometry.wrap_angle(pose.theta - before.theta))
        return moved < cfg.dwell_speed_mps * ctx.dt_s and turned < cfg.dwell_turn_rate_radps * ctx.dt_s

    def _ending(self, ctx: StepContext, done: bool, false_now: int) -> str | None:
        cfg = self.config
        if done:
            return "done"
        if ctx.bumps > 0 and cfg.collision == "terminate":
            return "bump"
        if false_now and cfg.false_announcement == "terminate":
            return "false_announcement"
        if ctx.idle_s >= cfg.idle_time_s:
            return "idle"
        return None

    @property
    def next_target(self) -> Cabinet | None:
        """The cabinet to visit next (privileged: the true task state), None once all are done."""
        return self._targets[self._done] if self._done < len(self._targets) else None

    def info(self) -> dict[str, Any]:
        done = self._done
        n = len(self._targets)
        arrived, distance, error = self._arrival_parts
        return {
            "cabinets_done": done,
            "next_cabinet": self._targets[done].index if done < n else None,
            "geodesic_to_next": self._progress.value if done < n else 0.0,
            "false_announcements": self._false,
            "movers": self._scene.mover_poses(),
            "arrival": {"in_square": distance == 0.0, "distance_to_square": distance, "heading_error": error}
            if done < n
            else None,
            "dwell_s": self._dwell,
        }

    def marks(self) -> dict[str, Any]:
        """For the renderer: the arrival squares of the order, numbered, done ones flagged."""
        squares = []
        for k, cab in enumerate(self._targets):
            squares.append((cab.square, str(k + 1), k < self._done))
        return {"squares": squares, "status": f"cabinets {self._done}/{len(self._targets)}"}


def _facing_potential(distance_to_square: float, heading_error: float) -> float:
    """The `facing` shaping potential: minus the heading error in the arrival square, -pi outside."""
    return -heading_error if distance_to_square == 0.0 else -math.pi


def _cell(grid: Grid, x: float, y: float) -> tuple[int, int]:
    c = int(np.clip((x - grid.x0) / grid.resolution, 0, grid.shape[1] - 1))
    r = int(np.clip((y - grid.y0) / grid.resolution, 0, grid.shape[0] - 1))
    return r, c


def _clearance(grid: Grid, world: Map) -> FloatArray:
    """Clearance of every cell to the world's static geometry (walls, cabinets, obstacles)."""
    static = np.vstack([world.structure_segments, world.cabinet_segments, world.obstacle_segments, world.low_segments])
    return clearance_grid(grid, static, cap=0.5)


def _costs(grid: Grid, base_clearance: FloatArray, extra: Segments) -> CostGrid:
    """The cost grid of the static world plus extra segments (closed doors, boxes)."""
    clearance = base_clearance
    if len(extra):
        clearance = np.minimum(base_clearance, clearance_grid(grid, extra, cap=0.5))
    return CostGrid.from_clearance(grid, clearance, inflation_m=FIELD_INFLATION_M)


class _Keepout:
    """Polygons to keep away from, each with its bounding box as plain floats and its edges
    (computed once, as the rejection samplers test many candidates against the same polygons)."""

    def __init__(self, polygons: list[FloatArray] = ()) -> None:  # type: ignore[assignment]
        self.polygons: list[FloatArray] = []
        self.boxes: list[tuple[float, float, float, float]] = []
        self.edges: list[Segments | None] = []  # each polygon's segments, made on first need
        for q in polygons:
            self.add(q)

    def add(self, q: FloatArray) -> None:
        self.polygons.append(q)
        self.boxes.append(_bbox(q))
        self.edges.append(None)

    def near(self, p: FloatArray, margin: float, extra: list[FloatArray] = ()) -> bool:  # type: ignore[assignment]
        """Whether polygon `p` comes within `margin` of any kept-out polygon (or of `extra`)."""
        plx, ply, phx, phy = _bbox(p)
        for k, (qlx, qly, qhx, qhy) in enumerate(self.boxes):
            gap = math.hypot(max(0.0, qlx - phx, plx - qhx), max(0.0, qly - phy, ply - qhy))
            if gap < margin:
                edges = self.edges[k]
                if edges is None:
                    edges = self.edges[k] = geometry.polygon_to_segments(self.polygons[k])
                if _polygon_distance(p, self.polygons[k], edges) < margin:
                    return True
        for q in extra:
            qlx, qly, qhx, qhy = _bbox(q)
            gap = math.hypot(max(0.0, qlx - phx, plx - qhx), max(0.0, qly - phy, ply - qhy))
            if gap < margin and _polygon_distance(p, q) < margin:
                return True
        return False


def _bbox(q: FloatArray) -> tuple[float, float, float, float]:
    xs, ys = q[:, 0].tolist(), q[:, 1].tolist()
    return min(xs), min(ys), max(xs), max(ys)


def _polygon_distance(p: FloatArray, q: FloatArray, q_edges: Segments | None = None) -> float:
    """Distance between two polygons (0 if they overlap); `q_edges`: q's segments, if known."""
    if geometry.point_in_polygon(p[0, 0], p[0, 1], q) or geometry.point_in_polygon(q[0, 0], q[0, 1], p):
        return 0.0
    return float(geometry.polygon_clearance(p, geometry.polygon_to_segments(q) if q_edges is None else q_edges))


def _mover_lane(m: MoverRecord) -> FloatArray:
    """The rectangle a mover sweeps between its two poses."""
    (x0, y0, yaw), (x1, y1, _) = m.init_pose, m.final_pose
    corners = box_corner_list(x0, y0, yaw, m.length, m.width) + box_corner_list(x1, y1, yaw, m.length, m.width)
    xs, ys = [p[0] for p in corners], [p[1] for p in corners]
    lo_x, lo_y, hi_x, hi_y = min(xs), min(ys), max(xs), max(ys)
    return np.array([(lo_x, lo_y), (hi_x, lo_y), (hi_x, hi_y), (lo_x, hi_y)])


# The walking person of the 2021 config (docs/facts/hospital-facts.md 1.6): 0.2 x 0.4 m at 0.5 m/s, ping-pong.
PERSON_LENGTH_M, PERSON_WIDTH_M, PERSON_SPEED_MPS = 0.2, 0.4, 0.5


@njit
def _run_bounds(free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For every cell, the first and last column of the run of free cells along its row."""
    rows, cols = free.shape
    lo = np.zeros((rows, cols), dtype=np.int64)
    hi = np.zeros((rows, cols), dtype=np.int64)
    for r in range(rows):
        c = 0
        while c < cols:
            start = c
            while c < cols and free[r, c] == free[r, start]:
                c += 1
            for k in range(start, c):
                lo[r, k] = start
                hi[r, k] = c - 1
    return lo, hi


class _Fields:
    """The geodesic field of each leg (distance to its arrival square), computed on first use: a
    leg's field is needed only once the robot is on it."""

    def __init__(self, costs: CostGrid, cells: list[tuple[np.ndarray, np.ndarray]]) -> None:
        self._costs = costs
        self._cells = cells
        self._fields: dict[int, GeodesicField] = {}

    def __len__(self) -> int:
        return len(self._cells)

    def __getitem__(self, k: int) -> GeodesicField:
        if k < 0:
            k += len(self._cells)
        field = self._fields.get(k)
        if field is None:
            rows, cols = self._cells[k]
            field = self._fields[k] = self._costs.field_from(rows, cols, np.zeros(len(rows)))
        return field


def _footprint_edges(pose: Pose, outline: FloatArray) -> Segments:
    placed = geometry.transform_points(pose, outline)
    return np.hstack([placed, np.roll(placed, -1, axis=0)])


def _check_cabinets_apart(world: Map, where: Any) -> None:
    """No two cabinets may be the same or overlap."""
    polygons = [world.polygon(c) for c in world.cabinets]
    for j, b in enumerate(polygons):
        for i in range(j):
            a = polygons[i]
            if a.shape == b.shape and np.allclose(np.sort(a, axis=0), np.sort(b, axis=0)):
                raise MapError(f"{where}: cabinets[{j}]: the same cabinet as cabinets[{i}]")
            if geometry.polygon_clearance(b, geometry.polygon_to_segments(a), 0.01) <= 0.0:
                raise MapError(f"{where}: cabinets[{j}]: overlaps cabinets[{i}]")


def _check_doors_in_openings(world: Map, where: Any) -> None:
    """A door stands in an opening of the walls: both ends of its long axis touch a wall."""
    walls = world.structure_segments
    if not len(walls):
        return
    for k, door in enumerate(world.doors):
        poly = world.polygon(door)
        edges = np.roll(poly, -1, axis=0) - poly
        lengths = np.hypot(edges[:, 0], edges[:, 1])
        short = np.argsort(lengths)[:2]  # the two short sides: the ends against the jambs
        for e in short:
            mx, my = (poly[e] + 0.5 * edges[e]).tolist()
            if geometry.point_clearance(mx, my, walls) > 0.05:
                raise MapError(
                    f"{where}: doors[{k}]: its end at ({mx:.2f}, {my:.2f}) touches no wall: a door must fill an "
                    "opening of the walls, not stand in a room"
                )


class _Reachable:
    """Whether, with extra segments in the way (closed doors, boxes), the start area still reaches
    every cabinet of the order (its dock point, else any cell of its arrival square)."""

    def __init__(self, grid: Grid, clearance: FloatArray, centre: FloatArray, targets: list[Cabinet]) -> None:
        self.grid, self.clearance, self.targets = grid, clearance, targets
        self.centre = (float(centre[0]), float(centre[1]))

    def __call__(self, segments: Segments) -> bool:
        costs = _costs(self.grid, self.clearance, segments)
        mask = costs.reachable_from(*self.centre)
        for cab in self.targets:
            if not mask[_cell(self.grid, *cab.dock_point())]:
                # The dock point's cell may be blocked while the square is not: ask the square.
                rows, cols = costs.region_cells(cab.square)
                if not mask[rows, cols].any():
                    return False
        return True


_NEEDS = {
    "n_closed_doors": "closed doors must leave every cabinet of the order reachable from the start area",
    "n_movers": "a person needs a straight lane of 2 m or more, clear of the start area, the arrival squares "
    "and the other people",
    "n_boxes": "a box needs a free spot off the walls, the doors, the start area, the arrival squares and the "
    "people's lanes that blocks no route to a cabinet",
}


def _shortfall_message(shortfall: dict[str, tuple[int, int]], where: Any, generated: bool) -> str:
    tries = f"{POPULATE_TRIES} generated hospitals" if generated else f"{POPULATE_TRIES} draws on {where}"
    counts = "; ".join(f"{key}: {want} asked, at most {got} placed" for key, (want, got) in shortfall.items())
    needs = "; ".join(_NEEDS[key] for key in shortfall)
    return f"could not place what the options ask for in {tries} ({counts}): {needs}. Ask for fewer."


@dataclass(frozen=True, eq=False)
class _PersonLanes:
    """Where a person may walk: the cells a path may pass through and, for each cell, its free run
    along its row and its column (from a clearance grid that is 0 outside the building)."""

    candidates: np.ndarray
    row_lo: np.ndarray
    row_hi: np.ndarray
    col_lo: np.ndarray
    col_hi: np.ndarray

    @classmethod
    def of(cls, grid: Grid, clearance: FloatArray) -> _PersonLanes:
        need = 0.5 * PERSON_WIDTH_M + 0.15
        free = clearance >= need
        row_lo, row_hi = _run_bounds(free)  # each cell's free run along its row
        col_lo, col_hi = (a.T for a in _run_bounds(np.ascontiguousarray(free.T)))
        return cls(np.argwhere(clearance >= need + 0.05), row_lo, row_hi, col_lo, col_hi)


def _draw_person(
    rng: np.random.Generator,
    grid: Grid,
    lanes: _PersonLanes,
    area: FloatArray,
    squares: list[FloatArray],
    others: list[MoverRecord],
    hallway: tuple[tuple[float, float, float, float], ...] = (),
) -> MoverRecord | None:
    """A walking person on a straight 2-6 m path along a grid axis with wall clearance >= half its
    width + 0.15 m, away from the start area and the arrival squares (docs/facts/hospital-facts.md 3);
    `lanes` keeps the path inside the building. Given the `hallway`'s legs, the path runs along a
    leg and starts at its end farther from the start area (the person comes towards the start)."""
    res = grid.resolution
    candidates = lanes.candidates
    if hallway:
        candidates = _in_hallway(grid, candidates, hallway)
    if len(candidates) == 0:
        return None
    row_lo, row_hi, col_lo, col_hi = lanes.row_lo, lanes.row_hi, lanes.col_lo, lanes.col_hi
    keep_out = _Keepout([area] + squares + [_mover_lane(o) for o in others])
    for _ in range(40):
        r, c = candidates[int(rng.integers(len(candidates)))]
        horizontal = bool(rng.random() < 0.5) if not hallway else _along_leg(grid, r, c, hallway)
        lo, hi = (row_lo[r, c], row_hi[r, c]) if horizontal else (col_lo[r, c], col_hi[r, c])
        free_m = (hi - lo) * res - PERSON_LENGTH_M
        if free_m < 2.0:
            continue
        length = float(rng.uniform(2.0, min(6.0, free_m)))
        offset = float(rng.uniform(0.0, free_m - length))
        if horizontal:
            x0 = grid.x0 + (0.5 + lo) * res + 0.5 * PERSON_LENGTH_M + offset
            y = grid.y0 + (r + 0.5) * res
            init, final, yaw = (x0, y), (x0 + length, y), 0.0
        else:
            y0 = grid.y0 + (0.5 + lo) * res + 0.5 * PERSON_LENGTH_M + offset
            x = grid.x0 + (c + 0.5) * res
            init, final, yaw = (x, y0), (x, y0 + length), math.pi / 2
        if rng.random() < 0.5:
            init, final = final, init
        if hallway:  # towards the start: from the lane's end farther from it
            centre = area.mean(axis=0)
            if math.dist(init, centre) < math.dist(final, centre):
                init, final = final, init
        record = MoverRecord(
            length=PERSON_LENGTH_M,
            width=PERSON_WIDTH_M,
            trigger_radius=float(rng.uniform(2.0, 10.0)),
            velocity=PERSON_SPEED_MPS,
            init_pose=(init[0], init[1], yaw),
            final_pose=(final[0], final[1], yaw),
            repeat=True,
        )
        lane = _mover_lane(record)
        margin = 0.3 + record.half_diagonal_m
        if keep_out.near(lane, margin):
            continue
        return record
    return None


def _in_hallway(grid: Grid, cells: np.ndarray, hallway: tuple[tuple[float, float, float, float], ...]) -> np.ndarray:
    """The candidate cells (rows of (row, col)) whose centres lie in one of the hallway's legs."""
    xs = grid.x0 + (cells[:, 1] + 0.5) * grid.resolution
    ys = grid.y0 + (cells[:, 0] + 0.5) * grid.resolution
    inside = np.zeros(len(cells), dtype=bool)
    for x0, y0, x1, y1 in hallway:
        inside |= (xs > x0) & (xs < x1) & (ys > y0) & (ys < y1)
    return cells[inside]


def _along_leg(grid: Grid, r: int, c: int, hallway: tuple[tuple[float, float, float, float], ...]) -> bool:
    """Whether the hallway leg holding cell (r, c) runs along x (its longer side)."""
    x, y = grid.x0 + (c + 0.5) * grid.resolution, grid.y0 + (r + 0.5) * grid.resolution
    for x0, y0, x1, y1 in hallway:
        if x0 < x < x1 and y0 < y < y1:
            return (x1 - x0) >= (y1 - y0)
    return True


class HospitalMetrics(EpisodeMetrics):
    """What a hospital episode's record carries beyond the common core: when each cabinet of the
    order was counted (`leg_done_s`, simulated seconds) and the false announcements; its progress
    is the fraction of the order done."""

    columns = (
        ("progress", lambda s: f"{100 * s.progress_mean:.1f} %"),
        ("bumps by kind", lambda s: ", ".join(f"{k} {n}" for k, n in s.bumps_by_kind.items() if n) or "-"),
        ("s within 0.5 m of a mover", lambda s: f"{s.near_mover_s_mean:.1f}"),
    )
    figures = ("legs", "bumps")

    def reset(self, env: Any, info: dict[str, Any]) -> None:
        self.order = info["task"].cabinet_order
        self.legs: list[float] = []

    def step(self, env: Any, info: dict[str, Any]) -> None:
        if info["cabinets_done"] > len(self.legs):
            self.legs.append(round(float(info["sim_time"]), 6))

    def progress(self, info: dict[str, Any]) -> float:
        return float(info["cabinets_done"]) / len(self.order)

    def finish(self, env: Any, info: dict[str, Any], agent: Any) -> dict[str, Any]:
        return {"false_announcements": int(info["false_announcements"]), "leg_done_s": self.legs}

    @classmethod
    def summarize(cls, records: list[Any]) -> dict[str, Any]:
        n = len(records)
        return {"no_false_announcement_rate": sum(r.metrics["false_announcements"] == 0 for r in records) / n}

    @classmethod
    def summary_rows(cls, block: dict[str, Any]) -> list[tuple[str, str]]:
        rate = block["no_false_announcement_rate"]
        return [("no false announcement", f"{100 * rate:.1f} % of episodes")] if rate < 1.0 else []
