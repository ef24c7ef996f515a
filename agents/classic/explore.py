"""The classic explore agent (2018): map an unknown hospital, park backwards, find the object.

It is given nothing of the building (`info["task"]` holds the rules only) and senses with the LRF
and odometry. It thinks in its odometry frame at reset. Each step:

    scan -> pose (odometry; optionally corrected by correlative scan-to-map matching against the
            agent's own grid, `scan_matching`, off by default: see `ExploreAgentConfig`)
         -> occupancy grid (log-odds along every beam: free before the end point, occupied at it)
         -> state machine -> Dijkstra on the planning grid (occupancy inflated by the footprint,
            unknown cells blocked) -> path (string-pulled) -> potential field -> safety filter

The states:

    LOOK      turn a full circle in place; facing back, fit the parking wall (the nearest wall
              behind the start) from the scan
    EXPLORE   frontier exploration: the nearest reachable frontier (free cells next to unknown
              ones), weighted by its size; a frontier the robot makes no progress towards is
              given up; done when no frontier is left (or the exploration budget is spent)
    PARK      drive to 0.4 m in front of the parking wall, turn to point away from it
    REVERSE   back up at 0.06 m/s with the heading held until the odometry keeps counting while
              the scan stops moving (the wall is touched), then stand still
    SEARCH    with the map kept as it was at parking, look for what it does not explain and
              stands free in the scan (the object, placed once the robot has parked); go into
              the rooms not looked into since parking, those that need the most doors to reach
              first (the course's hint; rooms and doors cut from the map at its narrow
              passages, `_room_depths`), nearest first
    APPROACH  drive to 0.5 m from the object, face it, creep in until the LRF reads 0.3 m
    FOUND     stand still (the env counts the find after 1 s)

Hand-written in numpy and numba: this is the course's subject. Not built: a scan matcher that
beats the odometry (the correlative one here random-walks the heading), loop closure, reading
the prior map of a start in "find" (it maps again from the parked start, and searches
nearest-first).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from pico_gym.agents.base import Agent, RobotSpec
from pico_gym.agents.classic.astar import string_pull
from pico_gym.agents.classic.localisation import scan_points
from pico_gym.agents.classic.potential_field import (
    attract_and_repel,
    footprint_clearance,
    footprint_distance,
    heading_rate,
    keep_in_view,
    motion_for,
    safe_turn,
    safety_filter,
)
from pico_gym.jit import njit
from pico_gym.overlay import Overlay
from pico_gym.tasks.explore import OccupancyBelief
from pico_gym.types import FloatArray, Pose
from pico_gym.world.geometry import compose, inverse, wrap_angle
from pico_gym.world.grid import CostGrid, Grid


class State(Enum):
    LOOK = "look"
    EXPLORE = "explore"
    PARK = "park"
    REVERSE = "reverse"
    PARKED = "parked"
    SEARCH = "search"
    APPROACH = "approach"
    FOUND = "found"


@dataclass(frozen=True)
class ExploreAgentConfig:
    """Settings of the classic explore agent (times in seconds, converted with the control period).

    Attributes:
        cell_m: the occupancy grid's cell [m]; plan_cell_m: the planning grid's.
        size_m: the side of the square the occupancy grid covers, centred on the start [m].
        map_range_m: beams mark free space up to this range (farther, the pose's angular error
            smears the map) [m].
        beam_stride: every this-many-th beam updates the map.
        hit, miss, clamp: log-odds added at an end point, along a beam, and their bound.
        occupied, free: log-odds above which a cell is occupied, below which it is free.
        inflate_m: cells closer than this to an occupied cell are blocked for planning [m].
        comfort_m: cells closer than this cost more (the path keeps off the walls) [m].
        narrow_m: where the path's clearance is below this, the robot drives sideways [m].
        cruise_mps: speed in open space [m/s].
        frontier_min_cells: smaller frontiers are ignored.
        replan_s: how often the plan is remade.
        give_up_s: a target approached by less than 0.2 m in this long is given up.
        explore_budget_s: exploration stops after this long, to leave time to park and find.
        park_standoff_m: the centre's distance to the parking wall before reversing [m].
        reverse_mps: the reversing speed (the rule allows 0.1 m/s at contact) [m/s].
        object_hits: evidence needed for an unexplained cluster to be the object.
        object_max_m: only runs of beams this short, standing free, count as evidence [m].
        room_join_m, room_middle_m: the room/door graph's cut (`_room_depths`): free cells
            farther than `room_join_m` from the walls, grouped, are a room's middle where the
            walls are `room_middle_m` away somewhere in them (a 2018 room is 2.0 m or wider, a
            hallway 1.8 m or narrower, a door 1.5 m or narrower) [m].
        stop_range_m: the final creep stops when the LRF reads this towards the object [m].
        scan_matching: correct the odometry by correlative scan-to-map matching. Off by default:
            measured, its accepted corrections (1 cm, 0.11 deg steps) random-walk the heading by
            1-3 deg a minute, while the course's odometry drifts 0.2-0.6 deg a minute.
        safety_floor_m: the safety filter lets nothing come closer to the footprint than this
            plus twice the LRF's noise, and tries a command without its turn before scaling it
            down (`MotionConfig.floor`, `drop_turn`; the hospital agent's): measured on dev
            seeds 100-129, bumps 13.3 % -> 3.3 % (0: the old filter).
        blind_memory_s: the blind sector is covered by the cells the LRF hit within this long
            (0: ever). The odometry drifts 0.1-0.3 m over the minutes between mapping a door and
            coming back to it, so an old hit stands where the jamb was seen then, not where it
            is now relative to the pose: the robot was held by such phantom jambs (and searched
            until the time ran out). What is behind the robot it saw moments ago. Measured on
            dev seeds 100-159 and 200-259, successes of 120 (bumps): 107 (1) with every hit ever,
            110 (1) within 60 s, 112 (1) within 120 s, 113 (0) within 240 s.
        square_gain, square_min, square_window_deg: the heading pulled towards the building's
            axes (a 2018 hospital is rectilinear: every wall is parallel or perpendicular to the
            others, `_wall_directions`): the walls' direction modulo 90 deg in each scan against
            the one seen while turning at the start; where the scan's pieces of wall agree
            (their mean resultant of 4a is `square_min` or more) and it is within
            `square_window_deg` of the start's, the heading moves `square_gain` of the way per
            step. Off by default (0): measured on dev seeds 100-159 and 200-259, the pose holds
            within 0.5 deg and 9 cm over 10 minutes where odometry alone drifts 2-3 deg and
            0.3-1 m (dev 153, 216, 240), and the maps come out straight, but the successes did
            not follow (108 of 120 at gain 0.02, 111 with `blind_memory_s` 0, against 113): what
            fails is the narrow doors, not the pose.
    """

    cell_m: float = 0.05
    plan_cell_m: float = 0.1
    size_m: float = 48.0
    map_range_m: float = 5.0
    beam_stride: int = 3
    hit: float = 0.9
    miss: float = 0.4
    clamp: float = 6.0
    occupied: float = 1.0
    free: float = -1.0
    inflate_m: float = 0.13
    comfort_m: float = 0.4
    narrow_m: float = 0.33
    cruise_mps: float = 0.4
    frontier_min_cells: int = 5
    replan_s: float = 1.0
    give_up_s: float = 10.0
    explore_budget_s: float = 420.0
    park_standoff_m: float = 0.4
    reverse_mps: float = 0.06
    object_hits: float = 8.0
    object_max_m: float = 0.8
    room_join_m: float = 0.92
    room_middle_m: float = 1.02
    stop_range_m: float = 0.3
    scan_matching: bool = False
    square_gain: float = 0.0
    square_min: float = 0.6
    square_window_deg: float = 5.0
    safety_floor_m: float = 0.015
    blind_memory_s: float = 240.0


# --- grids (numba) ------------------------------------------------------------------------------


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


@njit
def _best_pose(
    points: np.ndarray,
    logodds: np.ndarray,
    x0: float,
    y0: float,
    res: float,
    px: float,
    py: float,
    theta: float,
    span_xy: float,
    step_xy: float,
    span_th: float,
    step_th: float,
    cap: float,
) -> tuple[float, float, float, float, float]:
    """Correlative scan matching: of the poses within the spans around (px, py, theta), the one
    whose end points land on the most occupied map (each scores its cell's log-odds, clipped to
    [0, cap]); returns it with its score and the score of the centre pose."""
    rows, cols = logodds.shape
    n_xy = int(round(span_xy / step_xy))
    n_th = int(round(span_th / step_th))
    best = (-1.0, px, py, theta)
    centre = 0.0
    for it in range(-n_th, n_th + 1):
        th = theta + it * step_th
        c, s = math.cos(th), math.sin(th)
        for ix in range(-n_xy, n_xy + 1):
            for iy in range(-n_xy, n_xy + 1):
                x, y = px + ix * step_xy, py + iy * step_xy
                score = 0.0
                for k in range(points.shape[0]):
                    wx = x + c * points[k, 0] - s * points[k, 1]
                    wy = y + s * points[k, 0] + c * points[k, 1]
                    col = int(math.floor((wx - x0) / res))
                    row = int(math.floor((wy - y0) / res))
                    if 0 <= row < rows and 0 <= col < cols:
                        v = logodds[row, col]
                        if v > 0.0:
                            score += min(v, cap)
                # Ties go to the pose nearest the prediction.
                penalty = 1e-6 * (abs(ix) + abs(iy) + abs(it))
                if score - penalty > best[0]:
                    best = (score - penalty, x, y, th)
                if ix == 0 and iy == 0 and it == 0:
                    centre = score
    return best[1], best[2], best[3], best[0], centre


@njit
def _wall_directions(
    ranges: FloatArray, angles: FloatArray, gap: int, stride: int, max_r: float
) -> tuple[float, float, int]:
    """The walls' directions in a scan, modulo 90 deg: the sum of (cos 4a, sin 4a) over the
    directions a (robot frame) of straight pieces of wall (three end points, `gap` beams apart,
    8-60 cm end to end, the middle within 1.5 cm of the line through the other two), and how
    many pieces. A rectilinear building's walls all give one 4a; corners and clutter fail the
    straightness test or scatter."""
    c4 = 0.0
    s4 = 0.0
    n = 0
    for k in range(0, ranges.shape[0] - 2 * gap, stride):
        r0, r1, r2 = ranges[k], ranges[k + gap], ranges[k + 2 * gap]
        if r0 < 0.1 or r1 < 0.1 or r2 < 0.1 or r0 > max_r or r1 > max_r or r2 > max_r:
            continue
        x0, y0 = r0 * math.cos(angles[k]), r0 * math.sin(angles[k])
        x1, y1 = r1 * math.cos(angles[k + gap]), r1 * math.sin(angles[k + gap])
        x2, y2 = r2 * math.cos(angles[k + 2 * gap]), r2 * math.sin(angles[k + 2 * gap])
        ex, ey = x2 - x0, y2 - y0
        length = math.hypot(ex, ey)
        if length < 0.08 or length > 0.6:
            continue
        if abs(ex * (y1 - y0) - ey * (x1 - x0)) / length > 0.015:
            continue
        a = 4.0 * math.atan2(ey, ex)
        c4 += math.cos(a)
        s4 += math.sin(a)
        n += 1
    return c4, s4, n


@njit
def _distance_transform(blocked: np.ndarray, res: float, cap: float) -> np.ndarray:
    """Distance from each cell centre to the nearest blocked cell (two-pass chamfer, 1 / sqrt 2)."""
    rows, cols = blocked.shape
    d = np.full((rows, cols), cap)
    diag = math.sqrt(2.0) * res
    for r in range(rows):
        for c in range(cols):
            if blocked[r, c]:
                d[r, c] = 0.0
    for r in range(rows):
        for c in range(cols):
            v = d[r, c]
            if r > 0:
                v = min(v, d[r - 1, c] + res)
                if c > 0:
                    v = min(v, d[r - 1, c - 1] + diag)
                if c < cols - 1:
                    v = min(v, d[r - 1, c + 1] + diag)
            if c > 0:
                v = min(v, d[r, c - 1] + res)
            d[r, c] = v
    for r in range(rows - 1, -1, -1):
        for c in range(cols - 1, -1, -1):
            v = d[r, c]
            if r < rows - 1:
                v = min(v, d[r + 1, c] + res)
                if c > 0:
                    v = min(v, d[r + 1, c - 1] + diag)
                if c < cols - 1:
                    v = min(v, d[r + 1, c + 1] + diag)
            if c < cols - 1:
                v = min(v, d[r, c + 1] + res)
            d[r, c] = v
    return d


@njit
def _label(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """8-connected components of `mask`: per cell its component's number (0 outside the mask,
    1, 2, ... inside) and, by number, the components' sizes (compiled: the search labels
    thousands of cells a second)."""
    rows, cols = mask.shape
    label = np.zeros((rows, cols), dtype=np.int64)
    sizes = [0]
    stack = np.empty(rows * cols, dtype=np.int64)
    for r0 in range(rows):
        for c0 in range(cols):
            if not mask[r0, c0] or label[r0, c0]:
                continue
            n = len(sizes)
            label[r0, c0] = n
            top, count = 1, 0
            stack[0] = r0 * cols + c0
            while top:
                top -= 1
                r, c = stack[top] // cols, stack[top] % cols
                count += 1
                for dr in (-1, 0, 1):
                    for dc in (-1, 0, 1):
                        rr, cc = r + dr, c + dc
                        if 0 <= rr < rows and 0 <= cc < cols and mask[rr, cc] and not label[rr, cc]:
                            label[rr, cc] = n
                            stack[top] = rr * cols + cc
                            top += 1
            sizes.append(count)
    return label, np.array(sizes)


@njit
def _component_sizes(mask: np.ndarray) -> np.ndarray:
    """Per cell, the size of its 8-connected component of `mask` (0 outside the mask)."""
    label, sizes = _label(mask)
    return sizes[label]


@njit
def _grow(label: np.ndarray, space: np.ndarray, steps: int) -> np.ndarray:
    """`label`'s regions grown into the unlabelled cells of `space`, `steps` 8-neighbour steps at
    most, breadth first (each cell to the region that reaches it first)."""
    rows, cols = label.shape
    out = label.copy()
    front = np.empty(rows * cols, dtype=np.int64)
    n = 0
    for r in range(rows):
        for c in range(cols):
            if out[r, c]:
                front[n] = r * cols + c
                n += 1
    for _ in range(steps):
        grown = np.empty(rows * cols, dtype=np.int64)
        m = 0
        for i in range(n):
            r, c = front[i] // cols, front[i] % cols
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = r + dr, c + dc
                    if 0 <= rr < rows and 0 <= cc < cols and space[rr, cc] and not out[rr, cc]:
                        out[rr, cc] = out[r, c]
                        grown[m] = rr * cols + cc
                        m += 1
        front, n = grown, m
    return out


def _room_depths(
    free: np.ndarray, walls: np.ndarray, start: tuple[int, int], res: float, join_m: float, room_m: float
) -> np.ndarray:
    """Per free cell, how many rooms one passes through to reach it from `start`, the start's own
    room or hallway not counted (0 elsewhere and in the start's part; -1 where unreachable).

    Rooms are cut from the free space at its narrow passages: the free cells farther than
    `join_m` from every wall cell, grouped (a door narrower than 2 `join_m` cuts them), make a
    room's core where somewhere in them the walls are `room_m` away (a room's middle, not a
    hallway's); each core is grown back over the free cells within `join_m` + 0.1 m of it.
    What no core reaches (a narrow hallway, a door's middle, a room's corners) joins no room:
    passing through it counts nothing. A room's depth is the fewest rooms entered on the way to
    it, itself included (the course's "doors to reach it" for rooms hanging off a hallway as a
    tree). A core within 1 m of the start is the hallway's (a wide hallway has one)."""
    clearance = _distance_transform(walls, res, 2.0 * room_m)
    cores, _ = _label(free & (clearance > join_m))
    widest = np.zeros(int(cores.max()) + 1)
    np.maximum.at(widest, cores.ravel(), clearance.ravel())
    keep = widest >= room_m
    keep[0] = False
    cores = (np.cumsum(keep) * keep)[cores]
    rooms = _grow(cores, free, int(round(join_m / res)) + 1)
    gaps, _ = _label(free & (rooms == 0))
    # Nodes: the rooms 1..R, then the gaps R+1..R+G.
    n_rooms = int(rooms.max())
    node = np.where(rooms > 0, rooms, np.where(gaps > 0, gaps + n_rooms, 0))
    n = int(node.max()) + 1
    links = [set() for _ in range(n)]
    pairs = (
        (node[1:, :], node[:-1, :]),
        (node[:, 1:], node[:, :-1]),
        (node[1:, 1:], node[:-1, :-1]),
        (node[1:, :-1], node[:-1, 1:]),
    )
    for a, b in pairs:
        touch = (a != b) & (a > 0) & (b > 0)
        for u, v in set(zip(a[touch].tolist(), b[touch].tolist(), strict=True)):
            links[u].add(v)
            links[v].add(u)
    depth = np.full(n, -1)
    first = int(node[start])
    k = int(round(1.0 / res))
    r, c = start
    near = cores[max(r - k, 0) : r + k + 1, max(c - k, 0) : c + k + 1]
    if near.any():
        first = int(np.bincount(near[near > 0]).argmax())  # the hallway's core
    if first == 0:
        return np.where(free, -1, 0)
    # 0-1 breadth first: entering a room costs one, a gap nothing.
    depth[first] = 0
    queue = [first]
    while queue:
        u = queue.pop(0)
        for v in links[u]:
            d = depth[u] + (1 if v <= n_rooms else 0)
            if depth[v] < 0 or d < depth[v]:
                depth[v] = d
                if v <= n_rooms:
                    queue.append(v)
                else:
                    queue.insert(0, v)
    out = np.where(node > 0, depth[node], 0)
    return np.where(free, out, 0)


def _components(mask: np.ndarray) -> list[np.ndarray]:
    """8-connected components of a boolean mask, as arrays of (row, col)."""
    seen = np.zeros(mask.shape, dtype=bool)
    out = []
    for r0, c0 in np.argwhere(mask):
        if seen[r0, c0]:
            continue
        stack = [(int(r0), int(c0))]
        seen[r0, c0] = True
        cells = []
        while stack:
            r, c = stack.pop()
            cells.append((r, c))
            for rr, cc in (
                (r + 1, c),
                (r - 1, c),
                (r, c + 1),
                (r, c - 1),
                (r + 1, c + 1),
                (r + 1, c - 1),
                (r - 1, c + 1),
                (r - 1, c - 1),
            ):
                if 0 <= rr < mask.shape[0] and 0 <= cc < mask.shape[1] and mask[rr, cc] and not seen[rr, cc]:
                    seen[rr, cc] = True
                    stack.append((rr, cc))
        out.append(np.array(cells))
    return out


# --- the agent ----------------------------------------------------------------------------------


def _free_standing(ranges: FloatArray, angles: FloatArray, longest_m: float, jump_m: float = 0.15) -> np.ndarray:
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


def _opening(cells: np.ndarray, unknown: np.ndarray, occupied: np.ndarray, half: int = 3) -> bool:
    """Whether a small frontier opens into the unknown (a door seen at a grazing angle) rather
    than into a gap of a mapped wall: beside some unknown cell it touches, across the way into
    it, at least 5 of the 7 cells are not occupied."""
    rows, cols = unknown.shape
    for r, c in cells:
        for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            ur, uc = r + dr, c + dc
            if not (0 <= ur < rows and 0 <= uc < cols and unknown[ur, uc]):
                continue
            clear = 0
            for k in range(-half, half + 1):
                qr, qc = ur + k * dc, uc + k * dr  # across the direction (dr, dc)
                clear += 0 <= qr < rows and 0 <= qc < cols and not occupied[qr, qc]
            if clear >= 2 * half - 1:
                return True
    return False


class ExploreAgent(Agent):
    """The classic explore strategy (see the module docstring)."""

    name = "classic"

    def __init__(self, spec: RobotSpec, config: ExploreAgentConfig | None = None) -> None:
        super().__init__(spec)
        self.config = config or ExploreAgentConfig()
        floor = self.config.safety_floor_m
        self.motion = dataclasses.replace(
            motion_for(spec), floor=floor + 2.0 * spec.lrf.noise_m if floor > 0 else 0.0, drop_turn=floor > 0
        )
        self.follow = dataclasses.replace(self.motion, repulsion_range=0.15, repulsion_gain=0.004)
        self.angles = np.ascontiguousarray(spec.beam_angles, dtype=np.float64)
        self._steps = lambda seconds: max(1, round(seconds / spec.dt_s))
        # The beams straight ahead: backing up along the heading lengthens them by exactly the
        # distance moved, whatever the wall they hit (beams to the side may hit walls parallel to
        # the motion, which do not move at all).
        self._front = np.flatnonzero(np.abs(self.angles) < 0.02)

    # --- episode ----------------------------------------------------------------------------
    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:
        cfg = self.config
        task = (info or {}).get("task")
        self.phase = getattr(task, "phase", "explore")
        odom = Pose(*(float(v) for v in obs["odom"]))
        n = int(round(cfg.size_m / cfg.cell_m))
        n += n % 2
        # The agent's frame is the odometry frame at reset; the grid is centred on the start.
        self.grid = Grid(odom.x - 0.5 * cfg.size_m, odom.y - 0.5 * cfg.size_m, cfg.cell_m, (n, n))
        self.plan_grid = Grid(self.grid.x0, self.grid.y0, cfg.plan_cell_m, (n // 2, n // 2))
        self.logodds = np.zeros((n, n), dtype=np.float64)
        self.hits = np.zeros((n, n), dtype=np.uint16)
        self.last_hit = np.zeros((n, n), dtype=np.int32)  # the step of each cell's latest hit
        self.checked = np.zeros((n // 2, n // 2), dtype=bool)
        self.known = (n, 0, n, 0)  # rows and columns (fine cells) the beams may have reached
        self._coarse_step = -1
        self.correction = Pose(0.0, 0.0, 0.0)  # agent frame <- odometry frame
        self.pose = odom
        self.start = odom
        self.steps = 0
        self.state_steps = 0
        self.state = State.LOOK
        self.turned = 0.0
        self.previous_odom = odom
        self.previous_ranges: FloatArray | None = None
        self.wall: tuple[FloatArray, FloatArray] | None = None  # (point, unit normal into the building)
        self.path: list[FloatArray] = []
        self.plan_step = -(10**9)
        self.goal: FloatArray | None = None
        self.best = math.inf
        self.best_step = 0
        self.given_up: list[FloatArray] = []
        self.stuck = 0
        self.reversed_m = 0.0
        self.stored: np.ndarray | None = None
        self.before_touch: np.ndarray | None = None
        self.axes = np.zeros(2)  # the walls' (cos 4a, sin 4a) summed in the agent frame while looking
        self.depths: np.ndarray | None = None  # rooms entered to reach each planning cell (at parking)
        self.evidence = np.zeros((n // 2, n // 2))
        self.object: FloatArray | None = None
        self.fits = 0
        self.frontiers: list[FloatArray] = []
        self.backoff_until = 0
        self.unstick_until = 0
        self.still_steps = 0
        self.unsticks = 0
        self._lrf_points = 0
        self.step_out_until = 0
        self.step_out = (0.0, 0.0, 0.0)
        self.retried: list[FloatArray] = []
        self.at_standoff = False
        self.small_goal = False

    def belief(self) -> None:
        """No pose on a given map to report (the explore agent has no map frame to localise in)."""
        return None

    def map_belief(self) -> OccupancyBelief:
        """The agent's occupancy grid in its odometry frame at reset (for `env.belief_iou`)."""
        cfg = self.config
        cells = np.full(self.logodds.shape, -1, dtype=np.int8)
        cells[self.logodds < cfg.free] = 0
        cells[self.logodds > cfg.occupied] = 1
        return OccupancyBelief(cells, (self.grid.x0, self.grid.y0), self.grid.resolution)

    def _go(self, state: State) -> None:
        self.state = state
        self.state_steps = 0
        self.path = []
        self.plan_step = -(10**9)
        self.best = math.inf
        self.best_step = self.steps

    # --- the step -------------------------------------------------------------------------------
    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        cfg = self.config
        ranges = np.asarray(obs["lrf"], dtype=np.float64)
        odom = Pose(*(float(v) for v in obs["odom"]))
        self.steps += 1
        self.state_steps += 1
        delta = compose(inverse(self.previous_odom), odom)
        self.pose = compose(compose(self.correction, self.previous_odom), delta)
        self._align(ranges)
        if cfg.square_gain > 0.0:
            self._square(ranges)
        self.correction = compose(self.pose, inverse(odom))
        g = self.grid
        _integrate(
            self.logodds,
            self.hits,
            self.last_hit,
            self.steps,
            self.checked,
            g.x0,
            g.y0,
            g.resolution,
            self.pose.x,
            self.pose.y,
            self.pose.theta,
            self.angles,
            ranges,
            cfg.beam_stride,
            self.spec.lrf.range_max_m,
            cfg.map_range_m,
            cfg.hit,
            cfg.miss,
            cfg.clamp,
        )
        reach = int(math.ceil(cfg.map_range_m / g.resolution)) + 2
        r, c = int((self.pose.y - g.y0) / g.resolution), int((self.pose.x - g.x0) / g.resolution)
        k0, k1, k2, k3 = self.known
        n = self.logodds.shape[0]
        self.known = (
            max(min(k0, r - reach), 0),
            min(max(k1, r + reach), n),
            max(min(k2, c - reach), 0),
            min(max(k3, c + reach), n),
        )
        near = scan_points(ranges, self.angles, self.spec.lrf.range_max_m, len(ranges))
        near = near[np.hypot(near[:, 0], near[:, 1]) < 1.2]
        behind = self._mapped_near(0.7)
        blind = np.abs(np.arctan2(behind[:, 1], behind[:, 0])) > self.spec.lrf.angle_max_rad - 0.05
        # The map covers the LRF's blind sector, its points pulled towards the footprint (`_wary`:
        # a cell centre may lie beyond its wall). The potential field and the safety filters see
        # the same points (the field seeing them where they were mapped: dev seeds 100-129, bumps
        # 3.3 -> 13.3 %); the field's local minimum they make in a doorway (dev seed 123: 500 s
        # still) is escaped in `_follow`.
        self._lrf_points = len(near)
        near = np.vstack([near, self._wary(behind[blind])])
        if self.stored is not None:
            self._look_for_object(ranges)
        moving = math.hypot(delta.x, delta.y) > 0.003 or abs(delta.theta) > 0.01
        waiting = self.state in (State.PARKED, State.FOUND, State.REVERSE)
        self.still_steps = 0 if moving or waiting else self.still_steps + 1
        if moving:
            self.unsticks = 0
        if self.still_steps > self._steps(8.0):
            self.unstick_until = self.steps + self._steps(1.5)
            self.unsticks += 1
            self.still_steps = 0
            self.path = []
        if self.steps < self.unstick_until:
            # Boxed in (the filters stop every way the plan wants): towards the most open
            # direction in view, whatever the plan, then plan again (the 30 s idle rule).
            view = np.abs(self.angles) < 1.6
            k = int(np.argmax(np.where(view, ranges, -1.0)))
            a = float(self.angles[k])
            command = (0.12 * math.cos(a), 0.12 * math.sin(a), 0.0)
            vx, vy, w = safety_filter(near, command, self.motion)
            if vx == vy == 0.0 and self.unsticks >= 2:
                # Wedged for 16 s, every way refused within the filters' margins (a jamb 2 cm
                # beside it: dev seed 208): the idle rule ends the episode at 30 s, so it edges
                # out with the margins cut to 1 cm and what the LRF sees now.
                tight = dataclasses.replace(self.motion, margin=0.01, floor=0.01, slack=0.005)
                vx, vy, w = safety_filter(near[: self._lrf_points], command, tight)
            self.previous_odom = odom
            self.previous_ranges = ranges
            return np.array([vx, vy, w], dtype=np.float32)
        vx, vy, w = getattr(self, f"_{self.state.value}")(ranges, near, odom, delta)
        if self.state is not State.REVERSE:
            vx, vy, w = self._filtered(near, vx, vy, w)
        self.previous_odom = odom
        self.previous_ranges = ranges
        return np.array([vx, vy, w], dtype=np.float32)

    def _align(self, ranges: FloatArray) -> None:
        """Correlative scan-to-map matching around the odometry prediction (within 3 cm and
        0.9 deg: odometry drifts far less than that in a step, so a larger jump would be a bad
        match, e.g. a room seen for the first time)."""
        cfg = self.config
        if self.steps < 3 or not cfg.scan_matching:
            return
        points = scan_points(ranges, self.angles, min(cfg.map_range_m, self.spec.lrf.range_max_m), 180)
        if len(points) < 40:
            return
        g = self.grid
        p = self.pose
        x, y, th, score, centre = _best_pose(
            points, self.logodds, g.x0, g.y0, g.resolution, p.x, p.y, p.theta, 0.03, 0.01, 0.016, 0.002, 3.0
        )
        if score > 1.02 * centre + 1.0:
            self.pose = Pose(float(x), float(y), float(th))
            self.fits += 1

    def _square(self, ranges: FloatArray) -> None:
        """The heading pulled towards the building's axes (`square_gain`); while turning at the
        start, the axes are learnt (summed in the agent frame)."""
        cfg = self.config
        c4, s4, n = _wall_directions(ranges, self.angles, 8, 4, 4.0)
        if n < 20:
            return
        t4 = 4.0 * self.pose.theta
        wc, ws = c4 * math.cos(t4) - s4 * math.sin(t4), c4 * math.sin(t4) + s4 * math.cos(t4)
        if self.state is State.LOOK:
            self.axes += (wc, ws)
            return
        if not self.axes.any() or math.hypot(c4, s4) < cfg.square_min * n:
            return
        error = wrap_angle(math.atan2(ws, wc) - math.atan2(self.axes[1], self.axes[0])) / 4.0
        if abs(error) < math.radians(cfg.square_window_deg):
            self.pose = Pose(self.pose.x, self.pose.y, wrap_angle(self.pose.theta - cfg.square_gain * error))

    # --- states -------------------------------------------------------------------------------
    def _look(self, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> tuple[float, float, float]:
        if self.phase == "find" and self.state_steps <= self._steps(3.0):
            return 0.1, 0.0, 0.0  # started parked: off the wall before turning (0.3 m)
        self.turned += abs(delta.theta)
        behind = abs(wrap_angle(self.pose.theta - self.start.theta - math.pi))
        if self.wall is None and behind < 0.1 and self.phase != "find":
            self._fit_wall(ranges)
        if self._safe_turn(near, 1.0) < 0.5:
            # Too close to something to turn: away from it first (the start may be near a wall).
            v = attract_and_repel(
                near, np.zeros(2), dataclasses.replace(self.follow, repulsion_range=0.4, repulsion_gain=0.02), speed=0.1
            )
            return float(v[0]), float(v[1]), 0.0
        if self.turned >= 2 * math.pi + 0.2:
            if self.wall is None:  # nothing seen behind: assume the wall 0.6 m behind the start
                back = np.array([math.cos(self.start.theta), math.sin(self.start.theta)])
                self.wall = (np.array([self.start.x, self.start.y]) - 0.7 * back, back)
            self._go(State.SEARCH if self.phase == "find" else State.EXPLORE)
            if self.phase == "find":
                self.stored = self.logodds.copy()
                self.checked[:] = False
            return 0.0, 0.0, 0.0
        return 0.0, 0.0, 1.0

    def _fit_wall(self, ranges: FloatArray) -> None:
        """The parking wall: a line through the nearest points straight ahead (the robot faces back)."""
        pts = scan_points(ranges, self.angles, 2.0, len(ranges))
        keep = np.abs(np.arctan2(pts[:, 1], pts[:, 0])) < 0.45
        pts = pts[keep]
        if len(pts) < 20:
            return
        # The wall faces the robot within about 15 deg: keep the points near the depth straight
        # ahead (the side walls' points, nearer, would tilt the line).
        ahead = (
            float(np.median(pts[np.abs(pts[:, 1]) < 0.05, 0]))
            if (np.abs(pts[:, 1]) < 0.05).sum() >= 3
            else float(pts[:, 0].max())
        )
        pts = pts[np.abs(pts[:, 0] - ahead) < 0.15 + 0.3 * np.abs(pts[:, 1])]
        if len(pts) < 15:
            return
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        world = np.column_stack(
            [self.pose.x + c * pts[:, 0] - s * pts[:, 1], self.pose.y + s * pts[:, 0] + c * pts[:, 1]]
        )
        centre = world.mean(axis=0)
        _, _, vt = np.linalg.svd(world - centre)
        direction = vt[0]
        normal = np.array([-direction[1], direction[0]])
        start = np.array([self.start.x, self.start.y])
        if (start - centre) @ normal < 0:
            normal = -normal
        self.wall = (centre, normal)

    def _explore(self, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> tuple[float, float, float]:
        cfg = self.config
        if self.steps * self.spec.dt_s > cfg.explore_budget_s:
            self._go(State.PARK)
            return 0.0, 0.0, 0.0
        if self._replan_due():
            found = self._plan_to_frontier(self._unknown_mask())
            fresh = [q for q in self.given_up if not any(np.linalg.norm(q - r) < 0.3 for r in self.retried)]
            if not found and fresh:
                # Only frontiers given up on are left: they may have become reachable since (each
                # gets one more try).
                self.retried += fresh
                self.given_up = [q for q in self.given_up if not any(q is f for f in fresh)]
                found = self._plan_to_frontier(self._unknown_mask())
            self.small_goal = False
            if not found:
                # A door seen only at a grazing angle leaves a frontier of a cell or two (dev
                # seeds 106, 107: a room never entered): look at the small ones before parking.
                # Most are gaps in a mapped wall: one looked at from within 1 m is done (a door
                # there would have shown the room behind it, a large frontier).
                found = self.small_goal = self._plan_to_frontier(self._unknown_mask(), min_cells=1)
            if not found:
                self._go(State.PARK)
                return 0.0, 0.0, 0.0
        if self.small_goal and self.goal is not None:
            if np.linalg.norm(self.goal - np.array([self.pose.x, self.pose.y])) < 1.0:
                self.given_up.append(self.goal.copy())
                self.goal = None
                self.path = []
                return 0.0, 0.0, 0.0
        return self._follow(near)

    def _park(self, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> tuple[float, float, float]:
        cfg = self.config
        if not self.at_standoff and (self.state_steps == 1 or self._replan_due()):
            self._parking_spot()
        point, normal = self.wall
        foot = self.park_foot
        standoff = foot + normal * cfg.park_standoff_m
        here = np.array([self.pose.x, self.pose.y])
        heading = math.atan2(normal[1], normal[0])
        distance = float(np.linalg.norm(standoff - here))
        if distance < 0.4:  # (the path ends within 0.2 m of its goal cell)
            # Servo onto the stand-off point facing it (the way there may lie behind the robot,
            # in the LRF's blind sector), then turn in place to face away from the wall, then
            # reverse. Hysteresis: the turn may shift the centre a few centimetres.
            if distance < 0.04:
                self.at_standoff = True
            elif distance > 0.12:
                self.at_standoff = False
            v = self._to_robot(standoff) * 1.5
            speed = float(np.hypot(*v))
            if speed > 0.15:
                v *= 0.15 / speed
            if not self.at_standoff:
                error = wrap_angle(math.atan2(*(standoff - here)[::-1]) - self.pose.theta)
                turn = heading_rate(error, self.motion)
                return (float(v[0]), float(v[1]), turn) if abs(error) < 0.5 else (0.0, 0.0, turn)  # face it first
            error = wrap_angle(heading - self.pose.theta)
            # A door jamb beside the parking spot may leave no room to turn the last few degrees
            # (dev seed 117: 6 cm beside the robot, 11 deg to go, 400 s at the stand-off): within
            # the rule's 15 deg, reverse at the heading it has (the reverse corrects it if it can).
            cramped = abs(error) < 0.25 and self._filtered(near, 0.0, 0.0, heading_rate(error, self.motion))[2] == 0.0
            if distance < 0.06 and (abs(error) < 0.03 or cramped):
                self._go(State.REVERSE)
                self.stuck = 0
                self.reversed_m = 0.0
                self.reverse_log: list[tuple[float, FloatArray]] = []
                return 0.0, 0.0, 0.0
            return float(v[0]), float(v[1]), heading_rate(error, self.motion)
        if self._replan_due():
            if not self._plan_to(standoff):
                self.given_up.clear()
                return 0.0, 0.0, 0.6  # turn and look: the map may open a way
        return self._follow(near)

    def _parking_spot(self) -> None:
        """Refit the parking wall to the map, and pick where on it to park: behind the start if
        the way back from the stand-off is clear, else the nearest place along the wall that is
        (a room's wall may meet the parking wall beside the start: dev seed 126 reversed into it).
        The wall fitted at the start from one scan, 0.35-1 m away, may be off by 10 deg."""
        cfg = self.config
        point, normal = self.wall
        along = np.array([normal[1], -normal[0]])
        start = np.array([self.start.x, self.start.y])
        foot = point + along * float((start - point) @ along)
        g = self.grid
        k = int(2.0 / g.resolution)
        r0 = int((foot[1] - g.y0) / g.resolution)
        c0 = int((foot[0] - g.x0) / g.resolution)
        window = self.logodds[max(r0 - k, 0) : r0 + k + 1, max(c0 - k, 0) : c0 + k + 1]
        rows, cols = np.nonzero(window > cfg.occupied)
        pts = np.column_stack(
            [
                g.x0 + (cols + max(c0 - k, 0) + 0.5) * g.resolution,
                g.y0 + (rows + max(r0 - k, 0) + 0.5) * g.resolution,
            ]
        )
        for _ in range(2):  # the wall's cells near the foot, refitted
            rel = pts - foot
            on = (np.abs(rel @ normal) < 0.12) & (np.abs(rel @ along) < 1.0)
            if on.sum() < 10:
                break
            centre = pts[on].mean(axis=0)
            _, _, vt = np.linalg.svd(pts[on] - centre)
            fitted = np.array([-vt[0][1], vt[0][0]])
            fitted = fitted if fitted @ normal > 0 else -fitted
            if fitted @ self.wall[1] < math.cos(math.radians(20.0)):
                break
            normal = fitted
            along = np.array([normal[1], -normal[0]])
            foot = centre + along * float((start - centre) @ along)
        self.wall = (foot.copy(), normal)
        rel = pts - foot
        u, n = rel @ along, rel @ normal
        half = self.motion.half_width + 0.05
        depth = cfg.park_standoff_m + self.motion.half_depth + 0.05
        beside = (n > 0.07) & (n < depth)
        for t in sorted(np.arange(-0.6, 0.61, 0.05), key=abs):
            if not np.any(beside & (np.abs(u - t) < half)):
                self.park_foot = foot + along * t
                return
        self.park_foot = foot

    def _reverse(self, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> tuple[float, float, float]:
        cfg = self.config
        if self.state_steps == 1:  # its first step
            # The map to store: as it is before the rear touches. The object is placed once the
            # env counts the robot parked (0.5 s after the touch), seconds before this agent is
            # sure of the touch; a map stored later had the object in it where it stood in view
            # of the parking spot, and nothing there was ever unexplained (dev seed 466 passed
            # within 0.15 m of it and searched on until the time ran out).
            self.before_touch = self.logodds.copy()
        point, normal = self.wall
        heading = math.atan2(normal[1], normal[0])
        moved = -delta.x  # odometry says the robot moved back this much
        self.reversed_m += max(moved, 0.0)
        # Touched: over the last second the odometry counted at least 3 cm back while the scan
        # straight ahead moved less than a third of that, with the wall (as mapped) close behind.
        self.reverse_log.append((self.reversed_m, ranges[self._front]))
        # The rear edge's distance to the wall as the odometry has it (the corners touch first
        # when the heading is off).
        reach = self.motion.half_depth * math.cos(self.pose.theta - heading) + self.motion.half_width * abs(
            math.sin(self.pose.theta - heading)
        )
        gap = float((np.array([self.pose.x, self.pose.y]) - point) @ normal) - reach
        if len(self.reverse_log) > self._steps(1.0):
            then_m, then = self.reverse_log.pop(0)
            counted = self.reversed_m - then_m
            now = ranges[self._front]
            ok = (then < self.spec.lrf.range_max_m - 1e-6) & (now < self.spec.lrf.range_max_m - 1e-6)
            # Beams ahead that hit something in both scans, along the heading (nothing ahead in
            # range: the odometry's own gap decides below).
            ahead = (now[ok] - then[ok]) * np.cos(self.angles[self._front][ok])
            seen = float(np.median(ahead)) if ok.sum() >= 3 else counted
            self.stuck = self.stuck + 1 if counted > 0.03 and seen < counted / 3 and gap < 0.2 else 0
        # The odometry 8 cm past the wall (refitted to the map, within 2-3 cm): its wheels slip on
        # the spot (dev seed 102 counted 0.7 m against the wall, nothing ahead in range, and
        # searched with its pose 0.7 m off).
        if self.stuck >= 2 or gap < -0.08 or self.reversed_m > 1.0:
            # Touching: the centre is `reach` off the wall, whatever the odometry counted.
            here = np.array([self.pose.x, self.pose.y]) - normal * gap
            self.pose = Pose(float(here[0]), float(here[1]), self.pose.theta)
            self.correction = compose(self.pose, inverse(odom))
            self._go(State.PARKED)
            return 0.0, 0.0, 0.0
        # Hold the heading and the line through the stand-off point while backing up.
        along = np.array([normal[1], -normal[0]])
        offset = float((np.array([self.pose.x, self.pose.y]) - self.park_foot) @ along)
        correction = -along * float(np.clip(2.0 * offset, -0.03, 0.03))  # map frame
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        vy = -s * correction[0] + c * correction[1]
        w = self._safe_turn(near, heading_rate(wrap_angle(heading - self.pose.theta), self.motion))
        return -cfg.reverse_mps, float(vy), w

    def _parked(self, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> tuple[float, float, float]:
        if self.state_steps == self._steps(1.5):
            self.stored = self.before_touch  # PARKED comes only from REVERSE, which took it
            self.checked[:] = False
            self.evidence[:] = 0.0
            self.depths = self._room_depths()
            # What exploring gave up was frontiers; the search's goals are other places (a room's
            # door among them: dev seed 215 never went back into the room it had given up).
            self.given_up.clear()
        if self.state_steps > self._steps(1.5):
            # Off the wall before anything turns (a turn against it swings a corner into it).
            point, normal = self.wall
            gap = float((np.array([self.pose.x, self.pose.y]) - point) @ normal) - self.motion.half_depth
            if gap > 0.25 or self.state_steps > self._steps(6.0):
                self._go(State.SEARCH)
            return 0.1, 0.0, 0.0
        return 0.0, 0.0, 0.0

    def _search(self, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> tuple[float, float, float]:
        if self.object is not None:
            self._go(State.APPROACH)
            return 0.0, 0.0, 0.0
        if self._replan_due():
            self._isolated_object()
            if self.object is not None:
                return 0.0, 0.0, 0.0
            occupied, free = self._coarse()
            r0, r1, c0, c1 = self.view
            # Not looked at since parking; or never seen, for a start in "find" (it maps as it
            # goes; after exploring, what was never seen is the inside of walls and the outside).
            unseen = free & ~self.checked[r0:r1, c0:c1]
            if self.phase == "find":
                unseen |= ~occupied & ~free
            # Large unseen parts first (a room not looked into since parking); the specks the
            # blind sector leaves round the robot cost a trip each (dev seed 117 spent 160 s by
            # the parking wall). Large by the unseen area, not by the frontier's length (the
            # frontier across a 1.2 m hallway is 12 cells).
            large = _component_sizes(unseen) >= 30
            if self.depths is not None:
                # The hint: the object is in the room that needs the most doors to reach. Rooms
                # by depth, deepest first, each until looked into since parking.
                depths = self.depths[r0:r1, c0:c1]
                # Any frontier of a large unseen part counts, however short (a room glimpsed
                # through its door leaves a frontier of two or three cells there: dev seed 112
                # searched the hallway for 400 s with the object's room beyond one).
                for d in range(int(depths.max()), 0, -1):
                    if self._plan_to_frontier(large & (depths == d), min_cells=1):
                        return self._follow(near)
            if not self._plan_to_frontier(large, min_cells=1) and not self._plan_to_frontier(unseen):
                self.checked[:] = False  # looked everywhere: look again
                return 0.0, 0.0, 0.8
        return self._follow(near)

    def _room_depths(self) -> np.ndarray:
        """`_room_depths` of the map (full planning grid), walls being the occupied cells in
        groups of four or more (a stray hit inside a room would cut its middle)."""
        cfg = self.config
        occupied, free = self._coarse()
        walls = occupied & (_component_sizes(occupied) >= 4)
        start = self._plan_cell(np.array([self.start.x, self.start.y]))
        depths = _room_depths(free, walls, start, cfg.plan_cell_m, cfg.room_join_m, cfg.room_middle_m)
        full = np.zeros(self.checked.shape, dtype=np.int64)
        r0, r1, c0, c1 = self.view
        full[r0:r1, c0:c1] = depths
        return full

    def _isolated_object(self) -> None:
        """Something small standing free: a cluster of occupied planning cells, 0.1-0.8 m across,
        with free space all round it (0.3 m), is the object, whether or not the stored map
        knew the place (a start in "find" has no stored map of the far rooms)."""
        occupied, free = self._coarse()
        ring = 3
        p = self.view_grid
        for cells in _components(occupied):
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
            if self.phase != "find" and self._in_stored(cells):
                continue  # there before the object was (dev seeds 220, 244: a jamb mapped anew off its place)
            spot = np.array(
                [p.x0 + (cells[:, 1].mean() + 0.5) * p.resolution, p.y0 + (cells[:, 0].mean() + 0.5) * p.resolution]
            )
            if all(np.linalg.norm(spot - q) > 0.5 for q in self.given_up):
                self.object = spot
                return

    def _in_stored(self, cells: np.ndarray, reach: int = 2) -> bool:
        """Whether the map stored at parking had anything occupied within `reach` planning cells
        of these (view) cells: the object is placed once the robot has parked."""
        r0, _, c0, _ = self.view
        stored = self.stored
        n = stored.shape[0]
        for r, c in cells:
            fr, fc = 2 * (r + r0), 2 * (c + c0)
            k = 2 * reach
            if (
                stored[max(fr - k, 0) : min(fr + k + 2, n), max(fc - k, 0) : min(fc + k + 2, n)] > self.config.occupied
            ).any():
                return True
        return False

    def _approach(self, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> tuple[float, float, float]:
        cfg = self.config
        obj = self.object
        here = np.array([self.pose.x, self.pose.y])
        distance = float(np.linalg.norm(obj - here))
        bearing = math.atan2(obj[1] - here[1], obj[0] - here[0])
        error = wrap_angle(bearing - self.pose.theta)
        if distance < 0.9:
            # Face it and creep in until the LRF reads the stop range towards it.
            rel = np.abs(np.array([wrap_angle(a - error) for a in self.angles[::5]])) < 0.3
            ahead = ranges[::5][rel]
            closest = float(ahead.min()) if len(ahead) else math.inf
            if closest <= cfg.stop_range_m and abs(error) < self.motion.visible_bearing:
                self._go(State.FOUND)
                return 0.0, 0.0, 0.0
            # Towards it as it turns (holonomic; a turn a jamb refuses must not stop the creep:
            # dev seed 248 stood 300 s in a door, 0.65 m from the object, facing 27 deg off it).
            forward = 0.1 if abs(error) < self.motion.visible_bearing else 0.0
            return forward * math.cos(error), forward * math.sin(error), heading_rate(error, self.motion)
        if self._replan_due():
            if not self._plan_to(obj, stop_m=0.6):
                self.object = None
                self._go(State.SEARCH)
                return 0.0, 0.0, 0.0
        return self._follow(near)

    def _found(self, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> tuple[float, float, float]:
        if self.state_steps > self._steps(5.0):
            # Not counted (a false object?): give it up and search on.
            self.given_up.append(self.object.copy())
            self.evidence[:] = 0.0
            self.object = None
            self._go(State.SEARCH)
        return 0.0, 0.0, 0.0

    def _wary(self, points: FloatArray, pull_m: float = 0.08) -> FloatArray:
        """Mapped points pulled `pull_m` towards the footprint (never into it): a cell centre may
        lie a few centimetres beyond the wall it stands for, and the pose may be off as much."""
        if len(points) == 0:
            return points
        d, away = footprint_distance(points, self.motion)
        return points - away * np.minimum(pull_m, np.maximum(d - 0.005, 0.0))[:, None]

    def _mapped_near(self, radius: float) -> FloatArray:
        """Cells within `radius` of the robot where the LRF has hit something at least twice, the
        latest within `blind_memory_s`, and cells never seen free within 15 cm of those, in the
        robot frame (for the blind sector: what was seen there, even if since grazed, and what
        may stand beside it unseen)."""
        g = self.grid
        r, c = int((self.pose.y - g.y0) / g.resolution), int((self.pose.x - g.x0) / g.resolution)
        k = int(math.ceil(radius / g.resolution))
        rs, cs = slice(max(r - k, 0), r + k + 1), slice(max(c - k, 0), c + k + 1)
        hit = self.hits[rs, cs] >= 2
        if self.config.blind_memory_s > 0.0:
            hit &= self.last_hit[rs, cs] >= self.steps - self._steps(self.config.blind_memory_s)
        # With the cells never seen free within 15 cm of a hit: a jamb's end face, seen only at
        # grazing angles, may have no hits of its own (dev seed 118: a turn just past a door
        # swung the blind rear corner into a jamb end mapped 16 cm short).
        grown = hit.copy()
        for _ in range(3):
            grown[1:, :] |= grown[:-1, :].copy()
            grown[:-1, :] |= grown[1:, :].copy()
            grown[:, 1:] |= grown[:, :-1].copy()
            grown[:, :-1] |= grown[:, 1:].copy()
        rows, cols = np.nonzero(hit | (grown & (self.logodds[rs, cs] >= self.config.free)))
        xs = g.x0 + (cols + max(c - k, 0) + 0.5) * g.resolution - self.pose.x
        ys = g.y0 + (rows + max(r - k, 0) + 0.5) * g.resolution - self.pose.y
        cs, sn = math.cos(self.pose.theta), math.sin(self.pose.theta)
        return np.column_stack([cs * xs + sn * ys, -sn * xs + cs * ys])

    # --- perception of the object ------------------------------------------------------------
    def _look_for_object(self, ranges: FloatArray) -> None:
        cfg = self.config
        # Only what stands free in the scan (a short run of beams with the background farther on
        # both sides): a wall the drifted pose sees off its mapped place is a long run (dev
        # seeds 217 and 229 chased such walls back at the parking wall, 0.2 m off after 200 s).
        standing = _free_standing(ranges, self.angles, cfg.object_max_m)
        pts = scan_points(np.where(standing, ranges, np.inf), self.angles, min(4.0, self.spec.lrf.range_max_m), 250)
        if len(pts) == 0:
            self.evidence *= 0.98
            return
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        wx = self.pose.x + c * pts[:, 0] - s * pts[:, 1]
        wy = self.pose.y + s * pts[:, 0] + c * pts[:, 1]
        g = self.grid
        col = np.floor((wx - g.x0) / g.resolution).astype(np.int64)
        row = np.floor((wy - g.y0) / g.resolution).astype(np.int64)
        n = self.stored.shape[0]
        ok = (row >= 2) & (row < n - 2) & (col >= 2) & (col < n - 2)
        row, col = row[ok], col[ok]
        # Unexplained: the stored map is confidently free all around the end point.
        worst = np.full(len(row), -np.inf)
        for dr in (-4, -2, 0, 2, 4):
            for dc in (-4, -2, 0, 2, 4):
                worst = np.maximum(worst, self.stored[np.clip(row + dr, 0, n - 1), np.clip(col + dc, 0, n - 1)])
        new = worst < cfg.free
        self.evidence *= 0.98
        np.add.at(self.evidence, (row[new] // 2, col[new] // 2), 1.0)
        if self.object is None and self.evidence.max() >= cfg.object_hits:
            r, c2 = np.unravel_index(int(np.argmax(self.evidence)), self.evidence.shape)
            p = self.plan_grid
            spot = np.array([p.x0 + (c2 + 0.5) * p.resolution, p.y0 + (r + 0.5) * p.resolution])
            if all(np.linalg.norm(spot - q) > 0.5 for q in self.given_up):
                self.object = spot

    # --- planning -------------------------------------------------------------------------------
    def _replan_due(self) -> bool:
        cfg = self.config
        if not self.path or self.steps - self.plan_step >= self._steps(cfg.replan_s):
            return True
        return False

    def _coarse(self) -> tuple[np.ndarray, np.ndarray]:
        """The planning grid over the mapped area (`self.view`): occupied (any fine cell occupied)
        and free (mean log-odds free); computed once per step."""
        if self._coarse_step == self.steps:
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
        occupied = (blocks > cfg.occupied).any(axis=(1, 3))
        free = (blocks.mean(axis=(1, 3)) < cfg.free) & ~occupied
        self._coarse_step, self._coarse_cache = self.steps, (occupied, free)
        return occupied, free

    def _free_mask(self) -> np.ndarray:
        return self._coarse()[1]

    def _unknown_mask(self) -> np.ndarray:
        occupied, free = self._coarse()
        return ~occupied & ~free

    def _costs(self) -> tuple[CostGrid, np.ndarray, np.ndarray]:
        cfg = self.config
        occupied, free = self._coarse()
        clearance = _distance_transform(occupied, cfg.plan_cell_m, 1.0)
        self._occupied_clearance = clearance
        clearance = np.where(free, clearance, 0.0)  # unknown cells are not for driving through
        here = self._plan_cell(np.array([self.pose.x, self.pose.y]))
        r, c = here
        # The robot's own cells are drivable (it stands there).
        clearance[max(r - 1, 0) : r + 2, max(c - 1, 0) : c + 2] = np.maximum(
            clearance[max(r - 1, 0) : r + 2, max(c - 1, 0) : c + 2], cfg.inflate_m + 0.01
        )
        costs = CostGrid.from_clearance(self.view_grid, clearance, cfg.comfort_m, 4.0, cfg.inflate_m)
        return costs, clearance, free

    def _plan_to_frontier(
        self, unknown: np.ndarray, within: np.ndarray | None = None, min_cells: int | None = None
    ) -> bool:
        """Plan to the best frontier: free cells next to `unknown` cells (nearest, weighted by size)."""
        cfg = self.config
        min_cells = cfg.frontier_min_cells if min_cells is None else min_cells
        costs, clearance, free = self._costs()
        region = free if within is None else within
        neighbour = np.zeros_like(unknown)
        neighbour[1:, :] |= unknown[:-1, :]
        neighbour[:-1, :] |= unknown[1:, :]
        neighbour[:, 1:] |= unknown[:, :-1]
        neighbour[:, :-1] |= unknown[:, 1:]
        frontier = region & neighbour & ~unknown & np.isfinite(costs.cost)
        here = self._plan_cell(np.array([self.pose.x, self.pose.y]))
        field = costs.field_from(np.array([here[0]]), np.array([here[1]]), np.zeros(1))
        frontier &= np.isfinite(field.distance)
        best, best_score = None, math.inf
        p = self.view_grid
        self.frontiers = []
        occupied = self._coarse()[0]
        for cells in _components(frontier):
            if len(cells) < min_cells:
                continue
            if len(cells) < cfg.frontier_min_cells and not _opening(cells, unknown, occupied):
                continue
            d = field.distance[cells[:, 0], cells[:, 1]]
            k = int(np.argmin(d))
            spot = np.array([p.x0 + (cells[k, 1] + 0.5) * p.resolution, p.y0 + (cells[k, 0] + 0.5) * p.resolution])
            if any(np.linalg.norm(spot - q) < 0.5 for q in self.given_up):
                continue
            self.frontiers.append(spot)
            score = float(d[k]) - 0.03 * min(len(cells), 60)
            if score < best_score:
                best, best_score = (tuple(cells[k]), spot), score
        if best is None:
            return False
        return self._path_from_field(field, costs, best[0], best[1])

    def _plan_to(self, goal: FloatArray, stop_m: float = 0.0) -> bool:
        costs, _, _ = self._costs()
        here = self._plan_cell(np.array([self.pose.x, self.pose.y]))
        field = costs.field_from(np.array([here[0]]), np.array([here[1]]), np.zeros(1))
        p = self.view_grid
        xs = p.x0 + (np.arange(p.shape[1]) + 0.5) * p.resolution
        ys = p.y0 + (np.arange(p.shape[0]) + 0.5) * p.resolution
        r0, c0 = self._plan_cell(goal)
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
        return self._path_from_field(field, costs, cell, spot)

    def _path_from_field(self, field: Any, costs: CostGrid, cell: tuple[int, int], spot: FloatArray) -> bool:
        """Walk down the field from the goal cell to the robot; string-pull; keep as the path."""
        d = field.distance
        r, c = cell
        cells = [(r, c)]
        for _ in range(d.size):
            if d[r, c] <= 0.0:
                break
            best = (d[r, c], r, c)
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = r + dr, c + dc
                    if 0 <= rr < d.shape[0] and 0 <= cc < d.shape[1] and d[rr, cc] < best[0]:
                        best = (d[rr, cc], rr, cc)
            if best[1:] == (r, c):
                break
            r, c = best[1], best[2]
            cells.append((r, c))
        cells.reverse()
        # Straight lines only where they keep the comfort clearance: a pulled string would hug door
        # jambs at the inflation radius; through a narrow door the field's own cells are kept.
        p = self.view_grid
        self._clearance = self._occupied_clearance
        blocked = ~np.isfinite(costs.cost) | (self._clearance < 0.75 * self.config.comfort_m)
        pulled = string_pull(blocked, cells)
        self.path = [
            np.array([p.x0 + (cc + 0.5) * p.resolution, p.y0 + (rr + 0.5) * p.resolution]) for rr, cc in pulled[1:]
        ]
        if not self.path:
            self.path = [spot]
        self.plan_step = self.steps
        if self.goal is None or np.linalg.norm(self.goal - spot) > 0.3:
            self.goal = spot
            self.best = math.inf
            self.best_step = self.steps
        return True

    def _follow(self, near: FloatArray) -> tuple[float, float, float]:
        cfg = self.config
        here = np.array([self.pose.x, self.pose.y])
        while len(self.path) > 1 and np.linalg.norm(self.path[0] - here) < 0.3:
            self.path.pop(0)
        if not self.path:
            return 0.0, 0.0, 0.0
        if self.goal is not None:
            # Progress along the path, not towards the goal: a way round a wall first leads away
            # from it (dev seed 146 gave up the hallway's far leg from a room beside it, and
            # parked with two rooms unseen).
            remaining = float(np.linalg.norm(self.path[0] - here)) + sum(
                float(np.linalg.norm(b - a)) for a, b in zip(self.path[:-1], self.path[1:], strict=False)
            )
            if remaining < self.best - 0.2:
                self.best, self.best_step = remaining, self.steps
            elif self.steps - self.best_step > self._steps(cfg.give_up_s):
                self.given_up.append(self.goal.copy())
                self.goal = None
                self.path = []
                self.backoff_until = self.steps + self._steps(1.5)
                return 0.0, 0.0, 0.0
        if self.steps < self.backoff_until:
            # Away from what is nearest (the way it came, as the LRF sees it), then plan anew.
            v = attract_and_repel(
                near, np.zeros(2), dataclasses.replace(self.follow, repulsion_range=0.4, repulsion_gain=0.02), speed=0.2
            )
            return float(v[0]), float(v[1]), 0.0
        target = self.path[0]
        travel = math.atan2(target[1] - here[1], target[0] - here[0])
        tight = self._tight_ahead(here, 1.2)
        # Slower the closer anything is (the map behind the robot may be a few centimetres off).
        closest = float(footprint_clearance(near, self.motion).min()) if len(near) else 1.0
        speed = min(0.2 if tight else cfg.cruise_mps, max(0.08, 0.08 + 1.5 * (closest - 0.05)))
        goal = self._to_robot(target)
        v = attract_and_repel(near, goal, self.follow, speed=speed)
        u = goal / max(float(np.hypot(*goal)), 1e-9)
        if float(v @ u) < 0.25 * speed:
            # A local minimum of the field (a doorway's jambs push back as hard as the path
            # pulls on: dev seed 123 stood 500 s in one): keep the push across the way, drop the
            # push against it; the safety filter still guards the footprint.
            v = v - float(v @ u) * u + 0.25 * speed * u
        heading = travel - math.pi / 2 if tight else travel
        error = wrap_angle(heading - self.pose.theta)
        if self.steps < self.step_out_until:
            return self.step_out
        if self.still_steps >= self._steps(1.0) and abs(math.atan2(goal[1], goal[0])) > self.motion.visible_bearing:
            # Stuck with the way on behind (a new plan turned it round in or by a door): the
            # blind sector lets it neither back out nor turn past the jamb, so it steps out
            # ahead, where the LRF sees, and turns there (dev seed 226 stood 200 s so); edging
            # off a jamb beside it if straight on is too close to it (dev seed 208).
            for side in (0.0, 0.06, -0.06):
                if self._filtered(near, 0.15, side, 0.0)[0] > 0.05:
                    self.step_out = (0.15, side, 0.0)
                    self.step_out_until = self.steps + self._steps(2.0)
                    return self.step_out
        r, c = self._plan_cell(here)
        if self._clearance[r, c] < cfg.narrow_m:
            # In the doorway itself: no turning (the jamb's far corners have not been seen), the
            # holonomic base translates through at the heading it came in with; unless that is
            # wedged across the door (the filters have stopped it for a second: dev seed 107
            # stood 45 s entered at 33 deg), then it turns towards the way as the turn filter lets it.
            if self.still_steps < self._steps(1.0):
                return float(v[0]), float(v[1]), 0.0
            w = min(max(heading_rate(error, self.motion), -0.3), 0.3)  # slowly: the map is built as it turns
            return float(v[0]), float(v[1]), self._safe_turn(near, w)
        if abs(error) > 1.0:
            v = v * 0.2  # turn first
        return float(v[0]), float(v[1]), self._safe_turn(near, heading_rate(error, self.motion))

    def _filtered(self, near: FloatArray, vx: float, vy: float, w: float) -> tuple[float, float, float]:
        """A command as the safety filters let it through (in view, clear of `near`)."""
        v = keep_in_view(np.array([vx, vy]), self.motion)
        vx, vy, w = safety_filter(near, (float(v[0]), float(v[1]), float(w)), self.motion)
        w = self._safe_turn(near, w)
        return self._no_creep(near, vx, vy, w)

    def _no_creep(self, near: FloatArray, vx: float, vy: float, w: float) -> tuple[float, float, float]:
        """Stop a command that brings anything within 2.5 cm of the footprint closer still (the
        shared safety filter lets a point already inside its margin come a little closer per
        step, which, step after step, is a slow drive into the wall)."""
        if len(near) == 0:
            return vx, vy, w
        d_now = footprint_clearance(near, self.motion)
        close = d_now < 0.05
        if not close.any():
            return vx, vy, w
        pts = near[close]
        a = -w * 0.3
        c, s = math.cos(a), math.sin(a)
        moved = (pts - np.array([vx, vy]) * 0.3) @ np.array([[c, -s], [s, c]]).T
        d_after = footprint_clearance(moved, self.motion)
        if np.any((d_after < 0.025) & (d_after < d_now[close] - 1e-4)):
            return 0.0, 0.0, 0.0
        return vx, vy, w

    def _safe_turn(self, near: FloatArray, w: float) -> float:
        return safe_turn(near, w, self.motion)

    def _tight_ahead(self, here: FloatArray, length_m: float) -> bool:
        """Whether the path's next `length_m` passes anywhere narrower than `narrow_m` (so the
        robot turns sideways before it gets there, not in the door)."""
        cfg = self.config
        points = [here, *self.path]
        left = length_m
        for a, b in zip(points[:-1], points[1:], strict=False):
            span = float(np.linalg.norm(b - a))
            for t in np.linspace(0.0, min(span, left), max(2, int(min(span, left) / 0.05) + 1)):
                q = a + (b - a) * (t / span if span > 1e-9 else 0.0)
                r, c = self._plan_cell(q)
                if self._clearance[r, c] < cfg.narrow_m:
                    return True
            left -= span
            if left <= 0:
                break
        return False

    def _plan_cell(self, p: FloatArray) -> tuple[int, int]:
        """A point's cell in the planning view (clipped to it)."""
        g = self.view_grid
        c = int(np.clip((p[0] - g.x0) / g.resolution, 0, g.shape[1] - 1))
        r = int(np.clip((p[1] - g.y0) / g.resolution, 0, g.shape[0] - 1))
        return r, c

    def _to_robot(self, p: FloatArray) -> FloatArray:
        dx, dy = p[0] - self.pose.x, p[1] - self.pose.y
        c, s = math.cos(self.pose.theta), math.sin(self.pose.theta)
        return np.array([c * dx + s * dy, -s * dx + c * dy])

    def overlay(self) -> Overlay:
        """The occupied cells, the path and target, in the agent's (odometry) frame."""
        g = self.grid
        rows, cols = np.nonzero(self.logodds > self.config.occupied)
        take = slice(None, None, max(1, len(rows) // 3000))
        pts = np.column_stack([g.x0 + (cols[take] + 0.5) * g.resolution, g.y0 + (rows[take] + 0.5) * g.resolution])
        here = np.array([self.pose.x, self.pose.y])
        path = np.array([here, *self.path]) if self.path else np.zeros((0, 2))
        crosses = [(f[0] - d, f[1] - d, f[0] + d, f[1] + d) for f in self.frontiers for d in (0.1,)] + [
            (f[0] - d, f[1] + d, f[0] + d, f[1] - d) for f in self.frontiers for d in (0.1,)
        ]
        return Overlay(
            frame="odom",
            segments=np.array(crosses, dtype=float).reshape(-1, 4),
            points=pts.reshape(-1, 2),
            path=path.reshape(-1, 2),
            target=self.goal if self.object is None else self.object,
            text=f"classic explore: {self.state.value}",
        )


def build(env: Any, **kwargs: Any) -> ExploreAgent:
    """The classic explore agent for an env's robot (`make_agent("classic", env)`)."""
    return ExploreAgent(RobotSpec.of(env), **kwargs)
