"""Pure planar geometry: poses, segments, polygons and the distances between them.

Everything here is a pure function of arrays. The functions used on the hot path (clearance of
the robot footprint, point-in-polygon) are compiled with numba; the rest is plain numpy.
Segments are (N, 4) float64 arrays of rows (x1, y1, x2, y2); polygons are (M, 2) arrays of
vertices, implicitly closed.
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.jit import njit
from pico_gym.types import FloatArray, Pose, Segments

TWO_PI = 2.0 * math.pi


@njit
def wrap_angle(angle: float) -> float:
    """Wrap an angle to [-pi, pi).

    >>> round(wrap_angle(3.0 * math.pi / 2.0), 6)
    -1.570796
    """
    return (angle + math.pi) % TWO_PI - math.pi


def compose(a: Pose, b: Pose) -> Pose:
    """Return the pose a * b: b expressed in a's frame, moved to a's parent frame.

    >>> compose(Pose(1.0, 0.0, math.pi / 2), Pose(1.0, 0.0, 0.0))[:2] == (1.0, 1.0)
    True
    """
    c, s = math.cos(a.theta), math.sin(a.theta)
    return Pose(
        a.x + c * b.x - s * b.y,
        a.y + s * b.x + c * b.y,
        float(wrap_angle(a.theta + b.theta)),
    )


def inverse(a: Pose) -> Pose:
    """Return the inverse transform of a pose, so that compose(inverse(a), a) is the identity."""
    c, s = math.cos(a.theta), math.sin(a.theta)
    return Pose(-c * a.x - s * a.y, s * a.x - c * a.y, float(wrap_angle(-a.theta)))


def transform_points(pose: Pose, points: FloatArray) -> FloatArray:
    """Move (N, 2) points from the frame of `pose` to its parent frame."""
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    rot = np.array([[c, -s], [s, c]])
    return points @ rot.T + np.array([pose.x, pose.y])


def polygon_to_segments(polygon: FloatArray) -> Segments:
    """Return the edges of a closed polygon as segments."""
    polygon = np.asarray(polygon, dtype=np.float64)
    out = np.empty((len(polygon), 4))
    out[:, :2] = polygon
    out[:-1, 2:] = polygon[1:]
    out[-1:, 2:] = polygon[:1]
    return out


@njit
def point_segment_distance(px: float, py: float, x1: float, y1: float, x2: float, y2: float) -> float:
    """Euclidean distance from point (px, py) to the segment (x1, y1)-(x2, y2)."""
    ex = x2 - x1
    ey = y2 - y1
    length_sq = ex * ex + ey * ey
    t = 0.0
    if length_sq > 0.0:
        t = ((px - x1) * ex + (py - y1) * ey) / length_sq
        t = min(1.0, max(0.0, t))
    dx = x1 + t * ex - px
    dy = y1 + t * ey - py
    return math.sqrt(dx * dx + dy * dy)


@njit
def _orientation(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit
def segments_intersect(ax: float, ay: float, bx: float, by: float, cx: float, cy: float, dx: float, dy: float) -> bool:
    """True when the closed segments a-b and c-d share at least one point."""
    d1 = _orientation(cx, cy, dx, dy, ax, ay)
    d2 = _orientation(cx, cy, dx, dy, bx, by)
    d3 = _orientation(ax, ay, bx, by, cx, cy)
    d4 = _orientation(ax, ay, bx, by, dx, dy)
    if ((d1 > 0.0 and d2 < 0.0) or (d1 < 0.0 and d2 > 0.0)) and ((d3 > 0.0 and d4 < 0.0) or (d3 < 0.0 and d4 > 0.0)):
        return True
    # Collinear and touching cases.
    if d1 == 0.0 and point_segment_distance(ax, ay, cx, cy, dx, dy) == 0.0:
        return True
    if d2 == 0.0 and point_segment_distance(bx, by, cx, cy, dx, dy) == 0.0:
        return True
    if d3 == 0.0 and point_segment_distance(cx, cy, ax, ay, bx, by) == 0.0:
        return True
    if d4 == 0.0 and point_segment_distance(dx, dy, ax, ay, bx, by) == 0.0:
        return True
    return False


@njit
def segment_segment_distance(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float, dx: float, dy: float
) -> float:
    """Distance between the segments a-b and c-d (0 when they intersect)."""
    if segments_intersect(ax, ay, bx, by, cx, cy, dx, dy):
        return 0.0
    return min(
        point_segment_distance(ax, ay, cx, cy, dx, dy),
        point_segment_distance(bx, by, cx, cy, dx, dy),
        point_segment_distance(cx, cy, ax, ay, bx, by),
        point_segment_distance(dx, dy, ax, ay, bx, by),
    )


@njit
def point_in_polygon(px: float, py: float, polygon: FloatArray) -> bool:
    """Even-odd rule point-in-polygon test (points on the boundary may go either way)."""
    inside = False
    n = polygon.shape[0]
    j = n - 1
    for i in range(n):
        xi, yi = polygon[i, 0], polygon[i, 1]
        xj, yj = polygon[j, 0], polygon[j, 1]
        if (yi > py) != (yj > py):
            x_cross = xi + (py - yi) * (xj - xi) / (yj - yi)
            if px < x_cross:
                inside = not inside
        j = i
    return inside


@njit
def polygon_clearance(polygon: FloatArray, segments: Segments, limit: float = math.inf) -> float:
    """Distance from a closed polygon to the nearest segment; 0 when any segment touches it.

    A segment lying entirely inside the polygon counts as touching. Segments whose bounding box is
    farther than `limit` (or than the nearest segment so far) from the polygon's bounding box are
    skipped, so the answer is exact when it is below `limit` and at least `limit` otherwise.
    """
    n = polygon.shape[0]
    p_min_x = polygon[:, 0].min()
    p_max_x = polygon[:, 0].max()
    p_min_y = polygon[:, 1].min()
    p_max_y = polygon[:, 1].max()
    best = limit
    for s in range(segments.shape[0]):
        x1, y1, x2, y2 = segments[s, 0], segments[s, 1], segments[s, 2], segments[s, 3]
        # The gap between the bounding boxes is a lower bound of the distance: a segment farther
        # than the nearest so far cannot be nearer (the answer is the same as without the test).
        if (
            max(x1, x2) < p_min_x - best
            or min(x1, x2) > p_max_x + best
            or max(y1, y2) < p_min_y - best
            or min(y1, y2) > p_max_y + best
        ):
            continue
        if point_in_polygon(x1, y1, polygon):
            return 0.0
        for i in range(n):
            j = (i + 1) % n
            d = segment_segment_distance(polygon[i, 0], polygon[i, 1], polygon[j, 0], polygon[j, 1], x1, y1, x2, y2)
            if d < best:
                best = d
                if best == 0.0:
                    return 0.0
    return best


@njit
def point_clearance(px: float, py: float, segments: Segments) -> float:
    """Distance from a point to the nearest segment (inf when there are none)."""
    best = math.inf
    for s in range(segments.shape[0]):
        d = point_segment_distance(px, py, segments[s, 0], segments[s, 1], segments[s, 2], segments[s, 3])
        if d < best:
            best = d
    return best


@njit
def footprint_clearance(
    x: float, y: float, theta: float, outline: FloatArray, segments: Segments, limit: float
) -> float:
    """`polygon_clearance` of a robot-frame outline placed at pose (x, y, theta)."""
    c, s = math.cos(theta), math.sin(theta)
    placed = np.empty_like(outline)
    for i in range(outline.shape[0]):
        placed[i, 0] = x + c * outline[i, 0] - s * outline[i, 1]
        placed[i, 1] = y + s * outline[i, 0] + c * outline[i, 1]
    return polygon_clearance(placed, segments, limit)
