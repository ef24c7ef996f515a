"""A uniform grid over wall segments: the LRF's broad phase on large maps.

Each cell lists the segments that touch it (tested against the cell's box widened by `PAD_M`, so
a beam grazing a cell boundary cannot miss a segment through rounding). A beam walks the cells it
passes in order (Amanatides and Woo's traversal) and stops at the first cell whose exit lies
beyond the nearest hit found so far: what a beam costs follows what it passes, not the size of the
map. The hit test is exact ray/segment intersection in the map frame (not a raster, no
resolution): it agrees with the angular broad phase of `pico_gym.sensors.lrf` to rounding
(~1e-15 m). Each cell keeps its own copy of its segments' coordinates, so a test reads memory in
order. A scan costs O(beams x cells passed), nothing per segment of the map.
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.jit import njit
from pico_gym.types import Segments

# A segment is listed in every cell whose box, widened by this much, it touches.
PAD_M = 1e-6
# Cell side: CELL_SCALE / sqrt(wall length per square metre of the bounding box), clamped: dense
# clutter wants small cells (few segments per cell), sparse rooms large ones (few cells per beam).
# Measured on rooms with 20-2,000 segments and the 2021 hospital (`pico-gym bench-env`).
CELL_SCALE = 0.6
MIN_CELL_M = 0.15
MAX_CELL_M = 4.0
# Below this many segments the angular broad phase of the LRF is faster than the grid (measured).
GRID_MIN_SEGMENTS = 300
MAX_CELLS = 1 << 20
# Tolerance in the segment's parameter for a beam through an end point (as the angular cast).
_ENDPOINT_TOL = 1e-9


@njit
def _touches(x1: float, y1: float, x2: float, y2: float, bx0: float, by0: float, bx1: float, by1: float) -> bool:
    """Does segment (x1, y1)-(x2, y2) touch the box [bx0, bx1] x [by0, by1]? (bounding boxes overlap)"""
    ex = x2 - x1
    ey = y2 - y1
    # Signed side of the four corners to the segment's line: all strictly on one side = no touch.
    d00 = ex * (by0 - y1) - ey * (bx0 - x1)
    d01 = ex * (by1 - y1) - ey * (bx0 - x1)
    d10 = ex * (by0 - y1) - ey * (bx1 - x1)
    d11 = ex * (by1 - y1) - ey * (bx1 - x1)
    if d00 > 0.0 and d01 > 0.0 and d10 > 0.0 and d11 > 0.0:
        return False
    if d00 < 0.0 and d01 < 0.0 and d10 < 0.0 and d11 < 0.0:
        return False
    return True


@njit
def _visit(
    segments: Segments, x0: float, y0: float, h: float, nx: int, ny: int, counts: np.ndarray, items: np.ndarray
) -> None:
    """Count (items empty) or list (items sized, counts = each cell's next free slot) the cells' segments."""
    fill = items.shape[0] > 0
    for k in range(segments.shape[0]):
        x1, y1, x2, y2 = segments[k, 0], segments[k, 1], segments[k, 2], segments[k, 3]
        i0 = max(0, int(math.floor((min(x1, x2) - PAD_M - x0) / h)))
        i1 = min(nx - 1, int(math.floor((max(x1, x2) + PAD_M - x0) / h)))
        j0 = max(0, int(math.floor((min(y1, y2) - PAD_M - y0) / h)))
        j1 = min(ny - 1, int(math.floor((max(y1, y2) + PAD_M - y0) / h)))
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                bx0 = x0 + i * h - PAD_M
                by0 = y0 + j * h - PAD_M
                if _touches(x1, y1, x2, y2, bx0, by0, bx0 + h + 2 * PAD_M, by0 + h + 2 * PAD_M):
                    c = j * nx + i
                    if fill:
                        items[counts[c]] = k
                        counts[c] += 1
                    else:
                        counts[c + 1] += 1


def _build(segments: Segments, x0: float, y0: float, h: float, nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists of the segments touching each cell: (starts (nx*ny+1,), items)."""
    counts = np.zeros(nx * ny + 1, dtype=np.int64)
    _visit(segments, x0, y0, h, nx, ny, counts, np.empty(0, dtype=np.int32))
    starts = np.cumsum(counts)
    items = np.empty(int(starts[-1]), dtype=np.int32)
    _visit(segments, x0, y0, h, nx, ny, starts[:-1].copy(), items)
    return starts, items


@njit
def _pack(segments: Segments, items: np.ndarray) -> np.ndarray:
    """Per cell entry: (x1, y1, dx, dy), in cell order (no indirection per test)."""
    data = np.empty((items.shape[0], 4))
    for q in range(items.shape[0]):
        k = items[q]
        data[q, 0] = segments[k, 0]
        data[q, 1] = segments[k, 1]
        data[q, 2] = segments[k, 2] - segments[k, 0]
        data[q, 3] = segments[k, 3] - segments[k, 1]
    return data


@njit
def _slab(p: float, w: float, size: float, t_in: float, t_out: float) -> tuple[float, float]:
    """Narrow the beam's [t_in, t_out] to where it lies within [0, size] along one axis
    (p: the sensor's coordinate, w: the beam's direction component)."""
    if w != 0.0:
        ta = -p / w
        tb = (size - p) / w
        return max(t_in, min(ta, tb)), min(t_out, max(ta, tb))
    if not 0.0 <= p <= size:
        return t_in, -1.0
    return t_in, t_out


@njit
def _axis(p: float, w: float, i: int, h: float) -> tuple[int, float, float]:
    """The traversal along one axis from cell i: (step, t at the next cell boundary, t per cell)."""
    if w > 0.0:
        r = 1.0 / w
        return 1, ((i + 1) * h - p) * r, h * r
    if w < 0.0:
        r = 1.0 / w
        return -1, (i * h - p) * r, -h * r
    return 0, math.inf, math.inf


@njit
def _cast_grid(  # noqa: C901 (a compiled kernel, one loop nest: docs/compiled-twins.md)
    x: float,
    y: float,
    theta: float,
    data: np.ndarray,
    one_sided: np.ndarray | None,
    starts: np.ndarray,
    x0: float,
    y0: float,
    h: float,
    nx: int,
    ny: int,
    beam_cos: np.ndarray,
    beam_sin: np.ndarray,
    max_range: float,
    out: np.ndarray,
) -> None:
    """Exact ranges into `out` (inf where nothing is hit within max_range).

    `one_sided`: a back-face flag per entry of `data`, or None (compiled without the test: most
    grids have no one-sided segments, and the test costs ~3 % of a scan)."""
    c = math.cos(theta)
    s = math.sin(theta)
    px = x - x0
    py = y - y0
    gw = nx * h
    gh = ny * h
    inside = 0.0 <= px < gw and 0.0 <= py < gh
    i_in = min(nx - 1, max(0, int(math.floor(px / h))))
    j_in = min(ny - 1, max(0, int(math.floor(py / h))))
    for b in range(beam_cos.shape[0]):
        dc = beam_cos[b]
        ds = beam_sin[b]
        # The beam in the map frame.
        wx = c * dc - s * ds
        wy = s * dc + c * ds
        best = math.inf
        t_out = max_range
        i = i_in
        j = j_in
        if not inside:
            # Where the beam enters the grid (t >= 0), if it does.
            t_in, t_out = _slab(px, wx, gw, 0.0, t_out)
            t_in, t_out = _slab(py, wy, gh, t_in, t_out)
            if t_in > t_out:
                out[b] = math.inf
                continue
            i = min(nx - 1, max(0, int(math.floor((px + t_in * wx) / h))))
            j = min(ny - 1, max(0, int(math.floor((py + t_in * wy) / h))))
        step_i, t_next_x, dt_x = _axis(px, wx, i, h)
        step_j, t_next_y, dt_y = _axis(py, wy, j, h)
        # Cells left along each axis before the beam leaves the grid; the cell index kept as one
        # number (a step in y moves it by a row).
        left_i = nx - 1 - i if step_i > 0 else i
        left_j = ny - 1 - j if step_j > 0 else j
        row_step = step_j * nx
        cell = j * nx + i
        while True:
            for q in range(starts[cell], starts[cell + 1]):
                ax = data[q, 0] - x
                ay = data[q, 1] - y
                ex = data[q, 2]
                ey = data[q, 3]
                num = ax * ey - ay * ex
                if one_sided is not None:
                    if one_sided[q] and num <= 0.0:
                        continue  # the sensor is on a one-sided segment's solid side: a back face
                denom = wx * ey - wy * ex
                if denom == 0.0:
                    continue
                inv = 1.0 / denom  # one division per test (the hit's range and its place on the segment)
                r = num * inv
                if r > 0.0 and r < best:
                    u = (ax * wy - ay * wx) * inv
                    if -_ENDPOINT_TOL <= u <= 1.0 + _ENDPOINT_TOL:
                        best = r
            # Stop at the first cell boundary beyond the nearest hit (later cells are farther).
            if t_next_x < t_next_y:
                if best <= t_next_x or t_next_x > t_out or left_i == 0:
                    break
                cell += step_i
                left_i -= 1
                t_next_x += dt_x
            else:
                if best <= t_next_y or t_next_y > t_out or left_j == 0:
                    break
                cell += row_step
                left_j -= 1
                t_next_y += dt_y
        out[b] = best if best <= max_range else math.inf


class SegmentGrid:
    """Static segments with their uniform-grid index (built once; the segments must not change).

    Args:
        segments: (N, 4) segments (x1, y1, x2, y2); copied.
        one_sided: optional back-face flags per segment (see `pico_gym.sensors.lrf.lrf_ranges`).
        cell_m: the cell side; by default from the segments' density (MIN_CELL_M..MAX_CELL_M).
    """

    def __init__(self, segments: Segments, one_sided: np.ndarray | None = None, cell_m: float | None = None) -> None:
        segs = np.array(segments, dtype=np.float64).reshape(-1, 4)
        if not np.isfinite(segs).all():
            raise ValueError("SegmentGrid: segments must be finite")
        self.segments = segs
        self.one_sided = (
            np.zeros(0, dtype=np.bool_) if one_sided is None else np.ascontiguousarray(one_sided, dtype=np.bool_)
        )
        if self.one_sided.size not in (0, len(segs)):
            raise ValueError(f"SegmentGrid: one_sided has {self.one_sided.size} flags for {len(segs)} segments")
        n = len(segs)
        lo = segs.reshape(-1, 2).min(axis=0) if n else np.zeros(2)
        hi = segs.reshape(-1, 2).max(axis=0) if n else np.ones(2)
        extent = np.maximum(hi - lo, 1e-3)
        if cell_m is None:
            length = float(np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1]).sum()) if n else 0.0
            density = max(length / float(extent[0] * extent[1]), 1e-6)
            cell_m = min(MAX_CELL_M, max(MIN_CELL_M, CELL_SCALE / math.sqrt(density)))
        cell_m = max(float(cell_m), math.sqrt(float(extent[0] * extent[1]) / MAX_CELLS))
        self.cell_m = cell_m
        self.origin = (float(lo[0]) - 2 * PAD_M, float(lo[1]) - 2 * PAD_M)
        self.shape = (int(extent[0] / cell_m) + 1, int(extent[1] / cell_m) + 1)
        self.starts, items = _build(segs, self.origin[0], self.origin[1], cell_m, *self.shape)
        self._data = _pack(segs, items)
        # Each entry's back-face flag, or None when no segment has one (the cast then skips the test).
        self._one_sided = self.one_sided[items] if self.one_sided.any() else None
        # The grid as `_cast_grid`'s arguments `data` .. `ny`, for a compiled caller that fuses the
        # cast into a call of its own (`pico_gym.sensors.lrf.lrf_ranges`).
        self.kernel_args = (self._data, self._one_sided, self.starts, *self.origin, cell_m, *self.shape)

    def __len__(self) -> int:
        return len(self.segments)

    def cast(
        self,
        x: float,
        y: float,
        theta: float,
        beam_cos: np.ndarray,
        beam_sin: np.ndarray,
        max_range: float,
        out: np.ndarray,
    ) -> None:
        """Exact ranges of the beams (unit directions in the sensor frame) into `out`; inf for no hit."""
        x0, y0 = self.origin
        nx, ny = self.shape
        _cast_grid(
            x,
            y,
            theta,
            self._data,
            self._one_sided,
            self.starts,
            x0,
            y0,
            self.cell_m,
            nx,
            ny,
            beam_cos,
            beam_sin,
            max_range,
            out,
        )
