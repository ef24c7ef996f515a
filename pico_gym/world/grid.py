"""Grids over a map: exact wall clearance per cell and the geodesic distance field to a goal line.

The geodesic field is computed once per reset (Dijkstra on a 16-connected grid, whose error
against true Euclidean path length is below 3 %) so that a step only looks it up. It measures the
shortest collision-free path of the robot's origin: cells closer to a wall than half a grid step
are blocked (so no grid edge crosses a wall), and cells closer than the robot's inscribed radius
cost more, so that paths keep the clearance a real robot needs without forbidding the cells a robot
in a corner starts in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pico_gym.jit import njit
from pico_gym.types import FloatArray, Segments
from pico_gym.world.geometry import point_segment_distance

# A budget: the geodesic and clearance grids of a map may have at most this many cells (a 200 x 200 m
# map at 0.05 m; each cell costs about 20 bytes over the grids an episode builds).
MAX_GRID_CELLS = 16_000_000

# 16-connected moves (dr, dc): 8 neighbours plus the knight moves.
_MOVES = np.array(
    [
        (0, 1),
        (1, 0),
        (0, -1),
        (-1, 0),
        (1, 1),
        (1, -1),
        (-1, 1),
        (-1, -1),
        (1, 2),
        (2, 1),
        (-1, 2),
        (-2, 1),
        (1, -2),
        (2, -1),
        (-1, -2),
        (-2, -1),
    ],
    dtype=np.int64,
)


@dataclass(frozen=True)
class Grid:
    """A regular grid: cell (r, c) has its centre at (x0 + (c + 0.5) * res, y0 + (r + 0.5) * res)."""

    x0: float
    y0: float
    resolution: float
    shape: tuple[int, int]

    @staticmethod
    def covering(bounds: tuple[float, float, float, float], resolution: float, margin: float) -> Grid:
        """A grid over a bounding box (xmin, ymin, xmax, ymax) grown by a margin."""
        xmin, ymin, xmax, ymax = bounds
        cols = int(math.ceil((xmax - xmin + 2 * margin) / resolution))
        rows = int(math.ceil((ymax - ymin + 2 * margin) / resolution))
        if rows * cols > MAX_GRID_CELLS:
            raise ValueError(
                f"a grid of {cols:,} x {rows:,} cells at {resolution} m over {xmax - xmin:.1f} x {ymax - ymin:.1f} m; "
                f"the limit is {MAX_GRID_CELLS:,} cells (a smaller map or a coarser resolution)"
            )
        return Grid(xmin - margin, ymin - margin, resolution, (rows, cols))

    def centres(self) -> tuple[FloatArray, FloatArray]:
        """x and y of the cell centres, each of the grid's shape."""
        rows, cols = self.shape
        xs = self.x0 + (np.arange(cols) + 0.5) * self.resolution
        ys = self.y0 + (np.arange(rows) + 0.5) * self.resolution
        return np.meshgrid(xs, ys)


@njit
def _clearance(x0: float, y0: float, res: float, rows: int, cols: int, segments: Segments, cap: float) -> FloatArray:
    out = np.full((rows, cols), cap)
    for k in range(segments.shape[0]):
        x1, y1, x2, y2 = segments[k, 0], segments[k, 1], segments[k, 2], segments[k, 3]
        # Only cells within `cap` of the segment can get a smaller value.
        c_lo = max(0, int((min(x1, x2) - cap - x0) / res) - 1)
        c_hi = min(cols - 1, int((max(x1, x2) + cap - x0) / res) + 1)
        r_lo = max(0, int((min(y1, y2) - cap - y0) / res) - 1)
        r_hi = min(rows - 1, int((max(y1, y2) + cap - y0) / res) + 1)
        for r in range(r_lo, r_hi + 1):
            py = y0 + (r + 0.5) * res
            for c in range(c_lo, c_hi + 1):
                px = x0 + (c + 0.5) * res
                d = point_segment_distance(px, py, x1, y1, x2, y2)
                if d < out[r, c]:
                    out[r, c] = d
    return out


def clearance_grid(grid: Grid, segments: Segments, cap: float = 1.0) -> FloatArray:
    """Distance from each cell centre to the nearest segment, capped at `cap` metres."""
    return _clearance(
        grid.x0, grid.y0, grid.resolution, grid.shape[0], grid.shape[1], np.ascontiguousarray(segments), cap
    )


