"""One episode's world: static geometry tagged by kind, door states, unknown boxes, movers.

A `Map` is what a file (or the generator) describes; a `Scene` is what one episode is made of:
the map's walls, cabinets and static obstacles, the doors closed this episode, the boxes placed
this episode and the moving objects with their state. Physics, the LRF, clearance and the renderer
all read the scene. Its static part is built once per episode as one segment array, ordered so
that what the LRF sees is a prefix (a view, never copied per step); movers add four segments each,
rewritten in place as they move.

Moving objects follow the course simulator exactly (emc_simulator src/moving_object.cpp, see
hospital-facts.md 1.6): a box of `length` x `width` keeping its initial yaw, travelling straight
from `init_pose` to `final_pose` at `velocity`; it starts (once) when the robot's origin comes
within `trigger_radius` of its centre, pauses while the centre distance is below
r_pause = hypot(w/2, l/2) + 0.3 m, stops within 0.1 m of `final_pose`, or with `repeat` swaps the
two poses and goes back (ping-pong).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pico_gym.types import FloatArray, Pose, Segments
from pico_gym.world import geometry
from pico_gym.world.map import Map

# What a segment is, for bumps by kind (index = the code in `Scene.static_kinds`).
KINDS = ("wall", "cabinet", "door", "box", "mover")
WALL, CABINET, DOOR, BOX, MOVER = range(5)

# emc_simulator moving_object.cpp: a paused object resumes when the robot is farther than its
# half-diagonal plus this margin; a non-repeating object stops within this distance of its goal.
MOVER_PAUSE_MARGIN_M = 0.3
MOVER_ARRIVE_M = 0.1
MOVER_RECORD_KEYS = ("length", "width", "trigger_radius", "velocity", "init_pose", "final_pose", "repeat")


@dataclass(frozen=True)
class MoverRecord:
    """A course moving-object record (emc_simulator config format), in the map frame.

    Attributes:
        length: extent along the object's own x [m].
        width: extent along its y [m].
        trigger_radius: it starts when the robot comes this close to its centre [m].
        velocity: its speed [m/s].
        init_pose: (x, y, yaw) where it stands at the start.
        final_pose: (x, y, yaw) where it goes (its yaw stays the initial one).
        repeat: ping-pong between the two poses instead of stopping.
    """

    length: float
    width: float
    trigger_radius: float
    velocity: float
    init_pose: tuple[float, float, float]
    final_pose: tuple[float, float, float]
    repeat: bool = False

    def __post_init__(self) -> None:
        for name in ("length", "width", "velocity"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")
        if not (math.isfinite(self.trigger_radius) and self.trigger_radius >= 0):
            raise ValueError(f"trigger_radius must be a number >= 0, got {self.trigger_radius!r}")

    @property
    def pause_radius_m(self) -> float:
        """The robot's centre distance under which the object waits."""
        return math.hypot(0.5 * self.width, 0.5 * self.length) + MOVER_PAUSE_MARGIN_M

    @property
    def half_diagonal_m(self) -> float:
        return math.hypot(0.5 * self.width, 0.5 * self.length)

    def to_dict(self) -> dict[str, Any]:
        return {
            "length": self.length,
            "width": self.width,
            "trigger_radius": self.trigger_radius,
            "velocity": self.velocity,
            "init_pose": list(self.init_pose),
            "final_pose": list(self.final_pose),
            "repeat": self.repeat,
        }


