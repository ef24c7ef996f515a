"""The finish line of an escape map that has none (`finish="auto"`), found from its walls.

A course escape-room heightmap has no finish line: the room's corridor simply runs out of the
drawn walls. The rules put the finish line more than 3 m down the corridor from its mouth
(docs/facts/pico-facts.md). This finds it:

1. the free space the robot can reach from its start (cells farther than `PASS_M` from every
   solid segment, on a 5 cm grid) must leave the walls' bounding box;
2. along the shortest way out, the corridor is the last stretch with a wall on both sides within
   `MAX_CORRIDOR_M` across the way: its mouth where that stretch begins, its open end where it
   stops;
3. the line crosses the corridor `RULE_DEPTH_M` + `MARGIN_M` past the mouth, perpendicular to the
   way, from wall to wall; a corridor shorter than that gets the line at its open end, with a
   warning that says so;
4. with that line as a wall nothing outside may be reachable any more: one opening only.

Anything else (no opening, several, a line that meets no wall on a side) is refused with a
message that says how to add `finish` to a map JSON.
"""

from __future__ import annotations

import numpy as np

from pico_gym.types import FloatArray, Segments
from pico_gym.world.grid import CostGrid, Grid, clearance_grid, descend, flood

RESOLUTION_M = 0.05
PASS_M = 0.12  # the robot's centre passes where this far from everything (its half depth, 0.1 m, + 2 cm)
MAX_CORRIDOR_M = 1.6  # a corridor is at most 1.5 m wide (the rules), measured on a slanted line
RULE_DEPTH_M = 3.0  # the rules: the finish line is more than 3 m down the corridor
MARGIN_M = 0.2
REACH_M = 2.0  # how far the line may reach from the path to each wall
HOW_TO = (
    'add "finish": [[x1, y1], [x2, y2]] (the line across the corridor, map frame) to a map JSON that '
    'references the image ({"heightmap": {"image": "room.png"}, "finish": ...}; maps/README.md)'
)


class FinishError(ValueError):
    """No finish line can be found from the walls (the message says how to give one)."""


def auto_finish(segments: Segments, start: tuple[float, float], where: str) -> tuple[FloatArray, str | None]:
    """The finish line (2, 2) of an escape map from its solid segments and a start point, and a
    warning when the corridor is too short for the rules' depth (None otherwise).

    Raises:
        FinishError: naming the map and why, and how to add `finish` by hand.
    """
    xmin, ymin = segments[:, [0, 2]].min(), segments[:, [1, 3]].min()
    xmax, ymax = segments[:, [0, 2]].max(), segments[:, [1, 3]].max()
    grid = Grid.covering((xmin, ymin, xmax, ymax), RESOLUTION_M, margin=1.0)
    out_of_box = _out_of_box(grid, (xmin, ymin, xmax, ymax))
    r0, c0, reachable = _reach(grid, segments, start, where)
    out = reachable & out_of_box
    if not out.any():
        raise FinishError(f"{where}: finish: the room is closed: the free space never leaves the walls; {HOW_TO}")
    clearance = clearance_grid(grid, segments, cap=REACH_M)
    costs = CostGrid.from_clearance(grid, clearance, inflation_m=PASS_M)
    rows, cols = np.nonzero(out)
    field = costs.field_from(rows, cols, np.zeros(len(rows)), allowed=reachable)
    path = descend(field.distance, costs.knight_ok, r0, c0)
    xs, ys = grid.centres()
    points = np.column_stack([xs[path[:, 0], path[:, 1]], ys[path[:, 0], path[:, 1]]])
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
    mouth, end = _corridor(points, along, segments, where)
    warning = None
    target = along[mouth] + RULE_DEPTH_M + MARGIN_M
    if target > along[end]:
        target = along[end]
        warning = (
            f"{where}: the corridor is about {along[end] - along[mouth]:.1f} m long, shorter than the rules' "
            f"{RULE_DEPTH_M:.0f} m: the finish line is at its open end"
        )
    line = _across(points, along, target, segments)
    if line is None:
        raise FinishError(f"{where}: finish: the line across the corridor meets no wall on one side; {HOW_TO}")
    # Exactly one opening: with the line as a wall, nothing outside may be reachable any more.
    closed = np.vstack([segments, line.reshape(1, 4)])
    _, _, still = _reach(grid, closed, start, where)
    if (still & out_of_box).any():
        raise FinishError(
            f"{where}: finish: the free space leaves the walls through more than one opening, where an escape "
            f"room has one corridor; {HOW_TO}"
        )
    return line, warning


