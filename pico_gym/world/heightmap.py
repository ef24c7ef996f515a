"""Course heightmap images to wall segments.

A heightmap is a grey image at 0.025 m per pixel in which a pixel's value is its height, as in the
course simulator (emc_simulator, src/heightmap.cpp): 255 is free floor, any lower value is an
obstacle (255 - v) / 255 m tall, so a pixel of value 0 is a 1 m block, except that near-white
pixels whose occupancy (255 - v) / 255 is below 0.1 (v >= 230, ROS map_server's free threshold,
which the course simulator later adopted) are floor: a user who drew a map means those specks as
floor. Pixels lower than the laser plane (0.3 m) are solid but invisible to the LRF. 4-connected
blobs of grey 51..204 are doors. Pixel edges between obstacle and floor are merged into long axis-aligned segments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pico_gym.jit import njit
from pico_gym.types import Segments

# Course simulator facts (emc_simulator heightmap.cpp): 0.025 m per pixel, blocks 1 m tall for
# value 0, door blobs are grey strictly between 50 and 205.
COURSE_RESOLUTION_M = 0.025
BLOCK_HEIGHT_M = 1.0
DOOR_GREY_MIN = 51
DOOR_GREY_MAX = 204
# docs/facts/pico-facts.md: the LRF is mounted 0.3 m above the floor; lower objects are not seen.
LASER_PLANE_HEIGHT_M = 0.3
# ROS map_server's free threshold (occupancy below it is free), which the course simulator later
# adopted: pixel values 230-255 are floor.
FREE_OCCUPANCY = 0.1
# Budgets: an image larger than this (100 x 100 m at the course's 0.025 m), or with more door
# blobs, is refused with an error instead of exhausting memory.
MAX_IMAGE_PIXELS = 16_000_000
MAX_DOOR_BLOBS = 1000


class ImageError(ValueError):
    """The file could not be read as an image."""


@dataclass(frozen=True)
class HeightmapGeometry:
    """What a heightmap contributes to a map, in the map frame.

    Attributes:
        visible: segments of obstacles at least as tall as the laser plane (seen and solid).
        low: segments of obstacles below the laser plane (solid, not seen by the LRF).
        doors: one segment array per door blob (its outline).
        visible_one_sided: the visible segments are closed outlines directed with the free side
            on their left (fitted outlines are): the LRF may skip those whose free side faces away,
            as no beam from free space can reach them first.
    """

    visible: Segments
    low: Segments
    doors: tuple[Segments, ...]
    visible_one_sided: bool = False


def read_grey(path: Path) -> np.ndarray:
    """Read an image file as a uint8 grey array; transparent pixels count as free (white)."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            if image.width * image.height > MAX_IMAGE_PIXELS:
                raise ImageError(
                    f"{image.width} x {image.height} pixels; the limit is {MAX_IMAGE_PIXELS:,} "
                    f"(100 x 100 m at {COURSE_RESOLUTION_M} m per pixel)"
                )
            image.load()
            if image.mode in ("RGBA", "LA", "PA") or (image.mode == "P" and "transparency" in image.info):
                rgba = image.convert("RGBA")
                white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
                image = Image.alpha_composite(white, rgba)
            grey = np.asarray(image.convert("L"), dtype=np.uint8)
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError, Image.DecompressionBombError) as error:
        raise ImageError(f"not a readable image ({error})") from None
    return grey


def _edge_runs(solid: np.ndarray) -> np.ndarray:
    """Horizontal boundary runs of a boolean image, in pixel-corner coordinates.

    Returns rows (c0, r, c1, r, side): a boundary on the grid line above pixel row r from corner
    column c0 to c1, with side +1 when the solid pixel is above the line and -1 when it is below.
    """
    h, w = solid.shape
    padded = np.zeros((h + 2, w + 2), dtype=np.int8)
    padded[1:-1, 1:-1] = solid
    # code > 0: solid above the line (row r-1), < 0: solid below (row r); for lines r = 0..h.
    code = padded[:-1, 1:-1] - padded[1:, 1:-1]
    code = np.pad(code, ((0, 0), (1, 1)))
    change = code[:, 1:] != code[:, :-1]
    rows, cols = np.nonzero(change)
    # Each change marks where a run ends and/or the next begins; split them per line.
    values = code[rows, cols + 1]
    prev_values = code[rows, cols]
    starts = values != 0
    ends = prev_values != 0
    start_r, start_c, start_v = rows[starts], cols[starts], values[starts]
    end_r, end_c = rows[ends], cols[ends]
    order_s = np.lexsort((start_c, start_r))
    order_e = np.lexsort((end_c, end_r))
    start_r, start_c, start_v = start_r[order_s], start_c[order_s], start_v[order_s]
    end_c = end_c[order_e]
    runs = np.column_stack([start_c, start_r, end_c, start_r, np.sign(start_v)])
    return runs.astype(np.float64)


