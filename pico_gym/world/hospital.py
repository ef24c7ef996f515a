"""Hospital worlds: cabinet geometry (fronts, arrival squares) and the hospital generator.

Cabinets (course rule, docs/facts/hospital-facts.md 1.8): a cabinet is a closed polygon whose first segment is
its front; the robot has arrived when its centre is inside the square in front of the front (side
= the front's length) and it faces the front. `Cabinet` computes that square and heading.

The generator follows the 2019 rules (docs/facts/hospital-facts.md section 3): a hallway U(1.2, 1.8) m wide,
straight (I) or with one bend (L); 3-6 rectangular rooms of 2.0-4.5 m off both sides of it,
separated by 0.2 m walls; a door U(0.5, 1.0) m from each room to the hallway, at least 0.3 m
from the corners of the wall it is in, and with probability 0.3 an extra door to a neighbouring
room (loops allowed, as in 2019); 1-2 cabinets of 0.4 x 0.4 m per room (3-8 in all), backs against
a room wall, fronts facing the room, each arrival square (plus 0.3 m) clear of walls, door
approaches and other squares, and admitting the robot facing the cabinet; a 1 x 1 m start area
in the hallway. Walls are the outline of the free space (rooms, hallway, door openings), which is
what the LRF and the robot can touch. Every draw comes from the generator passed in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from pico_gym.robot import RobotConfig
from pico_gym.types import FloatArray, Pose, Segments
from pico_gym.world import geometry
from pico_gym.world.map import Map

WALL_M = 0.2  # course maps: walls are 0.2 m blocks
CABINET_SIDE_M = 0.4  # every known final used 0.4 x 0.4 m cabinets
START_AREA_SIDE_M = 1.0  # 2019 rule: a 1 x 1 m start area


@dataclass(frozen=True)
class Cabinet:
    """A cabinet's front and the arrival rule's geometry, map frame.

    Attributes:
        index: its number (index in the map's cabinets).
        polygon: its outline.
        front: (2, 2) the front segment's end points.
        normal: unit normal of the front pointing away from the cabinet (into the room).
    """

    index: int
    polygon: FloatArray
    front: FloatArray
    normal: FloatArray

    @staticmethod
    def of(world: Map, index: int) -> Cabinet:
        pairs = world.cabinets[index]
        polygon = world.polygon(pairs)
        i, j = pairs[0]
        front = world.points[[i, j]]
        d = front[1] - front[0]
        length = float(np.hypot(*d))
        if length <= 0:
            raise ValueError(f"{world.source or world.name}: cabinets[{index}]: its front has zero length")
        normal = np.array([-d[1], d[0]]) / length
        if (front.mean(axis=0) - polygon.mean(axis=0)) @ normal < 0:
            normal = -normal
        return Cabinet(index, polygon, front, normal)

    @property
    def side_m(self) -> float:
        """The front's length: the arrival square's side."""
        return self._side  # type: ignore[attr-defined]

    @property
    def square(self) -> FloatArray:
        """(4, 2) corners of the arrival square in front of the front."""
        return self._square.copy()  # type: ignore[attr-defined]

    @property
    def facing_rad(self) -> float:
        """The heading that looks at the front."""
        return float(math.atan2(-self.normal[1], -self.normal[0]))

    def dock_point(self, depth_m: float = 0.3) -> FloatArray:
        """A point on the square's centre line `depth_m` from the front (where the best poses are)."""
        return self._middle + self.normal * min(depth_m, 0.75 * self._side)  # type: ignore[attr-defined]

    def __post_init__(self) -> None:
        a, b = self.front
        side = float(np.hypot(*(b - a)))
        # Computed once: resets ask for these many times (the same values as computing them anew).
        object.__setattr__(self, "_side", side)
        object.__setattr__(self, "_middle", self.front.mean(axis=0))
        out = self.normal * side
        object.__setattr__(self, "_square", np.array([a, b, b + out, a + out]))
        # Plain floats for the per-step predicate: a, the unit front direction, the normal, the side.
        frame = (float(a[0]), float(a[1]), float((b[0] - a[0]) / side), float((b[1] - a[1]) / side))
        object.__setattr__(self, "_frame", (*frame, float(self.normal[0]), float(self.normal[1]), side))
        object.__setattr__(self, "_facing", math.atan2(-float(self.normal[1]), -float(self.normal[0])))

    def arrival(self, pose: Pose, tolerance_rad: float) -> tuple[bool, float, float]:
        """The arrival predicate and its parts: (arrived, distance of the centre to the square [m],
        heading error [rad])."""
        ax, ay, tx, ty, nx, ny, side = self._frame  # type: ignore[attr-defined]
        rx, ry = pose[0] - ax, pose[1] - ay
        along = rx * tx + ry * ty
        depth = rx * nx + ry * ny
        dx = max(0.0, -along, along - side)
        dy = max(0.0, -depth, depth - side)
        distance = math.hypot(dx, dy)
        error = abs(math.remainder(pose[2] - self._facing, 2.0 * math.pi))  # type: ignore[attr-defined]
        return distance == 0.0 and error <= tolerance_rad, distance, error


def cabinets_of(world: Map) -> tuple[Cabinet, ...]:
    return tuple(Cabinet.of(world, i) for i in range(len(world.cabinets)))


def square_admits_robot(
    cabinet: Cabinet, segments: Segments, robot: RobotConfig, clearance_m: float = 0.05, tolerance_rad: float = 0.26
) -> bool:
    """Whether some pose with the centre in the square, facing the front (within +-15 deg), keeps
    `clearance_m` from every segment (docs/facts/hospital-facts.md 3, the generator's feasibility check)."""
    side = cabinet.side_m
    a = cabinet.front[0]
    t = (cabinet.front[1] - a) / side
    for depth in np.linspace(0.25, 0.95, 8) * side:
        for along in np.linspace(0.2, 0.8, 7) * side:
            x, y = a + t * along + cabinet.normal * depth
            for dth in (0.0, -tolerance_rad * 0.5, tolerance_rad * 0.5):
                pose = Pose(float(x), float(y), cabinet.facing_rad + dth)
                footprint = geometry.transform_points(pose, robot.outline)
                if geometry.polygon_clearance(footprint, segments, clearance_m + 0.01) >= clearance_m:
                    return True
    return False


# --- the generator --------------------------------------------------------------------------


@dataclass(frozen=True)
class HospitalConfig:
    """Ranges the hospital generator draws from (uniformly unless said otherwise).

    Attributes:
        hallway_width_m: the hallway's width [m].
        hallway_shapes: shapes to choose from: "I" (straight) and "L" (one bend).
        n_rooms: range of the number of rooms.
        room_side_m: range of a room's width along the hallway and its depth [m].
        door_width_m: range of a door opening's width [m].
        door_corner_margin_m: a door keeps this far from the corners of its wall [m].
        extra_door_probability: chance of a door between two neighbouring rooms.
        cabinets_per_room: range of cabinets per room.
        building_cabinets: range of the cabinets in the whole hospital.
    """

    hallway_width_m: tuple[float, float] = (1.2, 1.8)
    hallway_shapes: tuple[str, ...] = ("I", "L")
    n_rooms: tuple[int, int] = (3, 6)
    room_side_m: tuple[float, float] = (2.0, 4.5)
    door_width_m: tuple[float, float] = (0.5, 1.0)
    door_corner_margin_m: float = 0.3
    extra_door_probability: float = 0.3
    cabinets_per_room: tuple[int, int] = (1, 2)
    building_cabinets: tuple[int, int] = (3, 8)

    def __post_init__(self) -> None:
        if not 1 <= self.n_rooms[0] <= self.n_rooms[1]:
            raise ValueError(f"HospitalConfig.n_rooms must be a range of at least 1, got {self.n_rooms}")
        if not 0.5 <= self.door_width_m[0] <= self.door_width_m[1]:
            raise ValueError(f"HospitalConfig.door_width_m must start at >= 0.5 m, got {self.door_width_m}")
        if not self.hallway_width_m[0] >= 1.0 or self.hallway_width_m[0] > self.hallway_width_m[1]:
            raise ValueError(
                f"HospitalConfig.hallway_width_m must be a range from >= 1.0 m, got {self.hallway_width_m}"
            )
        if not set(self.hallway_shapes) <= {"I", "L"} or not self.hallway_shapes:
            raise ValueError(f"HospitalConfig.hallway_shapes must be among 'I', 'L', got {self.hallway_shapes}")
        if not 2.0 <= self.room_side_m[0] <= self.room_side_m[1]:
            raise ValueError(f"HospitalConfig.room_side_m must be a range from >= 2.0 m, got {self.room_side_m}")
        if not 1 <= self.building_cabinets[0] <= self.building_cabinets[1]:
            raise ValueError(
                f"HospitalConfig.building_cabinets must be a range of at least 1, got {self.building_cabinets}"
            )


Rect = tuple[float, float, float, float]  # (x0, y0, x1, y1)


@dataclass(frozen=True)
class GeneratedHospital:
    """A generated hospital: its map, and the parts it was built from."""

    map: Map
    hallway: tuple[Rect, ...]
    rooms: tuple[Rect, ...]
    doors: tuple[Rect, ...]
    shape: str


def _overlaps(a: Rect, b: Rect, margin: float = 0.0) -> bool:
    return a[0] < b[2] + margin and b[0] < a[2] + margin and a[1] < b[3] + margin and b[1] < a[3] + margin


def outline_segments(free: list[Rect]) -> Segments:
    """The boundary of a union of axis-aligned rectangles, merged into maximal straight segments.

    >>> outline_segments([(0, 0, 2, 1)]).shape
    (4, 4)
    """
    xs = np.unique(np.array([v for r in free for v in (r[0], r[2])]).round(9))
    ys = np.unique(np.array([v for r in free for v in (r[1], r[3])]).round(9))
    cx, cy = 0.5 * (xs[:-1] + xs[1:]), 0.5 * (ys[:-1] + ys[1:])
    cell = np.zeros((len(cy) + 2, len(cx) + 2), dtype=bool)  # padded: outside is not free
    for x0, y0, x1, y1 in free:
        cols = (cx > x0) & (cx < x1)
        rows = (cy > y0) & (cy < y1)
        cell[1:-1, 1:-1] |= rows[:, None] & cols[None, :]
    segments = []
    # Horizontal boundaries: between row r-1 and r (padded indices), at y = ys[r-1].
    diff = cell[1:, 1:-1] != cell[:-1, 1:-1]  # (len(ys), len(cx))
    for r in range(diff.shape[0]):
        run = None
        for c in range(diff.shape[1]):
            if diff[r, c] and run is None:
                run = c
            if run is not None and (not diff[r, c] or c == diff.shape[1] - 1):
                end = c if diff[r, c] else c - 1
                segments.append((xs[run], ys[r], xs[end + 1], ys[r]))
                run = None
    diff = cell[1:-1, 1:] != cell[1:-1, :-1]  # (len(cy), len(xs))
    for c in range(diff.shape[1]):
        run = None
        for r in range(diff.shape[0]):
            if diff[r, c] and run is None:
                run = r
            if run is not None and (not diff[r, c] or r == diff.shape[0] - 1):
                end = r if diff[r, c] else r - 1
                segments.append((xs[c], ys[run], xs[c], ys[end + 1]))
                run = None
    return np.array(segments, dtype=np.float64).reshape(-1, 4)


def _rect_polygon(r: Rect) -> FloatArray:
    x0, y0, x1, y1 = r
    return np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)], dtype=np.float64)


