"""The escape-room generator: a new room for every reset, following the challenge's rules.

Rules (docs/facts/pico-facts.md, "Escape room challenge"): a rectangular room of unknown size, one exit
corridor perpendicular to a wall, 0.5-1.5 m wide, anywhere along the wall including flush with a
room corner; the finish line more than 3 m into the corridor, the corridor walls a little longer,
the far end open; walls not perfectly straight, corridor walls not exactly parallel.

Every draw comes from the generator passed in. Solvability is checked exactly (not on a grid):
a route for the robot is a polyline along which a disc holding the footprint in any heading stays
clear of every wall (swept-disc clearance), plus a straight sideways/forward translation from the
start pose at its own heading to the first point of that route.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pico_gym.robot import RobotConfig
from pico_gym.types import FloatArray, Pose, Segments
from pico_gym.validate import number, span
from pico_gym.world import geometry
from pico_gym.world.map import Map

MAX_ROOM_SIDE_M = 30.0


@dataclass(frozen=True)
class EscapeRoomConfig:
    """Ranges the generator draws from (uniformly unless said otherwise).

    Attributes:
        room_side_m: range of each side of the room [m].
        corridor_width_m: range of the corridor width at its narrowest [m].
        finish_depth_m: range of the finish line's distance from the room wall [m] (> 3 m).
        corridor_extra_m: how much longer than the finish depth each corridor wall is [m].
        corner_exit_probability: chance that the exit is flush with a room corner.
        corner_jitter_m: room corners are displaced by up to this much [m].
        wall_bend_m: each room wall without the exit is bent at a random point by up to this [m].
        corridor_tilt_rad: each corridor wall deviates from the wall normal by up to this [rad].
        n_obstacles: number of small static boxes placed in the room (0 = off, the default), or a
            range (lo, hi) to draw it from per room.
        obstacle_side_m: range of the obstacles' side lengths [m].
    """

    room_side_m: tuple[float, float] = (2.5, 7.0)
    corridor_width_m: tuple[float, float] = (0.5, 1.5)
    finish_depth_m: tuple[float, float] = (3.1, 4.0)
    corridor_extra_m: tuple[float, float] = (0.2, 0.8)
    corner_exit_probability: float = 0.25
    corner_jitter_m: float = 0.04
    wall_bend_m: float = 0.04
    corridor_tilt_rad: float = math.radians(1.5)
    n_obstacles: int | tuple[int, int] = 0
    obstacle_side_m: tuple[float, float] = (0.2, 0.5)

    def __post_init__(self) -> None:
        # Budget: a room side beyond this makes the geodesic grid and the generator's checks
        # cost more memory than any escape room needs (the course's rooms are 2.5-7 m).
        span("EscapeRoomConfig.room_side_m", self.room_side_m, 1.0, MAX_ROOM_SIDE_M)
        span("EscapeRoomConfig.corridor_width_m", self.corridor_width_m, 0.0, 5.0)
        span("EscapeRoomConfig.finish_depth_m", self.finish_depth_m, 0.0, 20.0)
        span("EscapeRoomConfig.corridor_extra_m", self.corridor_extra_m, 0.0, 5.0)
        span("EscapeRoomConfig.obstacle_side_m", self.obstacle_side_m, 0.01, 2.0)
        number("EscapeRoomConfig.corner_exit_probability", self.corner_exit_probability, 0.0, 1.0)
        number("EscapeRoomConfig.corner_jitter_m", self.corner_jitter_m, 0.0, 0.2)
        number("EscapeRoomConfig.wall_bend_m", self.wall_bend_m, 0.0, 0.2)
        number("EscapeRoomConfig.corridor_tilt_rad", self.corridor_tilt_rad, 0.0, 0.2)
        if isinstance(self.n_obstacles, int) and not isinstance(self.n_obstacles, bool):
            number("EscapeRoomConfig.n_obstacles", self.n_obstacles, 0, 50, integer=True)
        else:  # a range, kept as a tuple of ints
            object.__setattr__(
                self, "n_obstacles", span("EscapeRoomConfig.n_obstacles", self.n_obstacles, 0, 50, integer=True)
            )
        if self.corridor_width_m[0] < 0.5:
            raise ValueError("EscapeRoomConfig.corridor_width_m must start at >= 0.5 m (the challenge's rule)")
        if self.finish_depth_m[0] <= 3.0:
            raise ValueError("EscapeRoomConfig.finish_depth_m must be > 3 m (the challenge's rule)")


@dataclass(frozen=True)
class EscapeRoom:
    """A generated room: the map, and what the generator knows about it (for checks and tests).

    Attributes:
        map: the world (walls, obstacles, finish line).
        room: (4, 2) room corners, counter-clockwise.
        mouth: (2, 2) the corridor's mouth end points on the room wall.
        corridor_walls: (2, 4) the two corridor wall segments, starting at the mouth.
        route: (K, 2) a route from the room's centre to past the finish line that a disc of the
            robot's circumradius can follow (the solvability witness).
        corridor_width_min_m: the corridor's narrowest width.
    """

    map: Map
    room: FloatArray
    mouth: FloatArray
    corridor_walls: Segments
    route: FloatArray
    corridor_width_min_m: float


def _rot(theta: float) -> FloatArray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def _bent_wall(a: FloatArray, b: FloatArray, rng: np.random.Generator, bend: float) -> list[FloatArray]:
    """Points of a wall from a to b with one bend of up to `bend` metres (a excluded, b included)."""
    t = rng.uniform(0.3, 0.7)
    d = b - a
    normal = np.array([-d[1], d[0]]) / np.linalg.norm(d)
    return [a + t * d + rng.uniform(-bend, bend) * normal, b]


def route_clearance(route: FloatArray, segments: Segments) -> float:
    """Smallest distance between a polyline route and the segments (exact)."""
    best = math.inf
    for (ax, ay), (bx, by) in zip(route[:-1], route[1:], strict=True):
        for x1, y1, x2, y2 in segments:
            best = min(best, geometry.segment_segment_distance(ax, ay, bx, by, x1, y1, x2, y2))
    return best


def translation_is_free(pose: Pose, target: FloatArray, robot: RobotConfig, segments: Segments) -> bool:
    """True when the footprint can translate at fixed heading from `pose` to `target` (exact).

    The area a convex part sweeps under a translation is the convex hull of its start and end
    positions, so checking those hulls is exact.
    """
    end = Pose(float(target[0]), float(target[1]), pose.theta)
    for part in robot.convex_parts:
        both = np.vstack([geometry.transform_points(pose, part), geometry.transform_points(end, part)])
        if geometry.polygon_clearance(_convex_hull(both), segments) <= 0.0:
            return False
    return True


def _convex_hull(points: FloatArray) -> FloatArray:
    """Counter-clockwise convex hull (Andrew's monotone chain)."""
    pts = sorted(map(tuple, points))

    def half(seq: list[tuple[float, float]]) -> list[tuple[float, float]]:
        out: list[tuple[float, float]] = []
        for p in seq:
            while (
                len(out) >= 2
                and (out[-1][0] - out[-2][0]) * (p[1] - out[-2][1]) - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])
                <= 0
            ):
                out.pop()
            out.append(p)
        return out

    lower, upper = half(pts), half(pts[::-1])
    return np.array(lower[:-1] + upper[:-1])


