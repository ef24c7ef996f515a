"""What the classic hospital agent makes of the map the course gave it, once per task.

The given map (`info["task"].map`: walls, cabinets, start area, door openings) is all the agent
knows of the building before it moves. From it, once: the likelihood field the localiser scores
scans on, a grid of the walls' clearance and what planning keeps off, the walls as points (for the
safety filter's blind sector), and the frame of each door opening.
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.agents.classic.hospital.config import HospitalAgentConfig
from pico_gym.agents.classic.localisation import Localiser
from pico_gym.types import FloatArray
from pico_gym.world.grid import Grid, clearance_grid, flood
from pico_gym.world.hospital import Cabinet, cabinets_of
from pico_gym.world.map import Map

# A door opening: its centre, the unit normal through it and its half width.
DoorFrame = tuple[FloatArray, FloatArray, float]


def door_frame(polygon: FloatArray) -> DoorFrame:
    """A door opening's centre, the unit normal through it and its half width (from its polygon:
    the opening's long side across the way, the wall's thickness along it)."""
    polygon = np.asarray(polygon, dtype=np.float64)
    centre = polygon.mean(axis=0)
    e1, e2 = polygon[1] - polygon[0], polygon[2] - polygon[1]
    long, short = (e1, e2) if np.hypot(*e1) >= np.hypot(*e2) else (e2, e1)
    normal = short / max(float(np.hypot(*short)), 1e-9)
    return centre, normal, 0.5 * float(np.hypot(*long))


def sample_segments(segments: FloatArray, spacing: float) -> FloatArray:
    """Points along segments, at most `spacing` apart (both ends included)."""
    out = []
    for x1, y1, x2, y2 in np.asarray(segments, dtype=np.float64):
        n = max(1, int(math.ceil(math.hypot(x2 - x1, y2 - y1) / spacing)))
        t = np.linspace(0.0, 1.0, n + 1)
        out.append(np.column_stack([x1 + t * (x2 - x1), y1 + t * (y2 - y1)]))
    return np.vstack(out) if out else np.zeros((0, 2))


class GivenMap:
    """The given map, prepared for localisation, planning and the safety filter.

    Attributes:
        world: the map as given.
        localiser: scan-to-map registration on its walls (`distance_at` tells how far a point is
            from the nearest wall: what the map does not explain).
        cabinets: the cabinets (fronts, arrival squares).
        grid: the planning and evidence grid covering the map.
        clearance: each cell's distance to the map's walls and cabinets [m] (capped at 0.5).
        blocked: the cells the robot's centre keeps off (`inflate_m`).
        start_region: the start area's polygon (None if the map gives none).
        wall_points: the walls and cabinets as points 4 cm apart, map frame.
        doors: the door openings' frames.
    """

    def __init__(self, world: Map, config: HospitalAgentConfig) -> None:
        self.world = world
        self.localiser = Localiser(world.wall_segments)
        self.cabinets: tuple[Cabinet, ...] = cabinets_of(world)
        self.grid = Grid.covering(world.bounds, config.cell_m, margin=0.3)
        walls = np.vstack([world.wall_segments, world.cabinet_segments])
        self.clearance = clearance_grid(self.grid, walls, cap=0.5)
        self.blocked = self.clearance < config.inflate_m
        self.start_region = world.polygon(world.start_area[0]) if world.start_area else None
        self.wall_points = sample_segments(walls, 0.04)
        self.wall_by_x = np.argsort(self.wall_points[:, 0], kind="stable")  # (for `EvidenceMap.remembered`)
        self.wall_x = self.wall_points[self.wall_by_x, 0]
        self.doors = [door_frame(world.polygon(d)) for d in world.doors]
        self._free: FloatArray | None = None

    def cell(self, p: FloatArray) -> tuple[int, int]:
        """The grid cell (row, column) of a map-frame point, clamped to the grid."""
        g = self.grid
        r = int(min(max((p[1] - g.y0) / g.resolution, 0.0), g.shape[0] - 1))  # (np.clip: ten times slower)
        c = int(min(max((p[0] - g.x0) / g.resolution, 0.0), g.shape[1] - 1))
        return r, c

    def centre(self, cell: tuple[int, int]) -> FloatArray:
        """A cell's centre, map frame."""
        g = self.grid
        return np.array([g.x0 + (cell[1] + 0.5) * g.resolution, g.y0 + (cell[0] + 0.5) * g.resolution])

    def free_positions(self) -> FloatArray:
        """Where the robot's centre can be on the map (0.2 m apart, inside the building)."""
        if self._free is None:
            g = self.grid
            inside = ~self.blocked
            if self.start_region is not None:
                r, c = self.cell(self.start_region.mean(axis=0))
                inside = flood(inside, r, c)
            rows, cols = np.nonzero(inside[::4, ::4])
            self._free = np.column_stack(
                [g.x0 + (4 * cols + 0.5) * g.resolution, g.y0 + (4 * rows + 0.5) * g.resolution]
            )
        return self._free

    def region(self) -> FloatArray:
        """Where the robot starts: the start area, else the whole map's bounds."""
        if self.start_region is not None:
            return self.start_region
        x0, y0, x1, y1 = self.world.bounds
        return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
