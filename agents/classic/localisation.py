"""Localisation on a given map: where the robot is, from LRF scans, odometry and the map alone.

The map becomes a likelihood field: for every cell of a grid, the distance to the nearest wall
(Thrun, Burgard and Fox, "Probabilistic Robotics", 6.4). A beam's end point scores by how close it
lands to a wall; one that lands far from every wall is unexplained (a box, a person, a closed
door) and scores a constant floor, so clutter lowers a pose's score without breaking it. All wall
points count, not corners: boxes in corners and closed doors flush with a wall do not remove what
the pose is judged on (the course teams' localisers were corner-based and failed on exactly that,
docs/facts/hospital-facts.md section 2).

- `global_search`: every pose of a region (x, y on a grid, any heading) scored against one or
  more scans taken at known odometry offsets; the best pose and how ambiguous it is (the best pose
  of a different mode scoring nearly as well).
- `refine`: scan-to-map registration from a predicted pose: Gauss-Newton on the likelihood
  field's distances of the explained end points (an ICP against the map without correspondences).
- `explained`: the fraction of beams the map explains at a pose (the health check).

Hand-written in numpy and numba: this is the course's subject.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pico_gym.jit import njit
from pico_gym.types import FloatArray, Pose, Segments
from pico_gym.world.geometry import point_segment_distance
from pico_gym.world.grid import Grid


@dataclass(frozen=True, eq=False)
class LikelihoodField:
    """Distance from each cell centre to the nearest wall [m], capped at `cap`, and which wall
    segment that is (-1: none within `cap`)."""

    grid: Grid
    distance: FloatArray
    cap: float
    segments: Segments
    nearest: np.ndarray

    @classmethod
    def of(cls, segments: Segments, resolution: float = 0.05, cap: float = 0.5) -> LikelihoodField:
        segments = np.ascontiguousarray(segments, dtype=np.float64).reshape(-1, 4)
        xs, ys = segments[:, [0, 2]], segments[:, [1, 3]]
        bounds = (float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max()))
        grid = Grid.covering(bounds, resolution, margin=cap + resolution)
        rows, cols = grid.shape
        distance, nearest = _nearest_segments(grid.x0, grid.y0, resolution, rows, cols, segments, cap)
        return cls(grid, distance, cap, segments, nearest)


@njit
def _nearest_segments(
    x0: float, y0: float, res: float, rows: int, cols: int, segments: Segments, cap: float
) -> tuple[FloatArray, np.ndarray]:
    """`clearance_grid`'s distances (capped) and, per cell, the index of the nearest segment."""
    best = np.full((rows, cols), cap)
    out = np.full((rows, cols), -1, dtype=np.int64)
    for k in range(segments.shape[0]):
        x1, y1, x2, y2 = segments[k, 0], segments[k, 1], segments[k, 2], segments[k, 3]
        c_lo = max(0, int((min(x1, x2) - cap - x0) / res) - 1)
        c_hi = min(cols - 1, int((max(x1, x2) + cap - x0) / res) + 1)
        r_lo = max(0, int((min(y1, y2) - cap - y0) / res) - 1)
        r_hi = min(rows - 1, int((max(y1, y2) + cap - y0) / res) + 1)
        for r in range(r_lo, r_hi + 1):
            py = y0 + (r + 0.5) * res
            for c in range(c_lo, c_hi + 1):
                d = point_segment_distance(x0 + (c + 0.5) * res, py, x1, y1, x2, y2)
                if d < best[r, c]:
                    best[r, c] = d
                    out[r, c] = k
    return best, out


@njit
def _sample(dist: FloatArray, x0: float, y0: float, res: float, cap: float, x: float, y: float) -> float:
    """Bilinear distance at (x, y); `cap` outside the grid."""
    fx = (x - x0) / res - 0.5
    fy = (y - y0) / res - 0.5
    c = int(math.floor(fx))
    r = int(math.floor(fy))
    rows, cols = dist.shape
    if r < 0 or c < 0 or r + 1 >= rows or c + 1 >= cols:
        return cap
    tx, ty = fx - c, fy - r
    return (
        (1 - tx) * (1 - ty) * dist[r, c]
        + tx * (1 - ty) * dist[r, c + 1]
        + (1 - tx) * ty * dist[r + 1, c]
        + tx * ty * dist[r + 1, c + 1]
    )