def _dijkstra(
    cost: FloatArray,
    knight_ok: np.ndarray,
    seeds_r: np.ndarray,
    seeds_c: np.ndarray,
    seeds_v: FloatArray,
    res: float,
    window: tuple[int, int, int, int] = (0, -1, 0, -1),
    heap_room: int | None = None,
    allowed: np.ndarray | None = None,
) -> FloatArray:
    """Dijkstra over the cells (16 moves: 4 straight, 4 diagonal, 8 knight).

    `window` (r0, r1, c0, c1), inclusive, non-empty: stop as soon as every free cell in it is
    settled. Only those cells then hold their final distances (the rest may be unsettled).

    `allowed` (bool, the grid's shape): the search enters only these cells (the rest stay `inf`);
    default: every free cell.

    Without a window the search takes buckets (`_dijkstra_buckets`: the same distances bit for
    bit, about 1.8x faster on escape rooms); with one, or when the costs rule buckets out, a heap.
    Either has room for as many entries as there are cells (plus the seeds) unless `heap_room`
    says otherwise; a search that needs more starts over with twice the room."""
    room = cost.size + len(seeds_r) if heap_room is None else heap_room
    if allowed is None:
        allowed = np.isfinite(cost)
    if window == (0, -1, 0, -1):  # no early stop: the bucket search, unless the costs rule it out
        entries = max(1, room)
        while True:
            dist, status = _dijkstra_buckets(cost, knight_ok, allowed, seeds_r, seeds_c, seeds_v, res, entries)
            if status == 0:
                return dist
            if status == 2:
                break
            entries *= 2
    while True:
        dist, done = _dijkstra_run(cost, knight_ok, allowed, seeds_r, seeds_c, seeds_v, res, window, max(1, room))
        if done:
            return dist
        room *= 2


@njit
def _dijkstra_run(  # noqa: C901 (a compiled kernel, one loop nest: docs/compiled-twins.md)
    cost: FloatArray,
    knight_ok: np.ndarray,
    allowed: np.ndarray,
    seeds_r: np.ndarray,
    seeds_c: np.ndarray,
    seeds_v: FloatArray,
    res: float,
    window: tuple[int, int, int, int],
    room: int,
) -> tuple[FloatArray, bool]:
    """`_dijkstra` with a heap of `room` entries; False (and a partial result) when that is too few.

    The heap holds (distance, r * cols + c) pairs in two arrays, ordered as those pairs, at most
    one per cell (a cell reached again with a smaller distance has its entry lowered in place:
    `where` keeps each cell's place in the heap). The pairs are unique, so the settle order, and
    with it every settled distance, is that of any correct search over them (Python's heapq with
    its stale entries included)."""
    rows, cols = cost.shape
    dist = np.full((rows, cols), np.inf)
    free = np.isfinite(cost)
    open_ = free & allowed  # the cells the search may enter
    where = np.full(rows * cols, -1, dtype=np.int64)  # each cell's heap index, -1 when not in it
    wr0, wr1, wc0, wc1 = max(window[0], 0), min(window[1], rows - 1), max(window[2], 0), min(window[3], cols - 1)
    waiting = 0  # free cells of the window not settled yet
    for r in range(wr0, wr1 + 1):
        for c in range(wc0, wc1 + 1):
            if open_[r, c]:
                waiting += 1
    stop_early = waiting > 0
    n_moves = _MOVES.shape[0]
    # Half of each move's length [m] (its cost is that times the sum of the two cells' costs).
    half = np.empty(n_moves)
    for m in range(n_moves):
        dr, dc = _MOVES[m, 0], _MOVES[m, 1]
        half[m] = math.sqrt(dr * dr + dc * dc) * res * 0.5
    keys = np.empty(room)
    cells = np.empty(room, dtype=np.int64)
    size = 0
    for i in range(seeds_r.shape[0]):
        r, c = seeds_r[i], seeds_c[i]
        if open_[r, c] and seeds_v[i] < dist[r, c]:
            size = _offer(keys, cells, where, size, room, seeds_v[i], r * cols + c)
            if size < 0:
                return dist, False
            dist[r, c] = seeds_v[i]
    while size > 0:
        d, k = keys[0], cells[0]
        where[k] = -1
        size = _heap_pop(keys, cells, where, size)
        r, c = k // cols, k % cols
        if stop_early and wr0 <= r <= wr1 and wc0 <= c <= wc1:
            waiting -= 1
            if waiting == 0:
                return dist, True
        cost_here = cost[r, c]
        knight_here = knight_ok[r, c]
        for m in range(n_moves):
            dr, dc = _MOVES[m, 0], _MOVES[m, 1]
            rr, cc = r + dr, c + dc
            if rr < 0 or rr >= rows or cc < 0 or cc >= cols:
                continue
            if not open_[rr, cc]:
                continue
            if m >= 8 and not (knight_here and knight_ok[rr, cc]):
                continue
            if m >= 4 and m < 8 and not (free[r + dr, c] and free[r, c + dc]):
                continue  # no diagonal squeeze between two blocked cells
            nd = d + half[m] * (cost_here + cost[rr, cc])
            if nd < dist[rr, cc]:
                size = _offer(keys, cells, where, size, room, nd, rr * cols + cc)
                if size < 0:
                    return dist, False
                dist[rr, cc] = nd
    return dist, True


