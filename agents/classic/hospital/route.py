"""The classic hospital agent's planner: A* on the planning grid, string pulling, doors crossed
square on; and the questions the state machine asks of the way ahead.

A plan is tried in tiers: with the no-go discs (where the robot recently made no progress), then
without them, then squeezed (the evidence inflated by the robot's half depth only, for a gap
beside a box it can pass sideways). The path is string-pulled, and every door of the map it
crosses gets a waypoint on the door's centre line before and after it (a pulled string cuts
through a door at a slant the footprint cannot take).
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.agents.classic.astar import astar, string_pull
from pico_gym.agents.classic.hospital.config import HospitalAgentConfig
from pico_gym.agents.classic.hospital.evidence import EvidenceMap
from pico_gym.agents.classic.hospital.given import GivenMap
from pico_gym.jit import njit
from pico_gym.types import FloatArray, Pose


@njit
def _near_segment(
    seen: np.ndarray, x0: float, y0: float, res: float, ax: float, ay: float, bx: float, by: float, k: int
) -> bool:
    """Whether a `seen` cell lies within k cells (a square) of the segment a-b: samples at most
    0.05 m apart (both ends included), each sample's cell clipped into the grid."""
    rows, cols = seen.shape
    dx, dy = bx - ax, by - ay
    n = max(2, int(math.sqrt(dx * dx + dy * dy) / 0.05))
    step = 1.0 / (n - 1)
    for i in range(n):
        t = 1.0 if i == n - 1 else i * step
        r = int(min(max((ay + t * dy - y0) / res, 0.0), rows - 1))
        c = int(min(max((ax + t * dx - x0) / res, 0.0), cols - 1))
        for rr in range(max(r - k, 0), min(r + k + 1, rows)):
            for cc in range(max(c - k, 0), min(c + k + 1, cols)):
                if seen[rr, cc]:
                    return True
    return False