def generate_escape_room(
    rng: np.random.Generator,
    config: EscapeRoomConfig = EscapeRoomConfig(),
    robot: RobotConfig | None = None,
    max_tries: int = 100,
) -> EscapeRoom:
    """Draw a solvable escape room.

    Args:
        rng: every random draw comes from here.
        config: the ranges to draw from.
        robot: the robot that must fit through (its circumradius sets the route clearance).
        max_tries: redraws allowed before giving up.

    Returns:
        The room. Raises RuntimeError if no solvable room was drawn in `max_tries` (a config
        that cannot be satisfied).
    """
    robot = robot or RobotConfig()
    for _ in range(max_tries):
        room = _draw_room(rng, config)
        if room is not None and route_clearance(room.route, room.map.solid_segments()) > robot.circumradius_m:
            return room
    raise RuntimeError(f"no solvable escape room in {max_tries} draws with {config}")


def _draw_room(rng: np.random.Generator, cfg: EscapeRoomConfig) -> EscapeRoom | None:
    width = rng.uniform(*cfg.room_side_m)
    height = rng.uniform(*cfg.room_side_m)
    jitter = rng.uniform(-cfg.corner_jitter_m, cfg.corner_jitter_m, size=(4, 2))
    # Room-local frame: the exit wall is the top one (from top-left to top-right), exit going +y.
    bl, br, tr, tl = np.array([[0, 0], [width, 0], [width, height], [0, height]], dtype=float) + jitter
    corridor_w = rng.uniform(*cfg.corridor_width_m)
    top = tr - tl
    top_len = float(np.linalg.norm(top))
    top_dir = top / top_len
    up = np.array([-top_dir[1], top_dir[0]])  # outward normal of the top wall

    u = rng.random()
    if u < cfg.corner_exit_probability / 2:
        offset = 0.0  # flush with the top-left corner
    elif u < cfg.corner_exit_probability:
        offset = top_len - corridor_w  # flush with the top-right corner
    else:
        offset = rng.uniform(0.0, top_len - corridor_w)
    flush_left = offset == 0.0
    flush_right = offset == top_len - corridor_w
    mouth_l = tl + offset * top_dir
    mouth_r = mouth_l + corridor_w * top_dir

    finish_depth = rng.uniform(*cfg.finish_depth_m)
    extra_l, extra_r = rng.uniform(*cfg.corridor_extra_m, size=2)
    tilt_l, tilt_r = rng.uniform(-cfg.corridor_tilt_rad, cfg.corridor_tilt_rad, size=2)
    dir_l = _rot(tilt_l) @ up
    dir_r = _rot(tilt_r) @ up
    # Flush with a corner: the room's side wall continues as the corridor wall.
    if flush_left:
        dir_l = (tl - bl) / np.linalg.norm(tl - bl)
    if flush_right:
        dir_r = (tr - br) / np.linalg.norm(tr - br)
    len_l = (finish_depth + extra_l) / float(dir_l @ up)
    len_r = (finish_depth + extra_r) / float(dir_r @ up)
    end_l = mouth_l + len_l * dir_l
    end_r = mouth_r + len_r * dir_r
    # The walls are straight, so the corridor is narrowest at the mouth or where a wall ends.
    depth = min(len_l * float(dir_l @ up), len_r * float(dir_r @ up))
    far_gap = (mouth_r + depth / float(dir_r @ up) * dir_r) - (mouth_l + depth / float(dir_l @ up) * dir_l)
    width_min = min(corridor_w, float(far_gap @ top_dir))
    if width_min < cfg.corridor_width_m[0]:
        return None

    # Finish line: across the corridor at finish_depth from the mouth, perpendicular to `up`.
    mouth_mid = 0.5 * (mouth_l + mouth_r)

    def at_depth(start: FloatArray, direction: FloatArray, d: float) -> FloatArray:
        return start + d / float(direction @ up) * direction

    finish = np.array([at_depth(mouth_l, dir_l, finish_depth), at_depth(mouth_r, dir_r, finish_depth)])
    finish_mid = finish.mean(axis=0)

    # The walls: one open chain from the left corridor wall's far end round the room to the right
    # corridor wall's far end; the room's three exit-less walls are bent once each.
    chain = [end_l, mouth_l] + ([] if flush_left else [tl])
    chain += _bent_wall(tl, bl, rng, cfg.wall_bend_m) + _bent_wall(bl, br, rng, cfg.wall_bend_m)
    chain += _bent_wall(br, tr, rng, cfg.wall_bend_m)
    chain += ([] if flush_right else [mouth_r]) + [end_r]

    # Place the room in the world: rotated by a multiple of 90 degrees about the room's centre.
    turn = float(rng.integers(4)) * (math.pi / 2.0)
    room_centre = 0.25 * (bl + br + tr + tl)
    rot = _rot(turn)

    def place(p: FloatArray) -> FloatArray:
        return (np.asarray(p) - room_centre) @ rot.T

    points = [place(p) for p in chain]
    walls = [(i, i + 1) for i in range(len(points) - 1)]
    # The route runs along the corridor's midline (straight, as the corridor walls are).
    along = (finish_mid - mouth_mid) / np.linalg.norm(finish_mid - mouth_mid)
    route = np.array([room_centre, mouth_mid - 0.6 * up, mouth_mid, finish_mid, finish_mid + 0.3 * along])
    route = np.array([place(p) for p in route])

    obstacles = _place_obstacles(rng, cfg, place(bl), place(br), place(tr), place(tl), route)
    if obstacles is None:
        return None
    world = Map(
        points=np.array(points),
        walls=np.array(walls, dtype=np.int64),
        name="generated",
        finish=place(finish),
        obstacles=tuple(obstacles),
    )
    return EscapeRoom(
        map=world,
        room=np.array([place(bl), place(br), place(tr), place(tl)]),
        mouth=np.array([place(mouth_l), place(mouth_r)]),
        corridor_walls=np.array(
            [np.concatenate([place(mouth_l), place(end_l)]), np.concatenate([place(mouth_r), place(end_r)])]
        ),
        route=route,
        corridor_width_min_m=width_min,
    )