def _hallway_legs(rng: np.random.Generator, cfg: HospitalConfig | Any, shape: str) -> list[Rect]:
    """The hallway's legs: a straight one, and for an L a second one up from its far end (`cfg`:
    any config with a `hallway_width_m` range)."""
    width = float(rng.uniform(*cfg.hallway_width_m))
    length = float(rng.uniform(6.0, 11.0))
    legs: list[Rect] = [(0.0, 0.0, length, width)]
    if shape == "L":
        up = float(rng.uniform(4.0, 8.0))
        legs.append((length - width, width, length, width + up))
    return legs


def row_rooms(
    rng: np.random.Generator, legs: list[Rect], target_rooms: int, room_side_m: tuple[float, float]
) -> tuple[list[Rect], list[tuple[int, str]], list[tuple[int, str, int]]]:
    """Rooms in rows along both sides of the hallway legs, 0.2 m walls apart, until `target_rooms`.

    Returns the rooms, the (leg, side) each hangs off and its (leg, side, position in its row).
    """
    rooms: list[Rect] = []
    attach: list[tuple[int, str]] = []  # (leg index, side) each room hangs off
    row_of: list[tuple[int, str, int]] = []  # (leg, side, position in its row)
    sides = [(k, side) for k in range(len(legs)) for side in ("low", "high")]
    order = rng.permutation(len(sides))
    lo, hi = room_side_m
    for s in order:
        k, side = sides[s]
        x0, y0, x1, y1 = legs[k]
        horizontal = (x1 - x0) >= (y1 - y0)
        start, stop = (x0, x1) if horizontal else (y0, y1)
        pos = start
        n_in_row = 0
        while len(rooms) < target_rooms:
            w = float(rng.uniform(lo, hi))
            d = float(rng.uniform(lo, hi))
            if pos + w > stop + 1e-9:
                w = stop - pos
                if w < lo:
                    break
            if horizontal:
                room = (
                    (pos, y1 + WALL_M, pos + w, y1 + WALL_M + d)
                    if side == "high"
                    else (pos, y0 - WALL_M - d, pos + w, y0 - WALL_M)
                )
            else:
                room = (
                    (x1 + WALL_M, pos, x1 + WALL_M + d, pos + w)
                    if side == "high"
                    else (x0 - WALL_M - d, pos, x0 - WALL_M, pos + w)
                )
            if any(_overlaps(room, r, WALL_M - 1e-6) for r in rooms + legs):
                pos += w + WALL_M
                continue
            rooms.append(room)
            attach.append((k, side))
            row_of.append((k, side, n_in_row))
            n_in_row += 1
            pos += w + WALL_M
        if len(rooms) >= target_rooms:
            break
    return rooms, attach, row_of