@njit
def _dijkstra_buckets(  # noqa: C901 (a compiled kernel, one loop nest: docs/compiled-twins.md)
    cost: FloatArray,
    knight_ok: np.ndarray,
    allowed: np.ndarray,
    seeds_r: np.ndarray,
    seeds_c: np.ndarray,
    seeds_v: FloatArray,
    res: float,
    room: int,
) -> tuple[FloatArray, int]:
    """`_dijkstra_run` without a window, bit for bit, with buckets in place of the heap. Returns
    the distances and 0, or 1 when `room` entries are too few, or 2 when the costs rule buckets
    out (a cost of zero, an infinite seed, or costs or seeds so far apart that the ring of
    buckets would outgrow the grid) and the heap must search.

    Every move adds at least the shortest move between two cells of the lowest cost, so the cells
    whose distances lie within one bucket narrower than that cannot lower one another: settling
    them in any order gives each cell the smallest of its neighbours' offers, which is what the
    heap gives it. A cell lowered again gets a new entry (the old one is skipped when its key no
    longer is the cell's distance; a cell takes at most one entry from each neighbour). The
    buckets are a ring as wide as the longest move (or the seeds' spread), since an offer lands
    at most that far ahead."""
    rows, cols = cost.shape
    n = rows * cols
    costs, knight, allow = cost.ravel(), knight_ok.ravel(), allowed.ravel()
    dist = np.full(n, np.inf)
    out = dist.reshape(rows, cols)
    free = np.empty(n, dtype=np.bool_)
    open_ = np.empty(n, dtype=np.bool_)  # the cells the search may enter
    c_min, c_max = np.inf, 0.0
    for k in range(n):
        v = costs[k]
        free[k] = np.isfinite(v)
        open_[k] = free[k] and allow[k]
        if open_[k]:
            c_min, c_max = min(c_min, v), max(c_max, v)
    n_moves = _MOVES.shape[0]
    half = np.empty(n_moves)  # as in `_dijkstra_run`
    step = np.empty(n_moves, dtype=np.int64)  # each move's offset in the flat grid
    for m in range(n_moves):
        dr, dc = _MOVES[m, 0], _MOVES[m, 1]
        half[m] = math.sqrt(dr * dr + dc * dc) * res * 0.5
        step[m] = dr * cols + dc
    low, high = np.inf, -np.inf  # the seeds' values
    for i in range(seeds_r.shape[0]):
        if open_[seeds_r[i] * cols + seeds_c[i]] and seeds_v[i] < np.inf:
            low, high = min(low, seeds_v[i]), max(high, seeds_v[i])
    if low == np.inf:
        return out, 0  # no seed in the open: nothing is reachable
    if not (c_min > 0.0 and np.isfinite(high - low)):
        return out, 2
    # A bucket a hair narrower than the shortest move, so rounding cannot put an offer in its own.
    width = half[0] * (c_min + c_min) * (1.0 - 1e-6)
    span = max(math.ceil(half[n_moves - 1] * (c_max + c_max) / width), (high - low) / width)
    if span > 4 * n + 64:
        return out, 2  # costs or seeds too far apart for a ring of sane size: the heap searches
    ring = int(span) + 3
    head = np.full(ring, -1, dtype=np.int64)  # each bucket's newest entry; entries chain by `after`
    after = np.empty(room, dtype=np.int64)
    keys = np.empty(room)
    cells = np.empty(room, dtype=np.int64)
    used = 0  # entries written
    waiting = 0  # entries not taken yet
    for i in range(seeds_r.shape[0]):
        k, v = seeds_r[i] * cols + seeds_c[i], seeds_v[i]
        if open_[k] and v < dist[k]:
            if used == room:
                return out, 1
            b = int((v - low) / width)
            keys[used], cells[used], after[used], head[b] = v, k, head[b], used
            used += 1
            waiting += 1
            dist[k] = v
    b = 0
    while waiting > 0:
        e = head[b % ring]
        head[b % ring] = -1
        while e >= 0:
            waiting -= 1
            d, k = keys[e], cells[e]
            e = after[e]
            if d != dist[k]:
                continue  # lowered since: a newer entry settles it
            r = k // cols
            c = k - r * cols
            cost_here = costs[k]
            inside = 2 <= r < rows - 2 and 2 <= c < cols - 2  # every move stays on the grid
            for m in range(n_moves if knight[k] else 8):
                if inside:
                    kk = k + step[m]
                else:
                    rr, cc = r + _MOVES[m, 0], c + _MOVES[m, 1]
                    if rr < 0 or rr >= rows or cc < 0 or cc >= cols:
                        continue
                    kk = rr * cols + cc
                if not open_[kk]:
                    continue
                if m >= 8:
                    if not knight[kk]:
                        continue
                elif m >= 4 and not (free[k + _MOVES[m, 0] * cols] and free[k + _MOVES[m, 1]]):
                    continue  # no diagonal squeeze between two blocked cells
                nd = d + half[m] * (cost_here + costs[kk])
                if nd < dist[kk]:
                    nb = int((nd - low) / width)
                    if nb <= b or nb >= b + ring:
                        return out, 2  # (cannot happen; the heap would still be right)
                    if used == room:
                        return out, 1
                    keys[used], cells[used], after[used], head[nb % ring] = nd, kk, head[nb % ring], used
                    used += 1
                    waiting += 1
                    dist[kk] = nd
        b += 1
    return out, 0


