"""The classic hospital agent: localise on the given map, plan around what the map does not show,
dock at every cabinet in order.

It knows what the course gave the teams (`info["task"]` at reset: the given map and the cabinet
order, the arrival rule) and senses with the LRF and odometry; nothing else. Each step:

    scan -> pose (odometry prediction, then scan-to-map registration, with a health check)
         -> evidence grid (end points the map does not explain accumulate; beams passing clear)
         -> state machine -> A* on the inflated map + evidence -> potential field -> safety filter

The states:

    LOCALISE  turn in place, joining scans at their odometry offsets, until one pose of the start
              area (any heading) explains them clearly better than any other (`Localiser`)
    RELOCALISE the same over the whole map's free space (coarse to fine), when the registration
              has explained too few beams for a while and local searches did not help (kidnapped)
    NAVIGATE  follow an A* path (string-pulled) to the next cabinet's dock point: forward where
              there is room (the LRF sees ahead and to both sides), sideways where it is narrow
              (the robot's 0.2 m depth across the way, as through a 0.5 m door)
    DOCK      servo into the arrival square, facing the front: on the front's line as the LRF sees
              it (its depth and angle; `fit_front`), on the pose estimate until it is in view
    DWELL     stand still for the task's dwell time (or, arrival="announce", announce the
              arrival once), then take the next cabinet
    YIELD     no path while something the map does not explain is close (a person crossing the
              way, one paused because the robot is near): keep out of its pause radius, watch
              it (the beams clear the cells it leaves) and plan again every half second; what
              does not move while watched is a box: RECOVER
    RECOVER   no path or no progress: back off, fade (never wipe) the evidence, plan again
    DONE      every cabinet visited

People: clusters of what the map does not explain are tracked (`tracking.PeopleTracker`); the
points of one seen walking are kept out of the registration (a person beside a door jamb dragged
the estimate 0.3 m onto the jamb) and the cells it walked through are cleared (no wall left
behind). Tried and measured worse on dev seeds, so not used: planning around a moving track's
predicted disc (the hallway closes, the robot waits: timeouts), and its predicted points in the
safety filter (more bumps). YIELD still reacts to what it sees.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from pico_gym.agents.base import Agent, RobotSpec
from pico_gym.agents.classic.astar import astar, string_pull
from pico_gym.agents.classic.localisation import Localiser, scan_points
from pico_gym.agents.classic.potential_field import (
    MotionConfig,
    attract_and_repel,
    footprint_distance,
    heading_rate,
    keep_in_view,
    motion_for,
    safe_turn,
    safety_filter,
)
from pico_gym.agents.classic.tracking import PeopleTracker, TrackerConfig
from pico_gym.agents.shield import ScanMemory, SeenFree, blind_translation, blind_turn
from pico_gym.jit import njit
from pico_gym.overlay import Overlay
from pico_gym.types import FloatArray, Pose
from pico_gym.world.geometry import compose, inverse, wrap_angle
from pico_gym.world.grid import Grid, clearance_grid, flood
from pico_gym.world.hospital import Cabinet, cabinets_of


class State(Enum):
    LOCALISE = "localise"
    RELOCALISE = "relocalise"
    NAVIGATE = "navigate"
    DOCK = "dock"
    DWELL = "dwell"
    YIELD = "yield"
    RECOVER = "recover"
    DONE = "done"


@dataclass(frozen=True)
class HospitalAgentConfig:
    """Parameters of the classic hospital agent (SI units).

    Attributes:
        cell_m: planning and evidence grid resolution [m].
        inflate_m: the robot's centre keeps this far from walls when planning [m] (its half
            depth 0.1 m + margin: it drives sideways).
        replan_s: plan again at least this often [s].
        lookahead_m: the path point this far ahead is the set-point [m].
        dock_depth_m: the dock point's distance from the cabinet's front [m] (the best poses
            are 0.3-0.4 m deep, hospital-facts.md 1.8).
        dock_radius_m: within this of the dock point, NAVIGATE hands over to DOCK [m].
        dock_speed: speed limit while docking [m/s].
        dwell_margin_s: stand still this much longer than the task's dwell time [s].
        face_within_m: turn to face the cabinet once this close to the dock point [m].
        roomy_m: drive forward where walls and evidence are at least this far from the centre
            (here and at the set-point), else sideways [m].
        door_approach_m: a path through a door passes waypoints this far before and after it on
            its centre line [m].
        unexplained_m: an end point farther than this from every wall of the map is evidence of
            something the map does not show [m].
        evidence_hit, evidence_miss, evidence_block, evidence_max: the evidence grid's counts: a
            hit adds, a beam passing through subtracts, a cell at `evidence_block` or more is
            an obstacle, none exceeds `evidence_max`.
        localise_turn_rad: LOCALISE searches again after turning this much [rad].
        registration_prior: how strongly the scan-to-map registration holds to the odometry
            prediction (`Localiser.refine`'s prior; per m^2 and rad^2 against unit-weight residuals).
        doubt_health, doubt_s, doubt_scans: a health under this for this long [s] checks the
            pose against the whole map with this many scans of the last seconds (one a second)
            (`_check_elsewhere`); lost when a pose elsewhere scores `doubt_gain` more per point
            (mean log-likelihood, nats: an unexplained point scores log(0.05) = -3, so 0.6 is
            about a fifth more of the points explained).
        lost_after: after this many local relocalisations (one per 3 s of poor health) that did
            not restore it, the pose is lost: RELOCALISE searches the whole map.
        health_min: below this fraction of explained beams the registration is not trusted.
        stuck_s: no progress towards the goal for this long (or within 0.3 m of one spot for
            twice this long, whatever the plans say) means RECOVER [s].
        recover_s: RECOVER backs off for at most this long [s] ...
        clear_m: ... or until what the map does not explain is this far [m] ...
        recover_wait_s: ... then waits this long before planning again [s].
        max_still_s: standing still this long (not dwelling) means RECOVER [s].
        unexplained_margin_m: the safety filter keeps this much more room from points the map does
            not explain (boxes, people: they move, or were seen late) than from its walls [m].
        nogo_m, nogo_s: where NAVIGATE made no progress, a disc of this radius just ahead of the
            robot is kept out of the plan for this long [m, s], so the next plan tries another
            way (fading the evidence alone sent it back into the same gap); a plan that finds
            no way with them is made without them.
        squeeze_m: when no plan is found otherwise, evidence is inflated by only this much and
            the safety filter drops `unexplained_margin_m` while following that plan [m].
        beams: beams per scan the localiser uses.
        track_beams: beams per scan the people tracker clusters (every k-th of the LRF's).
        track_people: track clusters the map does not explain (`tracking.PeopleTracker`): the
            points of moving ones (people, carts) are left out of the scan-to-map registration.
        clear_trails: ... and the cells a moving track walked through are cleared (a person
            leaves no wall behind; where it stands it is evidence like anything else).
        escape_people: what RECOVER and YIELD back away from and watch, and what driving
            sideways keeps in view, is the last scan's points off the map and also where the
            people tracker last saw each person walking (within its `lost_s`): a person who
            paused just behind the robot is in no scan, and the robot backed away from what it
            saw into that person. False: the last scan's points only.
        blind_memory_s: the safety filter's blind sector (behind the LRF's view) also holds the
            near end points of the last this many seconds of scans, kept with odometry
            (`pico_gym.agents.shield.ScanMemory`): a person who walked out of view behind the
            robot was in those scans [s] (0: the map's walls and the evidence only).
        people_cuts_m: while a person tracked walking (or remembered after it left the view) is
            within this distance of the robot, no translation or turn may sweep the footprint's
            rear into space that no scan of the last `blind_memory_s` saw free
            (`pico_gym.agents.shield.blind_translation`, `blind_turn`) [m] (0: off; needs
            `blind_memory_s` > 0).
        yield_range_m: no path with something the map does not explain this close means
            YIELD, not RECOVER [m].
        yield_keep_m: YIELD backs away to keep this far from it (the simulator's cart pauses
            within 0.86 m of the robot, a person within 0.52 m) [m].
        yield_max_s: a YIELD that has not found a path after this long hands over to RECOVER [s].
        yield_static_s: ... and one that has seen nothing move for this long [s] (a box);
            after which no plan failure YIELDs for `yield_static_memory_s` [s].
        safety_floor_m: the safety filter lets nothing come closer to the footprint than this
            plus twice the LRF's noise (`MotionConfig.floor`) [m].
        turn_keep_m: turning is cut so that half a second of it keeps every point this far off
            the footprint (or no closer than it is): PICO is twice as wide as deep, and a turn
            next to a cabinet swings a corner into it (0: no cut).
    """

    cell_m: float = 0.05
    inflate_m: float = 0.15
    replan_s: float = 1.0
    lookahead_m: float = 0.4
    dock_depth_m: float = 0.33
    dock_radius_m: float = 0.5
    dock_speed: float = 0.25
    dwell_margin_s: float = 0.3
    face_within_m: float = 1.0
    roomy_m: float = 0.4
    door_approach_m: float = 0.4
    unexplained_m: float = 0.15
    evidence_hit: float = 1.0
    evidence_miss: float = 0.34
    evidence_block: float = 2.0
    evidence_max: float = 6.0
    localise_turn_rad: float = 0.6
    health_min: float = 0.4
    lost_after: int = 2
    doubt_health: float = 0.7
    doubt_s: float = 1.0
    doubt_scans: int = 4
    doubt_gain: float = 0.6
    registration_prior: float = 4.0
    stuck_s: float = 8.0
    recover_s: float = 4.0
    recover_wait_s: float = 2.5
    clear_m: float = 0.9
    max_still_s: float = 20.0
    turn_keep_m: float = 0.05
    safety_floor_m: float = 0.015
    yield_range_m: float = 2.0
    yield_keep_m: float = 1.0
    yield_max_s: float = 15.0
    yield_static_s: float = 3.0
    yield_static_memory_s: float = 30.0
    unexplained_margin_m: float = 0.08
    nogo_m: float = 0.3
    nogo_s: float = 60.0
    squeeze_m: float = 0.1
    beams: int = 90
    track_beams: int = 250
    track_people: bool = True
    clear_trails: bool = True
    escape_people: bool = False
    blind_memory_s: float = 0.0
    people_cuts_m: float = 0.0
    tracker: TrackerConfig = dataclasses.field(default_factory=TrackerConfig)

    def __post_init__(self) -> None:
        if not isinstance(self.escape_people, bool):
            raise ValueError(f"HospitalAgentConfig.escape_people must be true or false, got {self.escape_people!r}")
        for name, top in (("blind_memory_s", 60.0), ("people_cuts_m", 10.0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= top:
                raise ValueError(f"HospitalAgentConfig.{name} must be a number in [0, {top:g}], got {value!r}")
        if self.people_cuts_m > 0.0 and self.blind_memory_s <= 0.0:
            raise ValueError(
                "HospitalAgentConfig.people_cuts_m needs blind_memory_s > 0 (the scans that vouch for free space)"
            )


@njit
def _update_evidence(
    evidence: FloatArray,
    x0: float,
    y0: float,
    res: float,
    ox: float,
    oy: float,
    ex: FloatArray,
    ey: FloatArray,
    unexplained: np.ndarray,
    hit: float,
    miss: float,
    top: float,
) -> None:
    """Beams from (ox, oy) to their end points: cells a beam passes through lose `miss` (up to
    0.15 m before its end), an unexplained end point's cell gains `hit`."""
    rows, cols = evidence.shape
    for i in range(ex.shape[0]):
        dx, dy = ex[i] - ox, ey[i] - oy
        length = math.hypot(dx, dy)
        n = int((length - 0.15) / (0.5 * res))
        for k in range(n):
            t = (k * 0.5 * res) / length
            c = int((ox + t * dx - x0) / res)
            r = int((oy + t * dy - y0) / res)
            if 0 <= r < rows and 0 <= c < cols and evidence[r, c] > 0.0:
                evidence[r, c] = max(0.0, evidence[r, c] - miss)
        if unexplained[i]:
            c = int((ex[i] - x0) / res)
            r = int((ey[i] - y0) / res)
            if 0 <= r < rows and 0 <= c < cols:
                evidence[r, c] = min(top, evidence[r, c] + hit)


@njit
def _near_segment(
    seen: np.ndarray, x0: float, y0: float, res: float, ax: float, ay: float, bx: float, by: float, k: int
) -> bool:
    """Whether a `seen` cell lies within k cells (a square) of the segment a-b: samples at most
    0.05 m apart (both ends included), each sample's cell clipped into the grid."""
    rows, cols = seen.shape
    dx, dy = bx - ax, by - ay
    n = max(2, int(math.sqrt(dx * dx + dy * dy) / 0.05))
    step = 1.0 / (n - 1)
    for i in range(n):
        t = 1.0 if i == n - 1 else i * step
        r = int(min(max((ay + t * dy - y0) / res, 0.0), rows - 1))
        c = int(min(max((ax + t * dx - x0) / res, 0.0), cols - 1))
        for rr in range(max(r - k, 0), min(r + k + 1, rows)):
            for cc in range(max(c - k, 0), min(c + k + 1, cols)):
                if seen[rr, cc]:
                    return True
    return False


@dataclass(frozen=True)
class FrontFit:
    """A cabinet's front as the LRF sees it, robot frame.

    Attributes:
        goal: (2,) where the robot's centre should be: on the front's centre line, `depth` in
            front of the fitted line.
        heading_error: how far the robot must turn to face the front squarely [rad].
        depth_m: the robot centre's distance from the fitted line [m].
        n_points: the scan points the line was fitted to.
    """

    goal: FloatArray
    heading_error: float
    depth_m: float
    n_points: int


def fit_front(
    points: FloatArray, front: FloatArray, depth_m: float, within_m: float = 0.08, min_points: int = 8
) -> FrontFit | None:
    """Fit a line to the scan points (robot frame) near where a cabinet's front is expected
    (`front`: its two end points, robot frame, from the pose estimate), and the docking goal it
    gives: depth and angle come from the line itself, so they hold even when the pose estimate
    is a few centimetres or degrees off; only the position along the front comes from the
    estimate (the middle of the expected front, projected onto the line). None when fewer than
    `min_points` points lie within `within_m` of the expected front.

    >>> front = np.array([[0.5, 0.3], [0.5, -0.3]])  # a 0.6 m front 0.5 m straight ahead
    >>> pts = np.column_stack([np.full(31, 0.52), np.linspace(-0.3, 0.3, 31)])  # seen 2 cm deeper
    >>> fit = fit_front(pts, front, 0.33)
    >>> [round(float(v), 3) + 0.0 for v in fit.goal], round(fit.heading_error, 3), round(fit.depth_m, 3)
    ([0.19, 0.0], 0.0, 0.52)
    """
    a, b = np.asarray(front[0], dtype=np.float64), np.asarray(front[1], dtype=np.float64)
    along = b - a
    length = float(np.hypot(*along))
    if length < 1e-9 or len(points) == 0:
        return None
    u = along / length
    rel = points - a
    t = rel @ u
    off = rel @ np.array([-u[1], u[0]])
    near = points[(np.abs(off) <= within_m) & (t >= -0.05) & (t <= length + 0.05)]
    if len(near) < min_points:
        return None
    centre = near.mean(axis=0)
    _, _, vt = np.linalg.svd(near - centre, full_matrices=False)
    direction = vt[0]
    normal = np.array([-direction[1], direction[0]])
    if centre @ normal > 0:  # the normal points from the line towards the robot (the origin)
        normal = -normal
    depth = float(-(centre @ normal))
    middle = 0.5 * (a + b)
    on_line = centre + direction * float((middle - centre) @ direction)
    goal = on_line + normal * depth_m
    heading_error = math.atan2(-normal[1], -normal[0])  # facing the front: x along -normal
    return FrontFit(goal, heading_error, depth, len(near))


def _door_frame(polygon: FloatArray) -> tuple[FloatArray, FloatArray, float]:
    """A door opening's centre, the unit normal through it and its half width (from its polygon:
    the opening's long side across the way, the wall's thickness along it)."""
    polygon = np.asarray(polygon, dtype=np.float64)
    centre = polygon.mean(axis=0)
    e1, e2 = polygon[1] - polygon[0], polygon[2] - polygon[1]
    long, short = (e1, e2) if np.hypot(*e1) >= np.hypot(*e2) else (e2, e1)
    normal = short / max(float(np.hypot(*short)), 1e-9)
    return centre, normal, 0.5 * float(np.hypot(*long))


def _sample_segments(segments: FloatArray, spacing: float) -> FloatArray:
    """Points along segments, at most `spacing` apart (both ends included)."""
    out = []
    for x1, y1, x2, y2 in np.asarray(segments, dtype=np.float64):
        n = max(1, int(math.ceil(math.hypot(x2 - x1, y2 - y1) / spacing)))
        t = np.linspace(0.0, 1.0, n + 1)
        out.append(np.column_stack([x1 + t * (x2 - x1), y1 + t * (y2 - y1)]))
    return np.vstack(out) if out else np.zeros((0, 2))


@njit
def _dilate(mask: np.ndarray, radius_cells: int) -> np.ndarray:
    rows, cols = mask.shape
    out = np.zeros((rows, cols), dtype=np.bool_)
    r2 = radius_cells * radius_cells
    for r in range(rows):
        for c in range(cols):
            if mask[r, c]:
                for dr in range(-radius_cells, radius_cells + 1):
                    for dc in range(-radius_cells, radius_cells + 1):
                        if dr * dr + dc * dc <= r2:
                            rr, cc = r + dr, c + dc
                            if 0 <= rr < rows and 0 <= cc < cols:
                                out[rr, cc] = True
    return out


class HospitalAgent(Agent):
    """The classic hospital strategy (see the module docstring)."""

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
        self._steps = lambda seconds: max(1, round(seconds / spec.dt_s))

    # --- episode ----------------------------------------------------------------------------
    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:
        """Start an episode: needs `info["task"]` (the given map and the cabinet order)."""
        task = (info or {}).get("task")
        if task is None:
            raise ValueError("the classic hospital agent needs info['task'] from reset (the given map and order)")
        cfg = self.config
        if task is not self._task:
            world = task.map
            self._task = task
            self.localiser = Localiser(world.wall_segments)
            self.cabinets: tuple[Cabinet, ...] = cabinets_of(world)
            self.grid = Grid.covering(world.bounds, cfg.cell_m, margin=0.3)
            walls = np.vstack([world.wall_segments, world.cabinet_segments])
            self.map_clearance = clearance_grid(self.grid, walls, cap=0.5)
            self.map_blocked = self.map_clearance < cfg.inflate_m
            self.start_region = world.polygon(world.start_area[0]) if world.start_area else None
            self.wall_points = _sample_segments(walls, 0.04)  # the map's walls as points, map frame
            self._wall_by_x = np.argsort(self.wall_points[:, 0], kind="stable")  # (for `_remembered`)
            self._wall_x = self.wall_points[self._wall_by_x, 0]
            self.doors = [_door_frame(world.polygon(d)) for d in world.doors]
            self._free: FloatArray | None = None
        self.order = list(task.cabinet_order)
        self.dwell_s = float(task.dwell_s)
        self.announce = getattr(task, "arrival", "dwell") == "announce"
        self._announcing = False  # this step's action announces an arrival
        self.evidence = np.zeros(self.grid.shape)  # what stands still
        self.people_evidence = np.zeros(self.grid.shape)  # hits on people seen walking
        self._seen_grid: np.ndarray | None = None  # both, thresholded (made when first asked)
        self.state = State.LOCALISE
        self.state_steps = 0
        self.done = 0
        self.pose = Pose(0.0, 0.0, 0.0)
        self.localised = False
        self.odom0: Pose | None = None
        self.odom_prev: Pose | None = None
        self.loc_points: list[FloatArray] = []
        self.turned_since_search = math.inf
        self.turned_total = 0.0
        self.unhealthy_steps = 0
        self._elsewhere: tuple[Pose, Pose] | None = None  # (odometry, pose) a check found elsewhere
        self._recent: list[tuple[Pose, FloatArray]] = []  # (odometry, points) of recent scans
        self.doubt_steps = 0  # steps in a row with the health under doubt_health
        self.lost_attempts = 0  # local relocalisations that did not restore the health
        self.relocalised = 0  # whole-map relocalisations done
        self.path: list[FloatArray] = []
        self.plan_step = -(10**9)
        self.steps = 0
        self.best_distance = math.inf
        self.progress_step = 0
        self.side = 0.0
        self.target: FloatArray | None = None
        self.front_fit: FrontFit | None = None
        self._scan_robot = np.zeros((0, 2))
        self._fixed = np.zeros((0, 2))
        self._memory = ScanMemory(cfg.blind_memory_s, self.spec.dt_s)
        lrf = self.spec.lrf
        self._people_free = (
            SeenFree(
                cfg.blind_memory_s, self.spec.dt_s, lrf.angle_min_rad, lrf.angle_max_rad, lrf.range_min_m,
                lrf.range_max_m, self.motion.half_depth, self.motion.half_width,
            )
            if cfg.people_cuts_m > 0.0
            else None
        )  # fmt: skip
        self.health = 0.0
        self.localise_s: float | None = None
        self._last_points = np.zeros((0, 2))
        self.still_steps = 0
        self.nogo: list[tuple[float, float, int]] = []  # (x, y, until step), map frame
        self._static_until = 0  # no YIELD before this step (a blocker was seen not to move)
        self.squeeze = False  # the current path needed the squeeze (see `blocked`)
        self._anchor: tuple[FloatArray, int] | None = None  # (spot, step) of `_going_nowhere`
        self._blocked_spots = []
        self._yield_seen = np.zeros((0, 2))
        self._moved_step = -(10**9)
        self.tracker = PeopleTracker(cfg.tracker, self.doors)
        self._cleared: set[tuple[int, float]] = set()  # (track, time) of trail positions cleared

    def belief(self) -> Pose | None:
        """The agent's estimate of its pose in the map frame (None before it has localised)."""
        return self.pose if self.localised else None

    def _go(self, state: State) -> None:
        self.state = state
        self.state_steps = 0
        self.path = []
        self.plan_step = -(10**9)
        self.best_distance = math.inf
        self.progress_step = self.steps
        self._yield_seen = np.zeros((0, 2))
        self._moved_step = -(10**9)
        self._anchor = None
        self._blocked_spots: list[FloatArray] = []  # escape spots the robot could not move towards

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
        if self.odom0 is None:
            self.odom0 = odom
        if self.localised:
            self._track(odom, points)
            if cfg.track_people:
                self._track_people(ranges)
        self._odom = odom
        self.odom_prev = odom
        near = scan_points(ranges, self.angles, lrf.range_max_m, len(ranges))
        self._scan_robot = near  # every valid end point, robot frame (docking fits the front to it)
        near = near[np.hypot(near[:, 0], near[:, 1]) < 1.2]
        if self.localised:
            # The blind sector behind the robot: the map's walls and what the evidence holds there.
            behind = self._remembered()
            near = np.vstack([near, behind[np.abs(np.arctan2(behind[:, 1], behind[:, 0])) > lrf.angle_max_rad - 0.05]])
            near = self._wary(near)
        self._memory.add(self._scan_robot, odom)  # (after `near`: this step's scan is in it already)
        if self._people_free is not None:
            self._people_free.add(ranges, odom)
        return near

    def _decide(self, near: FloatArray) -> tuple[float, float, float]:
        """The state machine's command for this step (before the safety filter)."""
        if self.state in (State.LOCALISE, State.RELOCALISE):
            command = self._localise(self._odom, self._last_points, near)
        elif self.state is State.DONE:
            command = (0.0, 0.0, 0.0)
        else:
            command = getattr(self, f"_{self.state.value}")(near)
        return command

    def _max_still_s(self) -> float:
        """How long the robot may stand still (not dwelling) before it recovers, in this state [s]."""
        return self.config.max_still_s

    def _finish(self, near: FloatArray, command: tuple[float, float, float]) -> np.ndarray:
        """The command through the safety filter (kept in the LRF's view, turns cut near corners,
        scaled down until the footprint keeps its margin), and the never-stand-still rule."""
        if self._people_free is not None and self._person_near():
            free = self._people_free
            command = self._blind_cuts(command, lambda pts: free.free(pts, self._odom, aged=False))
        vx, vy, w = command
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
        return any(
            t.moving and math.hypot(*(t.position - here)) < reach for t in (*self.tracker.tracks, *self.tracker.dropped)
        )

    def _blind_cuts(
        self, command: tuple[float, float, float], seen_free: Callable[[FloatArray], FloatArray], translate: bool = True
    ) -> tuple[float, float, float]:
        """The command with no translation (while navigating, with `translate`) and no turn that
        sweeps the footprint's rear into space `seen_free` does not vouch for (`_translate`,
        `blind_turn`); recovering or yielding, a robot boxed in must be free to edge out. (First,
        so that a turn in place is left to the safety filter.)"""
        vx, vy = keep_in_view(np.array(command[:2]), self.motion)
        if translate and self.state is State.NAVIGATE:
            vx, vy = self._translate((vx, vy, command[2]), seen_free)
        twist = (float(vx), float(vy), command[2])
        return (twist[0], twist[1], blind_turn(twist, self.motion, *self._view, seen_free=seen_free))

    def _translate(
        self, twist: tuple[float, float, float], seen_free: Callable[[FloatArray], FloatArray]
    ) -> tuple[float, float]:
        """`_blind_cuts`' translation: no part of the footprint's rear into unvouched space."""
        return blind_translation(twist, self.motion, *self._view, seen_free=seen_free)

    # --- localisation ---------------------------------------------------------------------------
    def _track(self, odom: Pose, points: FloatArray) -> None:
        """Odometry prediction, then registration against the map if enough beams agree."""
        cfg = self.config
        predicted = compose(self.pose, compose(inverse(self.odom_prev), odom))
        fixed = self._without_people(points, predicted)
        self._fixed = fixed
        if self.steps % self._steps(1.0) == 0:  # one scan a second for `_check_elsewhere`
            self._recent = [*self._recent[-(self.config.doubt_scans - 1) :], (odom, fixed)]
        pose = self.localiser.refine(predicted, fixed, prior=cfg.registration_prior)
        health = self.localiser.explained(pose, fixed)
        self.health = health
        if health >= cfg.health_min and math.hypot(pose.x - predicted.x, pose.y - predicted.y) < 0.2:
            self.pose = pose
            self.unhealthy_steps = 0
            self.lost_attempts = 0
        else:
            self.pose = predicted
            self.unhealthy_steps += 1
        if health < cfg.doubt_health and self.state is not State.RELOCALISE:
            self.doubt_steps += 1
            if self.doubt_steps >= self._steps(cfg.doubt_s):
                self.doubt_steps = 0
                self._check_elsewhere(odom, fixed)
        else:
            self.doubt_steps = 0
        if self.unhealthy_steps >= self._steps(3.0) and self.state is not State.RELOCALISE:
            self._relocalise_near(points)
            self.lost_attempts += 1
            if self.lost_attempts >= cfg.lost_after:
                self._lost()
        self._update_world(points)

    def _without_people(self, points: FloatArray, pose: Pose) -> FloatArray:
        """Robot-frame points less those on a moving track (a person beside a wall would pull the
        registration onto that wall)."""
        moving = self.tracker.moving() if self.config.track_people else []
        if not moving:
            return points
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        ex = pose.x + c * points[:, 0] - s * points[:, 1]
        ey = pose.y + s * points[:, 0] + c * points[:, 1]
        keep = np.ones(len(points), dtype=bool)
        now = self.steps * self.spec.dt_s
        for t in moving:
            centre = t.predict(now - t.seen_s)
            keep &= np.hypot(ex - centre[0], ey - centre[1]) > t.radius_m + 0.15
        return points[keep]

    def _relocalise_near(self, points: FloatArray) -> None:
        """A local global search (1 x 1 m around the estimate, any heading)."""
        x, y = self.pose.x, self.pose.y
        region = np.array([[x - 0.5, y - 0.5], [x + 0.5, y - 0.5], [x + 0.5, y + 0.5], [x - 0.5, y + 0.5]])
        result = self.localiser.global_search(region, points)
        if result.margin > self.localiser.config.unique_margin:
            self.pose = result.pose
        self.unhealthy_steps = 0

    def _localise(self, odom: Pose, points: FloatArray, near: FloatArray) -> tuple[float, float, float]:
        """Turn in place, joining scans at their odometry offsets, until one pose explains them
        clearly better than any other: of the start area (LOCALISE), or of the whole map's free
        space (RELOCALISE, after the pose was lost); after a full turn, the best one."""
        cfg = self.config
        if self.odom0 is None:
            self.odom0 = odom
        offset = compose(inverse(self.odom0), odom)  # this scan's pose in the first scan's frame
        if self.turned_since_search >= cfg.localise_turn_rad:
            c, sn = math.cos(offset.theta), math.sin(offset.theta)
            moved = np.column_stack(
                [offset.x + c * points[:, 0] - sn * points[:, 1], offset.y + sn * points[:, 0] + c * points[:, 1]]
            )
            self.loc_points.append(moved)
            joined = np.vstack(self.loc_points)
            if self.state is State.RELOCALISE:
                result = self.localiser.search_everywhere(self._free_positions(), joined)
                # The pose it had when it was judged lost, unless a pose elsewhere clearly beats
                # it: a hospital's rooms look alike, and a false alarm must not move it.
                kept = self.localiser.refine(self._lost_from, joined)
                kept_score = float(self.localiser.scores(np.array([tuple(kept)]), joined)[0])
                if (result.score - kept_score) * len(joined) < self.localiser.config.unique_margin:
                    result = dataclasses.replace(result, pose=kept, rival_score=-math.inf)
            else:
                region = self.start_region
                if region is None:  # no start area given: the whole map
                    x0, y0, x1, y1 = self._task.map.bounds
                    region = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
                result = self.localiser.global_search(region, joined)
            self.turned_since_search = 0.0
            needed = self.localiser.config.unique_margin
            if self.state is State.RELOCALISE:  # the whole map holds far more look-alikes than a start area
                needed *= 1.0 if len(self.loc_points) >= 3 else math.inf
            if result.margin > needed or self.turned_total > 2.0 * math.pi:
                before, self.pose = self.pose, compose(result.pose, offset)
                if not self.localised:
                    self.localised = True
                    self.localise_s = self.steps * self.spec.dt_s
                else:
                    self.relocalised += 1
                    if math.hypot(self.pose.x - before.x, self.pose.y - before.y) > 0.3:
                        self.evidence *= 0.5  # built on the lost pose: fade it (passing beams clear the rest)
                        self.people_evidence *= 0.5
                        self._seen_grid = None
                self.unhealthy_steps = 0
                self.lost_attempts = 0
                self._update_world(points)
                self._go(State.NAVIGATE)
                return 0.0, 0.0, 0.0
        turn = 0.8 * self.motion.max_turn
        self.turned_since_search += turn * self.spec.dt_s
        self.turned_total += turn * self.spec.dt_s
        return 0.0, 0.0, turn

    def _check_elsewhere(self, odom: Pose, points: FloatArray) -> None:
        """A doubtful pose (few beams explained for a while) against the whole map: when a pose
        elsewhere explains the last few scans (joined at their odometry offsets) far better, the
        pose is lost (a wrong pose in one of a hospital's alike rooms can still explain most beams,
        so the health check alone misses it; one scan full of people and boxes can line up with
        walls elsewhere, the scans of a few seconds of travel seldom do)."""
        joined = [points]
        for then, pts in self._recent[:-1]:
            off = compose(inverse(odom), then)  # that scan's pose in this one's frame
            c, s = math.cos(off.theta), math.sin(off.theta)
            joined.append(
                np.column_stack([off.x + c * pts[:, 0] - s * pts[:, 1], off.y + s * pts[:, 0] + c * pts[:, 1]])
            )
        joined = np.vstack(joined)
        result = self.localiser.search_everywhere(self._free_positions(), joined)
        here = float(self.localiser.scores(np.array([tuple(self.pose)]), joined)[0])
        far = math.hypot(result.pose.x - self.pose.x, result.pose.y - self.pose.y) > 0.5
        if not (far and result.score - here > self.config.doubt_gain):
            self._elsewhere = None
            return
        # Lost only when two checks in a row find the same pose elsewhere (moved by odometry):
        # clutter that happens to line up with walls elsewhere seldom does so twice.
        before = self._elsewhere
        self._elsewhere = (odom, result.pose)
        if before is not None:
            then, there = before
            expected = compose(there, compose(inverse(then), odom))
            if (
                math.hypot(expected.x - result.pose.x, expected.y - result.pose.y) < 0.3
                and abs(wrap_angle(expected.theta - result.pose.theta)) < 0.3
            ):
                self._elsewhere = None
                self._lost()

    def _lost(self) -> None:
        """The pose is lost (kidnapped, or the registration slid off): search the whole map."""
        self._lost_from = self.pose
        self._go(State.RELOCALISE)
        self.odom0 = None
        self.loc_points = []
        self.turned_since_search = math.inf
        self.turned_total = 0.0

    def _free_positions(self) -> FloatArray:
        """Where the robot's centre can be on the given map (0.2 m apart, inside the building)."""
        if self._free is None:
            g = self.grid
            inside = ~self.map_blocked
            if self.start_region is not None:
                r, c = self._cell(self.start_region.mean(axis=0))
                inside = flood(inside, r, c)
            rows, cols = np.nonzero(inside[::4, ::4])
            self._free = np.column_stack(
                [g.x0 + (4 * cols + 0.5) * g.resolution, g.y0 + (4 * rows + 0.5) * g.resolution]
            )
        return self._free

    # --- world model ---------------------------------------------------------------------------
    def _update_world(self, points: FloatArray) -> None:
        cfg, g = self.config, self.grid
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        ex = self.pose.x + c * points[:, 0] - s * points[:, 1]
        ey = self.pose.y + s * points[:, 0] + c * points[:, 1]
        unexplained = self.localiser.distance_at(ex, ey) > cfg.unexplained_m
        person = np.zeros(len(points), dtype=bool)
        for t in self.tracker.moving() if cfg.track_people else ():
            person |= np.hypot(ex - t.position[0], ey - t.position[1]) <= t.radius_m + 0.15
        ex, ey = np.ascontiguousarray(ex), np.ascontiguousarray(ey)
        for grid, hits in ((self.evidence, unexplained & ~person), (self.people_evidence, unexplained & person)):
            _update_evidence(
                grid,
                g.x0,
                g.y0,
                g.resolution,
                self.pose.x,
                self.pose.y,
                ex,
                ey,
                hits,
                cfg.evidence_hit,
                cfg.evidence_miss,
                cfg.evidence_max,
            )
        self._seen_grid = None

    def seen(self) -> np.ndarray:
        """The cells held to be obstacles the map does not show: still ones and people (bool)."""
        if self._seen_grid is None:
            block = self.config.evidence_block
            self._seen_grid = (self.evidence >= block) | (self.people_evidence >= block)
        return self._seen_grid

    def _track_people(self, ranges: FloatArray) -> None:
        """Cluster the scan's unexplained points into tracks; clear the cells moving ones left."""
        cfg = self.config
        pts = self._to_map(scan_points(ranges, self.angles, self.spec.lrf.range_max_m, cfg.track_beams))
        unexplained = (
            self.localiser.distance_at(np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1]))
            > cfg.unexplained_m
        )
        now = self.steps * self.spec.dt_s
        self.tracker.update(pts, unexplained, now)
        for t in self.tracker.moving() if cfg.clear_trails else ():
            for when, p in t.history:
                key = (t.id, when)
                if key in self._cleared or now - when < 0.5 or np.hypot(*(p - t.position)) <= t.radius_m + 0.15:
                    continue
                self._cleared.add(key)
                k = int(math.ceil((t.radius_m + 0.1) / cfg.cell_m))
                r, c = self._cell(p)
                window = (slice(max(r - k, 0), r + k + 1), slice(max(c - k, 0), c + k + 1))
                self.people_evidence[window] = 0.0
                if when < t.moving_since_s:  # seen before it was known to walk: in the still layer
                    k = int(math.ceil(t.radius_m / cfg.cell_m))
                    self.evidence[max(r - k, 0) : r + k + 1, max(c - k, 0) : c + k + 1] = 0.0
                self._seen_grid = None
        if len(self._cleared) > 5000:
            self._cleared = {(i, w) for i, w in self._cleared if now - w < 10.0}

    def _wary(self, near: FloatArray) -> FloatArray:
        """`near` with the points the map does not explain pulled `unexplained_margin_m` towards
        the robot, so the safety filter keeps that much more room from boxes and people (not on
        a squeezed path: that gap has no room for it)."""
        margin = 0.0 if self.squeeze else self.config.unexplained_margin_m
        if margin <= 0.0 or len(near) == 0:
            return near
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        ex = self.pose.x + c * near[:, 0] - s * near[:, 1]
        ey = self.pose.y + s * near[:, 0] + c * near[:, 1]
        odd = self.localiser.distance_at(ex, ey) > self.config.unexplained_m
        if not odd.any():
            return near
        d, away = footprint_distance(near[odd], self.motion)
        closer = np.maximum(d - margin, np.minimum(d, 0.001))  # never into the footprint (ignored there)
        out = near.copy()
        out[odd] -= away * (d - closer)[:, None]
        return out

    def _remembered(self) -> FloatArray:
        """Robot-frame points within 1.2 m (a square): the map's walls and the evidence cells, in
        the order of `wall_points` and of the grid's cells."""
        g, x, y = self.grid, self.pose.x, self.pose.y
        # Only the walls and cells round the robot are looked at (a margin past the square).
        lo, hi = np.searchsorted(self._wall_x, (x - 1.25, x + 1.25))
        walls = self.wall_points[np.sort(self._wall_by_x[lo:hi])]
        k = int(1.25 / g.resolution) + 2
        r0, c0 = max(int((y - g.y0) / g.resolution) - k, 0), max(int((x - g.x0) / g.resolution) - k, 0)
        rows, cols = np.nonzero(self.seen()[r0 : r0 + 2 * k + 1, c0 : c0 + 2 * k + 1])
        rows, cols = rows + r0, cols + c0
        seen = np.column_stack([g.x0 + (cols + 0.5) * g.resolution, g.y0 + (rows + 0.5) * g.resolution])
        pts = np.vstack([walls, seen])
        mapped = self._to_robot(pts[(np.abs(pts[:, 0] - x) < 1.2) & (np.abs(pts[:, 1] - y) < 1.2)])
        if not self._memory.steps:
            return mapped
        return np.vstack([mapped, self._memory.recent(self._odom)])  # the last scans' (`blind_memory_s`)

    def blocked(self, nogo: bool = False, squeeze: bool = False) -> np.ndarray:
        """The planning grid: the map inflated, plus the evidence of what it does not show (and,
        with `nogo`, the discs where the robot recently made no progress). With `squeeze` the
        evidence is inflated by only `squeeze_m`: the robot's half depth, for a gap between a box
        and a wall that it can pass sideways only without the extra margin."""
        cfg = self.config
        seen = self.seen()
        inflate = cfg.squeeze_m if squeeze else cfg.inflate_m + 0.05
        out = (
            self.map_blocked.copy()
            if not seen.any()
            else self.map_blocked | _dilate(seen, int(math.ceil(inflate / cfg.cell_m - 1e-9)))
        )
        if nogo:
            g = self.grid
            k = int(math.ceil(cfg.nogo_m / cfg.cell_m))
            for x, y, _until in self.nogo:
                r, c = self._cell(np.array([x, y]))
                rr, cc = np.ogrid[-k : k + 1, -k : k + 1]
                disc = rr * rr + cc * cc <= k * k
                r0, c0 = max(r - k, 0), max(c - k, 0)
                r1, c1 = min(r + k + 1, g.shape[0]), min(c + k + 1, g.shape[1])
                out[r0:r1, c0:c1] |= disc[r0 - (r - k) : r1 - (r - k), c0 - (c - k) : c1 - (c - k)]
        return out

    def _cell(self, p: FloatArray) -> tuple[int, int]:
        """The grid cell (row, column) of a map-frame point, clamped to the grid."""
        g = self.grid
        r = int(min(max((p[1] - g.y0) / g.resolution, 0.0), g.shape[0] - 1))  # (np.clip: ten times slower)
        c = int(min(max((p[0] - g.x0) / g.resolution, 0.0), g.shape[1] - 1))
        return r, c

    def _centre(self, cell: tuple[int, int]) -> FloatArray:
        g = self.grid
        return np.array([g.x0 + (cell[1] + 0.5) * g.resolution, g.y0 + (cell[0] + 0.5) * g.resolution])

    def _plan(self, goal: FloatArray) -> bool:
        self.nogo = [n for n in self.nogo if n[2] > self.steps]
        here = np.array([self.pose.x, self.pose.y])
        start, end = self._cell(here), self._cell(goal)
        k = int(self.config.inflate_m / self.config.cell_m)
        path = None
        tiers = [(True, False)] if self.nogo else []
        tiers += [(False, False), (False, True)]
        for nogo, squeeze in tiers:
            self.squeeze = squeeze
            blocked = self.blocked(nogo, squeeze)
            for r, c in (start, end):  # the robot's own cell (and the goal's) may touch the inflation
                blocked[max(r - k, 0) : r + k + 1, max(c - k, 0) : c + k + 1] = False
            path = astar(blocked, start, end)
            if path is not None:
                break
        self.plan_step = self.steps
        if path is None:
            self.path = []
            self.squeeze = False
            return False
        cells = string_pull(blocked, path.cells)
        self.path = self._through_doors([here] + [self._centre(c) for c in cells[1:]] + [goal])[1:]
        return True

    def _through_doors(self, path: list[FloatArray]) -> list[FloatArray]:
        """Cross every door of the map square on: a waypoint on its centre line before and after
        it (string pulling cuts through a door at a slant the footprint cannot take)."""
        out = [path[0]]
        for a, b in zip(path[:-1], path[1:], strict=True):
            for centre, normal, _half in self.doors:
                da, db = float((a - centre) @ normal), float((b - centre) @ normal)
                if da * db >= 0.0:
                    continue  # this leg does not cross the door's line
                t = da / (da - db)
                cross = a + t * (b - a)
                along = cross - centre - normal * float((cross - centre) @ normal)
                if float(np.hypot(*along)) > _half + 0.3:
                    continue  # crosses the line elsewhere
                side = 1.0 if da > 0 else -1.0
                for k in (side, -side):
                    w = centre + k * self.config.door_approach_m * normal
                    if float(np.linalg.norm(w - out[-1])) > 0.05:
                        out.append(w)
            out.append(b)
        return out

    # --- motion helpers ---------------------------------------------------------------------------
    def _to_map(self, points: FloatArray) -> FloatArray:
        """Robot-frame points (N, 2) in the map frame, at the pose estimate."""
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        return np.column_stack(
            [self.pose.x + c * points[:, 0] - s * points[:, 1], self.pose.y + s * points[:, 0] + c * points[:, 1]]
        )

    def _to_robot(self, p: FloatArray) -> FloatArray:
        """Map-frame points (N, 2), or one point (2,), in the robot frame, at the pose estimate."""
        d = np.asarray(p) - np.array([self.pose.x, self.pose.y])
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)

    def _cabinet(self) -> Cabinet:
        return self.cabinets[self.order[self.done]]

    def _dock_point(self) -> FloatArray:
        return self._cabinet().dock_point(self.config.dock_depth_m)

    def _remaining(self, here: FloatArray) -> float:
        """The length of the planned way from here to its end [m]."""
        points = [here, *self.path]
        return float(sum(np.linalg.norm(b - a) for a, b in zip(points[:-1], points[1:], strict=True)))

    def _going_nowhere(self, here: FloatArray) -> bool:
        """True when the robot has stayed within 0.3 m of one spot for twice `stuck_s`."""
        if self._anchor is None or float(np.linalg.norm(here - self._anchor[0])) > 0.3:
            self._anchor = (here.copy(), self.steps)
        return self.steps - self._anchor[1] > self._steps(2.0 * self.config.stuck_s)

    def _progress(self, distance: float) -> bool:
        """Track progress to the goal; True when there was none for `stuck_s`."""
        if distance < self.best_distance - 0.1:
            self.best_distance = distance
            self.progress_step = self.steps
        return self.steps - self.progress_step > self._steps(self.config.stuck_s)

    # --- states --------------------------------------------------------------------------------
    def _navigate(self, near: FloatArray) -> tuple[float, float, float]:
        cfg = self.config
        goal = self._dock_point()
        here = np.array([self.pose.x, self.pose.y])
        distance = float(np.linalg.norm(goal - here))
        if distance < cfg.dock_radius_m:
            self._go(State.DOCK)
            return 0.0, 0.0, 0.0
        if not self.path or self.steps - self.plan_step >= self._steps(cfg.replan_s) or self._path_blocked():
            if not self._plan(goal):
                yielding = self._blocker() is not None and self.steps >= self._static_until
                self._go(State.YIELD if yielding else State.RECOVER)
                return 0.0, 0.0, 0.0
            remaining = self._remaining(here)
            if remaining > self.best_distance + 0.5:  # a new, longer way round: progress counts anew
                self.best_distance = remaining
                self.progress_step = self.steps
        while len(self.path) > 1 and np.linalg.norm(self.path[0] - here) < cfg.lookahead_m:
            self.path.pop(0)
        # Progress along the way, not as the crow flies; and, since plans that alternate between
        # two ways round each restart that count, the robot must also get somewhere at all.
        if self._progress(self._remaining(here)) or self._going_nowhere(here):
            ahead = self.path[0] - here
            gap = float(np.hypot(*ahead))
            spot = here + ahead * min(1.0, (cfg.nogo_m + 0.1) / gap) if gap > 1e-6 else here
            if float(np.linalg.norm(goal - spot)) > cfg.nogo_m + 0.3:  # never the goal itself
                self.nogo.append((float(spot[0]), float(spot[1]), self.steps + self._steps(cfg.nogo_s)))
            self._go(State.RECOVER)
            return 0.0, 0.0, 0.0
        if self.still_steps >= self._steps(1.0) and self._holding_a_person():
            # Stopped inside a person's pause radius: it waits for the robot, the robot for it.
            self._go(State.YIELD)
            return 0.0, 0.0, 0.0
        target = self.path[0]
        self.target = target
        v = attract_and_repel(near, self._to_robot(target), self.follow)
        travel = math.atan2(target[1] - here[1], target[0] - here[0])
        if distance < cfg.face_within_m and self._clear_way(here, goal):
            heading = self._cabinet().facing_rad
        elif self._roomy(here) and self._roomy(target):
            heading = travel  # forward: the LRF sees the way ahead and both sides
        else:
            # Sideways: the direction of travel at the robot's +y (or -y, whichever is nearer).
            # Face the more open side (the LRF sees what may come from there; the blind back
            # is to the nearer wall), else the nearer turn; decided afresh every 2 s.
            # Something the map does not explain close by (a person, a box) is kept in view first.
            unexplained = self._unexplained_near()
            if self.side == 0.0 or self.state_steps % self._steps(2.0) == 0 or len(unexplained):
                towards = None
                if len(unexplained):
                    mx, my = unexplained.mean(axis=0)
                    towards = self.pose.theta + math.atan2(my, mx)
                scores = []
                for side in (1.0, -1.0):
                    h = travel - side * math.pi / 2
                    ahead = here + 0.6 * np.array([math.cos(h), math.sin(h)])
                    turn = abs(wrap_angle(h - self.pose.theta))
                    watch = 0.0 if towards is None else round(math.cos(h - towards), 1)
                    scores.append((watch, round(float(self.map_clearance[self._cell(ahead)]), 1), -turn, side))
                self.side = max(scores)[3]
            heading = travel - self.side * math.pi / 2
        return float(v[0]), float(v[1]), heading_rate(heading - self.pose.theta, self.motion)

    def _clear_way(self, a: FloatArray, b: FloatArray) -> bool:
        """Whether the straight way from a to b keeps the robot's half width (0.2 m) and the
        margin off what the map does not explain: turned to face a cabinet early, the robot
        drives the last metre forward, which a box beside the way does not leave room for."""
        seen = self.seen()
        if not seen.any():
            return True
        k = int(math.ceil((0.2 + self.config.unexplained_margin_m + 0.05) / self.config.cell_m))
        return not self._evidence_along(seen, a, b, k)

    def _roomy(self, p: FloatArray, within_m: float | None = None) -> bool:
        """Room to drive forward (the robot's 0.4 m width across the way) at a map-frame point:
        the map's walls and the evidence at least `roomy_m` (or `within_m`) away."""
        within = self.config.roomy_m if within_m is None else within_m
        r, c = self._cell(p)
        if self.map_clearance[r, c] < within:
            return False
        k = int(math.ceil(within / self.config.cell_m))
        return not bool(self.seen()[max(r - k, 0) : r + k + 1, max(c - k, 0) : c + k + 1].any())

    def _path_blocked(self) -> bool:
        """Whether the next stretch of the path runs through a cell now blocked by evidence."""
        seen = self.seen()
        if not seen.any() or not self.path:
            return False
        here = np.array([self.pose.x, self.pose.y])
        legs = zip([here, *self.path[:-1]], self.path[:3], strict=False)
        return any(self._evidence_along(seen, a, b, 2) for a, b in legs)

    def _evidence_along(self, seen: np.ndarray, a: FloatArray, b: FloatArray, k: int) -> bool:
        """Whether a `seen` cell lies within k cells (a square) of the segment a-b (map frame)."""
        g = self.grid
        return bool(
            _near_segment(seen, g.x0, g.y0, g.resolution, float(a[0]), float(a[1]), float(b[0]), float(b[1]), k)
        )

    def _dock(self, near: FloatArray) -> tuple[float, float, float]:
        """Servo into the arrival square facing the front: on the front as the LRF sees it
        (`fit_front`) once it is in view, else on the pose estimate."""
        cfg = self.config
        cab = self._cabinet()
        goal = self._dock_point()
        here = np.array([self.pose.x, self.pose.y])
        if float(np.linalg.norm(goal - here)) > cfg.dock_radius_m + 0.4 or self.state_steps > self._steps(15.0):
            self._go(State.NAVIGATE)
            return 0.0, 0.0, 0.0
        fit = fit_front(self._scan_robot, np.array([self._to_robot(p) for p in cab.front]), cfg.dock_depth_m)
        self.front_fit = fit
        if fit is not None:
            error, heading_error = fit.goal, fit.heading_error
            arrived = True  # the fit's errors decide (the square is around its goal)
        else:
            error = self._to_robot(goal)
            heading_error = wrap_angle(cab.facing_rad - self.pose.theta)
            arrived = cab.arrival(self.pose, math.radians(4.0))[0]
        distance = float(np.hypot(*error))
        if arrived and distance < 0.06 and abs(heading_error) < math.radians(4.0):
            self._go(State.DWELL)
            return 0.0, 0.0, 0.0
        v = error * min(1.5, cfg.dock_speed / max(distance, 1e-9))
        return float(v[0]), float(v[1]), heading_rate(heading_error, self.motion)

    def _dwell(self, near: FloatArray) -> tuple[float, float, float]:
        """Stand still for the dwell (arrival="dwell"), or announce the arrival once and go on
        (arrival="announce": the arrival rule then asks for no stillness). Not while the scan
        fits the map poorly without a check against the whole map (the pose may be lost in a
        look-alike spot: that arrival would count for nothing)."""
        if self.state_steps == 1 and self.health < self.config.doubt_health and self.localised:
            self._check_elsewhere(self._odom, self._fixed)  # a look-alike spot while lost?
            if self.state is not State.DWELL:
                return 0.0, 0.0, 0.0
        if self.announce:
            self._announcing = True
            self.done += 1
            self._go(State.DONE if self.done >= len(self.order) else State.NAVIGATE)
            return 0.0, 0.0, 0.0
        if self.state_steps * self.spec.dt_s >= self.dwell_s + self.config.dwell_margin_s:
            self.done += 1
            self._go(State.DONE if self.done >= len(self.order) else State.NAVIGATE)
        return 0.0, 0.0, 0.0

    def _blocker(self) -> FloatArray | None:
        """The nearest point within `yield_range_m` that the map does not explain (robot frame)."""
        pts = self._unexplained_near(self.config.yield_range_m)
        if len(pts) == 0:
            return None
        return pts[int(np.argmin(np.hypot(pts[:, 0], pts[:, 1])))]

    def _yield(self, near: FloatArray) -> tuple[float, float, float]:
        """Keep out of the blocker's pause radius and watch it: a person walking across the way
        moves on (a paused one resumes once the robot is far enough), the beams clear the cells
        it leaves, and a plan goes through again. No fading: what is really there stays."""
        cfg = self.config
        if self.state_steps * self.spec.dt_s >= cfg.yield_max_s:
            self._go(State.RECOVER)
            return 0.0, 0.0, 0.0
        if self.state_steps % self._steps(0.5) == 0:
            if not self._holding_a_person() and self._plan(self._dock_point()):
                path = self.path
                self._go(State.NAVIGATE)
                self.path, self.plan_step = path, self.steps
                return 0.0, 0.0, 0.0
            if self._moved():
                self._moved_step = self.steps
        if self.steps - max(self._moved_step, self.steps - self.state_steps) >= self._steps(cfg.yield_static_s):
            # Nothing moved: a box (or a cart at the end of its run). Watching it again would only
            # renew its evidence: RECOVER (which fades it) from now on, for a while.
            self._static_until = self.steps + self._steps(cfg.yield_static_memory_s)
            self._go(State.RECOVER)
            return 0.0, 0.0, 0.0
        blocker = self._blocker()
        if blocker is None:
            return 0.0, 0.0, 0.3  # it left the view: look round (never idle)
        w = heading_rate(math.atan2(blocker[1], blocker[0]), self.motion)
        if float(np.hypot(*blocker)) < cfg.yield_keep_m:
            v = attract_and_repel(
                near, self._to_robot(self._escape_spot(self._unexplained_near())), self.motion, speed=0.2
            )
            return float(v[0]), float(v[1]), w
        return 0.0, 0.0, w

    def _holding_a_person(self) -> bool:
        """Whether the robot is inside a moving track's pause radius (+ 0.1 m): the simulator's
        person or cart waits there until the robot leaves (hospital-facts.md 1.6)."""
        if not self.config.track_people:
            return False
        return any(
            math.hypot(t.position[0] - self.pose.x, t.position[1] - self.pose.y) < t.pause_radius_m + 0.1
            for t in self.tracker.moving()
        )

    def _moved(self) -> bool:
        """Whether something the map does not explain is where nothing was at the last check
        (map frame, 0.15 m apart): a person walking, not a box seen again."""
        here = self._to_map(self._unexplained_near(self.config.yield_range_m))
        before, self._yield_seen = self._yield_seen, here
        if len(before) == 0 or len(here) == 0:
            return False
        gaps = np.hypot(here[:, None, 0] - before[None, :, 0], here[:, None, 1] - before[None, :, 1]).min(axis=1)
        return bool((gaps > 0.15).any())

    def _recover(self, near: FloatArray) -> tuple[float, float, float]:
        """Back away from what the map does not explain (a person waits while the robot is within
        half its diagonal + 0.3 m, so a robot that waits close by waits forever), to `clear_m`
        from it or for `recover_s`, then wait a little for it to move on, then plan again."""
        cfg = self.config
        if self.state_steps == 1:
            self.evidence *= 0.5  # fade, never wipe: what is really there is seen again
            self.people_evidence *= 0.5
            self._seen_grid = None
        t = self.state_steps * self.spec.dt_s
        unexplained = self._unexplained_near()
        far = len(unexplained) == 0 or float(np.hypot(unexplained[:, 0], unexplained[:, 1]).min()) > cfg.clear_m
        if t >= cfg.recover_s + cfg.recover_wait_s:
            self._go(State.NAVIGATE)
            return 0.0, 0.0, 0.0
        if t >= cfg.recover_s or far:
            if len(near) and float(np.hypot(near[:, 0], near[:, 1]).min()) < 0.35:
                v = attract_and_repel(near, np.zeros(2), self.motion, speed=0.15)  # room to turn first
                return float(v[0]), float(v[1]), 0.0
            return 0.0, 0.0, 0.3  # wait, turning slowly (the LRF looks round; never idle)
        v = attract_and_repel(near, self._to_robot(self._escape_spot(unexplained)), self.motion, speed=0.25)
        return float(v[0]), float(v[1]), 0.0

    def _escape_spot(self, unexplained: FloatArray) -> FloatArray:
        """Where to back off to (map frame): of the spots 0.6 and 0.9 m away in 16 directions that
        the map and the evidence leave room for the robot's centre, the one farthest from what the
        map does not explain."""
        here = np.array([self.pose.x, self.pose.y])
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        others = here + unexplained @ np.array([[c, s], [-s, c]])  # robot frame -> map frame
        best, best_score = here, -math.inf
        for a, reach in ((a, r) for r in (0.6, 0.9) for a in np.linspace(0.0, 2.0 * math.pi, 16, endpoint=False)):
            spot = here + reach * np.array([math.cos(a), math.sin(a)])
            # Room for the robot's centre (beside a wall too: wedged between a wall and a paused
            # person, the way out is along the wall).
            if not self._roomy(spot, self.config.inflate_m) or not self._straight_way(here, spot):
                continue
            if any(np.hypot(*(spot - bad)) < 0.3 for bad in self._blocked_spots):
                continue
            score = float(np.hypot(*(others - spot).T).min()) if len(others) else 0.0
            if score > best_score:
                best, best_score = spot, score
        if self.still_steps >= self._steps(1.0) and best is not here:
            # The safety filter has held the robot still on the way there: another way out.
            self._blocked_spots.append(best)
            self.still_steps = 0
        return best

    def _straight_way(self, a: FloatArray, b: FloatArray) -> bool:
        """Whether the robot's centre can go straight from a to b: the map's walls keep the
        robot's half depth off the way (a spot behind a wall is near but not reachable)."""
        n = max(2, int(np.linalg.norm(b - a) / 0.05))
        g = self.grid
        way = a + np.linspace(0.0, 1.0, n)[1:, None] * (b - a)
        rows = np.clip((way[:, 1] - g.y0) / g.resolution, 0, g.shape[0] - 1).astype(np.int64)  # as `_cell`
        cols = np.clip((way[:, 0] - g.x0) / g.resolution, 0, g.shape[1] - 1).astype(np.int64)
        return not bool((self.map_clearance[rows, cols] < 0.1).any())

    def _unexplained_near(self, within_m: float = 1.5) -> FloatArray:
        """Robot-frame points within `within_m` of the last scan that the map does not explain,
        and with `escape_people` the people tracked walking within `within_m`."""
        pts = self._last_points
        if len(pts):
            seen = self._to_map(pts)
            d = self.localiser.distance_at(np.ascontiguousarray(seen[:, 0]), np.ascontiguousarray(seen[:, 1]))
            pts = pts[(d > self.config.unexplained_m) & (np.hypot(pts[:, 0], pts[:, 1]) < within_m)]
        if not (self._escapes_people() and self.localised and self.config.track_people):
            return pts
        walking = [t.position for t in self.tracker.moving()]
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
        g = self.grid
        rows, cols = np.nonzero(self.seen())
        evidence = np.column_stack([g.x0 + (cols + 0.5) * g.resolution, g.y0 + (rows + 0.5) * g.resolution])
        here = np.array([self.pose.x, self.pose.y])
        path = np.array([here, *self.path]) if self.path else np.zeros((0, 2))
        target = f" -> cabinet {self.order[self.done]}" if self.done < len(self.order) else ""
        segments = []
        ring = np.linspace(0.0, 2.0 * math.pi, 17)
        for t in self.tracker.moving() if self.localised else ():
            xs = t.position[0] + t.pause_radius_m * np.cos(ring)
            ys = t.position[1] + t.pause_radius_m * np.sin(ring)
            segments.append(np.column_stack([xs[:-1], ys[:-1], xs[1:], ys[1:]]))
        if self.done < len(self.order) and self.localised:
            sq = self._cabinet().square
            segments.append(np.column_stack([sq, np.roll(sq, -1, axis=0)]))
        if self.state is State.DOCK and self.front_fit is not None:
            c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
            goal = self.front_fit.goal
            gx, gy = self.pose.x + c * goal[0] - s * goal[1], self.pose.y + s * goal[0] + c * goal[1]
            segments.append(np.array([[self.pose.x, self.pose.y, gx, gy]]))
        return Overlay(
            frame="map",
            segments=np.vstack(segments) if segments else np.zeros((0, 4)),
            points=evidence.reshape(-1, 2),
            path=path.reshape(-1, 2),
            target=self.target,
            text=f"classic: {self.state.value}{target} ({self.done}/{len(self.order)}), fit {self.health:.2f}",
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
            self.localised = True
            self.localise_s = 0.0
            self._go(State.NAVIGATE)
        return super().act(obs)

    def _track(self, odom: Pose, points: FloatArray) -> None:
        self.pose = self._truth()
        self.health = 1.0
        self._update_world(points)


def build(env: Any, **kwargs: Any) -> HospitalAgent:
    """The classic hospital agent for an env's robot (`make_agent("classic", env)`)."""
    return HospitalAgent(RobotSpec.of(env), **kwargs)


def build_oracle(env: Any, **kwargs: Any) -> OraclePoseAgent:
    """The classic hospital agent handed the true pose (`make_agent("classic-oracle", env)`)."""
    return OraclePoseAgent(RobotSpec.of(env), env, **kwargs)