def _place_obstacles(
    rng: np.random.Generator,
    cfg: EscapeRoomConfig,
    bl: FloatArray,
    br: FloatArray,
    tr: FloatArray,
    tl: FloatArray,
    route: FloatArray,
) -> list[FloatArray] | None:
    """Small boxes in the room, kept off the route so the room stays solvable."""
    obstacles: list[FloatArray] = []
    room = np.array([bl, br, tr, tl])
    lo, hi = room.min(axis=0) + 0.4, room.max(axis=0) - 0.4
    count = cfg.n_obstacles
    if not isinstance(count, int):  # a range: drawn per room (a fixed count draws nothing)
        count = int(rng.integers(count[0], count[1] + 1))
    for _ in range(count):
        for _attempt in range(50):
            sx, sy = rng.uniform(*cfg.obstacle_side_m, size=2)
            cx, cy = rng.uniform(lo, hi)
            angle = rng.uniform(0, math.pi)
            box = np.array([[-sx, -sy], [sx, -sy], [sx, sy], [-sx, sy]]) * 0.5
            box = geometry.transform_points(Pose(cx, cy, angle), box)
            if route_clearance(route, geometry.polygon_to_segments(box)) > 0.6:
                obstacles.append(box)
                break
        else:
            return None
    return obstacles


def sample_start_pose(
    room: EscapeRoom,
    rng: np.random.Generator,
    robot: RobotConfig | None = None,
    clearance_m: float = 0.05,
    max_tries: int = 1000,
) -> Pose:
    """A start pose uniform over the free room (position and heading), with clearance.

    The pose is kept only if the robot can reach the solvability route from it by a straight
    translation at its start heading, so every start is solvable.
    """
    robot = robot or RobotConfig()
    segments = room.map.solid_segments()
    lo, hi = room.room.min(axis=0), room.room.max(axis=0)
    for _ in range(max_tries):
        x, y = rng.uniform(lo, hi)
        theta = float(rng.uniform(-math.pi, math.pi))
        if not geometry.point_in_polygon(x, y, room.room):
            continue
        pose = Pose(float(x), float(y), theta)
        footprint = geometry.transform_points(pose, robot.outline)
        if not all(geometry.point_in_polygon(px, py, room.room) for px, py in footprint):
            continue
        if geometry.polygon_clearance(footprint, segments) < clearance_m:
            continue
        if translation_is_free(pose, room.route[0], robot, segments):
            return pose
    raise RuntimeError("no start pose found: the room is too cluttered")