def generate_hospital(
    rng: np.random.Generator, config: HospitalConfig | None = None, robot: RobotConfig | None = None
) -> GeneratedHospital:
    """Draw a hospital by the 2019 rules (module docstring).

    Raises:
        RuntimeError: if no hospital satisfying the rules was found in 200 tries (the ranges in
            `config` contradict each other).
    """
    cfg = config or HospitalConfig()
    robot = robot or RobotConfig()
    for _ in range(200):
        built = _try_generate(rng, cfg, robot)
        if built is not None:
            return built
    raise RuntimeError(f"no hospital satisfies {cfg} (200 tries)")


def _try_generate(rng: np.random.Generator, cfg: HospitalConfig, robot: RobotConfig) -> GeneratedHospital | None:
    shape = str(cfg.hallway_shapes[int(rng.integers(len(cfg.hallway_shapes)))])
    legs = _hallway_legs(rng, cfg, shape)
    target_rooms = int(rng.integers(cfg.n_rooms[0], cfg.n_rooms[1] + 1))
    rooms, attach, row_of = row_rooms(rng, legs, target_rooms, cfg.room_side_m)
    if len(rooms) < cfg.n_rooms[0]:
        return None
    placed_doors = _doors(rng, cfg, legs, rooms, attach)
    if placed_doors is None:
        return None
    doors, room_doors = placed_doors
    free = list(legs) + rooms + doors
    walls = outline_segments(free)
    cabinets = _cabinets(rng, cfg, robot, rooms, room_doors, walls)
    if len(cabinets) < cfg.building_cabinets[0]:
        return None
    start_area = _start_area(rng, legs[0], doors)
    if start_area is None:
        return None
    world = _assemble(walls, cabinets, start_area, doors)
    return GeneratedHospital(world, tuple(legs), tuple(rooms), tuple(doors), shape)


