"""The classic explore agent's map: a log-odds occupancy grid in its odometry frame at reset.

Every beam marks the cells it passes free and its end point occupied (a grid walk per beam,
compiled: `_integrate`); hits are also counted per cell with the step of the latest one, for the
safety filter's memory of what is behind the robot (`mapped_near`). Planning reads a grid of
2 x 2 cells over the part of the map the beams can have reached (`coarse`).
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.agents.classic.explore.config import ExploreAgentConfig
from pico_gym.jit import njit
from pico_gym.tasks.explore import OccupancyBelief
from pico_gym.types import FloatArray, Pose
from pico_gym.world.grid import Grid


@njit
def _integrate(
    logodds: np.ndarray,
    hits: np.ndarray,
    last_hit: np.ndarray,
    step: int,
    checked: np.ndarray,
    x0: float,
    y0: float,
    res: float,
    px: float,
    py: float,
    theta: float,
    angles: np.ndarray,
    ranges: np.ndarray,
    stride: int,
    range_max: float,
    map_range: float,
    hit: float,
    miss: float,
    clamp: float,
) -> None:
    """Log-odds update along the beams (a grid walk per beam), `hits` counts the end points per
    cell (never cleared: thin things such as a door jamb's end are erased from the log-odds by
    beams grazing past, not from this), and `checked` (2x coarser) marks every cell a beam passed
    through."""
    rows, cols = logodds.shape
    fx, fy = (px - x0) / res, (py - y0) / res
    c0, q0 = int(math.floor(fx)), int(math.floor(fy))
    if c0 < 0 or c0 >= cols or q0 < 0 or q0 >= rows:
        return
    for k in range(0, angles.shape[0], stride):
        r = ranges[k]
        if r <= 0.05:
            continue
        hit_end = r < range_max - 1e-6 and r <= map_range
        length = min(r, map_range) / res
        a = theta + angles[k]
        dx, dy = math.cos(a), math.sin(a)
        c, q = c0, q0
        step_c = 1 if dx > 0 else -1
        step_q = 1 if dy > 0 else -1
        inv_x = 1.0 / abs(dx) if dx != 0.0 else math.inf
        inv_y = 1.0 / abs(dy) if dy != 0.0 else math.inf
        t_c = ((c + 1 - fx) if dx > 0 else (fx - c)) * inv_x
        t_q = ((q + 1 - fy) if dy > 0 else (fy - q)) * inv_y
        ec = int(math.floor(fx + dx * length))
        eq = int(math.floor(fy + dy * length))
        while True:
            if c == ec and q == eq:
                break
            logodds[q, c] = max(logodds[q, c] - miss, -clamp)
            checked[q // 2, c // 2] = True
            if t_c < t_q:
                if t_c > length:
                    break
                c += step_c
                t_c += inv_x
            else:
                if t_q > length:
                    break
                q += step_q
                t_q += inv_y
            if c < 0 or c >= cols or q < 0 or q >= rows:
                break
        if hit_end and 0 <= ec < cols and 0 <= eq < rows:
            logodds[eq, ec] = min(logodds[eq, ec] + hit + miss, clamp)
            if hits[eq, ec] < 60000:
                hits[eq, ec] += 1
            last_hit[eq, ec] = step
            checked[eq // 2, ec // 2] = True


class OccupancyMap:
    """The occupancy grid centred on the start, and its planning view.

    Attributes:
        grid: the fine grid (`cell_m`); plan_grid: the planning grid (`plan_cell_m`) over it.
        logodds: per fine cell, the log-odds of being occupied.
        hits, last_hit: per fine cell, the end points counted there and the step of the latest.
        checked: per planning cell, whether a beam passed through it (the search clears it at
            parking: "looked at since").
        known: the fine rows and columns (r0, r1, c0, c1) the beams may have reached.
        view, view_grid: the planning cells (r0, r1, c0, c1) of the last `coarse`, and its grid.
    """

    def __init__(self, config: ExploreAgentConfig, start: Pose) -> None:
        cfg = self.config = config
        n = int(round(cfg.size_m / cfg.cell_m))
        n += n % 2
        self.grid = Grid(start.x - 0.5 * cfg.size_m, start.y - 0.5 * cfg.size_m, cfg.cell_m, (n, n))
        self.plan_grid = Grid(self.grid.x0, self.grid.y0, cfg.plan_cell_m, (n // 2, n // 2))
        self.logodds = np.zeros((n, n), dtype=np.float64)
        self.hits = np.zeros((n, n), dtype=np.uint16)
        self.last_hit = np.zeros((n, n), dtype=np.int32)  # the step of each cell's latest hit
        self.checked = np.zeros((n // 2, n // 2), dtype=bool)
        self.known = (n, 0, n, 0)  # rows and columns (fine cells) the beams may have reached
        self._coarse_step = -1
        self._coarse_cache: tuple[np.ndarray, np.ndarray] = (np.zeros((0, 0), bool), np.zeros((0, 0), bool))
        self.view = (0, 0, 0, 0)
        self.view_grid = self.plan_grid

    def integrate(self, pose: Pose, angles: FloatArray, ranges: FloatArray, range_max: float, step: int) -> None:
        """One scan from `pose`: the log-odds along every `beam_stride`-th beam, the hits, the
        checked cells, and the extent the beams may have reached."""
        cfg, g = self.config, self.grid
        _integrate(
            self.logodds, self.hits, self.last_hit, step, self.checked, g.x0, g.y0, g.resolution,
            pose.x, pose.y, pose.theta, angles, ranges, cfg.beam_stride, range_max, cfg.map_range_m,
            cfg.hit, cfg.miss, cfg.clamp,
        )  # fmt: skip
        reach = int(math.ceil(cfg.map_range_m / g.resolution)) + 2
        r, c = int((pose.y - g.y0) / g.resolution), int((pose.x - g.x0) / g.resolution)
        k0, k1, k2, k3 = self.known
        n = self.logodds.shape[0]
        self.known = (
            max(min(k0, r - reach), 0),
            min(max(k1, r + reach), n),
            max(min(k2, c - reach), 0),
            min(max(k3, c + reach), n),
        )

    def coarse(self, step: int) -> tuple[np.ndarray, np.ndarray]:
        """The planning grid over the mapped area (`view`): occupied (any fine cell occupied)
        and free (mean log-odds free); computed once per step."""
        if self._coarse_step == step:
            return self._coarse_cache
        cfg = self.config
        r0, r1, c0, c1 = self.known  # fine cells
        r0, c0 = max(r0 // 2 - 2, 0), max(c0 // 2 - 2, 0)
        n = self.logodds.shape[0] // 2
        r1, c1 = min(r1 // 2 + 3, n), min(c1 // 2 + 3, n)
        p = self.plan_grid
        self.view = (r0, r1, c0, c1)
        self.view_grid = Grid(p.x0 + c0 * p.resolution, p.y0 + r0 * p.resolution, p.resolution, (r1 - r0, c1 - c0))
        blocks = self.logodds[2 * r0 : 2 * r1, 2 * c0 : 2 * c1].reshape(r1 - r0, 2, c1 - c0, 2)
        occupied: np.ndarray = np.asarray((blocks > cfg.occupied).any(axis=(1, 3)))
        free: np.ndarray = (blocks.mean(axis=(1, 3)) < cfg.free) & ~occupied
        self._coarse_step, self._coarse_cache = step, (occupied, free)
        return occupied, free

    def unknown(self, step: int) -> np.ndarray:
        """The planning view's cells neither occupied nor free."""
        occupied, free = self.coarse(step)
        return ~occupied & ~free

    def plan_cell(self, p: FloatArray) -> tuple[int, int]:
        """A point's cell in the planning view (clipped to it)."""
        g = self.view_grid
        c = int(np.clip((p[0] - g.x0) / g.resolution, 0, g.shape[1] - 1))
        r = int(np.clip((p[1] - g.y0) / g.resolution, 0, g.shape[0] - 1))
        return r, c

    def belief(self) -> OccupancyBelief:
        """The grid as -1 unknown, 0 free, 1 occupied (for `env.belief_iou`)."""
        cfg = self.config
        cells = np.full(self.logodds.shape, -1, dtype=np.int8)
        cells[self.logodds < cfg.free] = 0
        cells[self.logodds > cfg.occupied] = 1
        return OccupancyBelief(cells, (self.grid.x0, self.grid.y0), self.grid.resolution)

    def mapped_near(self, pose: Pose, radius: float, since_step: int | None) -> FloatArray:
        """Cells within `radius` of the robot where the LRF has hit something at least twice
        (the latest at or after `since_step`, if given), and cells never seen free within 15 cm
        of those, in the robot frame (for the blind sector: what was seen there, even if since
        grazed, and what may stand beside it unseen)."""
        g = self.grid
        r, c = int((pose.y - g.y0) / g.resolution), int((pose.x - g.x0) / g.resolution)
        k = int(math.ceil(radius / g.resolution))
        rs, cs = slice(max(r - k, 0), r + k + 1), slice(max(c - k, 0), c + k + 1)
        hit = self.hits[rs, cs] >= 2
        if since_step is not None:
            hit &= self.last_hit[rs, cs] >= since_step
        # With the cells never seen free within 15 cm of a hit: a jamb's end face, seen only at
        # grazing angles, may have no hits of its own (a turn just past a door swung the blind
        # rear corner into a jamb end mapped 16 cm short).
        grown = hit.copy()
        for _ in range(3):
            grown[1:, :] |= grown[:-1, :].copy()
            grown[:-1, :] |= grown[1:, :].copy()
            grown[:, 1:] |= grown[:, :-1].copy()
            grown[:, :-1] |= grown[:, 1:].copy()
        rows, cols = np.nonzero(hit | (grown & (self.logodds[rs, cs] >= self.config.free)))
        xs = g.x0 + (cols + max(c - k, 0) + 0.5) * g.resolution - pose.x
        ys = g.y0 + (rows + max(r - k, 0) + 0.5) * g.resolution - pose.y
        cs_, sn = math.cos(pose.theta), math.sin(pose.theta)
        return np.column_stack([cs_ * xs + sn * ys, -sn * xs + cs_ * ys])

    def occupied_points(self, most: int = 3000) -> FloatArray:
        """The occupied cells' centres (at most about `most`, evenly thinned), for drawing."""
        g = self.grid
        rows, cols = np.nonzero(self.logodds > self.config.occupied)
        take = slice(None, None, max(1, len(rows) // most))
        return np.column_stack([g.x0 + (cols[take] + 0.5) * g.resolution, g.y0 + (rows[take] + 0.5) * g.resolution])