@njit
def _pose_scores(
    poses: FloatArray,
    px: FloatArray,
    py: FloatArray,
    dist: FloatArray,
    x0: float,
    y0: float,
    res: float,
    cap: float,
    sigma: float,
    floor: float,
) -> FloatArray:
    """Mean per-point log-likelihood of robot-frame points (px, py) at each pose (x, y, theta)."""
    out = np.empty(poses.shape[0])
    inv = 0.5 / (sigma * sigma)
    log_floor = math.log(floor)
    n = px.shape[0]
    for k in range(poses.shape[0]):
        c, s = math.cos(poses[k, 2]), math.sin(poses[k, 2])
        total = 0.0
        for i in range(n):
            x = poses[k, 0] + c * px[i] - s * py[i]
            y = poses[k, 1] + s * px[i] + c * py[i]
            d = _sample(dist, x0, y0, res, cap, x, y)
            total += max(-d * d * inv, log_floor)
        out[k] = total / max(n, 1)
    return out


@dataclass(frozen=True)
class SearchResult:
    """The best pose of a global search, its score, and the best score of any pose farther than
    the ambiguity radius from it (in position or heading): close to `score` means ambiguous."""

    pose: Pose
    score: float
    rival_score: float
    rival: Pose
    n_points: int

    @property
    def margin(self) -> float:
        """How much better the best pose explains the points than the best rival: the difference
        of their summed log-likelihoods [nats]."""
        return (self.score - self.rival_score) * self.n_points


@dataclass(frozen=True)
class LocaliserConfig:
    """Parameters of the localiser (SI units).

    Attributes:
        sigma: spread of a beam's end point about the wall it hits [m] (sensor noise + map error).
        floor: the likelihood of an unexplained end point, relative to a hit on a wall.
        explained_within: an end point this close to a wall is explained [m].
        beams: how many beams (evenly spaced) a scan contributes.
        step_xy, step_theta: the global search's grid [m], [rad].
        distinct_xy, distinct_theta: poses farther apart than this are different modes.
        unique_margin: the best mode must beat every other by this (summed log-likelihood, nats;
            beams are not independent, so this is far above what statistics alone would ask).
    """

    sigma: float = 0.05
    floor: float = 0.05
    explained_within: float = 0.1
    beams: int = 90
    step_xy: float = 0.05
    step_theta: float = math.radians(2.0)
    distinct_xy: float = 0.3
    distinct_theta: float = math.radians(20.0)
    unique_margin: float = 10.0


# (number of ranges, beams) -> (the angles, which beams, their cos and sin): agents call
# `scan_points` a few times a step with the same angles.
_GEOMETRY: dict[tuple[int, int], tuple[FloatArray, np.ndarray, FloatArray, FloatArray]] = {}


def _beam_geometry(angles: FloatArray, n: int, beams: int) -> tuple[np.ndarray, FloatArray, FloatArray]:
    """Which of `n` beams `scan_points` takes, and their directions' cos and sin (kept for the
    next call with equal angles: compared by content, never by identity)."""
    hit = _GEOMETRY.get((n, beams))
    if hit is not None and hit[0].dtype == np.asarray(angles).dtype and np.array_equal(hit[0], angles):
        return hit[1], hit[2], hit[3]
    take = np.linspace(0, n - 1, min(beams, n)).astype(np.int64)
    a = np.asarray(angles)[take]
    if len(_GEOMETRY) >= 16:
        _GEOMETRY.clear()
    entry = _GEOMETRY[(n, beams)] = (np.array(angles), take, np.cos(a), np.sin(a))
    return entry[1], entry[2], entry[3]


def scan_points(
    ranges: FloatArray, angles: FloatArray, range_max: float, beams: int, offset: Pose | None = None
) -> FloatArray:
    """(n, 2) end points of the valid beams of a scan in the robot frame (or, with `offset`, in
    the frame the offset pose is given in), `beams` of them evenly spaced."""
    ranges = np.asarray(ranges, dtype=np.float64)
    take, cos, sin = _beam_geometry(angles, len(ranges), beams)
    r = ranges[take]
    ok = (r > 0.05) & (r < range_max - 1e-6)
    pts = np.column_stack([r[ok] * cos[ok], r[ok] * sin[ok]])
    if offset is not None:
        c, s = math.cos(offset.theta), math.sin(offset.theta)
        pts = np.column_stack([offset.x + c * pts[:, 0] - s * pts[:, 1], offset.y + s * pts[:, 0] + c * pts[:, 1]])
    return pts


