"""The classic hospital agent's world model: what the given map does not show.

Closed doors, boxes and people are not on the given map. End points the map does not explain
(farther than `unexplained_m` from every wall) accumulate in an evidence grid, and beams passing
through a cell clear it (`update`); a cell with enough evidence is an obstacle (`seen`). People are
tracked (`tracking.PeopleTracker`): the hits on one seen walking go to a layer of their own, and the
cells a walking track left are cleared (`track_people`), so a person leaves no wall behind. The
planning grid is the map's inflation plus the evidence (`blocked`), and the safety filter's blind
sector holds the map's walls and the evidence behind the robot (`remembered`).
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.agents.classic.hospital.config import HospitalAgentConfig
from pico_gym.agents.classic.hospital.given import GivenMap
from pico_gym.agents.classic.localisation import scan_points
from pico_gym.agents.classic.potential_field import MotionConfig, footprint_distance
from pico_gym.agents.classic.tracking import PeopleTracker, Track
from pico_gym.agents.shield import ScanMemory
from pico_gym.jit import njit
from pico_gym.types import FloatArray, Pose


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


def to_map(pose: Pose, points: FloatArray) -> FloatArray:
    """Robot-frame points (N, 2) in the map frame, at `pose`."""
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    return np.column_stack([pose.x + c * points[:, 0] - s * points[:, 1], pose.y + s * points[:, 0] + c * points[:, 1]])


def to_robot(pose: Pose, p: FloatArray) -> FloatArray:
    """Map-frame points (N, 2), or one point (2,), in the robot frame at `pose`."""
    d = np.asarray(p) - np.array([pose.x, pose.y])
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)


class EvidenceMap:
    """Evidence of what the map does not show, and the people tracked (map frame).

    Attributes:
        evidence: what stands still, per cell of the given map's grid.
        people_evidence: hits on people seen walking.
        tracker: the people tracker.
    """

    def __init__(self, given: GivenMap, config: HospitalAgentConfig) -> None:
        self.given, self.config = given, config
        self.evidence = np.zeros(given.grid.shape)
        self.people_evidence = np.zeros(given.grid.shape)
        self._seen_grid: np.ndarray | None = None  # both, thresholded (made when first asked)
        self.tracker = PeopleTracker(config.tracker, given.doors)
        self._cleared: set[tuple[int, float]] = set()  # (track, time) of trail positions cleared

    def moving(self) -> list[Track]:
        """The people tracked walking (none when tracking is off)."""
        return self.tracker.moving() if self.config.track_people else []

    def walking(self) -> list[Track]:
        """The tracker's walking tracks, seen this scan or not, and those dropped but remembered
        (none when tracking is off)."""
        return self.tracker.walking() if self.config.track_people else []

    def unexplained(self, x: FloatArray, y: FloatArray) -> np.ndarray:
        """Which map-frame points the map does not explain (farther than `unexplained_m` from its walls)."""
        return self.given.localiser.distance_at(x, y) > self.config.unexplained_m

    def update(self, pose: Pose, points: FloatArray) -> None:
        """A scan's robot-frame end points from `pose`: beams clear, unexplained end points add
        (to the people layer where a walking track stands)."""
        cfg, g = self.config, self.given.grid
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        ex = pose.x + c * points[:, 0] - s * points[:, 1]
        ey = pose.y + s * points[:, 0] + c * points[:, 1]
        unexplained = self.unexplained(ex, ey)
        person = np.zeros(len(points), dtype=bool)
        for t in self.moving():
            person |= np.hypot(ex - t.position[0], ey - t.position[1]) <= t.radius_m + 0.15
        ex, ey = np.ascontiguousarray(ex), np.ascontiguousarray(ey)
        for grid, hits in ((self.evidence, unexplained & ~person), (self.people_evidence, unexplained & person)):
            _update_evidence(
                grid, g.x0, g.y0, g.resolution, pose.x, pose.y, ex, ey, hits,
                cfg.evidence_hit, cfg.evidence_miss, cfg.evidence_max,
            )  # fmt: skip
        self._seen_grid = None

    def fade(self) -> None:
        """Halve the evidence (never wipe it: what is really there is seen again)."""
        self.evidence *= 0.5
        self.people_evidence *= 0.5
        self._seen_grid = None

    def seen(self) -> np.ndarray:
        """The cells held to be obstacles the map does not show: still ones and people (bool)."""
        if self._seen_grid is None:
            block = self.config.evidence_block
            self._seen_grid = (self.evidence >= block) | (self.people_evidence >= block)
        return self._seen_grid

    def track_people(self, pose: Pose, ranges: FloatArray, angles: FloatArray, range_max: float, now: float) -> None:
        """Cluster the scan's unexplained points into tracks; clear the cells moving ones left."""
        cfg = self.config
        pts = to_map(pose, scan_points(ranges, angles, range_max, cfg.track_beams))
        unexplained = self.unexplained(np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1]))
        self.tracker.update(pts, unexplained, now)
        for t in self.tracker.moving() if cfg.clear_trails else ():
            for when, p in t.history:
                key = (t.id, when)
                if key in self._cleared or now - when < 0.5 or np.hypot(*(p - t.position)) <= t.radius_m + 0.15:
                    continue
                self._cleared.add(key)
                k = int(math.ceil((t.radius_m + 0.1) / cfg.cell_m))
                r, c = self.given.cell(p)
                window = (slice(max(r - k, 0), r + k + 1), slice(max(c - k, 0), c + k + 1))
                self.people_evidence[window] = 0.0
                if when < t.moving_since_s:  # seen before it was known to walk: in the still layer
                    k = int(math.ceil(t.radius_m / cfg.cell_m))
                    self.evidence[max(r - k, 0) : r + k + 1, max(c - k, 0) : c + k + 1] = 0.0
                self._seen_grid = None
        if len(self._cleared) > 5000:
            self._cleared = {(i, w) for i, w in self._cleared if now - w < 10.0}

    def without_people(self, points: FloatArray, pose: Pose, now: float) -> FloatArray:
        """Robot-frame points less those on a moving track (a person beside a wall would pull the
        registration onto that wall)."""
        moving = self.moving()
        if not moving:
            return points
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        ex = pose.x + c * points[:, 0] - s * points[:, 1]
        ey = pose.y + s * points[:, 0] + c * points[:, 1]
        keep = np.ones(len(points), dtype=bool)
        for t in moving:
            centre = t.predict(now - t.seen_s)
            keep &= np.hypot(ex - centre[0], ey - centre[1]) > t.radius_m + 0.15
        return points[keep]

    def wary(self, pose: Pose, near: FloatArray, motion: MotionConfig, squeeze: bool) -> FloatArray:
        """`near` with the points the map does not explain pulled `unexplained_margin_m` towards
        the robot, so the safety filter keeps that much more room from boxes and people (not on
        a squeezed path: that gap has no room for it)."""
        margin = 0.0 if squeeze else self.config.unexplained_margin_m
        if margin <= 0.0 or len(near) == 0:
            return near
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        ex = pose.x + c * near[:, 0] - s * near[:, 1]
        ey = pose.y + s * near[:, 0] + c * near[:, 1]
        odd = self.unexplained(ex, ey)
        if not odd.any():
            return near
        d, away = footprint_distance(near[odd], motion)
        closer = np.maximum(d - margin, np.minimum(d, 0.001))  # never into the footprint (ignored there)
        out = near.copy()
        out[odd] -= away * (d - closer)[:, None]
        return out

    def remembered(self, pose: Pose, memory: ScanMemory, odom: Pose) -> FloatArray:
        """Robot-frame points within 1.2 m (a square): the map's walls and the evidence cells, in
        the order of `wall_points` and of the grid's cells; then `memory`'s recent scans."""
        given = self.given
        g, x, y = given.grid, pose.x, pose.y
        # Only the walls and cells round the robot are looked at (a margin past the square).
        lo, hi = np.searchsorted(given.wall_x, (x - 1.25, x + 1.25))
        walls = given.wall_points[np.sort(given.wall_by_x[lo:hi])]
        k = int(1.25 / g.resolution) + 2
        r0, c0 = max(int((y - g.y0) / g.resolution) - k, 0), max(int((x - g.x0) / g.resolution) - k, 0)
        rows, cols = np.nonzero(self.seen()[r0 : r0 + 2 * k + 1, c0 : c0 + 2 * k + 1])
        rows, cols = rows + r0, cols + c0
        seen = np.column_stack([g.x0 + (cols + 0.5) * g.resolution, g.y0 + (rows + 0.5) * g.resolution])
        pts = np.vstack([walls, seen])
        mapped = to_robot(pose, pts[(np.abs(pts[:, 0] - x) < 1.2) & (np.abs(pts[:, 1] - y) < 1.2)])
        if not memory.steps:
            return mapped
        return np.vstack([mapped, memory.recent(odom)])  # the last scans' (`blind_memory_s`)

    def blocked(self, nogo: list[tuple[float, float, int]] = (), squeeze: bool = False) -> np.ndarray:  # type: ignore[assignment]
        """The planning grid: the map inflated, plus the evidence of what it does not show (and
        the `nogo` discs, (x, y, until) where the robot recently made no progress). With
        `squeeze` the evidence is inflated by only `squeeze_m`: the robot's half depth, for a
        gap between a box and a wall that it can pass sideways only without the extra margin."""
        cfg, given = self.config, self.given
        seen = self.seen()
        inflate = cfg.squeeze_m if squeeze else cfg.inflate_m + 0.05
        out = (
            given.blocked.copy()
            if not seen.any()
            else given.blocked | _dilate(seen, int(math.ceil(inflate / cfg.cell_m - 1e-9)))
        )
        g = given.grid
        k = int(math.ceil(cfg.nogo_m / cfg.cell_m))
        for x, y, _until in nogo:
            r, c = given.cell(np.array([x, y]))
            rr, cc = np.ogrid[-k : k + 1, -k : k + 1]
            disc = rr * rr + cc * cc <= k * k
            r0, c0 = max(r - k, 0), max(c - k, 0)
            r1, c1 = min(r + k + 1, g.shape[0]), min(c + k + 1, g.shape[1])
            out[r0:r1, c0:c1] |= disc[r0 - (r - k) : r1 - (r - k), c0 - (c - k) : c1 - (c - k)]
        return out