def _boundary_segments(solid: np.ndarray) -> np.ndarray:
    """All boundary segments of a boolean image in pixel-corner coordinates (col, row)."""
    if not solid.any():
        return np.zeros((0, 4))
    horizontal = _edge_runs(solid)[:, :4]
    vertical = _edge_runs(solid.T)[:, :4]
    vertical = vertical[:, [1, 0, 3, 2]]  # transpose back: (row, col) -> (col, row)
    return np.vstack([horizontal, vertical])


def _contours(solid: np.ndarray) -> list[np.ndarray]:
    """The pixel outline of a boolean image as closed loops of pixel corners (col, row).

    Every boundary between a solid pixel and a free one (or the image edge) is a unit edge,
    directed with the solid pixel on its left; the edges are linked into loops. Where two solid
    pixels touch only at a corner, the loop turns so that the two pixels stay separate.
    """
    h, w = solid.shape
    padded = np.zeros((h + 2, w + 2), dtype=bool)
    padded[1:-1, 1:-1] = solid
    edges: dict[tuple[int, int], list[tuple[int, int]]] = {}

    def add(r0: np.ndarray, c0: np.ndarray, r1: np.ndarray, c1: np.ndarray) -> None:
        for a, b, c, d in zip(r0.tolist(), c0.tolist(), r1.tolist(), c1.tolist(), strict=True):
            edges.setdefault((b, a), []).append((d, c))

    # Image coordinates: corner (col, row), rows growing downwards. Pixel (r, c) spans corners
    # (c, r)..(c + 1, r + 1). Solid on the left of the direction of travel (in image axes).
    rr, cc = np.nonzero(padded[1:-1, 1:-1] & ~padded[:-2, 1:-1])  # free above: edge on the top side
    add(rr, cc + 1, rr, cc)
    rr, cc = np.nonzero(padded[1:-1, 1:-1] & ~padded[2:, 1:-1])  # free below: bottom side
    add(rr + 1, cc, rr + 1, cc + 1)
    rr, cc = np.nonzero(padded[1:-1, 1:-1] & ~padded[1:-1, :-2])  # free on the left: left side
    add(rr, cc, rr + 1, cc)
    rr, cc = np.nonzero(padded[1:-1, 1:-1] & ~padded[1:-1, 2:])  # free on the right: right side
    add(rr + 1, cc + 1, rr, cc + 1)
    loops = []
    while edges:
        start = next(iter(edges))
        loop: list[tuple[int, int]] = []
        prev: tuple[int, int] | None = None
        cur = start
        while True:
            outs = edges[cur]
            if len(outs) == 1 or prev is None:
                nxt = outs.pop()
            else:  # two pixels touching at a corner: take the left turn (either is a valid outline)
                dx, dy = cur[0] - prev[0], cur[1] - prev[1]
                nxt = max(outs, key=lambda o: dx * (o[1] - cur[1]) - dy * (o[0] - cur[0]))
                outs.remove(nxt)
            if not outs:
                del edges[cur]
            loop.append(cur)
            prev, cur = cur, nxt
            if cur == start:
                break
        loops.append(np.array(loop, dtype=np.float64))
    return loops


# A pixel corner between two straight runs at least this long (pixels) is a true corner of the
# outline (a wall's corner), kept as a vertex; shorter runs are a staircase, fitted through.
_TRUE_CORNER_RUN_PX = 3


