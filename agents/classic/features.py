"""Scan features: corners, open ends and exits (corridor mouths), from extracted lines.

- A corner joins two consecutive lines of one section at an angle; it is concave when it recedes
  from the robot (a room's inner corner) and convex when it points at it.
- An open end is a section's end point behind which the scan continues farther away (or reads no
  hit): a wall ends there and space goes on behind it.
- An exit is a gap 0.5-1.5 m wide along a wall line that starts at a line's end and ends either at
  the next piece of the same wall (the wall continues beyond the mouth) or at a wall crossing the
  line (an exit flush with a room corner, whose side wall continues as a corridor wall). Beams
  through the gap must reach well beyond it, so a shadow is not taken for an exit.

Working along wall lines rather than pairing open ends is what makes the hard cases work: the two
ends of a mouth need not face each other or both be visible as open ends, and a straight wall
across the robot's heading has no corner to invent (corners need two lines at an angle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pico_gym.agents.classic.split_merge import Lines, Scan, sections
from pico_gym.types import FloatArray

# Challenge rule: exits are 0.5-1.5 m wide; allow for noise and crooked walls.
EXIT_WIDTH_M = (0.42, 1.7)
# Lines meeting at more than this angle form a corner [rad].
CORNER_ANGLE_RAD = math.radians(30.0)
# Line end points closer than this can form a corner [m].
CORNER_GAP_M = 0.15
# Two lines are one wall when their directions differ less than this [rad] ...
COLLINEAR_ANGLE_RAD = math.radians(8.0)
# ... and their offset across is below this [m].
COLLINEAR_OFFSET_M = 0.12
# Beams through a gap must reach this far beyond it [m] ...
BEYOND_M = 0.3
# ... for at least this fraction of them, and at least this many beams.
BEYOND_FRACTION = 0.6
MIN_BEAMS_THROUGH = 3
# Lines shorter than this do not define a wall for exit detection [m].
MIN_WALL_M = 0.25
# A mouth lies in a room wall: a line at least this long must run up to the gap [m] (on either
# side; for an exit flush with a corner, on the side away from the corner). A box's face
# extended to a wall is not a mouth: the challenge's boxes are at most 0.5 m.
ROOM_WALL_M = 0.6


@dataclass(frozen=True)
class Corner:
    """A corner point and whether it is concave (receding) as seen from the robot."""

    point: FloatArray
    concave: bool


@dataclass(frozen=True)
class Exit:
    """A corridor mouth seen in a scan (robot frame).

    Attributes:
        a, b: the mouth's end points on the wall line.
        outward: unit normal of the mouth pointing away from the robot's side (into the corridor).
        through: number of beams passing through the gap.
    """

    a: FloatArray
    b: FloatArray
    outward: FloatArray
    through: int

    @property
    def width(self) -> float:
        return float(np.linalg.norm(self.b - self.a))

    @property
    def centre(self) -> FloatArray:
        return 0.5 * (self.a + self.b)


@dataclass(frozen=True)
class Features:
    """All features of one scan."""

    corners: list[Corner]
    open_ends: FloatArray
    exits: list[Exit]


def _direction(seg: FloatArray) -> FloatArray:
    d = seg[2:] - seg[:2]
    return d / max(float(np.linalg.norm(d)), 1e-12)


def _line_intersection(p: FloatArray, d: FloatArray, q: FloatArray, e: FloatArray) -> FloatArray | None:
    den = d[0] * e[1] - d[1] * e[0]
    if abs(den) < 1e-9:
        return None
    t = ((q[0] - p[0]) * e[1] - (q[1] - p[1]) * e[0]) / den
    return p + t * d


def find_corners(lines: Lines) -> list[Corner]:
    """Corners between consecutive lines of the same section."""
    corners = []
    for k in range(len(lines) - 1):
        if lines.sections[k] != lines.sections[k + 1]:
            continue
        s1, s2 = lines.segments[k], lines.segments[k + 1]
        if np.linalg.norm(s1[2:] - s2[:2]) > CORNER_GAP_M:
            continue
        d1, d2 = _direction(s1), _direction(s2)
        angle = math.acos(min(1.0, abs(float(d1 @ d2))))
        if angle < CORNER_ANGLE_RAD:
            continue
        c = _line_intersection(s1[:2], d1, s2[:2], d2)
        if c is None:
            continue
        chord = 0.5 * (c - 0.2 * d1 + c + 0.2 * d2)
        corners.append(Corner(c, bool(np.linalg.norm(c) > np.linalg.norm(chord))))
    return corners


def find_open_ends(scan: Scan, raw_ranges: np.ndarray, range_max: float, jump_m: float = 0.2) -> list[int]:
    """Indices (into scan.points) of section ends behind which the scan continues farther."""
    ends = []
    n_beams = len(raw_ranges)
    for first, last in sections(scan, jump_m):
        for idx, step in ((first, -1), (last, 1)):
            beam = int(scan.beams[idx])
            neighbour = beam + step
            if not 0 <= neighbour < n_beams:
                continue
            r_next = float(raw_ranges[neighbour])
            far = r_next >= range_max - 1e-3 or r_next <= 0.0 or r_next > scan.ranges[idx] + jump_m
            if far:
                ends.append(idx)
    return ends


def _beams_beyond(
    a: FloatArray, b: FloatArray, raw_ranges: np.ndarray, beam_angles: FloatArray, range_max: float
) -> tuple[int, float]:
    """How many beams pass between a and b, and the fraction that reaches BEYOND_M past the gap."""
    ta, tb = math.atan2(a[1], a[0]), math.atan2(b[1], b[0])
    lo, hi = min(ta, tb), max(ta, tb)
    if hi - lo > math.pi:  # the gap straddles the back; not visible as a whole
        return 0, 0.0
    i0, i1 = np.searchsorted(beam_angles, lo), np.searchsorted(beam_angles, hi)
    # keep away from the edges, where beams hit the mouth's own end points
    idx = np.arange(i0, i1)
    if len(idx) > 4:
        idx = idx[1:-1]
    if len(idx) == 0:
        return 0, 0.0
    angles = beam_angles[idx]
    dirs = np.column_stack([np.cos(angles), np.sin(angles)])
    # distance along each beam to the mouth line
    e = b - a
    den = dirs[:, 0] * e[1] - dirs[:, 1] * e[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (a[0] * e[1] - a[1] * e[0]) / den
    r = raw_ranges[idx]
    beyond = (r >= range_max - 1e-3) | (r <= 0.0) | (r > t + BEYOND_M)
    return len(idx), float(np.mean(beyond))


def find_exits(
    scan: Scan, lines: Lines, raw_ranges: np.ndarray, beam_angles: FloatArray, range_max: float
) -> list[Exit]:
    """Corridor mouths: gaps of exit width along wall lines, with beams reaching beyond them.

    Every end of a wall line is a candidate mouth edge, not only open ends: the near edge of a
    mouth usually is not one, as the scan runs on from the room wall into the corridor wall there.
    """
    segs = lines.segments
    lengths = np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1])
    exits: list[Exit] = []
    for k, seg in enumerate(segs):
        if lengths[k] < MIN_WALL_M:
            continue
        d = _direction(seg)
        normal = np.array([-d[1], d[0]])
        for end_point, outward_dir in ((seg[:2], -d), (seg[2:], d)):
            candidates = _far_edges(segs, lengths, k, end_point, outward_dir)
            if not candidates:
                continue
            far_point, far_length = min(candidates, key=lambda pc: float(np.linalg.norm(pc[0] - end_point)))
            width = float(np.linalg.norm(far_point - end_point))
            if not EXIT_WIDTH_M[0] <= width <= EXIT_WIDTH_M[1]:
                continue
            if max(lengths[k], far_length) < ROOM_WALL_M:
                continue
            n_through, fraction = _beams_beyond(end_point, far_point, raw_ranges, beam_angles, range_max)
            if n_through < MIN_BEAMS_THROUGH or fraction < BEYOND_FRACTION:
                continue
            centre = 0.5 * (end_point + far_point)
            outward = normal if float(centre @ normal) > 0 else -normal
            exits.append(Exit(end_point.copy(), far_point, outward, n_through))
    return _dedupe(exits)


def _far_edges(
    segs: np.ndarray, lengths: np.ndarray, k: int, end_point: FloatArray, outward_dir: FloatArray
) -> list[tuple[FloatArray, float]]:
    """Where a gap past `end_point` of line k could close: (point, length of the wall there)."""
    seg = segs[k]
    d = _direction(seg)
    normal = np.array([-d[1], d[0]])
    candidates: list[tuple[FloatArray, float]] = []
    for j, other in enumerate(segs):
        # (the far side may be a short piece: the rest of that wall can be out of view)
        if j == k:
            continue
        e = _direction(other)
        if math.acos(min(1.0, abs(float(d @ e)))) < COLLINEAR_ANGLE_RAD:
            # The same wall continuing after the gap: its near end along the line.
            offsets = [(p - seg[:2]) @ normal for p in (other[:2], other[2:])]
            if max(abs(o) for o in offsets) > COLLINEAR_OFFSET_M:
                continue
            along = [float((p - end_point) @ outward_dir) for p in (other[:2], other[2:])]
            near = min(along)
            if near > 0:
                candidates.append((end_point + near * outward_dir, float(lengths[j])))
        else:
            # A wall crossing the line beyond the gap (exit flush with a corner).
            c = _line_intersection(end_point, outward_dir, other[:2], e)
            # (a wall through the end point itself is this wall's own corner)
            if c is None or float((c - end_point) @ outward_dir) < 0.5 * EXIT_WIDTH_M[0]:
                continue
            t = float((c - other[:2]) @ e)
            length = float(np.linalg.norm(other[2:] - other[:2]))
            if -0.15 <= t <= length + 0.15:
                # flush with a corner: the wall with the gap is this line itself
                candidates.append((c, 0.0))
    return candidates


def _dedupe(exits: list[Exit]) -> list[Exit]:
    """Keep one exit per mouth (the one seen through the most beams)."""
    kept: list[Exit] = []
    for ex in sorted(exits, key=lambda e: -e.through):
        if all(np.linalg.norm(ex.centre - k.centre) > 0.3 for k in kept):
            kept.append(ex)
    return kept


def extract_features(
    scan: Scan, lines: Lines, raw_ranges: np.ndarray, beam_angles: FloatArray, range_max: float
) -> Features:
    """Corners, open ends and exits of one scan."""
    open_ends = scan.points[find_open_ends(scan, raw_ranges, range_max)] if len(scan.points) else np.zeros((0, 2))
    return Features(find_corners(lines), open_ends, find_exits(scan, lines, raw_ranges, beam_angles, range_max))