def mover_record(data: Any, where: str) -> MoverRecord:
    """A `MoverRecord` from a course record (dict); ValueError naming `where` and the key."""
    if not isinstance(data, dict):
        raise ValueError(f"{where}: expected an object with keys {', '.join(MOVER_RECORD_KEYS)}, got {data!r}")
    for key in MOVER_RECORD_KEYS:
        if key not in data:
            raise ValueError(f"{where}: missing key '{key}'")

    def number(key: str) -> float:
        v = data[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"{where}.{key}: expected a finite number, got {v!r}")
        return float(v)

    def pose(key: str) -> tuple[float, float, float]:
        v = data[key]
        if not (isinstance(v, list) and len(v) == 3 and all(isinstance(a, (int, float)) for a in v)):
            raise ValueError(f"{where}.{key}: expected [x, y, yaw], got {v!r}")
        if not all(math.isfinite(a) for a in v):
            raise ValueError(f"{where}.{key}: expected finite numbers, got {v!r}")
        return float(v[0]), float(v[1]), float(v[2])

    values = {k: number(k) for k in ("length", "width", "trigger_radius", "velocity")}
    for k in ("length", "width", "velocity"):
        if values[k] <= 0:
            raise ValueError(f"{where}.{k}: must be positive, got {values[k]}")
    if values["trigger_radius"] < 0:
        raise ValueError(f"{where}.trigger_radius: must be >= 0, got {values['trigger_radius']}")
    if not isinstance(data["repeat"], bool):
        raise ValueError(f"{where}.repeat: expected true or false, got {data['repeat']!r}")
    return MoverRecord(init_pose=pose("init_pose"), final_pose=pose("final_pose"), repeat=data["repeat"], **values)


def box_corners(x: float, y: float, yaw: float, length: float, width: float) -> FloatArray:
    """(4, 2) corners of a length x width box centred at (x, y), its length along yaw."""
    c, s = math.cos(yaw), math.sin(yaw)
    hl, hw = 0.5 * length, 0.5 * width
    local = np.array([(hl, -hw), (hl, hw), (-hl, hw), (-hl, -hw)])
    return np.column_stack([x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]])


class Mover:
    """A moving object and its state (exactly the course simulator's rules, module docstring)."""

    def __init__(self, record: MoverRecord) -> None:
        self.record = record
        self.x, self.y, self.yaw = record.init_pose
        self._goal = (record.final_pose[0], record.final_pose[1])
        self._origin = (record.init_pose[0], record.init_pose[1])
        self.triggered = False
        self.paused = False
        self.finished = False

    @property
    def pose(self) -> Pose:
        return Pose(self.x, self.y, self.yaw)

    def advance(self, duration_s: float, robot_x: float, robot_y: float) -> None:
        """Move for `duration_s` (one physics sub-step) given the robot's position."""
        if self.finished:
            return
        rec = self.record
        distance = math.hypot(robot_x - self.x, robot_y - self.y)
        if not self.triggered:
            if distance >= rec.trigger_radius:
                return
            self.triggered = True
        self.paused = distance < rec.pause_radius_m
        if self.paused:
            return
        gx, gy = self._goal
        dx, dy = gx - self.x, gy - self.y
        remaining = math.hypot(dx, dy)
        if remaining <= MOVER_ARRIVE_M:
            if rec.repeat:
                self._goal, self._origin = self._origin, self._goal
                gx, gy = self._goal
                dx, dy = gx - self.x, gy - self.y
                remaining = math.hypot(dx, dy)
            else:
                self.finished = True
                return
        if remaining <= 0.0:
            return
        step = min(rec.velocity * duration_s, remaining)
        self.x += dx / remaining * step
        self.y += dy / remaining * step

    def corners(self) -> FloatArray:
        return box_corners(self.x, self.y, self.yaw, self.record.length, self.record.width)

    def write_segments(self, out: Segments) -> None:
        """Write the box's 4 edges into out (a (4, 4) view)."""
        corners = self.corners()
        out[:, :2] = corners
        out[:, 2:] = np.roll(corners, -1, axis=0)