def _simplify_loop(corners: np.ndarray, tolerance: float) -> np.ndarray:
    """A closed polyline with as few vertices as keep every corner and edge midpoint of the pixel
    outline within `tolerance` (pixels) of it: Douglas-Peucker whose vertices are edge midpoints
    (which lie on the smooth outline a staircase approximates) and the outline's true corners,
    judged on all the outline's points."""
    n = len(corners)
    mids = 0.5 * (corners + np.roll(corners, -1, axis=0))
    # Straight runs: edge i goes from corner i to i + 1; a run is a stretch of equal directions.
    direction = np.roll(corners, -1, axis=0) - corners
    change = np.any(direction != np.roll(direction, 1, axis=0), axis=1)  # edge i starts a new run
    if not change.any():
        change[0] = True
    first = int(np.argmax(change))
    run_id = np.cumsum(np.roll(change, -first)) - 1
    run_id = np.roll(run_id, first)
    run_len = np.bincount(run_id)[run_id]
    true_corner = change & (run_len >= _TRUE_CORNER_RUN_PX) & (np.roll(run_len, 1) >= _TRUE_CORNER_RUN_PX)
    # Interleave: corner i, then midpoint of edge i (from corner i to i + 1).
    pts = np.empty((2 * n, 2))
    pts[0::2] = corners
    pts[1::2] = mids
    keep = np.zeros(2 * n, dtype=bool)
    a, b = 1, 1 + 2 * (n // 2)  # two midpoints far apart split the loop into two open chains
    keep[a] = keep[b] = True
    stack = [(a, b), (b, a + 2 * n)]
    while stack:
        i, j = stack.pop()
        if j - i <= 2:
            continue
        idx = np.arange(i + 1, j) % (2 * n)
        p, q = pts[i % (2 * n)], pts[j % (2 * n)]
        d = q - p
        length = float(np.hypot(*d))
        rel = pts[idx] - p
        if length > 0:
            t = np.clip((rel @ d) / (length * length), 0.0, 1.0)
            dist = np.hypot(rel[:, 0] - t * d[0], rel[:, 1] - t * d[1])
        else:
            dist = np.hypot(rel[:, 0], rel[:, 1])
        # Midpoints and true corners may become vertices; every point is judged.
        span = np.arange(i + 1, j)
        candidates = (span % 2 == 1) | ((span % 2 == 0) & true_corner[(span // 2) % n])
        if dist.max() <= tolerance:
            continue
        split_order = np.argsort(-np.where(candidates, dist, -1.0))
        k = int(np.arange(i + 1, j)[split_order[0]])
        keep[k % (2 * n)] = True
        stack += [(i, k), (k, j)]
    return pts[keep]


def _simplified_segments(solid: np.ndarray, tolerance_px: float) -> np.ndarray:
    """Boundary segments of a boolean image, pixel staircases fitted within `tolerance_px`."""
    if not solid.any():
        return np.zeros((0, 4))
    out = []
    for loop in _contours(solid):
        poly = _simplify_loop(loop, tolerance_px)
        out.append(np.hstack([poly, np.roll(poly, -1, axis=0)]))
    return np.vstack(out)


@njit
def _label_blobs(mask: np.ndarray) -> tuple[np.ndarray, int]:
    """4-connected components of a boolean image in one pass: (labels 1..n, 0 elsewhere; n)."""
    h, w = mask.shape
    labels = np.zeros((h, w), dtype=np.int32)
    stack = np.empty(h * w, dtype=np.int64)
    n = 0
    for r0 in range(h):
        for c0 in range(w):
            if not mask[r0, c0] or labels[r0, c0]:
                continue
            n += 1
            labels[r0, c0] = n
            top = 1
            stack[0] = r0 * w + c0
            while top > 0:
                top -= 1
                r, c = stack[top] // w, stack[top] % w
                for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                    rr, cc = r + dr, c + dc
                    if 0 <= rr < h and 0 <= cc < w and mask[rr, cc] and not labels[rr, cc]:
                        labels[rr, cc] = n
                        stack[top] = rr * w + cc
                        top += 1
    return labels, n


def _door_blobs(grey: np.ndarray) -> list[tuple[int, int, np.ndarray]]:
    """The 4-connected blobs of door grey, each as (row0, col0, its mask within its bounding box).

    Raises:
        ImageError: beyond MAX_DOOR_BLOBS blobs (a budget: each becomes a door of its own).
    """
    door = (grey >= DOOR_GREY_MIN) & (grey <= DOOR_GREY_MAX)
    if not door.any():
        return []
    labels, n = _label_blobs(door)
    if n > MAX_DOOR_BLOBS:
        raise ImageError(f"{n} door blobs (grey {DOOR_GREY_MIN}-{DOOR_GREY_MAX}); the limit is {MAX_DOOR_BLOBS}")
    rows, cols = np.nonzero(labels)
    ids = labels[rows, cols]
    order = np.argsort(ids, kind="stable")
    rows, cols, ids = rows[order], cols[order], ids[order]
    starts = np.searchsorted(ids, np.arange(1, n + 1))
    ends = np.append(starts[1:], len(ids))
    blobs = []
    for k in range(n):
        r, c = rows[starts[k] : ends[k]], cols[starts[k] : ends[k]]
        r0, c0 = int(r.min()), int(c.min())
        mask = np.zeros((int(r.max()) - r0 + 1, int(c.max()) - c0 + 1), dtype=bool)
        mask[r - r0, c - c0] = True
        blobs.append((r0, c0, mask))
    return blobs


def heightmap_geometry(
    grey: np.ndarray,
    resolution_m: float = COURSE_RESOLUTION_M,
    origin: tuple[float, float] | None = None,
    simplify_m: float | None = None,
    free_occupancy: float = FREE_OCCUPANCY,
    yaw: float = 0.0,
) -> HeightmapGeometry:
    """Convert a grey heightmap into wall segments in the map frame.

    Args:
        grey: (rows, cols) uint8 image.
        resolution_m: metres per pixel.
        origin: None for the course simulator's placement (image centre at the world origin,
            world x up the image, world y to the left); else the world position of the lower-left
            pixel corner with x right and y up, as a ROS map_server map.
        simplify_m: None keeps every pixel edge (merged into straight runs); a distance fits the
            pixel staircases of curved or slanted outlines with segments within that distance of
            the pixel outline (fewer segments: a faster LRF).
        free_occupancy: pixels whose occupancy (255 - v) / 255 is below this are floor.
        yaw: with `origin`, the image turned by this about the lower-left pixel corner (a ROS
            map's origin yaw).

    Returns:
        The visible, low and door segments.
    """
    rows, cols = grey.shape
    doors = _door_blobs(grey)
    # A pixel is floor when its occupancy (255 - v) / 255 is below `free_occupancy` (ROS map_server's
    # free threshold, which the course simulator later adopted): near-white specks are floor.
    obstacle = (255.0 - grey.astype(np.float64)) / 255.0 >= free_occupancy
    for r0, c0, mask in doors:
        obstacle[r0 : r0 + mask.shape[0], c0 : c0 + mask.shape[1]] &= ~mask
    height = (255.0 - grey.astype(np.float64)) / 255.0 * BLOCK_HEIGHT_M
    visible = obstacle & (height >= LASER_PLANE_HEIGHT_M)
    low = obstacle & ~visible

    def to_world(seg_px: np.ndarray) -> Segments:
        c = seg_px[:, [0, 2]]
        r = seg_px[:, [1, 3]]
        if origin is None:
            x = (rows / 2.0 - r) * resolution_m
            y = (cols / 2.0 - c) * resolution_m
        elif yaw == 0.0:
            x = origin[0] + c * resolution_m
            y = origin[1] + (rows - r) * resolution_m
        else:
            u, v = c * resolution_m, (rows - r) * resolution_m
            cy, sy = math.cos(yaw), math.sin(yaw)
            x = origin[0] + cy * u - sy * v
            y = origin[1] + sy * u + cy * v
        return np.column_stack([x[:, 0], y[:, 0], x[:, 1], y[:, 1]])

    doors_world = tuple(to_world(_boundary_segments(mask) + [c0, r0, c0, r0]) for r0, c0, mask in doors)
    if simplify_m is None:
        return HeightmapGeometry(to_world(_boundary_segments(visible)), to_world(_boundary_segments(low)), doors_world)
    tolerance_px = simplify_m / resolution_m
    seen = to_world(_simplified_segments(visible, tolerance_px))
    # The fitted loops run one way round their pixels; the placement may mirror them. Direct them
    # so the free side is on the left, checked on the image itself.
    if len(seen) and not _free_on_left(seen, visible, lambda xy: to_pixel(xy, rows, cols, resolution_m, origin, yaw)):
        seen = seen[:, [2, 3, 0, 1]]
    return HeightmapGeometry(seen, to_world(_simplified_segments(low, tolerance_px)), doors_world, True)


def to_pixel(
    xy: np.ndarray, rows: int, cols: int, resolution_m: float, origin: tuple[float, float] | None, yaw: float = 0.0
) -> np.ndarray:
    """(row, col) of the pixels holding map-frame points (n, 2): the inverse of the placement."""
    x, y = xy[:, 0], xy[:, 1]
    if origin is None:
        r, c = rows / 2.0 - x / resolution_m, cols / 2.0 - y / resolution_m
    elif yaw != 0.0:
        dx, dy = x - origin[0], y - origin[1]
        u, v = math.cos(yaw) * dx + math.sin(yaw) * dy, -math.sin(yaw) * dx + math.cos(yaw) * dy
        c, r = u / resolution_m, rows - v / resolution_m
    else:
        c, r = (x - origin[0]) / resolution_m, rows - (y - origin[1]) / resolution_m
    return np.column_stack([np.floor(r), np.floor(c)]).astype(np.int64)


def _free_on_left(segments: Segments, solid: np.ndarray, pixel_of) -> bool:  # noqa: ANN001
    """Whether the segments' left sides are free, by a vote of probes just beside the longest ones."""
    lengths = np.hypot(segments[:, 2] - segments[:, 0], segments[:, 3] - segments[:, 1])
    pick = segments[np.argsort(-lengths)[:50]]
    mid = 0.5 * (pick[:, :2] + pick[:, 2:])
    d = pick[:, 2:] - pick[:, :2]
    left = np.column_stack([-d[:, 1], d[:, 0]]) / np.hypot(d[:, 0], d[:, 1])[:, None]
    probe = pixel_of(mid + left * 1e-3 + left * 0.3 * np.hypot(*d.T)[:, None].clip(max=0.01))
    h, w = solid.shape
    inside = (probe[:, 0] >= 0) & (probe[:, 0] < h) & (probe[:, 1] >= 0) & (probe[:, 1] < w)
    free = ~solid[probe[inside, 0], probe[inside, 1]]
    return bool(free.mean() >= 0.5) if len(free) else True