def _doors(
    rng: np.random.Generator, cfg: HospitalConfig, legs: list[Rect], rooms: list[Rect], attach: list[tuple[int, str]]
) -> tuple[list[Rect], list[list[Rect]]] | None:
    """One door from each room to its hallway leg, at least the margin from the wall's corners,
    and extra doors between neighbouring rooms of a row (loops allowed, as in 2019); every door,
    and each room's. None if some room's wall to the hallway is too short for a door."""
    margin = cfg.door_corner_margin_m
    doors: list[Rect] = []
    room_doors: list[list[Rect]] = [[] for _ in rooms]
    for i, (room, (k, side)) in enumerate(zip(rooms, attach, strict=True)):
        door = hallway_door(rng, room, legs[k], side, cfg.door_width_m, margin)
        if door is None:
            return None
        doors.append(door)
        room_doors[i].append(door)
    for i in range(len(rooms)):
        for j in range(i + 1, len(rooms)):
            a, b = rooms[i], rooms[j]
            if rng.random() >= cfg.extra_door_probability:
                continue
            door = shared_wall_door(rng, a, b, cfg.door_width_m, cfg.door_corner_margin_m)
            if door is not None:
                doors.append(door)
                room_doors[i].append(door)
                room_doors[j].append(door)
    return doors, room_doors