class Localiser:
    """Global search and tracking against one map's likelihood field (see the module docstring)."""

    def __init__(self, segments: Segments, config: LocaliserConfig | None = None) -> None:
        self.config = config or LocaliserConfig()
        self.field = LikelihoodField.of(segments)

    def scores(self, poses: FloatArray, points: FloatArray) -> FloatArray:
        f, cfg = self.field, self.config
        g = f.grid
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
        return _pose_scores(
            np.ascontiguousarray(poses, dtype=np.float64),
            np.ascontiguousarray(pts[:, 0]),
            np.ascontiguousarray(pts[:, 1]),
            f.distance,
            g.x0,
            g.y0,
            g.resolution,
            f.cap,
            cfg.sigma,
            cfg.floor,
        )

    def global_search(self, region: FloatArray, points: FloatArray) -> SearchResult:
        """Score every pose of a polygon region (any heading) for robot-frame points.

        `points` may join several scans, each moved into the frame of the pose being searched by
        its odometry offset (`scan_points(..., offset=...)`)."""
        cfg = self.config
        region = np.asarray(region, dtype=np.float64)
        (x0, y0), (x1, y1) = region.min(axis=0), region.max(axis=0)
        xs = np.arange(x0, x1 + 1e-9, cfg.step_xy)
        ys = np.arange(y0, y1 + 1e-9, cfg.step_xy)
        gx, gy = np.meshgrid(xs, ys)
        keep = np.array([_inside(float(x), float(y), region) for x, y in zip(gx.ravel(), gy.ravel(), strict=True)])
        cx, cy = gx.ravel()[keep], gy.ravel()[keep]
        thetas = np.arange(-math.pi, math.pi, cfg.step_theta)
        poses = np.column_stack([np.repeat(cx, len(thetas)), np.repeat(cy, len(thetas)), np.tile(thetas, len(cx))])
        s = self.scores(poses, points)
        best = int(np.argmax(s))
        bx, by, bt = poses[best]
        far = (np.hypot(poses[:, 0] - bx, poses[:, 1] - by) > cfg.distinct_xy) | (
            np.abs(np.remainder(poses[:, 2] - bt + math.pi, 2 * math.pi) - math.pi) > cfg.distinct_theta
        )
        rival = int(np.argmax(np.where(far, s, -np.inf))) if far.any() else best
        pose = self.refine(Pose(float(bx), float(by), float(bt)), points)
        rival_score = float(s[rival]) if far.any() else -math.inf
        return SearchResult(pose, float(s[best]), rival_score, Pose(*poses[rival]), len(points))

    def search_everywhere(
        self, positions: FloatArray, points: FloatArray, step_theta: float = math.radians(6.0), keep: int = 12
    ) -> SearchResult:
        """A coarse-to-fine search over many positions (a whole map's free space): every position
        at headings `step_theta` apart, then the `keep` best poses that are distinct modes refined
        (`refine`) and scored again; the best of those and its best rival.

        A coarse grid alone would judge modes by how near a grid pose happens to fall to each;
        refining the candidates first compares the modes themselves."""
        cfg = self.config
        positions = np.asarray(positions, dtype=np.float64).reshape(-1, 2)
        thetas = np.arange(-math.pi, math.pi, step_theta)
        poses = np.column_stack(
            [
                np.repeat(positions[:, 0], len(thetas)),
                np.repeat(positions[:, 1], len(thetas)),
                np.tile(thetas, len(positions)),
            ]
        )
        s = self.scores(poses, points)
        candidates: list[Pose] = []
        for k in np.argsort(-s):
            x, y, t = poses[k]
            if all(
                math.hypot(x - c.x, y - c.y) > cfg.distinct_xy
                or abs(math.remainder(t - c.theta, 2 * math.pi)) > cfg.distinct_theta
                for c in candidates
            ):
                candidates.append(Pose(float(x), float(y), float(t)))
                if len(candidates) == keep:
                    break
        refined = [self.refine(c, points) for c in candidates]
        scores = self.scores(np.array([tuple(p) for p in refined]), points)
        order = np.argsort(-scores)
        best = refined[int(order[0])]
        rival_score, rival = -math.inf, best
        for k in order[1:]:
            p = refined[int(k)]
            if (
                math.hypot(p.x - best.x, p.y - best.y) > cfg.distinct_xy
                or abs(math.remainder(p.theta - best.theta, 2 * math.pi)) > cfg.distinct_theta
            ):
                rival_score, rival = float(scores[k]), p
                break
        return SearchResult(best, float(scores[order[0]]), rival_score, rival, len(points))

    def refine(self, guess: Pose, points: FloatArray, iterations: int = 6, prior: float = 0.0) -> Pose:
        """Scan-to-map registration (point-to-line ICP against the map): each end point that lands
        near a wall is paired with that wall segment (from the field's nearest-segment grid) and
        Gauss-Newton moves the pose to put the points on their lines; the rest are unexplained
        and left out.

        `prior` > 0 adds prior * |pose - guess|^2 (x, y in metres, heading in radians) to the
        squared residuals: where the points do not pin the pose down (only the two parallel walls
        of a hallway in view, the rest hidden by a person: nothing holds the pose along it), it
        stays at the guess instead of sliding on rounding noise."""
        cfg = self.config
        f = self.field
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
        x, y, th = guess
        x_0, y_0, th_0 = guess
        for _ in range(iterations):
            a, b, used = _icp_step(
                x,
                y,
                th,
                pts,
                f.nearest,
                f.segments,
                f.grid.x0,
                f.grid.y0,
                f.grid.resolution,
                2.0 * cfg.explained_within,
            )
            if used < 6:
                break
            if prior > 0.0:
                a = a + prior * np.eye(3)
                b = b + prior * np.array([x - x_0, y - y_0, th - th_0])
            step = np.clip(-np.linalg.solve(a + 1e-6 * np.eye(3), b), -0.1, 0.1)
            x, y, th = x + step[0], y + step[1], th + step[2]
            if abs(step[0]) + abs(step[1]) < 1e-5 and abs(step[2]) < 1e-5:
                break
        return Pose(float(x), float(y), float(math.remainder(th, 2 * math.pi)))

    def distance_at(self, xs: FloatArray, ys: FloatArray) -> FloatArray:
        """The field (distance to the nearest wall of the map) at map-frame points [m]."""
        return _field_at(self.field, np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64))

    def explained(self, pose: Pose, points: FloatArray) -> float:
        """The fraction of end points within `explained_within` of a wall of the map."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if len(pts) == 0:
            return 0.0
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        d = _field_at(self.field, pose.x + c * pts[:, 0] - s * pts[:, 1], pose.y + s * pts[:, 0] + c * pts[:, 1])
        return float(np.mean(d < self.config.explained_within))


@njit
def _icp_step(
    x: float,
    y: float,
    th: float,
    pts: FloatArray,
    nearest: np.ndarray,
    segments: Segments,
    x0: float,
    y0: float,
    res: float,
    within: float,
) -> tuple[FloatArray, FloatArray, int]:
    """The normal equations (A, b) of one Gauss-Newton step of point-to-line ICP, and how many
    points they hold (numba's linear algebra needs scipy: the 3 x 3 solve is numpy's)."""
    c, s = math.cos(th), math.sin(th)
    rows, cols = nearest.shape
    a = np.zeros((3, 3))
    b = np.zeros(3)
    used = 0
    for i in range(pts.shape[0]):
        wx = x + c * pts[i, 0] - s * pts[i, 1]
        wy = y + s * pts[i, 0] + c * pts[i, 1]
        col = int((wx - x0) / res)
        row = int((wy - y0) / res)
        if row < 0 or col < 0 or row >= rows or col >= cols:
            continue
        k = nearest[row, col]
        if k < 0:
            continue
        x1, y1, x2, y2 = segments[k, 0], segments[k, 1], segments[k, 2], segments[k, 3]
        ex, ey = x2 - x1, y2 - y1
        length = math.hypot(ex, ey)
        if length == 0.0:
            continue
        nx, ny = -ey / length, ex / length
        r = nx * (wx - x1) + ny * (wy - y1)
        if abs(r) > within:
            continue
        j0, j1 = nx, ny
        j2 = nx * (-(s * pts[i, 0] + c * pts[i, 1])) + ny * (c * pts[i, 0] - s * pts[i, 1])
        jac = (j0, j1, j2)
        for p in range(3):
            b[p] += jac[p] * r
            for q in range(3):
                a[p, q] += jac[p] * jac[q]
        used += 1
    return a, b, used


@njit
def _field_many(
    dist: FloatArray, x0: float, y0: float, res: float, cap: float, xs: FloatArray, ys: FloatArray
) -> FloatArray:
    out = np.empty(xs.shape[0])
    for i in range(xs.shape[0]):
        out[i] = _sample(dist, x0, y0, res, cap, xs[i], ys[i])
    return out


def _field_at(f: LikelihoodField, xs: FloatArray, ys: FloatArray) -> FloatArray:
    g = f.grid
    return _field_many(f.distance, g.x0, g.y0, g.resolution, f.cap, np.ascontiguousarray(xs), np.ascontiguousarray(ys))


def _inside(x: float, y: float, polygon: FloatArray) -> bool:
    from pico_gym.world.geometry import point_in_polygon

    return bool(point_in_polygon(x, y, polygon))
