"""The classic agent's local world model, in its own estimate of the odometry frame.

It holds what the robot has seen: a grid of laser hits (with the time each cell was last hit),
and exit tracks. Exits seen in new scans are associated with the tracks and correct them, so the
model follows the world as the robot moves. Odometry drift is corrected by aligning each scan to
the hits already in the grid (point-to-point ICP against nearby occupied cells): the agent's pose
estimate is the odometry pose composed with that correction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pico_gym.agents.classic.features import Exit
from pico_gym.jit import njit
from pico_gym.types import FloatArray, Pose
from pico_gym.world.geometry import compose, transform_points

# Grid cell size and half extent [m]: rooms are at most 7 m, corridors ~5 m, odometry starts
# anywhere in the room.
CELL_M = 0.05
HALF_EXTENT_M = 16.0
# A fresh exit observation within this of a track's centre belongs to it [m].
ASSOCIATION_M = 0.6
# Weight of a new observation when a track is updated.
TRACK_GAIN = 0.5


@dataclass(eq=False)
class ExitTrack:
    """A corridor mouth in the model frame, refined by every scan that sees it."""

    a: FloatArray
    b: FloatArray
    outward: FloatArray
    hits: int = 1
    misses: int = 0

    @property
    def centre(self) -> FloatArray:
        return 0.5 * (self.a + self.b)

    @property
    def width(self) -> float:
        return float(np.linalg.norm(self.b - self.a))


@njit
def _icp_pairs(
    points: FloatArray, grid: np.ndarray, x0: float, y0: float, cell: float, since: int
) -> tuple[FloatArray, FloatArray]:
    """For each point, the nearest recently hit cell centre in its 5x5 neighbourhood."""
    rows, cols = grid.shape
    src = np.empty_like(points)
    dst = np.empty_like(points)
    n = 0
    for i in range(points.shape[0]):
        c = int((points[i, 0] - x0) / cell)
        r = int((points[i, 1] - y0) / cell)
        best = 1e9
        bx = 0.0
        by = 0.0
        for dr in range(-2, 3):
            for dc in range(-2, 3):
                rr, cc = r + dr, c + dc
                if 0 <= rr < rows and 0 <= cc < cols and grid[rr, cc] >= 0 and grid[rr, cc] < since:
                    cx = x0 + (cc + 0.5) * cell
                    cy = y0 + (rr + 0.5) * cell
                    d = (cx - points[i, 0]) ** 2 + (cy - points[i, 1]) ** 2
                    if d < best:
                        best, bx, by = d, cx, cy
        if best < 1e8:
            src[n, 0], src[n, 1] = points[i, 0], points[i, 1]
            dst[n, 0], dst[n, 1] = bx, by
            n += 1
    return src[:n], dst[:n]


def _two_directions(directions: FloatArray) -> bool:
    """True when unit directions (K, 2) include two at least 45 deg apart (lines of >= 0.5 m)."""
    if len(directions) < 2:
        return False
    cos = np.abs(directions @ directions.T)
    return bool((cos < math.cos(math.radians(45.0))).any())


def rigid_fit(src: FloatArray, dst: FloatArray) -> Pose:
    """The rigid transform (least squares) that moves src onto dst (Kabsch in 2D)."""
    cs, cd = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - cs, dst - cd
    angle = math.atan2(float((a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]).sum()), float((a * b).sum()))
    c, s = math.cos(angle), math.sin(angle)
    t = cd - np.array([[c, -s], [s, c]]) @ cs
    return Pose(float(t[0]), float(t[1]), angle)


@dataclass
class WorldModel:
    """Hits grid, exit tracks and the odometry correction."""

    origin: FloatArray = field(default_factory=lambda: np.array([-HALF_EXTENT_M, -HALF_EXTENT_M]))
    last_hit: np.ndarray = field(
        default_factory=lambda: np.full((int(2 * HALF_EXTENT_M / CELL_M),) * 2, -1, dtype=np.int32)
    )
    tracks: list[ExitTrack] = field(default_factory=list)
    correction: Pose = Pose(0.0, 0.0, 0.0)
    step: int = 0

    def pose(self, odom: Pose) -> Pose:
        """The agent's pose estimate: odometry corrected by scan alignment."""
        return compose(self.correction, odom)

    def align(self, odom: Pose, points_robot: FloatArray, line_directions: FloatArray, min_age: int = 20) -> None:
        """Correct the odometry by matching a scan to older hits (a few ICP iterations).

        Only scans that pin the pose down in both directions are used: their lines must run in
        two directions at least 45 deg apart (in a corridor, a scan says nothing about the
        position along it, and ICP would slide). Only hits at least `min_age` steps old count,
        so the model is not aligned to itself, and half of each correction is applied.
        """
        if self.step < min_age or len(points_robot) < 30 or not _two_directions(line_directions):
            return
        pts = points_robot[:: max(1, len(points_robot) // 150)]
        since = self.step - min_age
        for _ in range(3):
            world = transform_points(self.pose(odom), pts)
            src, dst = _icp_pairs(world, self.last_hit, self.origin[0], self.origin[1], CELL_M, since)
            if len(src) < 0.5 * len(pts):
                return
            delta = rigid_fit(src, dst)
            if abs(delta.theta) > 0.05 or math.hypot(delta.x, delta.y) > 0.1:
                return  # a jump this large is a bad match, not drift
            delta = Pose(0.5 * delta.x, 0.5 * delta.y, 0.5 * delta.theta)
            self.correction = compose(delta, self.correction)
            if abs(delta.theta) < 1e-4 and math.hypot(delta.x, delta.y) < 1e-3:
                break

    def add_hits(self, pose: Pose, points_robot: FloatArray) -> None:
        """Record the scan's hits (in the model frame)."""
        world = transform_points(pose, points_robot)
        idx = np.floor((world - self.origin) / CELL_M).astype(np.int64)
        n = self.last_hit.shape[0]
        ok = (idx >= 0).all(axis=1) & (idx < n).all(axis=1)
        self.last_hit[idx[ok, 1], idx[ok, 0]] = self.step

    def hits_near(self, pose: Pose, radius: float, max_age: int) -> FloatArray:
        """Recent hit cells within `radius` of the pose, in the robot frame."""
        c = ((np.array([pose.x, pose.y]) - self.origin) / CELL_M).astype(int)
        k = int(radius / CELL_M) + 1
        r0, c0 = max(c[1] - k, 0), max(c[0] - k, 0)
        window = self.last_hit[r0 : c[1] + k + 1, c0 : c[0] + k + 1]
        rows, cols = np.nonzero((window >= 0) & (window >= self.step - max_age))
        if len(rows) == 0:
            return np.zeros((0, 2))
        world = self.origin + (np.column_stack([cols + c0, rows + r0]) + 0.5) * CELL_M
        d = world - np.array([pose.x, pose.y])
        ct, st = math.cos(pose.theta), math.sin(pose.theta)
        return np.column_stack([ct * d[:, 0] + st * d[:, 1], -st * d[:, 0] + ct * d[:, 1]])

    def blocked(self, inflate_m: float, max_age: int) -> np.ndarray:
        """Boolean grid of cells within `inflate_m` of a recent hit (for planning)."""
        hit = (self.last_hit >= 0) & (self.last_hit >= self.step - max_age)
        k = int(math.ceil(inflate_m / CELL_M))
        out = hit.copy()
        rr, cc = np.nonzero(hit)
        offsets = [(dr, dc) for dr in range(-k, k + 1) for dc in range(-k, k + 1) if dr * dr + dc * dc <= k * k]
        n = hit.shape[0]
        for dr, dc in offsets:
            r, c = rr + dr, cc + dc
            ok = (r >= 0) & (r < n) & (c >= 0) & (c < n)
            out[r[ok], c[ok]] = True
        return out

    def cell(self, point: FloatArray) -> tuple[int, int]:
        """(row, col) of a model-frame point."""
        c = np.floor((np.asarray(point) - self.origin) / CELL_M).astype(int)
        return int(c[1]), int(c[0])

    def centre_of(self, cell: tuple[int, int]) -> FloatArray:
        """Model-frame centre of a cell."""
        return self.origin + (np.array([cell[1], cell[0]]) + 0.5) * CELL_M

    def update_exits(self, pose: Pose, exits: list[Exit], fov_rad: float = 1.9, view_m: float = 4.0) -> None:
        """Associate a scan's exits (robot frame) with the tracks and correct them.

        A track whose mouth lies well in view (both ends within `fov_rad` of the heading, between
        1 m and `view_m` away, where detection is reliable) but is not detected gets a miss; a
        track with more than twice as many misses as hits is dropped, so a false exit seen a few
        times does not live on.
        """
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        rot = np.array([[c, -s], [s, c]])
        matched: set[int] = set()
        for ex in exits:
            a = transform_points(pose, ex.a[None])[0]
            b = transform_points(pose, ex.b[None])[0]
            outward = rot @ ex.outward
            centre = 0.5 * (a + b)
            match = None
            for track in self.tracks:
                if np.linalg.norm(track.centre - centre) < ASSOCIATION_M and float(track.outward @ outward) > 0.7:
                    match = track
                    break
            if match is None:
                self.tracks.append(ExitTrack(a, b, outward, hits=1))
                matched.add(id(self.tracks[-1]))
                continue
            matched.add(id(match))
            # Keep the end points' order consistent before averaging.
            if np.linalg.norm(match.a - a) > np.linalg.norm(match.a - b):
                a, b = b, a
            g = TRACK_GAIN
            match.a = (1 - g) * match.a + g * a
            match.b = (1 - g) * match.b + g * b
            o = (1 - g) * match.outward + g * outward
            match.outward = o / np.linalg.norm(o)
            match.hits += 1
        here = np.array([pose.x, pose.y])
        for track in self.tracks:
            if id(track) in matched:
                continue
            in_view = True
            for p in (track.a, track.b):
                d = p - here
                bearing = (math.atan2(d[1], d[0]) - pose.theta + math.pi) % (2 * math.pi) - math.pi
                in_view &= abs(bearing) < fov_rad and 1.0 < float(np.hypot(*d)) < view_m
            if in_view:
                track.misses += 1
        self.tracks = [t for t in self.tracks if t.misses <= 2 * t.hits]

    def best_exit(self, min_hits: int = 2) -> ExitTrack | None:
        """The most often seen exit with at least `min_hits` sightings."""
        good = [t for t in self.tracks if t.hits >= min_hits]
        return max(good, key=lambda t: t.hits) if good else None