def _cabinets(
    rng: np.random.Generator,
    cfg: HospitalConfig,
    robot: RobotConfig,
    rooms: list[Rect],
    room_doors: list[list[Rect]],
    walls: Segments,
) -> list[FloatArray]:
    """Cabinets against room walls, fronts facing into the room (as many as fit, up to the draw)."""
    cabinets: list[FloatArray] = []
    squares: list[FloatArray] = []
    target_cabinets = int(rng.integers(cfg.building_cabinets[0], cfg.building_cabinets[1] + 1))
    room_order = rng.permutation(len(rooms))
    for i in room_order:
        per_room = int(rng.integers(cfg.cabinets_per_room[0], cfg.cabinets_per_room[1] + 1))
        for _ in range(per_room):
            if len(cabinets) >= target_cabinets:
                break
            placed = _place_cabinet(rng, rooms[i], room_doors[i], squares, cabinets, walls, robot)
            if placed is not None:
                cabinets.append(placed[0])
                squares.append(placed[1])
    return cabinets


def _start_area(rng: np.random.Generator, leg: Rect, doors: list[Rect]) -> Rect | None:
    """The start area: 1 x 1 m in the first hallway leg, away from the doors (None: none found)."""
    x0, y0, x1, y1 = leg
    area_side = START_AREA_SIDE_M
    for _ in range(50):
        if y1 - y0 >= area_side + 0.1:
            sx = float(rng.uniform(x0 + 0.05, x1 - area_side - 0.05))
            sy = float(rng.uniform(y0 + 0.05, y1 - area_side - 0.05))
        else:
            sx = float(rng.uniform(x0 + 0.05, x1 - area_side - 0.05))
            sy = 0.5 * (y0 + y1 - area_side)
        area = (sx, sy, sx + area_side, sy + area_side)
        if not any(_overlaps(area, d, 0.3) for d in doors):
            return area
    return None


def hallway_door(
    rng: np.random.Generator, room: Rect, leg: Rect, side: str, width_m: tuple[float, float], margin: float
) -> Rect | None:
    """A door opening from `room` to the hallway leg it hangs off (on `side`), at least `margin`
    from the corners of the wall it is in; None if the shared wall is too short."""
    horizontal = (leg[2] - leg[0]) >= (leg[3] - leg[1])
    a0, a1 = (
        (max(room[0], leg[0]), min(room[2], leg[2])) if horizontal else (max(room[1], leg[1]), min(room[3], leg[3]))
    )
    width = float(rng.uniform(*width_m))
    if a1 - a0 < width + 2 * margin:
        return None
    s0 = float(rng.uniform(a0 + margin, a1 - margin - width))
    if horizontal:
        return (s0, leg[3], s0 + width, room[1]) if side == "high" else (s0, room[3], s0 + width, leg[1])
    return (leg[2], s0, room[0], s0 + width) if side == "high" else (room[2], s0, leg[0], s0 + width)


def shared_wall_door(
    rng: np.random.Generator, a: Rect, b: Rect, width_m: tuple[float, float], margin: float
) -> Rect | None:
    """A door in the 0.2 m wall between two rooms, if they share one long enough."""
    width = float(rng.uniform(*width_m))
    for p, q in ((a, b), (b, a)):
        if abs(q[0] - p[2] - WALL_M) < 1e-6:  # q right of p
            lo, hi = max(p[1], q[1]), min(p[3], q[3])
            if hi - lo >= width + 2 * margin:
                s = float(rng.uniform(lo + margin, hi - margin - width))
                return (p[2], s, q[0], s + width)
        if abs(q[1] - p[3] - WALL_M) < 1e-6:  # q above p
            lo, hi = max(p[0], q[0]), min(p[2], q[2])
            if hi - lo >= width + 2 * margin:
                s = float(rng.uniform(lo + margin, hi - margin - width))
                return (s, p[3], s + width, q[1])
    return None