@njit
def _offer(keys: FloatArray, cells: np.ndarray, where: np.ndarray, size: int, room: int, key: float, cell: int) -> int:
    """Enter (key, cell) into the heap of `size` entries: lower the cell's entry if it has one (key
    is smaller), else push one. Returns the new size, or -1 when a push finds no room."""
    hole = where[cell]
    if hole < 0:
        if size == room:
            return -1
        hole = size
        size += 1
    _sift_up(keys, cells, where, hole, key, cell)
    return size


@njit
def _sift_up(keys: FloatArray, cells: np.ndarray, where: np.ndarray, i: int, key: float, cell: int) -> None:
    """Put (key, cell) at the hole i, moving it up past the parents it orders before."""
    while i > 0:
        parent = (i - 1) >> 1
        pk = keys[parent]
        if pk < key or (pk == key and cells[parent] < cell):
            break
        keys[i] = pk
        cells[i] = cells[parent]
        where[cells[i]] = i
        i = parent
    keys[i] = key
    cells[i] = cell
    where[cell] = i


@njit
def _heap_pop(keys: FloatArray, cells: np.ndarray, where: np.ndarray, size: int) -> int:
    """Drop the smallest pair (index 0); returns the new size. The hole at the top moves down
    along the smaller children to a leaf, and the last entry moves up from there (Floyd's order:
    about half the comparisons of sifting it down from the top)."""
    size -= 1
    if size == 0:
        return 0
    key, cell = keys[size], cells[size]
    i = 0
    child = 1
    while child < size:
        right = child + 1
        if right < size and (keys[right] < keys[child] or (keys[right] == keys[child] and cells[right] < cells[child])):
            child = right
        keys[i] = keys[child]
        cells[i] = cells[child]
        where[cells[i]] = i
        i = child
        child = 2 * i + 1
    _sift_up(keys, cells, where, i, key, cell)
    return size