def _out_of_box(grid: Grid, box: tuple[float, float, float, float]) -> np.ndarray:
    xs, ys = grid.centres()
    xmin, ymin, xmax, ymax = box
    return (xs < xmin) | (xs > xmax) | (ys < ymin) | (ys > ymax)


def _reach(grid: Grid, segments: Segments, start: tuple[float, float], where: str) -> tuple[int, int, np.ndarray]:
    """The start's cell and the cells the robot's centre can reach from it."""
    costs = CostGrid.from_clearance(grid, clearance_grid(grid, segments, cap=REACH_M), inflation_m=PASS_M)
    r0, c0 = costs.cell_of(*start)
    if not np.isfinite(costs.cost[r0, c0]):
        raise FinishError(f"{where}: finish: the start {start} has no room for the robot; {HOW_TO}")
    return r0, c0, flood(np.isfinite(costs.cost), r0, c0)


def _corridor(points: FloatArray, along: FloatArray, segments: Segments, where: str) -> tuple[int, int]:
    """The indices along the path where the corridor begins (its mouth) and where it ends (the
    last point with a wall on both sides within a corridor's width)."""
    width = np.full(len(points), np.inf)
    for i in range(len(points)):
        line = _across(points, along, along[i], segments)
        if line is not None:
            width[i] = float(np.hypot(*(line[1] - line[0]))) - 0.1
    narrow = width <= MAX_CORRIDOR_M
    if not narrow.any():
        raise FinishError(f"{where}: finish: no corridor (at most {MAX_CORRIDOR_M} m wide) on the way out; {HOW_TO}")
    end = int(np.nonzero(narrow)[0][-1])
    mouth = end
    while mouth > 0 and narrow[mouth - 1]:
        mouth -= 1
    return mouth, end


def _across(points: FloatArray, along: FloatArray, s: float, segments: Segments) -> FloatArray | None:
    """The line across the corridor at arc length `s` of the path: perpendicular to the path's
    direction there (over +-0.3 m), from the nearest wall on one side to the nearest on the other,
    5 cm into each."""
    p = np.array([np.interp(s, along, points[:, 0]), np.interp(s, along, points[:, 1])])
    a = np.array([np.interp(s - 0.3, along, points[:, 0]), np.interp(s - 0.3, along, points[:, 1])])
    b = np.array([np.interp(s + 0.3, along, points[:, 0]), np.interp(s + 0.3, along, points[:, 1])])
    d = b - a
    if np.hypot(*d) < 1e-9:
        return None
    d = d / np.hypot(*d)
    n = np.array([-d[1], d[0]])
    t1, t2 = _ray(p, n, segments), _ray(p, -n, segments)
    if t1 is None or t2 is None:
        return None
    return np.array([p + (t1 + 0.05) * n, p - (t2 + 0.05) * n])


def _ray(p: FloatArray, u: FloatArray, segments: Segments) -> float | None:
    """Distance along the ray p + t u to the nearest segment (within REACH_M), or None."""
    a, e = segments[:, :2], segments[:, 2:] - segments[:, :2]
    den = u[0] * e[:, 1] - u[1] * e[:, 0]
    ok = np.abs(den) > 1e-12
    w = a - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / den
        v = (w[:, 0] * u[1] - w[:, 1] * u[0]) / den
    hit = ok & (t > 0) & (v >= 0) & (v <= 1) & (t <= REACH_M)
    return float(t[hit].min()) if hit.any() else None