def _place_cabinet(
    rng: np.random.Generator,
    room: Rect,
    doors: list[Rect],
    squares: list[FloatArray],
    cabinets: list[FloatArray],
    walls: Segments,
    robot: RobotConfig,
) -> tuple[FloatArray, FloatArray] | None:
    """A cabinet polygon (front first, counter-clockwise) against a wall of `room`, and its square."""
    c = CABINET_SIDE_M
    x0, y0, x1, y1 = room
    for _ in range(30):
        wall = int(rng.integers(4))  # 0 bottom, 1 right, 2 top, 3 left: the cabinet's back wall
        if wall in (0, 2):
            lo, hi = x0 + 0.5, x1 - 0.5 - c
        else:
            lo, hi = y0 + 0.5, y1 - 0.5 - c
        if hi <= lo:
            continue
        s = float(rng.uniform(lo, hi))
        if wall == 0:  # back on the bottom wall, front facing +y
            poly = np.array([(s + c, y0 + c), (s, y0 + c), (s, y0), (s + c, y0)])
            normal = np.array([0.0, 1.0])
        elif wall == 2:
            poly = np.array([(s, y1 - c), (s + c, y1 - c), (s + c, y1), (s, y1)])
            normal = np.array([0.0, -1.0])
        elif wall == 1:
            poly = np.array([(x1 - c, s + c), (x1 - c, s), (x1, s), (x1, s + c)])
            normal = np.array([-1.0, 0.0])
        else:
            poly = np.array([(x0 + c, s), (x0 + c, s + c), (x0, s + c), (x0, s)])
            normal = np.array([1.0, 0.0])
        front = poly[:2]
        square = np.array([front[0], front[1], front[1] + normal * c, front[0] + normal * c])
        keep_out = _bbox(np.vstack([poly, square]))
        if any(_overlaps(keep_out, d, 0.6) for d in doors):
            continue  # the door's approach
        if any(_overlaps(keep_out, _bbox(sq), 0.3) for sq in squares):
            continue
        if any(_overlaps(keep_out, _bbox(cb), 0.3) for cb in cabinets):
            continue
        if geometry.polygon_clearance(square, walls, 0.31) < 0.3:
            continue
        segs = np.vstack(
            [walls, geometry.polygon_to_segments(poly)] + [geometry.polygon_to_segments(p) for p in cabinets]
        )
        cab = Cabinet(len(cabinets), poly, front, normal)
        if not square_admits_robot(cab, segs, robot):
            continue
        return poly, square
    return None


def _bbox(points: FloatArray) -> Rect:
    return (float(points[:, 0].min()), float(points[:, 1].min()), float(points[:, 0].max()), float(points[:, 1].max()))


def _assemble(walls: Segments, cabinets: list[FloatArray], start_area: Rect, doors: list[Rect]) -> Map:
    """A `Map` (points + index pairs) from segments and polygons."""
    points: list[tuple[float, float]] = []
    index: dict[tuple[float, float], int] = {}

    def pid(x: float, y: float) -> int:
        key = (round(float(x), 9), round(float(y), 9))
        if key not in index:
            index[key] = len(points)
            points.append(key)
        return index[key]

    wall_pairs = [[pid(x1, y1), pid(x2, y2)] for x1, y1, x2, y2 in walls]

    def polygon_pairs(poly: FloatArray) -> np.ndarray:
        ids = [pid(x, y) for x, y in poly]
        return np.array([[ids[i], ids[(i + 1) % len(ids)]] for i in range(len(ids))], dtype=np.int64)

    cab_pairs = tuple(polygon_pairs(p) for p in cabinets)
    start_pairs = (polygon_pairs(_rect_polygon(start_area)),)
    door_pairs = tuple(polygon_pairs(_rect_polygon(d)) for d in doors)
    return Map(
        points=np.array(points, dtype=np.float64),
        walls=np.array(wall_pairs, dtype=np.int64).reshape(-1, 2),
        cabinets=cab_pairs,
        start_area=start_pairs,
        doors=door_pairs,
        name="generated hospital",
    )
