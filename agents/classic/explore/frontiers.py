"""The classic explore agent's planner: Dijkstra on the planning view of its own map, to the best
frontier or to a goal, string-pulled where that keeps the comfort clearance.

Frontier exploration (Yamauchi, "A frontier-based approach for autonomous exploration", 1997):
free cells next to unknown ones, grouped; the nearest group by path, weighted by its size, is the
goal. Unknown cells are not driven through, cells near walls cost more (`comfort_m`), cells
within `inflate_m` of a wall are blocked.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pico_gym.agents.classic.astar import string_pull
from pico_gym.agents.classic.explore.config import ExploreAgentConfig
from pico_gym.agents.classic.explore.occupancy import OccupancyMap
from pico_gym.agents.classic.explore.regions import components, distance_transform, opening
from pico_gym.types import FloatArray, Pose
from pico_gym.world.grid import CostGrid, descend


class FrontierPlanner:
    """The path and the goal, on the occupancy map's planning view.

    Attributes:
        path: the waypoints ahead (agent frame), the goal last.
        plan_step: the step the path was planned at.
        goal: the spot the path leads to; best, best_step: the shortest way left to it so far,
            and when (progress towards the goal).
        given_up: goals given up (no progress); retried: those given one more try.
        frontiers: the frontiers of the last plan (for drawing).
        small_goal: the goal is a small frontier (looked at from 1 m, it is done).
        clearance: each planning cell's distance to the nearest occupied one, at the last plan [m].
        anchor, anchor_step: a spot the robot has stayed within 0.5 m of since that step.
    """

    def __init__(self, config: ExploreAgentConfig, occupancy: OccupancyMap, dt_s: float) -> None:
        self.config, self.occupancy, self.dt_s = config, occupancy, dt_s
        self.path: list[FloatArray] = []
        self.plan_step = -(10**9)
        self.goal: FloatArray | None = None
        self.best = math.inf
        self.best_step = 0
        self.given_up: list[FloatArray] = []
        self.retried: list[FloatArray] = []
        self.frontiers: list[FloatArray] = []
        self.small_goal = False
        self.clearance = np.zeros((0, 0))
        self._occupied_clearance = np.zeros((0, 0))
        self.anchor: FloatArray | None = None
        self.anchor_step = 0

    def clear(self, step: int) -> None:
        """Forget the path and the progress (a new state plans afresh)."""
        self.path = []
        self.plan_step = -(10**9)
        self.best = math.inf
        self.best_step = step
        self.anchor = None

    def stayed(self, here: FloatArray, step: int) -> int:
        """How many steps the robot has stayed within 0.5 m of one spot (call every step: the
        spot moves to where it is once it is farther)."""
        if self.anchor is None or float(np.linalg.norm(here - self.anchor)) > 0.5:
            self.anchor, self.anchor_step = here.copy(), step
        return step - self.anchor_step

    def replan_due(self, step: int) -> bool:
        """No path, or one older than `replan_s`."""
        return not self.path or step - self.plan_step >= max(1, round(self.config.replan_s / self.dt_s))

    def costs(self, pose: Pose, step: int) -> tuple[CostGrid, np.ndarray, np.ndarray]:
        """The planning view's costs (unknown cells blocked, the robot's own cells drivable), its
        clearance and its free cells."""
        cfg = self.config
        occupied, free = self.occupancy.coarse(step)
        clearance = distance_transform(occupied, cfg.plan_cell_m, 1.0)
        self._occupied_clearance = clearance
        clearance = np.where(free, clearance, 0.0)  # unknown cells are not for driving through
        r, c = self.occupancy.plan_cell(np.array([pose.x, pose.y]))
        # The robot's own cells are drivable (it stands there).
        clearance[max(r - 1, 0) : r + 2, max(c - 1, 0) : c + 2] = np.maximum(
            clearance[max(r - 1, 0) : r + 2, max(c - 1, 0) : c + 2], cfg.inflate_m + 0.01
        )
        costs = CostGrid.from_clearance(self.occupancy.view_grid, clearance, cfg.comfort_m, 4.0, cfg.inflate_m)
        return costs, clearance, free

    def plan_to_frontier(
        self,
        pose: Pose,
        step: int,
        unknown: np.ndarray,
        within: np.ndarray | None = None,
        min_cells: int | None = None,
        bonus: np.ndarray | None = None,
    ) -> bool:
        """Plan to the best frontier: free cells (of `within`, else all) next to `unknown` cells
        (nearest by path, weighted by size, less `bonus` at the frontier's nearest cell [m]);
        frontiers smaller than `frontier_min_cells` count only if they open into the unknown."""
        cfg = self.config
        min_cells = cfg.frontier_min_cells if min_cells is None else min_cells
        costs, clearance, free = self.costs(pose, step)
        region = free if within is None else within
        neighbour = np.zeros_like(unknown)
        neighbour[1:, :] |= unknown[:-1, :]
        neighbour[:-1, :] |= unknown[1:, :]
        neighbour[:, 1:] |= unknown[:, :-1]
        neighbour[:, :-1] |= unknown[:, 1:]
        frontier = region & neighbour & ~unknown & np.isfinite(costs.cost)
        here = self.occupancy.plan_cell(np.array([pose.x, pose.y]))
        field = costs.field_from(np.array([here[0]]), np.array([here[1]]), np.zeros(1))
        frontier &= np.isfinite(field.distance)
        best, best_score = None, math.inf
        p = self.occupancy.view_grid
        self.frontiers = []
        occupied = self.occupancy.coarse(step)[0]
        for cells in components(frontier):
            if len(cells) < min_cells:
                continue
            if len(cells) < cfg.frontier_min_cells and not opening(cells, unknown, occupied):
                continue
            d = field.distance[cells[:, 0], cells[:, 1]]
            k = int(np.argmin(d))
            spot = np.array([p.x0 + (cells[k, 1] + 0.5) * p.resolution, p.y0 + (cells[k, 0] + 0.5) * p.resolution])
            if any(np.linalg.norm(spot - q) < 0.5 for q in self.given_up):
                continue
            self.frontiers.append(spot)
            score = float(d[k]) - 0.03 * min(len(cells), 60)
            if bonus is not None:
                score -= float(bonus[cells[k, 0], cells[k, 1]])
            if score < best_score:
                best, best_score = (tuple(cells[k]), spot), score
        if best is None:
            return False
        return self._path_from_field(field, costs, best[0], best[1], step)

    def plan_to(self, pose: Pose, step: int, goal: FloatArray, stop_m: float = 0.0) -> bool:
        """Plan to within about `stop_m` of `goal` (the reachable cell there that is nearest by
        path, with the distance from `stop_m` weighed in)."""
        costs, _, _ = self.costs(pose, step)
        here = self.occupancy.plan_cell(np.array([pose.x, pose.y]))
        field = costs.field_from(np.array([here[0]]), np.array([here[1]]), np.zeros(1))
        p = self.occupancy.view_grid
        xs = p.x0 + (np.arange(p.shape[1]) + 0.5) * p.resolution
        ys = p.y0 + (np.arange(p.shape[0]) + 0.5) * p.resolution
        r0, c0 = self.occupancy.plan_cell(goal)
        k = int(math.ceil((stop_m + 0.3) / p.resolution))
        rs = slice(max(r0 - k, 0), r0 + k + 1)
        cs = slice(max(c0 - k, 0), c0 + k + 1)
        gx, gy = np.meshgrid(xs[cs], ys[rs])
        window = field.distance[rs, cs]
        near = np.hypot(gx - goal[0], gy - goal[1])
        ok = np.isfinite(window) & (near <= stop_m + 0.3) & (near >= stop_m - 0.1)
        if not ok.any():
            return False
        score = np.where(ok, window + 2.0 * np.abs(near - stop_m), np.inf)
        i, j = np.unravel_index(int(np.argmin(score)), score.shape)
        cell = (rs.start + int(i), cs.start + int(j))
        spot = np.array([xs[cell[1]], ys[cell[0]]])
        return self._path_from_field(field, costs, cell, spot, step)

    def _path_from_field(self, field: Any, costs: CostGrid, cell: tuple[int, int], spot: FloatArray, step: int) -> bool:
        """Walk down the field from the goal cell to the robot; string-pull; keep as the path."""
        cells = [(int(r), int(c)) for r, c in descend(field.distance, costs.knight_ok, *cell)[::-1]]
        # Straight lines only where they keep the comfort clearance: a pulled string would hug door
        # jambs at the inflation radius; through a narrow door the field's own cells are kept.
        p = self.occupancy.view_grid
        self.clearance = self._occupied_clearance
        blocked = ~np.isfinite(costs.cost) | (self.clearance < 0.75 * self.config.comfort_m)
        pulled = string_pull(blocked, cells)
        self.path = [
            np.array([p.x0 + (cc + 0.5) * p.resolution, p.y0 + (rr + 0.5) * p.resolution]) for rr, cc in pulled[1:]
        ]
        if not self.path:
            self.path = [spot]
        self.plan_step = step
        if self.goal is None or np.linalg.norm(self.goal - spot) > 0.3:
            self.goal = spot
            self.best = math.inf
            self.best_step = step
        return True

    def remaining(self, here: FloatArray) -> float:
        """The length of the path left from `here` [m]."""
        return float(np.linalg.norm(self.path[0] - here)) + sum(
            float(np.linalg.norm(b - a)) for a, b in zip(self.path[:-1], self.path[1:], strict=False)
        )

    def tight_ahead(self, here: FloatArray, length_m: float) -> bool:
        """Whether the path's next `length_m` passes anywhere narrower than `narrow_m` (so the
        robot turns sideways before it gets there, not in the door)."""
        cfg = self.config
        points = [here, *self.path]
        left = length_m
        for a, b in zip(points[:-1], points[1:], strict=False):
            span = float(np.linalg.norm(b - a))
            for t in np.linspace(0.0, min(span, left), max(2, int(min(span, left) / 0.05) + 1)):
                q = a + (b - a) * (t / span if span > 1e-9 else 0.0)
                r, c = self.occupancy.plan_cell(q)
                if self.clearance[r, c] < cfg.narrow_m:
                    return True
            left -= span
            if left <= 0:
                break
        return False
