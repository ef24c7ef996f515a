"""Finding the object, for the classic explore agent: what stands free in the scan where the map
stored at parking had nothing (the object is placed once the robot has parked), and the rooms of
the map, cut at its narrow passages, with the rooms on the way to each counted.
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.agents.classic.explore.config import ExploreAgentConfig
from pico_gym.agents.classic.explore.occupancy import OccupancyMap
from pico_gym.agents.classic.explore.regions import component_sizes, components, room_depths
from pico_gym.agents.classic.localisation import scan_points
from pico_gym.types import FloatArray, Pose


def free_standing(ranges: FloatArray, angles: FloatArray, longest_m: float, jump_m: float = 0.15) -> np.ndarray:
    """Per beam, whether it is on something standing free: a run of three or more neighbouring
    beams (each within 0.1 m of the next), at most `longest_m` from end to end, with the beams
    on both sides of the run farther by more than `jump_m` (the background behind it)."""
    r = np.asarray(ranges, dtype=np.float64)
    n = len(r)
    cut = np.abs(np.diff(r)) > 0.1
    run = np.concatenate(([0], np.cumsum(cut)))
    starts = np.concatenate(([0], np.flatnonzero(cut) + 1))
    ends = np.concatenate((np.flatnonzero(cut), [n - 1]))
    x, y = r * np.cos(angles), r * np.sin(angles)
    extent = np.hypot(x[ends] - x[starts], y[ends] - y[starts])
    left = np.where(starts > 0, r[np.maximum(starts - 1, 0)], -np.inf)
    right = np.where(ends < n - 1, r[np.minimum(ends + 1, n - 1)], -np.inf)
    ok = (
        (ends - starts >= 2)
        & (extent <= longest_m)
        & (left > r[starts] + jump_m)
        & (right > r[ends] + jump_m)
        & np.isfinite(r[starts])
    )
    return ok[run]


class ObjectFinder:
    """Evidence of the object, and the map it is judged against.

    Attributes:
        stored: the log-odds as they were before the robot touched the parking wall (or, for a
            start in "find", after the first look round); None before.
        before_touch: the log-odds copied as reversing began.
        evidence: per planning cell, decaying counts of free-standing points the stored map
            does not explain.
        object: where the object is believed to be (agent frame), or None.
        rejected: the objects believed in and not counted found (false objects).
        depths: per planning cell of the whole grid, the rooms entered on the way from the start
            (`regions.room_depths`, made at parking).
    """

    def __init__(self, config: ExploreAgentConfig, occupancy: OccupancyMap) -> None:
        self.config, self.occupancy = config, occupancy
        self.stored: np.ndarray | None = None
        self.before_touch: np.ndarray | None = None
        n = occupancy.logodds.shape[0]
        self.evidence = np.zeros((n // 2, n // 2))
        self.object: FloatArray | None = None
        self.rejected: list[FloatArray] = []
        self.depths: np.ndarray | None = None

    def look(self, ranges: FloatArray, angles: FloatArray, pose: Pose, range_max: float, given_up: list) -> None:
        """Take in a scan: only what stands free in it (a short run of beams with the background
        farther on both sides: a wall the drifted pose sees off its mapped place is a long run),
        where the stored map is confidently free all round, adds evidence."""
        cfg = self.config
        standing = free_standing(ranges, angles, cfg.object_max_m)
        pts = scan_points(np.where(standing, ranges, np.inf), angles, min(4.0, range_max), 250)
        if len(pts) == 0:
            self.evidence *= 0.98
            return
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        wx = pose.x + c * pts[:, 0] - s * pts[:, 1]
        wy = pose.y + s * pts[:, 0] + c * pts[:, 1]
        g = self.occupancy.grid
        col = np.floor((wx - g.x0) / g.resolution).astype(np.int64)
        row = np.floor((wy - g.y0) / g.resolution).astype(np.int64)
        stored = self.stored
        assert stored is not None  # (looked for only once a map is stored)
        n = stored.shape[0]
        ok = (row >= 2) & (row < n - 2) & (col >= 2) & (col < n - 2)
        row, col = row[ok], col[ok]
        # Unexplained: the stored map is confidently free all around the end point.
        worst = np.full(len(row), -np.inf)
        for dr in (-4, -2, 0, 2, 4):
            for dc in (-4, -2, 0, 2, 4):
                worst = np.maximum(worst, stored[np.clip(row + dr, 0, n - 1), np.clip(col + dc, 0, n - 1)])
        new = worst < cfg.free
        self.evidence *= 0.98
        np.add.at(self.evidence, (row[new] // 2, col[new] // 2), 1.0)
        if self.object is None and self.evidence.max() >= cfg.object_hits:
            r, c2 = np.unravel_index(int(np.argmax(self.evidence)), self.evidence.shape)
            p = self.occupancy.plan_grid
            spot = np.array([p.x0 + (c2 + 0.5) * p.resolution, p.y0 + (r + 0.5) * p.resolution])
            if all(np.linalg.norm(spot - q) > 0.5 for q in given_up):
                self.object = spot

    def isolated(self, step: int, find_phase: bool, given_up: list) -> None:
        """Something small standing free: a cluster of occupied planning cells, 0.1-0.8 m across,
        with free space all round it (0.3 m), is the object, whether or not the stored map knew
        the place (a start in "find" has no stored map of the far rooms)."""
        occupied, free = self.occupancy.coarse(step)
        ring = 3
        p = self.occupancy.view_grid
        for cells in components(occupied):
            span = (cells.max(axis=0) - cells.min(axis=0) + 1) * p.resolution
            if len(cells) < 3 or span.max() > 0.8:
                continue
            r0, c0 = cells.min(axis=0) - ring
            r1, c1 = cells.max(axis=0) + ring + 1
            if r0 < 0 or c0 < 0 or r1 > occupied.shape[0] or c1 > occupied.shape[1]:
                continue
            window = occupied[r0:r1, c0:c1].copy()
            window[cells[:, 0] - r0, cells[:, 1] - c0] = False
            if window.any() or free[r0:r1, c0:c1].sum() < 0.6 * window.size:
                continue
            if not find_phase and self.in_stored(cells):
                continue  # there before the object was (a jamb mapped anew off its place)
            spot = np.array(
                [p.x0 + (cells[:, 1].mean() + 0.5) * p.resolution, p.y0 + (cells[:, 0].mean() + 0.5) * p.resolution]
            )
            if all(np.linalg.norm(spot - q) > 0.5 for q in given_up):
                self.object = spot
                return

    def in_stored(self, cells: np.ndarray, reach: int = 2) -> bool:
        """Whether the map stored at parking had anything occupied within `reach` planning cells
        of these (view) cells: the object is placed once the robot has parked."""
        r0, _, c0, _ = self.occupancy.view
        stored = self.stored
        assert stored is not None  # (asked only once a map is stored)
        n = stored.shape[0]
        for r, c in cells:
            fr, fc = 2 * (r + r0), 2 * (c + c0)
            k = 2 * reach
            if (
                stored[max(fr - k, 0) : min(fr + k + 2, n), max(fc - k, 0) : min(fc + k + 2, n)] > self.config.occupied
            ).any():
                return True
        return False

    def room_depths(self, step: int, start: Pose) -> np.ndarray:
        """`regions.room_depths` of the map (full planning grid), walls being the occupied cells
        in groups of four or more (a stray hit inside a room would cut its middle)."""
        cfg = self.config
        occupied, free = self.occupancy.coarse(step)
        walls = occupied & (component_sizes(occupied) >= 4)
        first = self.occupancy.plan_cell(np.array([start.x, start.y]))
        depths = room_depths(free, walls, first, cfg.plan_cell_m, cfg.room_join_m, cfg.room_middle_m)
        full = np.zeros(self.occupancy.checked.shape, dtype=np.int64)
        r0, r1, c0, c1 = self.occupancy.view
        full[r0:r1, c0:c1] = depths
        return full
