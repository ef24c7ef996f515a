"""A* search on an occupancy grid (8-connected, octile heuristic), then string pulling.

Hart, Nilsson and Raphael, "A Formal Basis for the Heuristic Determination of Minimum Cost Paths"
(1968). The grid is a boolean array of blocked cells (already inflated by the robot's radius);
the result is a list of cells from start to goal, or None when the goal cannot be reached. String
pulling keeps only the cells where a straight line to the next kept cell would cross a blocked one.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

SQRT2 = math.sqrt(2.0)
_MOVES = (
    (1, 0, 1.0),
    (-1, 0, 1.0),
    (0, 1, 1.0),
    (0, -1, 1.0),
    (1, 1, SQRT2),
    (1, -1, SQRT2),
    (-1, 1, SQRT2),
    (-1, -1, SQRT2),
)


@dataclass(frozen=True)
class Path:
    """A path of grid cells (row, col) and its length in cells."""

    cells: list[tuple[int, int]]
    length: float


def _octile(a: tuple[int, int], b: tuple[int, int]) -> float:
    dr, dc = abs(a[0] - b[0]), abs(a[1] - b[1])
    return max(dr, dc) + (SQRT2 - 1.0) * min(dr, dc)


def astar(blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> Path | None:
    """Shortest 8-connected path between two cells; diagonal moves may not cut blocked corners.

    >>> grid = np.zeros((3, 3), bool); grid[1, :2] = True
    >>> astar(grid, (0, 0), (2, 0)).cells
    [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0)]
    """
    rows, cols = blocked.shape
    if blocked[start] or blocked[goal]:
        return None
    g = {start: 0.0}
    parent: dict[tuple[int, int], tuple[int, int]] = {}
    frontier = [(_octile(start, goal), 0.0, start)]
    closed = set()
    while frontier:
        _, cost, cell = heapq.heappop(frontier)
        if cell in closed:
            continue
        if cell == goal:
            cells = [cell]
            while cell in parent:
                cell = parent[cell]
                cells.append(cell)
            return Path(cells[::-1], cost)
        closed.add(cell)
        r, c = cell
        for dr, dc, step in _MOVES:
            nr, nc = r + dr, c + dc
            if not (0 <= nr < rows and 0 <= nc < cols) or blocked[nr, nc]:
                continue
            if dr and dc and (blocked[r + dr, c] or blocked[r, c + dc]):
                continue
            new = cost + step
            if new < g.get((nr, nc), math.inf):
                g[(nr, nc)] = new
                parent[(nr, nc)] = cell
                heapq.heappush(frontier, (new + _octile((nr, nc), goal), new, (nr, nc)))
    return None


def line_is_free(blocked: np.ndarray, a: tuple[int, int], b: tuple[int, int]) -> bool:
    """True when the straight line between two cell centres crosses no blocked cell."""
    n = int(max(abs(b[0] - a[0]), abs(b[1] - a[1])) * 2) + 1
    rows = np.rint(np.linspace(a[0], b[0], n + 1)).astype(int)
    cols = np.rint(np.linspace(a[1], b[1], n + 1)).astype(int)
    return not blocked[rows, cols].any()


def string_pull(blocked: np.ndarray, cells: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Drop the cells a straight line can skip."""
    if len(cells) <= 2:
        return list(cells)
    kept = [cells[0]]
    i = 0
    while i < len(cells) - 1:
        j = len(cells) - 1
        while j > i + 1 and not line_is_free(blocked, cells[i], cells[j]):
            j -= 1
        kept.append(cells[j])
        i = j
    return kept
