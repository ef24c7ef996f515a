"""Split-and-merge line extraction from a laser scan.

The method of Nguyen et al., "A comparison of line extraction algorithms using 2D laser
rangefinder for indoor mobile robotics" (IROS 2005), as the course's teams used it: split the scan
into sections at jumps between neighbouring points; split each section recursively at the point
farthest from its end-to-end line while that distance exceeds a threshold; merge neighbouring
collinear pieces; refit every piece by total least squares; drop pieces with too few points.

Everything here is a pure function of arrays and returns small result objects.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pico_gym.jit import njit
from pico_gym.types import FloatArray

# Consecutive points farther apart than this start a new section [m]; exits are >= 0.5 m wide.
JUMP_M = 0.2
# A section is split where a point lies farther than this from its end-to-end line [m]:
# about 5x the LRF's noise half-width (0.01 m).
SPLIT_DISTANCE_M = 0.05
# Two neighbouring pieces merge when the merged piece still fits within this distance [m].
MERGE_DISTANCE_M = 0.04
# Pieces with fewer points are dropped (the teams used 3-6).
MIN_POINTS = 6


@dataclass(frozen=True)
class Scan:
    """A pre-processed scan in the robot frame.

    Attributes:
        points: (N, 2) Cartesian points of the valid beams, in beam order.
        beams: (N,) the beam index of each point.
        ranges: (N,) their ranges.
    """

    points: FloatArray
    beams: np.ndarray
    ranges: FloatArray


@dataclass(frozen=True)
class Lines:
    """Extracted lines.

    Attributes:
        segments: (K, 4) refitted segments (x1, y1, x2, y2), robot frame, in scan order.
        spans: (K, 2) first and last point index (into `Scan.points`) each segment covers.
        sections: (K,) the section each segment belongs to (sections are split at jumps).
    """

    segments: FloatArray
    spans: np.ndarray
    sections: np.ndarray

    def __len__(self) -> int:
        return len(self.segments)


def preprocess(
    ranges: np.ndarray,
    beam_angles: FloatArray,
    range_min: float,
    range_max: float,
    history: list[np.ndarray] | None = None,
) -> Scan:
    """Drop invalid readings (no hit or below the minimum), optionally average, go Cartesian.

    Args:
        ranges: the raw scan.
        beam_angles: bearing of each beam.
        range_min: readings at or below this are invalid (PICO-era no-hit reads 0).
        range_max: readings at or above this (minus 1 mm) are no-hits.
        history: earlier scans from the same pose to average with (beam-wise mean of the valid
            readings); None or empty for none.

    Returns:
        The valid points.
    """
    r = np.asarray(ranges, dtype=np.float64)
    if history:
        stack = np.vstack([r] + [np.asarray(h, dtype=np.float64) for h in history])
        valid_stack = (stack > range_min) & (stack < range_max - 1e-3)
        counts = valid_stack.sum(axis=0)
        r = np.where(counts > 0, (stack * valid_stack).sum(axis=0) / np.maximum(counts, 1), 0.0)
    valid = (r > range_min) & (r < range_max - 1e-3)
    beams = np.flatnonzero(valid)
    rr = r[beams]
    a = beam_angles[beams]
    return Scan(np.column_stack([rr * np.cos(a), rr * np.sin(a)]), beams, rr)


@njit
def _split(points: FloatArray, start: int, end: int, threshold: float, out_breaks: np.ndarray) -> int:
    """Iterative split of points[start..end] (inclusive); writes break indices, returns their count."""
    stack = [(start, end)]
    n = 0
    while len(stack) > 0:
        i, j = stack.pop()
        if j - i < 2:
            continue
        x1, y1 = points[i, 0], points[i, 1]
        dx, dy = points[j, 0] - x1, points[j, 1] - y1
        length = math.sqrt(dx * dx + dy * dy)
        best, best_k = -1.0, -1
        for k in range(i + 1, j):
            if length > 0.0:
                d = abs(dx * (points[k, 1] - y1) - dy * (points[k, 0] - x1)) / length
            else:
                d = math.hypot(points[k, 0] - x1, points[k, 1] - y1)
            if d > best:
                best, best_k = d, k
        if best > threshold:
            out_breaks[n] = best_k
            n += 1
            stack.append((best_k, j))
            stack.append((i, best_k))
    return n


def fit_line(points: FloatArray) -> tuple[FloatArray, FloatArray, float]:
    """Total-least-squares line through points: (centroid, unit direction, RMS distance)."""
    centroid = points.mean(axis=0)
    centred = points - centroid
    cov = centred.T @ centred
    eigvals, eigvecs = np.linalg.eigh(cov)
    direction = eigvecs[:, 1]
    rms = math.sqrt(max(eigvals[0], 0.0) / len(points))
    return centroid, direction, rms


def _max_distance(points: FloatArray, centroid: FloatArray, direction: FloatArray) -> float:
    normal = np.array([-direction[1], direction[0]])
    return float(np.abs((points - centroid) @ normal).max())


def _segment(points: FloatArray) -> FloatArray:
    """The fitted segment: the end points projected on the least-squares line."""
    centroid, direction, _ = fit_line(points)
    t = (points - centroid) @ direction
    a = centroid + t[0] * direction
    b = centroid + t[-1] * direction
    return np.array([a[0], a[1], b[0], b[1]])


def sections(scan: Scan, jump_m: float = JUMP_M) -> list[tuple[int, int]]:
    """Index ranges [first, last] of the runs of points without jumps or skipped beams between them."""
    n = len(scan.points)
    if n == 0:
        return []
    gaps = np.hypot(*np.diff(scan.points, axis=0).T) > jump_m
    skipped = np.diff(scan.beams) > 2  # invalid beams in between (no hit): an opening
    cuts = np.flatnonzero(gaps | skipped)
    starts = np.concatenate([[0], cuts + 1])
    ends = np.concatenate([cuts, [n - 1]])
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def split_and_merge(
    scan: Scan,
    jump_m: float = JUMP_M,
    split_m: float = SPLIT_DISTANCE_M,
    merge_m: float = MERGE_DISTANCE_M,
    min_points: int = MIN_POINTS,
) -> Lines:
    """Extract line segments from a scan.

    Args:
        scan: pre-processed points (see `preprocess`).
        jump_m: distance between neighbouring points that starts a new section.
        split_m: split threshold (distance of the farthest point to the end-to-end line).
        merge_m: neighbours merge when all their points lie within this of the merged line.
        min_points: pieces with fewer points are dropped.

    Returns:
        The refitted segments with the point spans they cover.
    """
    pts = np.ascontiguousarray(scan.points)
    breaks = np.empty(max(len(pts), 1), dtype=np.int64)
    segments, spans, section_ids = [], [], []
    for s_id, (first, last) in enumerate(sections(scan, jump_m)):
        if last - first + 1 < min_points:
            continue
        n = _split(pts, first, last, split_m, breaks)
        cuts = sorted(set(breaks[:n].tolist()))
        pieces = [[a, b] for a, b in zip([first] + cuts, cuts + [last], strict=True)]
        # Merge neighbours that are collinear after all.
        merged = [pieces[0]]
        for piece in pieces[1:]:
            a, b = merged[-1][0], piece[1]
            c, d, _ = fit_line(pts[a : b + 1])
            if _max_distance(pts[a : b + 1], c, d) < merge_m:
                merged[-1] = [a, b]
            else:
                merged.append(piece)
        for a, b in merged:
            # The shared break point belongs to both neighbours; fit each on its own points.
            if b - a + 1 >= min_points:
                segments.append(_segment(pts[a : b + 1]))
                spans.append((a, b))
                section_ids.append(s_id)
    if not segments:
        return Lines(np.zeros((0, 4)), np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64))
    return Lines(np.array(segments), np.array(spans, dtype=np.int64), np.array(section_ids, dtype=np.int64))