_NEIGHBOURS = tuple((dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc)
_KNIGHT_MOVES = tuple((int(dr), int(dc)) for dr, dc in _MOVES[8:])


def descend(distance: FloatArray, knight_ok: np.ndarray, r: int, c: int) -> np.ndarray:
    """The cells (n, 2) from (r, c) down a field of `CostGrid.field_from` to its seeds: to the
    lowest of the 8 neighbours; where none is lower, by the lowest knight move between cells
    clear enough for one (`knight_ok`), as the field's search moves. The 8 neighbours alone can
    leave a cell with no way down (about 1 in 500 cells of a planning map's field): a walk
    stopped there ended far from the seeds."""
    rows, cols = distance.shape
    path = [(r, c)]
    for _ in range(distance.size):
        best, step = distance[r, c], None
        if best <= 0.0:
            break
        for dr, dc in _NEIGHBOURS:
            rr, cc = r + dr, c + dc
            if 0 <= rr < rows and 0 <= cc < cols and distance[rr, cc] < best:
                best, step = distance[rr, cc], (rr, cc)
        if step is None and knight_ok[r, c]:
            for dr, dc in _KNIGHT_MOVES:
                rr, cc = r + dr, c + dc
                if 0 <= rr < rows and 0 <= cc < cols and knight_ok[rr, cc] and distance[rr, cc] < best:
                    best, step = distance[rr, cc], (rr, cc)
        if step is None:
            break
        r, c = step
        path.append(step)
    return np.array(path)


@dataclass(frozen=True)
class GeodesicField:
    """Shortest-path distance from every reachable cell to a goal line, metres.

    Values are negative beyond the line (how far past it), so progress keeps counting until the
    robot is wholly across. Cells that are blocked or unreachable hold `inf`.
    """

    grid: Grid
    distance: FloatArray

    def lookup(self, x: float, y: float) -> float:
        """The field at a point: bilinear over the finite surrounding cells, else the nearest finite one."""
        g = self.grid
        fx = (x - g.x0) / g.resolution - 0.5
        fy = (y - g.y0) / g.resolution - 0.5
        return float(_lookup(self.distance, fx, fy))


@njit
def _lookup(dist: FloatArray, fx: float, fy: float) -> float:
    rows, cols = dist.shape
    c0 = int(math.floor(fx))
    r0 = int(math.floor(fy))
    tx = fx - c0
    ty = fy - r0
    total = 0.0
    weight = 0.0
    for dr in range(2):
        for dc in range(2):
            r, c = r0 + dr, c0 + dc
            if 0 <= r < rows and 0 <= c < cols and np.isfinite(dist[r, c]):
                w = (tx if dc else 1.0 - tx) * (ty if dr else 1.0 - ty)
                total += w * dist[r, c]
                weight += w
    if weight > 1e-9:
        return total / weight
    # Close to a wall: take the best nearby cell plus the distance to it.
    best = math.inf
    for dr in range(-2, 4):
        for dc in range(-2, 4):
            r, c = r0 + dr, c0 + dc
            if 0 <= r < rows and 0 <= c < cols and np.isfinite(dist[r, c]):
                v = dist[r, c] + math.hypot(c - fx, r - fy)
                if v < best:
                    best = v
    return best


def flood(free: np.ndarray, r0: int, c0: int) -> np.ndarray:
    """The cells of `free` (bool) 4-connected to (r0, c0) (none if that cell is not free)."""
    return _flood(np.ascontiguousarray(free, dtype=np.bool_), int(r0), int(c0))


@njit
def _flood(free: np.ndarray, r0: int, c0: int) -> np.ndarray:
    rows, cols = free.shape
    seen = np.zeros((rows, cols), dtype=np.bool_)
    if not free[r0, c0]:
        return seen
    stack_r = np.empty(rows * cols, dtype=np.int64)
    stack_c = np.empty(rows * cols, dtype=np.int64)
    top = 0
    stack_r[0], stack_c[0] = r0, c0
    seen[r0, c0] = True
    top = 1
    while top > 0:
        top -= 1
        r, c = stack_r[top], stack_c[top]
        for m in range(8):
            dr, dc = _MOVES[m, 0], _MOVES[m, 1]
            rr, cc = r + dr, c + dc
            if rr < 0 or rr >= rows or cc < 0 or cc >= cols or seen[rr, cc] or not free[rr, cc]:
                continue
            if m >= 4 and not (free[r + dr, c] and free[r, c + dc]):
                continue  # no diagonal squeeze between two blocked cells
            seen[rr, cc] = True
            stack_r[top], stack_c[top] = rr, cc
            top += 1
    return seen


@dataclass(frozen=True)
class CostGrid:
    """The travel cost of every cell of a grid for the robot's origin (inf = blocked).

    Cells closer to a wall than `inflation_m` (at least half a diagonal grid step, so no grid edge
    crosses a wall) are blocked; cells within the comfort clearance cost more. Computed once per
    world and shared by every goal's field.
    """

    grid: Grid
    cost: FloatArray
    knight_ok: np.ndarray

    @staticmethod
    def of(
        grid: Grid,
        segments: Segments,
        comfort_clearance_m: float = 0.1,
        near_wall_cost: float = 3.0,
        inflation_m: float = 0.0,
    ) -> CostGrid:
        res = grid.resolution
        block_m = max(0.5 * math.sqrt(2.0) * res + 1e-9, inflation_m)
        clearance = clearance_grid(grid, segments, cap=max(comfort_clearance_m, 2 * res, block_m) + res)
        return CostGrid.from_clearance(grid, clearance, comfort_clearance_m, near_wall_cost, inflation_m)

    @staticmethod
    def from_clearance(
        grid: Grid,
        clearance: FloatArray,
        comfort_clearance_m: float = 0.1,
        near_wall_cost: float = 3.0,
        inflation_m: float = 0.0,
    ) -> CostGrid:
        """The cost grid from a clearance grid (capped above the comfort and inflation distances)."""
        res = grid.resolution
        block_m = max(0.5 * math.sqrt(2.0) * res + 1e-9, inflation_m)
        cost = np.where(clearance < comfort_clearance_m, near_wall_cost, 1.0)
        cost[clearance < block_m] = np.inf
        knight_ok = clearance > max(0.5 * math.sqrt(5.0) * res + 1e-9, inflation_m)
        return CostGrid(grid, cost, knight_ok)

    def field_from(
        self, seeds_r: np.ndarray, seeds_c: np.ndarray, seeds_v: FloatArray, allowed: np.ndarray | None = None
    ) -> GeodesicField:
        """The shortest-path distance from seed cells (with their initial values) to every cell
        (with `allowed`: to those cells only; the rest hold `inf`)."""
        distance = _dijkstra(
            self.cost,
            self.knight_ok,
            seeds_r.astype(np.int64),
            seeds_c.astype(np.int64),
            np.asarray(seeds_v, dtype=np.float64),
            self.grid.resolution,
            allowed=allowed,
        )
        return GeodesicField(self.grid, distance)

    def distance_at(self, seeds_r: np.ndarray, seeds_c: np.ndarray, x: float, y: float) -> float:
        """`field_from(seeds_r, seeds_c, 0).lookup(x, y)`, bit for bit, without computing the whole
        field: the search stops once the cells the lookup reads are settled."""
        g = self.grid
        fx = (x - g.x0) / g.resolution - 0.5
        fy = (y - g.y0) / g.resolution - 0.5
        c0, r0 = int(math.floor(fx)), int(math.floor(fy))
        distance = _dijkstra(
            self.cost,
            self.knight_ok,
            seeds_r.astype(np.int64),
            seeds_c.astype(np.int64),
            np.zeros(len(seeds_r)),
            g.resolution,
            (r0 - 2, r0 + 3, c0 - 2, c0 + 3),  # every cell `_lookup` may read
        )
        return float(_lookup(distance, fx, fy))

    def region_cells(self, polygon: FloatArray) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) of the cells whose centres lie inside a convex polygon (free or not)."""
        g = self.grid
        polygon = np.asarray(polygon, dtype=np.float64)
        (x0, y0), (x1, y1) = polygon.min(axis=0), polygon.max(axis=0)
        c0, r0 = max(0, int((x0 - g.x0) / g.resolution) - 1), max(0, int((y0 - g.y0) / g.resolution) - 1)
        c1 = min(g.shape[1], int((x1 - g.x0) / g.resolution) + 2)
        r1 = min(g.shape[0], int((y1 - g.y0) / g.resolution) + 2)
        xs = g.x0 + (np.arange(c0, c1) + 0.5) * g.resolution
        ys = g.y0 + (np.arange(r0, r1) + 0.5) * g.resolution
        gx, gy = np.meshgrid(xs, ys)
        rows, cols = np.nonzero(_inside_convex(gx, gy, polygon))
        return rows + r0, cols + c0

    def field_to_region(self, polygon: FloatArray) -> GeodesicField:
        """Distance to a region (a convex polygon, e.g. an arrival square): 0 inside it."""
        rows, cols = self.region_cells(polygon)
        free = np.isfinite(self.cost[rows, cols])
        return self.field_from(rows[free], cols[free], np.zeros(int(free.sum())))

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """The (row, col) of the cell holding a point (clipped to the grid)."""
        g = self.grid
        c = int(np.clip((x - g.x0) / g.resolution, 0, g.shape[1] - 1))
        r = int(np.clip((y - g.y0) / g.resolution, 0, g.shape[0] - 1))
        return r, c

    def reachable_from(self, x: float, y: float) -> np.ndarray:
        """Boolean mask of the cells connected to a point's cell (8-connected, as the field's moves
        without the knight moves): a flood fill, much cheaper than a field."""
        r, c = self.cell_of(x, y)
        return _flood(np.isfinite(self.cost), r, c)

    def field_from_point(self, x: float, y: float) -> GeodesicField:
        """Distance from a point (its cell) to every cell: what is reachable from there."""
        g = self.grid
        c = int(np.clip((x - g.x0) / g.resolution, 0, g.shape[1] - 1))
        r = int(np.clip((y - g.y0) / g.resolution, 0, g.shape[0] - 1))
        return self.field_from(np.array([r]), np.array([c]), np.zeros(1))


def _inside_convex(xs: FloatArray, ys: FloatArray, polygon: FloatArray) -> np.ndarray:
    """Cells whose centre lies inside a convex polygon (either orientation)."""
    inside_ccw = np.ones(xs.shape, dtype=bool)
    inside_cw = np.ones(xs.shape, dtype=bool)
    n = len(polygon)
    for i in range(n):
        (ax, ay), (bx, by) = polygon[i], polygon[(i + 1) % n]
        cross = (bx - ax) * (ys - ay) - (by - ay) * (xs - ax)
        inside_ccw &= cross >= -1e-12
        inside_cw &= cross <= 1e-12
    return inside_ccw | inside_cw


@njit
def _before_the_line(
    free: np.ndarray, knight_ok: np.ndarray, seed: np.ndarray, starts_r: np.ndarray, starts_c: np.ndarray
) -> np.ndarray:
    """The cells the field's moves reach from the start cells without passing through a seed
    cell (the seeds themselves included): where a robot can be before it crosses the line."""
    rows, cols = free.shape
    reached = np.zeros((rows, cols), dtype=np.bool_)
    stack = np.empty(rows * cols, dtype=np.int64)
    top = 0
    for i in range(starts_r.shape[0]):
        r, c = starts_r[i], starts_c[i]
        if 0 <= r < rows and 0 <= c < cols and free[r, c] and not reached[r, c]:
            reached[r, c] = True
            stack[top] = r * cols + c
            top += 1
    while top > 0:
        top -= 1
        r, c = stack[top] // cols, stack[top] % cols
        if seed[r, c]:
            continue  # past the line: where the robot's run ends
        for m in range(_MOVES.shape[0]):  # the moves and rules of `_dijkstra_run`
            dr, dc = _MOVES[m, 0], _MOVES[m, 1]
            rr, cc = r + dr, c + dc
            if rr < 0 or rr >= rows or cc < 0 or cc >= cols or reached[rr, cc] or not free[rr, cc]:
                continue
            if m >= 8 and not (knight_ok[r, c] and knight_ok[rr, cc]):
                continue
            if m >= 4 and m < 8 and not (free[r + dr, c] and free[r, c + dc]):
                continue
            reached[rr, cc] = True
            stack[top] = rr * cols + cc
            top += 1
    return reached


def geodesic_field(
    grid: Grid,
    segments: Segments,
    line: FloatArray,
    start_side: tuple[float, float],
    comfort_clearance_m: float = 0.1,
    near_wall_cost: float = 3.0,
    start: tuple[float, float] | None = None,
) -> GeodesicField:
    """Geodesic distance of every cell to a goal line.

    Args:
        grid: the grid to compute on.
        segments: the walls.
        line: (2, 2) end points of the goal line (a finish line spanning a corridor).
        start_side: a point on the side of the line the robot comes from.
        comfort_clearance_m: cells closer to a wall than this cost `near_wall_cost` times more.
        near_wall_cost: cost factor of cells within the comfort clearance.
        start: the robot's start, if known: the search then covers only the cells a robot can be
            in before it crosses the line from there (and the cells past the line, which hold
            the start values), and every other cell holds `inf`. Where it computes, the field
            is the full field bit for bit: a path through the cells it leaves out (around a
            building's outside, from the exit) enters again only across the line, where the
            cells past it start lower. On a drawn escape room that leaves out about 60 % of
            the cells (the grid's margin and the bounding box's room beside the corridor).

    Returns:
        The field; cells beyond the line hold minus their distance past it.
    """
    res = grid.resolution
    costs = CostGrid.of(grid, segments, comfort_clearance_m, near_wall_cost)
    (ax, ay), (bx, by) = line
    ux, uy = bx - ax, by - ay
    length = math.hypot(ux, uy)
    ux, uy = ux / length, uy / length
    nx, ny = -uy, ux  # unit normal of the line
    if (start_side[0] - ax) * nx + (start_side[1] - ay) * ny > 0:
        nx, ny = -nx, -ny  # make the normal point away from the start
    seed, seeds_r, seeds_c, seeds_v = _line_seeds(costs.cost, grid.x0, grid.y0, res, ax, ay, ux, uy, nx, ny, length)
    if start is None:
        return costs.field_from(seeds_r, seeds_c, seeds_v)
    # Every cell a lookup at the start may read (as `CostGrid.distance_at`'s window).
    c0 = int(math.floor((start[0] - grid.x0) / res - 0.5))
    r0 = int(math.floor((start[1] - grid.y0) / res - 0.5))
    near_r, near_c = np.mgrid[r0 - 2 : r0 + 4, c0 - 2 : c0 + 4]
    free = np.isfinite(costs.cost)
    allowed = _before_the_line(free, costs.knight_ok, seed, near_r.ravel(), near_c.ravel()) | seed
    return costs.field_from(seeds_r, seeds_c, seeds_v, allowed)


@njit
def _line_seeds(
    cost: FloatArray,
    x0: float,
    y0: float,
    res: float,
    ax: float,
    ay: float,
    ux: float,
    uy: float,
    nx: float,
    ny: float,
    length: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, FloatArray]:
    """The field's seeds: the free cells past the line (within its extent, widened by one cell)
    or on it, each at minus its distance past the line. Returns their mask and, in row-major
    order, their rows, columns and values. (`ux, uy`: the line's unit direction from (ax, ay);
    `nx, ny`: its unit normal pointing away from the start.)"""
    rows, cols = cost.shape
    seed = np.zeros((rows, cols), dtype=np.bool_)
    seeds_r = np.empty(rows * cols, dtype=np.int64)
    seeds_c = np.empty(rows * cols, dtype=np.int64)
    seeds_v = np.empty(rows * cols)
    n = 0
    for r in range(rows):
        dy = (y0 + (r + 0.5) * res) - ay  # (as `Grid.centres`)
        for c in range(cols):
            dx = (x0 + (c + 0.5) * res) - ax
            along = dx * ux + dy * uy
            across = dx * nx + dy * ny
            if across >= -0.5 * res and along >= -res and along <= length + res and np.isfinite(cost[r, c]):
                seed[r, c] = True
                seeds_r[n], seeds_c[n] = r, c
                seeds_v[n] = -(across if across >= 0.0 else 0.0)  # (as `-np.maximum(across, 0.0)`)
                n += 1
    return seed, seeds_r[:n].copy(), seeds_c[:n].copy(), seeds_v[:n].copy()
