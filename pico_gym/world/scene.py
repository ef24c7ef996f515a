"""One episode's world: static geometry tagged by kind, door states, unknown boxes, movers.

A `Map` is what a file (or the generator) describes; a `Scene` is what one episode is made of:
the map's walls, cabinets and static obstacles, the doors closed this episode, the boxes placed
this episode and the moving objects with their state. Physics, the LRF, clearance and the renderer
all read the scene. Its static part is built once per episode as one segment array, ordered so
that what the LRF sees is a prefix (a view, never copied per step); movers add four segments each,
rewritten in place as they move.

Moving objects follow the course simulator's rules (`pico_gym.world.movers`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pico_gym.types import FloatArray, Pose, Segments
from pico_gym.world import geometry
from pico_gym.world.map import Map
from pico_gym.world.movers import MoverRecord, Movers, box_corners, mover_record
from pico_gym.world.segment_grid import GRID_MIN_SEGMENTS, SegmentGrid

__all__ = ["KINDS", "MoverRecord", "Movers", "Scene", "SceneSnapshot", "box_corners", "mover_record"]

# What a segment is, for bumps by kind (index = the code in `Scene.static_kinds`).
KINDS = ("wall", "cabinet", "door", "box", "mover")
WALL, CABINET, DOOR, BOX, MOVER = range(5)
# Another robot (two robots in one world, `pico_gym.multi`): a bump kind beyond KINDS.
ROBOT_KIND = 5


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
    movers: Movers = field(default_factory=lambda: Movers(()))

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
        one_sided = np.zeros(n_seen, dtype=bool)
        one_sided[: len(world.structure_segments)] = world.structure_one_sided
        # The LRF's back-face culling flags (None when no segment has one: the plain cast).
        self.static_one_sided = one_sided if one_sided.any() else None
        # What the LRF casts against: the segments themselves on small maps, their grid on large ones.
        self.lrf_static: Segments | SegmentGrid = (
            SegmentGrid(self.static_seen, self.static_one_sided) if n_seen >= GRID_MIN_SEGMENTS else self.static_seen
        )
        self.mover_segments = np.zeros((4 * len(self.movers), 4))
        self.update_movers()

    @property
    def has_movers(self) -> bool:
        return len(self.movers) > 0

    @property
    def max_mover_speed_mps(self) -> float:
        return self.movers.max_speed_mps

    def update_movers(self) -> None:
        """Rewrite the movers' segments from their current poses."""
        self.movers.write_segments(self.mover_segments)

    def solid_segments(self) -> Segments:
        """Everything solid now (static plus movers): a new array (for checks, not the hot path)."""
        return np.vstack([self.static_solid, self.mover_segments])

    def mover_poses(self) -> np.ndarray:
        """(n_movers, 3) true poses of the movers."""
        return self.movers.poses()

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
        others: the other robots' true poses (two robots in one world), drawn in outline.
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
    others: tuple[Pose, ...] = ()  # other robots in the world (`pico_gym.multi`)