@dataclass(eq=False)
class Scene:
    """One episode's world.

    Attributes:
        map: the true static world (walls, cabinets, door openings, static obstacles).
        closed_doors: indices into `map.doors` of the doors closed this episode.
        boxes: polygons of the unknown boxes placed this episode (not in the map).
        movers: the moving objects, with their state.
    """

    map: Map
    closed_doors: tuple[int, ...] = ()
    boxes: tuple[FloatArray, ...] = ()
    movers: list[Mover] = field(default_factory=list)

    def __post_init__(self) -> None:
        world = self.map
        n_doors = len(world.door_segments)
        for d in self.closed_doors:
            if not 0 <= d < n_doors:
                raise ValueError(f"closed door index {d} out of range (the map has {n_doors} doors)")
        seen: list[Segments] = [world.structure_segments, world.cabinet_segments, world.obstacle_segments]
        kinds = [WALL, CABINET, BOX]
        for d in self.closed_doors:
            seen.append(world.door_segments[d])
            kinds.append(DOOR)
        for poly in self.boxes:
            seen.append(geometry.polygon_to_segments(poly))
            kinds.append(BOX)
        parts = seen + [world.low_segments]
        codes = kinds + [WALL]
        solid = np.ascontiguousarray(np.vstack([p.reshape(-1, 4) for p in parts]), dtype=np.float64)
        self.static_kinds = np.concatenate(
            [np.full(len(p.reshape(-1, 4)), k, dtype=np.int8) for p, k in zip(parts, codes, strict=True)]
        )
        self.static_solid = solid
        n_seen = sum(len(p.reshape(-1, 4)) for p in seen)
        self.static_seen = solid[:n_seen]  # a view: what the LRF sees is a prefix of what is solid
        self.mover_segments = np.zeros((4 * len(self.movers), 4))
        self.update_movers()

    @property
    def has_movers(self) -> bool:
        return bool(self.movers)

    @property
    def max_mover_speed_mps(self) -> float:
        return max((m.record.velocity for m in self.movers), default=0.0)

    def update_movers(self) -> None:
        """Rewrite the movers' segments from their current poses."""
        for i, mover in enumerate(self.movers):
            mover.write_segments(self.mover_segments[4 * i : 4 * i + 4])

    def advance_movers(self, duration_s: float, robot_x: float, robot_y: float) -> None:
        for mover in self.movers:
            mover.advance(duration_s, robot_x, robot_y)

    def solid_segments(self) -> Segments:
        """Everything solid now (static plus movers): a new array (for checks, not the hot path)."""
        return np.vstack([self.static_solid, self.mover_segments])

    def mover_poses(self) -> np.ndarray:
        """(n_movers, 3) true poses of the movers."""
        return np.array([m.pose for m in self.movers], dtype=np.float64).reshape(-1, 3)

    def kind_of_segment(self, index: int) -> str:
        return KINDS[int(self.static_kinds[index])]


@dataclass(frozen=True)
class SceneSnapshot:
    """What the renderer draws: a value copied from the env's state, no reference to the env.

    Attributes:
        map: the true static world.
        closed_doors: closed door indices.
        boxes: box polygons.
        movers: (n, 3) mover poses; mover_sizes: (n, 2) length, width; mover_pause_m: (n,) radii.
        pose: the robot's true pose; outline: its footprint (robot frame).
        trajectory: (k, 2) true positions so far; bump_points: (b, 2).
        scan_points: (m, 2) LRF hit points in the map frame.
        map_from_odom: the odometry frame's pose in the map frame (for agent overlays).
        sim_time_s, bumps: for the status line.
        marks: task-specific drawings (e.g. cabinets' arrival squares, order numbers, done flags).
    """

    map: Map
    closed_doors: tuple[int, ...]
    boxes: tuple[FloatArray, ...]
    movers: np.ndarray
    mover_sizes: np.ndarray
    mover_pause_m: np.ndarray
    pose: Pose
    outline: FloatArray
    trajectory: np.ndarray
    bump_points: np.ndarray
    scan_points: np.ndarray
    map_from_odom: Pose
    sim_time_s: float
    bumps: int
    marks: dict[str, Any] = field(default_factory=dict)