class RoutePlanner:
    """The path to the current goal and the no-go discs, on the given map and the evidence.

    Attributes:
        path: the waypoints ahead (map frame), the goal last.
        plan_step: the step the path was planned at.
        nogo: (x, y, until step) discs kept out of plans for a while.
        squeeze: the current path needed the squeeze (the safety filter then drops its extra
            margin from unexplained points).
    """

    def __init__(self, given: GivenMap, world: EvidenceMap, config: HospitalAgentConfig) -> None:
        self.given, self.world, self.config = given, world, config
        self.path: list[FloatArray] = []
        self.plan_step = -(10**9)
        self.nogo: list[tuple[float, float, int]] = []
        self.squeeze = False

    def clear(self) -> None:
        """Forget the path (a new state plans afresh)."""
        self.path = []
        self.plan_step = -(10**9)

    def plan(self, pose: Pose, goal: FloatArray, steps: int) -> bool:
        """Plan from the pose to `goal` (tiers: with the no-go discs, without, squeezed); False
        when no tier finds a way."""
        self.nogo = [n for n in self.nogo if n[2] > steps]
        here = np.array([pose.x, pose.y])
        start, end = self.given.cell(here), self.given.cell(goal)
        k = int(self.config.inflate_m / self.config.cell_m)
        path = None
        tiers = [(True, False)] if self.nogo else []
        tiers += [(False, False), (False, True)]
        for nogo, squeeze in tiers:
            self.squeeze = squeeze
            blocked = self.world.blocked(self.nogo if nogo else [], squeeze)
            for r, c in (start, end):  # the robot's own cell (and the goal's) may touch the inflation
                blocked[max(r - k, 0) : r + k + 1, max(c - k, 0) : c + k + 1] = False
            path = astar(blocked, start, end)
            if path is not None:
                break
        self.plan_step = steps
        if path is None:
            self.path = []
            self.squeeze = False
            return False
        cells = string_pull(blocked, path.cells)
        self.path = self.through_doors([here] + [self.given.centre(c) for c in cells[1:]] + [goal])[1:]
        return True

    def through_doors(self, path: list[FloatArray]) -> list[FloatArray]:
        """Cross every door of the map square on: a waypoint on its centre line before and after
        it (string pulling cuts through a door at a slant the footprint cannot take)."""
        out = [path[0]]
        for a, b in zip(path[:-1], path[1:], strict=True):
            for centre, normal, half in self.given.doors:
                da, db = float((a - centre) @ normal), float((b - centre) @ normal)
                if da * db >= 0.0:
                    continue  # this leg does not cross the door's line
                t = da / (da - db)
                cross = a + t * (b - a)
                along = cross - centre - normal * float((cross - centre) @ normal)
                if float(np.hypot(*along)) > half + 0.3:
                    continue  # crosses the line elsewhere
                side = 1.0 if da > 0 else -1.0
                for k in (side, -side):
                    w = centre + k * self.config.door_approach_m * normal
                    if float(np.linalg.norm(w - out[-1])) > 0.05:
                        out.append(w)
            out.append(b)
        return out

    def remaining(self, here: FloatArray) -> float:
        """The length of the planned way from here to its end [m]."""
        points = [here, *self.path]
        return float(sum(np.linalg.norm(b - a) for a, b in zip(points[:-1], points[1:], strict=True)))

    def path_blocked(self, pose: Pose) -> bool:
        """Whether the next stretch of the path runs through a cell now blocked by evidence."""
        seen = self.world.seen()
        if not seen.any() or not self.path:
            return False
        here = np.array([pose.x, pose.y])
        legs = zip([here, *self.path[:-1]], self.path[:3], strict=False)
        return any(self.evidence_along(seen, a, b, 2) for a, b in legs)

    def evidence_along(self, seen: np.ndarray, a: FloatArray, b: FloatArray, k: int) -> bool:
        """Whether a `seen` cell lies within k cells (a square) of the segment a-b (map frame)."""
        g = self.given.grid
        return bool(
            _near_segment(seen, g.x0, g.y0, g.resolution, float(a[0]), float(a[1]), float(b[0]), float(b[1]), k)
        )

    def clear_way(self, a: FloatArray, b: FloatArray) -> bool:
        """Whether the straight way from a to b keeps the robot's half width (0.2 m) and the
        margin off what the map does not explain: turned to face a cabinet early, the robot
        drives the last metre forward, which a box beside the way does not leave room for."""
        seen = self.world.seen()
        if not seen.any():
            return True
        k = int(math.ceil((0.2 + self.config.unexplained_margin_m + 0.05) / self.config.cell_m))
        return not self.evidence_along(seen, a, b, k)

    def roomy(self, p: FloatArray, within_m: float | None = None) -> bool:
        """Room to drive forward (the robot's 0.4 m width across the way) at a map-frame point:
        the map's walls and the evidence at least `roomy_m` (or `within_m`) away."""
        within = self.config.roomy_m if within_m is None else within_m
        r, c = self.given.cell(p)
        if self.given.clearance[r, c] < within:
            return False
        k = int(math.ceil(within / self.config.cell_m))
        return not bool(self.world.seen()[max(r - k, 0) : r + k + 1, max(c - k, 0) : c + k + 1].any())

    def straight_way(self, a: FloatArray, b: FloatArray) -> bool:
        """Whether the robot's centre can go straight from a to b: the map's walls keep the
        robot's half depth off the way (a spot behind a wall is near but not reachable)."""
        n = max(2, int(np.linalg.norm(b - a) / 0.05))
        g = self.given.grid
        way = a + np.linspace(0.0, 1.0, n)[1:, None] * (b - a)
        rows = np.clip((way[:, 1] - g.y0) / g.resolution, 0, g.shape[0] - 1).astype(np.int64)  # as `GivenMap.cell`
        cols = np.clip((way[:, 0] - g.x0) / g.resolution, 0, g.shape[1] - 1).astype(np.int64)
        return not bool((self.given.clearance[rows, cols] < 0.1).any())
