"""PICO's laser range finder: exact ray casting against wall segments, plus sensor noise.

The core is `lrf_ranges`, a pure function (pose, segments, beam angles) -> ranges. It is exact
ray/segment intersection, not a raster, with one of two broad phases, picked by the number of
segments (both give the same ranges, to rounding):

- angular (small scenes, below `GRID_MIN_SEGMENTS`): each segment in range covers an interval of
  bearings as seen from the sensor, and only the beams inside it are tested against it (found by
  binary search in the sorted beam angles). Its cost grows with the segments in range.
- a uniform grid (`pico_gym.world.segment_grid.SegmentGrid`, large maps): each beam walks the
  cells it passes and stops at the first hit, so its cost follows what a beam passes, not the size
  of the map. The env builds it once per episode (`Scene.lrf_static`); `lrf_ranges` keeps the
  last few it built.

Defaults are PICO's (docs/facts/pico-facts.md): 1000 beams over -2..+2 rad, 0.01-10 m, additive
uniform noise of +-0.01 m, mounted at the robot origin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import gymnasium as gym
import numpy as np

from pico_gym.jit import njit
from pico_gym.types import FloatArray, Pose, Segments
from pico_gym.validate import number
from pico_gym.world.segment_grid import GRID_MIN_SEGMENTS, SegmentGrid, _cast_grid

# PICO's laser (emc_simulator, PICO era): 1000 beams, -2..2 rad, 0.01..10 m, U(-0.01, 0.01) noise.
PICO_N_BEAMS = 1000
PICO_ANGLE_MIN_RAD = -2.0
PICO_ANGLE_MAX_RAD = 2.0
PICO_RANGE_MIN_M = 0.01
PICO_RANGE_MAX_M = 10.0
PICO_NOISE_M = 0.01
# Budgets: beyond these a scan costs more memory and time than any use of this sensor model needs.
MAX_BEAMS = 100_000
MAX_RANGE_M = 1000.0

# Tolerance (in the segment's own parameter) for a beam hitting a segment end point exactly, so a
# beam grazing a corner shared by two segments is not lost between them.
_ENDPOINT_TOL = 1e-9


@dataclass(frozen=True)
class LrfConfig:
    """Settings of the laser range finder.

    Attributes:
        n_beams: number of beams; the scan is computed for exactly these beams.
        angle_min_rad: bearing of the first beam (index 0, on the robot's right).
        angle_max_rad: bearing of the last beam.
        range_min_m: readings are clipped below at this range.
        range_max_m: maximum range; a beam that hits nothing reads this value.
        noise_m: half-width of the additive uniform noise U(-noise_m, +noise_m); 0 disables it.
        no_hit: "max" (a beam that hits nothing reads range_max_m, as since 2024) or "zero" (the
            PICO-era legacy reading of 0).
    """

    n_beams: int = PICO_N_BEAMS
    angle_min_rad: float = PICO_ANGLE_MIN_RAD
    angle_max_rad: float = PICO_ANGLE_MAX_RAD
    range_min_m: float = PICO_RANGE_MIN_M
    range_max_m: float = PICO_RANGE_MAX_M
    noise_m: float = PICO_NOISE_M
    no_hit: Literal["max", "zero"] = "max"

    def __post_init__(self) -> None:
        number("LrfConfig.n_beams", self.n_beams, 1, MAX_BEAMS, integer=True)
        for name in ("angle_min_rad", "angle_max_rad", "range_min_m", "range_max_m", "noise_m"):
            number(f"LrfConfig.{name}", getattr(self, name))
        number("LrfConfig.range_max_m", self.range_max_m, hi=MAX_RANGE_M, unit=" m")
        number("LrfConfig.noise_m", self.noise_m, hi=1.0, unit=" m")
        if not self.angle_max_rad >= self.angle_min_rad:
            raise ValueError("LrfConfig.angle_max_rad must be >= angle_min_rad")
        if self.angle_max_rad - self.angle_min_rad >= 2.0 * math.pi:
            raise ValueError("LrfConfig field of view must be below 2*pi")
        if not 0.0 <= self.range_min_m < self.range_max_m:
            raise ValueError("LrfConfig needs 0 <= range_min_m < range_max_m")
        if self.noise_m < 0.0:
            raise ValueError("LrfConfig.noise_m must be >= 0")
        if self.no_hit not in ("max", "zero"):
            raise ValueError(f"LrfConfig.no_hit must be 'max' or 'zero', got {self.no_hit!r}")

    @property
    def beam_angles(self) -> FloatArray:
        """Bearings of the beams in the robot frame, ascending, radians."""
        return np.linspace(self.angle_min_rad, self.angle_max_rad, self.n_beams)

    @property
    def angle_increment_rad(self) -> float:
        """Angle between neighbouring beams."""
        return 0.0 if self.n_beams == 1 else (self.angle_max_rad - self.angle_min_rad) / (self.n_beams - 1)


@njit
def _cast(
    x: float,
    y: float,
    theta: float,
    segments: Segments,
    beam_angles: FloatArray,
    beam_cos: FloatArray,
    beam_sin: FloatArray,
    max_range: float,
    out: FloatArray,
    clear: bool,
    one_sided: np.ndarray,
) -> bool:
    """Exact ranges into `out` (inf where nothing is hit); with clear=False, only shortens what
    `out` holds (a second set). Returns whether a hit beyond `max_range` may have been written (a
    segment in range reaches past it); when False, every range is within it or inf.

    `one_sided` (empty, or a flag per segment) marks segments of closed outlines directed with
    the free side on their left: one seen from its right is skipped, as a beam from free space
    always meets another segment of the outline first."""
    n = beam_angles.shape[0]
    culling = one_sided.shape[0] > 0
    if clear:
        out[:] = math.inf
    a_lo = beam_angles[0]
    a_hi = beam_angles[n - 1]
    c = math.cos(theta)
    s = math.sin(theta)
    m = segments.shape[0]
    if m >= _SORT_MIN_SEGMENTS:
        return _cast_sorted(x, y, c, s, segments, beam_angles, beam_cos, beam_sin, max_range, out, one_sided)
    reach_sq = max_range * max_range
    far = False
    for k in range(m):
        # The segment in the sensor frame.
        wx1 = segments[k, 0] - x
        wy1 = segments[k, 1] - y
        wx2 = segments[k, 2] - x
        wy2 = segments[k, 3] - y
        x1 = c * wx1 + s * wy1
        y1 = -s * wx1 + c * wy1
        x2 = c * wx2 + s * wy2
        y2 = -s * wx2 + c * wy2
        ex = x2 - x1
        ey = y2 - y1
        if culling and one_sided[k] and x1 * ey - y1 * ex <= 0.0:
            continue  # the sensor is on the segment's solid side: a back face
        # Cull segments out of range.
        length_sq = ex * ex + ey * ey
        t = 0.0
        if length_sq > 0.0:
            t = min(1.0, max(0.0, -(x1 * ex + y1 * ey) / length_sq))
        px = x1 + t * ex
        py = y1 + t * ey
        d_sq = px * px + py * py
        if d_sq > reach_sq:
            continue
        # A hit lies no farther than the farther end point: only then can it be out of range.
        far |= max(x1 * x1 + y1 * y1, x2 * x2 + y2 * y2) > reach_sq
        _cast_one(x1, y1, x2, y2, 0.0, beam_angles, beam_cos, beam_sin, a_lo, a_hi, out)
    return far


@njit
def _cast_sorted(
    x: float,
    y: float,
    c: float,
    s: float,
    segments: Segments,
    beam_angles: FloatArray,
    beam_cos: FloatArray,
    beam_sin: FloatArray,
    max_range: float,
    out: FloatArray,
    one_sided: np.ndarray,
) -> bool:
    """`_cast` for many segments (a building, not a room): nearest first, so that segments hidden
    behind nearer ones find their beams already shorter than their nearest point and are skipped.
    The bound's margin covers the rounding of r and of the distance, so the ranges are exactly
    those of casting every segment."""
    # The frame transform and culls repeat `_cast`'s: written once in a shared compiled helper
    # this loop measured 7 % slower (interleaved, same scenes), so the hot loop keeps its copy.
    culling = one_sided.shape[0] > 0
    a_lo = beam_angles[0]
    a_hi = beam_angles[beam_angles.shape[0] - 1]
    m = segments.shape[0]
    local = np.empty((m, 4))
    nearest = np.empty(m)
    kept = 0
    reach_sq = max_range * max_range
    far = False
    for k in range(m):
        wx1 = segments[k, 0] - x
        wy1 = segments[k, 1] - y
        wx2 = segments[k, 2] - x
        wy2 = segments[k, 3] - y
        x1 = c * wx1 + s * wy1
        y1 = -s * wx1 + c * wy1
        x2 = c * wx2 + s * wy2
        y2 = -s * wx2 + c * wy2
        ex = x2 - x1
        ey = y2 - y1
        if culling and one_sided[k] and x1 * ey - y1 * ex <= 0.0:
            continue
        length_sq = ex * ex + ey * ey
        t = 0.0
        if length_sq > 0.0:
            t = min(1.0, max(0.0, -(x1 * ex + y1 * ey) / length_sq))
        px = x1 + t * ex
        py = y1 + t * ey
        d_sq = px * px + py * py
        if d_sq > reach_sq:
            continue
        far |= max(x1 * x1 + y1 * y1, x2 * x2 + y2 * y2) > reach_sq
        local[kept, 0] = x1
        local[kept, 1] = y1
        local[kept, 2] = x2
        local[kept, 3] = y2
        nearest[kept] = d_sq
        kept += 1
    order = np.argsort(nearest[:kept])
    for j in range(kept):
        k = order[j]
        bound = math.sqrt(nearest[k]) * (1.0 - 1e-9)
        _cast_one(
            local[k, 0], local[k, 1], local[k, 2], local[k, 3], bound, beam_angles, beam_cos, beam_sin, a_lo, a_hi, out
        )
    return far


# From this many segments `_cast` sorts them near to far (measured: it pays on the hospitals'
# 60-70 segments, not on an escape room's 10-20).
_SORT_MIN_SEGMENTS = 32


@njit
def _cast_one(
    x1: float,
    y1: float,
    x2: float,
    y2: float,
    bound: float,
    beam_angles: FloatArray,
    beam_cos: FloatArray,
    beam_sin: FloatArray,
    a_lo: float,
    a_hi: float,
    out: FloatArray,
) -> None:
    """One segment (sensor frame) into `out`; beams already shorter than `bound` are skipped."""
    ex = x2 - x1
    ey = y2 - y1
    # The interval of bearings the segment covers, counter-clockwise from `start`.
    b1 = math.atan2(y1, x1)
    b2 = math.atan2(y2, x2)
    span = b2 - b1
    if span > math.pi:
        span -= 2.0 * math.pi
    elif span < -math.pi:
        span += 2.0 * math.pi
    start = b1
    if span < 0.0:
        start = b2
        span = -span
    cross_p1_e = x1 * ey - y1 * ex
    for shift in (-2.0 * math.pi, 0.0, 2.0 * math.pi):
        lo = start + shift - 1e-12
        hi = start + shift + span + 1e-12
        if hi < a_lo or lo > a_hi:
            continue
        i0 = np.searchsorted(beam_angles, lo, side="left")
        i1 = np.searchsorted(beam_angles, hi, side="right")
        for i in range(i0, i1):
            if out[i] < bound:
                continue  # occluded: this segment cannot be nearer
            dc = beam_cos[i]
            ds = beam_sin[i]
            denom = dc * ey - ds * ex
            if denom == 0.0:
                continue
            r = cross_p1_e / denom
            if r > 0.0 and r < out[i]:  # most beams of a cluttered view are already shorter
                if i0 < i < i1 - 1:
                    # A beam between two others of the span lies a whole beam step inside the
                    # segment's bearings: its hit is on the segment, no end-point test needed.
                    out[i] = r
                    continue
                u = (x1 * ds - y1 * dc) / denom
                if -_ENDPOINT_TOL <= u <= 1.0 + _ENDPOINT_TOL:
                    out[i] = r


@njit
def _noisy(
    ranges: FloatArray, unit: FloatArray, noise: float, rmin: float, rmax: float, no_hit: float, out: np.ndarray
) -> None:
    """Readings from exact ranges: + U(-noise, noise) (from uniform draws `unit`), clipped."""
    for i in range(ranges.shape[0]):
        r = ranges[i]
        if r > rmax:
            out[i] = no_hit
        else:
            out[i] = min(rmax, max(rmin, r + noise * (2.0 * unit[i] - 1.0)))


@njit
def _cast_noisy(
    x: float,
    y: float,
    theta: float,
    segments: Segments,
    beam_angles: FloatArray,
    beam_cos: FloatArray,
    beam_sin: FloatArray,
    one_sided: np.ndarray,
    dynamic: Segments,
    unit: FloatArray,
    reading: tuple[float, float, float, float],
    exact: FloatArray,
    out: np.ndarray,
) -> None:
    """`_cast` of `segments` and then of `dynamic` (no rows: none) into `exact`, then `_noisy`
    into `out`, in one call (fewer dispatches per scan); reading = (noise, rmin, rmax, no_hit)."""
    noise, rmin, rmax, no_hit = reading
    _cast(x, y, theta, segments, beam_angles, beam_cos, beam_sin, rmax, exact, True, one_sided)
    if dynamic.shape[0] > 0:
        _cast(x, y, theta, dynamic, beam_angles, beam_cos, beam_sin, rmax, exact, False, _NO_FLAGS)
    _noisy(exact, unit, noise, rmin, rmax, no_hit, out)


_NO_FLAGS = np.zeros(0, dtype=np.bool_)
_NO_SEGMENTS = np.zeros((0, 4))


@njit
def _equal(a: np.ndarray, b: np.ndarray) -> bool:
    """Same length and elements (1-D): a few times faster than np.array_equal on small arrays."""
    if a.shape[0] != b.shape[0]:
        return False
    same = True
    for i in range(a.shape[0]):  # no early exit: the loop vectorises
        same &= a[i] == b[i]
    return same


@njit
def _fine(x: float, y: float, theta: float, max_range: float) -> bool:
    """A finite pose and a finite positive range (what `lrf_ranges` refuses otherwise)."""
    return math.isfinite(x) and math.isfinite(y) and math.isfinite(theta) and 0.0 < max_range < math.inf


@njit
def _finite(segments: Segments) -> bool:
    """Every coordinate finite, without a temporary array (v - v is 0 for a finite v, else NaN)."""
    total = 0.0
    for k in range(segments.shape[0]):
        for j in range(segments.shape[1]):
            total += segments[k, j] - segments[k, j]
    return total == 0.0


@njit
def _no_hit_to_inf(out: FloatArray, max_range: float) -> None:
    for i in range(out.shape[0]):
        if out[i] > max_range:
            out[i] = math.inf


class _Recent:
    """The last few values computed from arrays, found again by content (never by identity: a
    caller may change an array in place between calls)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.entries: list[tuple[tuple[np.ndarray, ...], Any]] = []

    def get(self, keys: tuple[np.ndarray, ...], make: Any) -> Any:
        entries = self.entries
        if entries:  # the common case, a loop over poses of one scene: the newest entry, unrolled
            stored, value = entries[0]
            if len(keys) == 1:
                if stored[0].shape == keys[0].shape and _equal(stored[0].reshape(-1), keys[0].reshape(-1)):
                    return value
            elif (
                stored[0].shape == keys[0].shape
                and stored[1].shape == keys[1].shape
                and _equal(stored[0].reshape(-1), keys[0].reshape(-1))
                and _equal(stored[1].reshape(-1), keys[1].reshape(-1))
            ):
                return value
        for k, (stored, value) in enumerate(entries[1:], 1):
            if all(
                a.shape == b.shape and _equal(a.reshape(-1), b.reshape(-1)) for a, b in zip(stored, keys, strict=True)
            ):
                entries.insert(0, entries.pop(k))
                return value
        value = make()
        entries.insert(0, (tuple(a.copy() for a in keys), value))
        del entries[self.size :]
        return value


_BEAMS = _Recent(4)  # beam angles (checked ascending once) -> rows (angles, cos, sin)


@njit
def _cast_known_beams(
    x: float,
    y: float,
    theta: float,
    segments: Segments,
    beam_angles: FloatArray,
    known: FloatArray,
    max_range: float,
    out: FloatArray,
    one_sided: np.ndarray,
) -> bool:
    """`lrf_ranges`' small-scene cast in one call when `beam_angles` equal `known[0]` (`known`:
    the rows angles, cos, sin in one array, as every argument costs the call) and the arrays fit:
    (N, 4) segments below `GRID_MIN_SEGMENTS`, no flags or one a segment, one element of `out` a
    beam. False, without casting, when any does not hold (the caller's checked path then
    decides, and names what is wrong)."""
    n = segments.shape[0]
    if segments.shape[1] != 4 or n >= GRID_MIN_SEGMENTS or one_sided.shape[0] not in (0, n):
        return False
    if not (_fine(x, y, theta, max_range) and _finite(segments)):
        return False
    angles = known[0]
    if out.shape[0] != beam_angles.shape[0] or beam_angles.shape[0] != angles.shape[0]:
        return False
    same = True
    for i in range(out.shape[0]):  # the beams' check and `_cast`'s clearing in one pass
        same &= beam_angles[i] == angles[i]
        out[i] = math.inf
    if same and _cast(x, y, theta, segments, angles, known[1], known[2], max_range, out, False, one_sided):
        _no_hit_to_inf(out, max_range)
    return same


_GRIDS = _Recent(4)  # (segments, one-sided flags) -> SegmentGrid


@njit
def _same_segments(a: Segments, b: Segments) -> bool:
    """Equal C-contiguous (N, 4) arrays, compared flat (the loop vectorises)."""
    return a.shape[0] == b.shape[0] and _equal(a.reshape(-1), b.reshape(-1))


@njit
def _cast_known_grid(
    x: float,
    y: float,
    theta: float,
    segments: Segments,
    one_sided: np.ndarray,
    beam_angles: FloatArray,
    known_segments: Segments,
    known_one_sided: np.ndarray,
    known: FloatArray,
    max_range: float,
    out: FloatArray,
    grid: tuple,  # SegmentGrid.kernel_args
) -> bool:
    """`lrf_ranges`' grid cast in one call when the segments, flags and beams equal those the
    newest grid and beams were made from; False, without casting, when anything differs."""
    if not (_equal(one_sided, known_one_sided) and _same_segments(segments, known_segments)):
        return False
    return _cast_grid_known_beams(x, y, theta, beam_angles, known, max_range, out, grid)


@njit
def _cast_grid_known_beams(
    x: float,
    y: float,
    theta: float,
    beam_angles: FloatArray,
    known: FloatArray,
    max_range: float,
    out: FloatArray,
    grid: tuple,  # SegmentGrid.kernel_args
) -> bool:
    """`lrf_ranges` on a prebuilt `SegmentGrid` in one call when `beam_angles` equal `known[0]`
    (rows angles, cos, sin) and `out` holds one element a beam; False, without casting, when
    they differ."""
    if out.shape[0] != known.shape[1] or not _fine(x, y, theta, max_range) or not _equal(beam_angles, known[0]):
        return False
    data, flags, starts, x0, y0, h, nx, ny = grid
    _cast_grid(x, y, theta, data, flags, starts, x0, y0, h, nx, ny, known[1], known[2], max_range, out)
    return True


class _Typed:
    """A compiled twin of an `njit` function that runs for the given argument types only: numba's
    dispatcher then raises TypeError, before anything runs, for any other argument (a float32,
    read-only or strided array, a list), so `lrf_ranges` can try one compiled call with the
    caller's arguments as they come and take its checked path when they do not fit."""

    def __init__(self, function: Any, *signatures: tuple) -> None:
        self.function = function
        self.signatures = signatures
        self.dispatcher: Any = None

    def ready(self) -> Any:
        if self.dispatcher is None:
            dispatcher = njit(self.function.py_func)
            for signature in self.signatures:
                dispatcher.compile(signature)
            dispatcher.disable_compile()
            self.dispatcher = dispatcher
        return self.dispatcher


def _signatures() -> tuple[_Typed, _Typed, _Typed]:
    from numba import types as t

    f8, b1, i8 = t.float64, t.boolean, t.int64
    vec, flags, segs = f8[::1], b1[::1], f8[:, ::1]  # (beams: rows angles, cos, sin as segs)
    grids = [t.Tuple((segs, kind, i8[::1], f8, f8, f8, i8, i8)) for kind in (t.none, flags)]
    return (
        _Typed(_cast_known_beams, (f8, f8, f8, segs, vec, segs, f8, vec, flags)),
        _Typed(_cast_grid_known_beams, *[(f8, f8, f8, vec, segs, f8, vec, g) for g in grids]),
        _Typed(_cast_known_grid, *[(f8, f8, f8, segs, flags, vec, segs, flags, segs, f8, vec, g) for g in grids]),
    )


_SMALL_SCAN, _GRID_SCAN, _KNOWN_GRID_SCAN = _signatures()
# The rows (angles, cos, sin) of the newest beams `lrf_ranges` was called with, and its compiled
# fast paths, ready (set by `_beams`): None before the first call.
_FAST: tuple[FloatArray, Any, Any, Any] | None = None
_SMALL_SIZE = 4 * GRID_MIN_SEGMENTS  # the elements of an (N, 4) array the angular cast takes


def _beams(beam_angles: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The beams' cos and sin (kept: `_BEAMS`); these beams become `lrf_ranges`' fast ones."""
    global _FAST

    def make() -> FloatArray:
        if not np.isfinite(beam_angles).all():
            raise ValueError("beam_angles must be finite")
        if np.any(np.diff(beam_angles) < 0.0):
            raise ValueError("beam_angles must be sorted in ascending order")
        return np.stack([beam_angles, np.cos(beam_angles), np.sin(beam_angles)])

    known = _BEAMS.get((beam_angles,), make)
    _FAST = (known, _SMALL_SCAN.ready(), _GRID_SCAN.ready(), _KNOWN_GRID_SCAN.ready())
    return known[1], known[2]


def lrf_ranges(
    pose: Pose,
    segments: Segments | SegmentGrid,
    beam_angles: FloatArray,
    max_range: float = PICO_RANGE_MAX_M,
    one_sided: np.ndarray | None = None,
    out: FloatArray | None = None,
) -> FloatArray:
    """Exact noiseless ranges of a scan: distance along each beam to the nearest segment.

    Args:
        pose: sensor pose (x, y, theta) in the frame of the segments.
        segments: (N, 4) wall segments (x1, y1, x2, y2), or a prebuilt `SegmentGrid` of them.
        beam_angles: ascending beam bearings in the sensor frame, radians.
        max_range: hits farther than this are ignored.
        one_sided: optional flag per segment: a segment of a closed outline directed with the
            free side on its left, which the cast may skip when the sensor is on its other side
            (a `SegmentGrid` holds its own flags).
        out: optional float64 array of one element per beam to write the ranges into (and
            return), as numpy's `out=`: a loop over poses then allocates nothing.

    Returns:
        A float64 array (`out` when given), one range per beam, `inf` where the beam hits
        nothing within max_range.

    Raises:
        ValueError: when the beam angles are not finite and in ascending order, the pose or the
            segments are not finite, max_range is not a finite number > 0, `one_sided` does not
            hold one flag per segment, or `out` is not a contiguous float64 array of one element
            per beam.

    The beams' directions and, for `GRID_MIN_SEGMENTS` segments or more, the grid are kept for the
    next calls with equal arrays (equal by content, checked every call: an array may have changed in
    place), so a loop over poses costs the env's own scan plus that check; a prebuilt `SegmentGrid`
    (whose segments must not change) skips the check of the segments.

    >>> square = np.array([[-1, -1, 1, -1], [1, -1, 1, 1], [1, 1, -1, 1], [-1, 1, -1, -1]], float)
    >>> lrf_ranges(Pose(0.0, 0.0, 0.0), square, np.array([0.0, math.pi / 4])).round(6).tolist()
    [1.0, 1.414214]
    """
    fast = _FAST
    if fast is not None:
        # A loop over poses with the last call's beams: one compiled call with the arguments as
        # they come, whose types numba's dispatcher checks (anything else: TypeError) and whose
        # contents the kernel checks (anything else: False); then the checked path below.
        known, small_scan, grid_scan, known_grid_scan = fast
        buffer = np.empty(known.shape[1]) if out is None else out
        x, y, th = pose[0], pose[1], pose[2]
        try:
            if type(segments) is np.ndarray:
                flags = _NO_FLAGS if one_sided is None else one_sided
                if segments.size < _SMALL_SIZE:
                    if small_scan(x, y, th, segments, beam_angles, known, max_range, buffer, flags):
                        return buffer
                elif _GRIDS.entries:
                    (known_segments, known_flags), grid = _GRIDS.entries[0]
                    if known_grid_scan(
                        x, y, th, segments, flags, beam_angles, known_segments, known_flags, known, max_range, buffer,
                        grid.kernel_args,
                    ):  # fmt: skip
                        return buffer
            elif type(segments) is SegmentGrid:
                if grid_scan(x, y, th, beam_angles, known, max_range, buffer, segments.kernel_args):
                    return buffer
        except TypeError:
            pass
    return _checked_ranges(pose, segments, beam_angles, max_range, one_sided, out)


def _checked_ranges(
    pose: Pose,
    segments: Segments | SegmentGrid,
    beam_angles: FloatArray,
    max_range: float,
    one_sided: np.ndarray | None,
    out: FloatArray | None,
) -> FloatArray:
    """`lrf_ranges` past its fast path: every argument checked, the beams and grid looked up."""
    if not (type(beam_angles) is np.ndarray and beam_angles.dtype.char == "d" and beam_angles.ndim == 1):
        beam_angles = np.ascontiguousarray(beam_angles, dtype=np.float64).reshape(-1)
    if out is None:
        out = np.empty(beam_angles.shape[0])
    elif not (
        type(out) is np.ndarray
        and out.dtype.char == "d"
        and out.shape == beam_angles.shape
        and out.flags.c_contiguous
        and out.flags.writeable
    ):
        raise ValueError(
            f"out must be a writeable contiguous float64 array of shape {beam_angles.shape} (one per beam), "
            f"got {type(out).__name__} {getattr(out, 'dtype', '')} {getattr(out, 'shape', '')}"
        )
    x, y, th, max_range = float(pose[0]), float(pose[1]), float(pose[2]), float(max_range)
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(th)):
        raise ValueError(f"pose must be finite, got {(x, y, th)}")
    if not 0.0 < max_range < math.inf:
        raise ValueError(f"max_range must be a finite number > 0, got {max_range}")
    if isinstance(segments, SegmentGrid):
        cos, sin = _beams(beam_angles)
        segments.cast(x, y, th, cos, sin, max_range, out)
        return out
    segments, flags = _checked_segments(segments, one_sided)
    if len(segments) < GRID_MIN_SEGMENTS:
        cos, sin = _beams(beam_angles)
        if _cast(x, y, th, segments, beam_angles, cos, sin, max_range, out, True, flags):
            _no_hit_to_inf(out, max_range)
        return out
    grid = _GRIDS.get((segments, flags), lambda: SegmentGrid(segments, flags))
    cos, sin = _beams(beam_angles)
    grid.cast(x, y, th, cos, sin, max_range, out)
    return out


def _checked_segments(segments: Segments, one_sided: np.ndarray | None) -> tuple[Segments, np.ndarray]:
    """(N, 4) contiguous float64 finite segments and their one-sided flags (empty: none), or ValueError."""
    if not (
        type(segments) is np.ndarray
        and segments.dtype.char == "d"
        and segments.ndim == 2
        and segments.shape[1] == 4
        and segments.flags.c_contiguous
    ):
        segments = np.ascontiguousarray(segments, dtype=np.float64)
        if segments.size % 4:
            raise ValueError(f"segments must be (N, 4) rows (x1, y1, x2, y2), got shape {segments.shape}")
        segments = segments.reshape(-1, 4)
    if not np.isfinite(segments).all():
        raise ValueError("segments must be finite")
    flags = _NO_FLAGS if one_sided is None else np.ascontiguousarray(one_sided, dtype=np.bool_).reshape(-1)
    if flags.size not in (0, len(segments)):
        raise ValueError(f"one_sided must hold one flag per segment ({len(segments)}), got {flags.size}")
    return segments, flags


class Lrf:
    """The laser range finder: settings, observation space and noisy scans.

    It holds only its configuration and the beam directions; the map and the pose are passed to
    `scan` each time.
    """

    def __init__(self, config: LrfConfig) -> None:
        self.config = config
        self.beam_angles = config.beam_angles
        self._cos = np.cos(self.beam_angles)
        self._sin = np.sin(self.beam_angles)
        self._ranges = np.empty(config.n_beams)
        self._draws_noise = config.noise_m > 0.0
        self._unit = np.empty(config.n_beams) if self._draws_noise else np.full(config.n_beams, 0.5)  # 0.5: no noise
        # (noise, range_min, range_max, what a beam that hits nothing reads)
        no_hit = 0.0 if config.no_hit == "zero" else config.range_max_m
        self._reading = (config.noise_m, config.range_min_m, config.range_max_m, no_hit)

    @property
    def beams(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The beams as the compiled cast takes them: (angles, cos, sin), robot frame."""
        return self.beam_angles, self._cos, self._sin

    @property
    def reading(self) -> tuple[float, float, float, float]:
        """How a cast range becomes a reading, as the compiled noise takes it: (noise, range
        min, range max, what a beam that hits nothing reads)."""
        return self._reading

    @property
    def draws_noise(self) -> bool:
        """Whether a scan draws its noise (one uniform per beam) from the generator it is given."""
        return self._draws_noise

    def space(self) -> gym.spaces.Box:
        """The observation space of a scan, metres."""
        return gym.spaces.Box(0.0, self.config.range_max_m, shape=(self.config.n_beams,), dtype=np.float32)

    def exact(
        self,
        pose: Pose,
        segments: Segments | SegmentGrid,
        dynamic: Segments | None = None,
        one_sided: np.ndarray | None = None,
    ) -> FloatArray:
        """Noiseless ranges (above range_max_m for no hit). The returned array is reused by the next call.

        Args:
            pose: sensor pose.
            segments: the static segments the laser sees, as an array (the angular cast) or a
                `SegmentGrid` (the grid cast; `Scene.lrf_static` picks by size).
            dynamic: more segments (the movers' boxes, rewritten every step), cast into the same
                ranges without joining the two arrays.
            one_sided: flags of `segments` (see `lrf_ranges`; a `SegmentGrid` holds its own).
        """
        cfg = self.config
        x, y, th = pose[0], pose[1], pose[2]
        beams, cos, sin, rmax, out = self.beam_angles, self._cos, self._sin, cfg.range_max_m, self._ranges
        if isinstance(segments, SegmentGrid):
            _cast_grid(x, y, th, *segments.kernel_args, cos, sin, rmax, out)  # its `cast`, one call less
        else:
            _cast(x, y, th, segments, beams, cos, sin, rmax, out, True, _NO_FLAGS if one_sided is None else one_sided)
        if dynamic is not None and len(dynamic):
            _cast(x, y, th, dynamic, beams, cos, sin, rmax, out, False, _NO_FLAGS)
        return self._ranges

    def scan(
        self,
        pose: Pose,
        segments: Segments | SegmentGrid,
        rng: np.random.Generator,
        dynamic: Segments | None = None,
        one_sided: np.ndarray | None = None,
    ) -> np.ndarray:
        """A reading as the robot gets it: noise added, clipped to the range, no-hit convention.

        Args:
            pose: sensor pose in the map frame.
            segments: the static segments the laser sees.
            rng: the generator the noise is drawn from.
            dynamic: segments that move (see `exact`).

        Returns:
            float32 ranges in [0, range_max_m].
        """
        unit = self._unit
        if self._draws_noise:
            rng.random(out=unit)  # the same draws as rng.random(n_beams), into a kept buffer
        return self.read(pose, segments, unit, dynamic, one_sided)

    def read(
        self,
        pose: Pose,
        segments: Segments | SegmentGrid,
        unit: FloatArray,
        dynamic: Segments | None = None,
        one_sided: np.ndarray | None = None,
    ) -> np.ndarray:
        """`scan` with its noise already drawn: `unit` holds the n_beams uniforms of [0, 1) it
        would draw (any values when the config has no noise)."""
        out = np.empty(self.config.n_beams, dtype=np.float32)
        if not isinstance(segments, SegmentGrid):
            # The common small scene: cast (the movers too) and noise in one compiled call.
            flags = _NO_FLAGS if one_sided is None else one_sided
            x, y, th = pose[0], pose[1], pose[2]
            beams, cos, sin, ranges = self.beam_angles, self._cos, self._sin, self._ranges
            moving = _NO_SEGMENTS if dynamic is None else dynamic
            _cast_noisy(x, y, th, segments, beams, cos, sin, flags, moving, unit, self._reading, ranges, out)
        else:
            _noisy(self.exact(pose, segments, dynamic, one_sided), unit, *self._reading, out)
        return out
