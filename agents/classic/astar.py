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

from pico_gym.jit import njit

SQRT2 = math.sqrt(2.0)
# (d_row, d_col, length) of the 8 moves, in the order the search tries them (ties go to the first).
_MOVES = np.array(
    [
        (1, 0, 1.0),
        (-1, 0, 1.0),
        (0, 1, 1.0),
        (0, -1, 1.0),
        (1, 1, SQRT2),
        (1, -1, SQRT2),
        (-1, 1, SQRT2),
        (-1, -1, SQRT2),
    ]
)


@dataclass(frozen=True)
class Path:
    """A path of grid cells (row, col) and its length in cells."""

    cells: list[tuple[int, int]]
    length: float


@njit
def _octile(r: int, c: int, gr: int, gc: int) -> float:
    dr, dc = abs(r - gr), abs(c - gc)
    return max(dr, dc) + (SQRT2 - 1.0) * min(dr, dc)


@njit
def _search(blocked: np.ndarray, sr: int, sc: int, gr: int, gc: int, moves: np.ndarray) -> tuple[np.ndarray, float]:
    """The A* loop: the path's cells as (n, 2) rows from start to goal (none if unreachable), and
    its length. Heap entries (f, g, row, col) order as (f, g, (row, col)) tuples do."""
    rows, cols = blocked.shape
    g = np.full((rows, cols), np.inf)
    parent = np.full((rows, cols), -1, dtype=np.int64)  # row * cols + col of the cell before
    closed = np.zeros((rows, cols), dtype=np.bool_)
    g[sr, sc] = 0.0
    frontier = [(_octile(sr, sc, gr, gc), 0.0, sr, sc)]
    while len(frontier) > 0:
        _, cost, r, c = heapq.heappop(frontier)
        if closed[r, c]:
            continue
        if r == gr and c == gc:
            n = 1
            k = parent[r, c]
            while k >= 0:
                n += 1
                k = parent[k // cols, k % cols]
            out = np.empty((n, 2), dtype=np.int64)
            rr, cc = r, c
            for i in range(n - 1, -1, -1):
                out[i, 0], out[i, 1] = rr, cc
                k = parent[rr, cc]
                if k >= 0:
                    rr, cc = k // cols, k % cols
            return out, cost
        closed[r, c] = True
        for m in range(moves.shape[0]):
            dr, dc, step = int(moves[m, 0]), int(moves[m, 1]), moves[m, 2]
            nr, nc = r + dr, c + dc
            if not (0 <= nr < rows and 0 <= nc < cols) or blocked[nr, nc]:
                continue
            if dr != 0 and dc != 0 and (blocked[r + dr, c] or blocked[r, c + dc]):
                continue
            new = cost + step
            if new < g[nr, nc]:
                g[nr, nc] = new
                parent[nr, nc] = r * cols + c
                heapq.heappush(frontier, (new + _octile(nr, nc, gr, gc), new, nr, nc))
    return np.empty((0, 2), dtype=np.int64), math.inf


def astar(blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> Path | None:
    """Shortest 8-connected path between two cells; diagonal moves may not cut blocked corners.

    >>> grid = np.zeros((3, 3), bool); grid[1, :2] = True
    >>> astar(grid, (0, 0), (2, 0)).cells
    [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0)]
    """
    if blocked[start] or blocked[goal]:
        return None
    blocked = np.ascontiguousarray(blocked, dtype=np.bool_)
    cells, length = _search(blocked, int(start[0]), int(start[1]), int(goal[0]), int(goal[1]), _MOVES)
    if len(cells) == 0:
        return None
    return Path([(int(r), int(c)) for r, c in cells.tolist()], float(length))


@njit
def _line_is_free(blocked: np.ndarray, ar: int, ac: int, br: int, bc: int) -> bool:
    """`line_is_free` compiled: the same samples as numpy's linspace + rint."""
    n = int(max(abs(br - ar), abs(bc - ac)) * 2) + 1
    step_r = (br - ar) / n
    step_c = (bc - ac) / n
    for i in range(n + 1):
        if i == n:
            r, c = br, bc
        else:
            r = int(np.rint(i * step_r + ar))
            c = int(np.rint(i * step_c + ac))
        if blocked[r, c]:
            return False
    return True


def line_is_free(blocked: np.ndarray, a: tuple[int, int], b: tuple[int, int]) -> bool:
    """True when the straight line between two cell centres crosses no blocked cell."""
    return bool(
        _line_is_free(np.ascontiguousarray(blocked, dtype=np.bool_), int(a[0]), int(a[1]), int(b[0]), int(b[1]))
    )


@njit
def _string_pull(blocked: np.ndarray, cells: np.ndarray) -> np.ndarray:
    n = cells.shape[0]
    kept = np.empty(n, dtype=np.int64)
    kept[0] = 0
    k = 1
    i = 0
    while i < n - 1:
        j = n - 1
        while j > i + 1 and not _line_is_free(blocked, cells[i, 0], cells[i, 1], cells[j, 0], cells[j, 1]):
            j -= 1
        kept[k] = j
        k += 1
        i = j
    return kept[:k]


def string_pull(blocked: np.ndarray, cells: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Drop the cells a straight line can skip."""
    if len(cells) <= 2:
        return list(cells)
    arr = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
    kept = _string_pull(np.ascontiguousarray(blocked, dtype=np.bool_), arr)
    return [cells[i] for i in kept.tolist()]
