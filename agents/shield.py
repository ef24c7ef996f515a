"""What a learned agent's shield keeps the footprint off: the scan, and a short memory of it.

The hybrid agent's policy (`pico_gym.agents.hybrid`) commands pass the classic safety filter
(`pico_gym.agents.classic.potential_field.safety_filter`) before they reach the robot: the
footprint is kept off the points the filter is given. The LRF sees about 230 degrees; behind the
robot it is blind, and a robot that turns while it drives sideways swings its rear into what it
saw a moment ago and sees no more. `ScanMemory` keeps the scans' near end points of the last
seconds in the odometry frame (drift over a few seconds is millimetres) and hands them back in
the robot's frame; the filter takes those in its blind sector.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

import numpy as np

from pico_gym.agents.base import RobotSpec
from pico_gym.agents.classic.potential_field import MotionConfig, motion_for, safe_turn, safety_filter
from pico_gym.jit import njit
from pico_gym.types import FloatArray, Pose

# Points farther than this from the robot cannot matter to the filter within its horizon [m].
REACH_M = 1.2


class ScanShield:
    """A twist through the classic agents' safety filter on the current scan: the turn cut near
    corners (`safe_turn`), then the command scaled down until the footprint keeps its margin from
    the scan's end points within `REACH_M` (`safety_filter`). It knows only what the LRF sees now:
    nothing behind the robot.

    `PpoAgent(shield=True)` plays a policy through it, and `pico_gym.train.shielded.ShieldedActions`
    puts it in a training env, so that a policy is trained in the loop it is played in.
    """

    def __init__(self, spec: RobotSpec) -> None:
        self.motion = motion_for(spec)
        self._cos, self._sin = np.cos(spec.beam_angles), np.sin(spec.beam_angles)
        # Valid end points: beyond the range floor, short of a no-hit (1.3 m: a superset of REACH_M).
        self._far = min(spec.lrf.range_max_m - 1e-6, REACH_M + 0.1)

    def __call__(self, ranges: np.ndarray, twist: np.ndarray) -> np.ndarray:
        """The filtered twist (vx, vy, w) for a scan's ranges (as the env's `obs["lrf"]`)."""
        r = np.asarray(ranges, dtype=np.float64)
        ok = (r > 0.05) & (r < self._far)
        rk = r[ok]
        near = np.column_stack([rk * self._cos[ok], rk * self._sin[ok]])
        near = near[np.hypot(near[:, 0], near[:, 1]) < REACH_M]
        w = safe_turn(near, float(twist[2]), self.motion)
        return np.array(safety_filter(near, (float(twist[0]), float(twist[1]), w), self.motion))


class ScanMemory:
    """The near end points of the last `seconds` of scans (odometry frame).

    Args:
        seconds: how long a point is kept.
        dt_s: the control period (one scan per step).
        stride: keep every `stride`-th end point (1,000 beams: 2 cm apart at 1 m with 5).
    """

    def __init__(self, seconds: float, dt_s: float, stride: int = 5) -> None:
        if not (math.isfinite(seconds) and seconds >= 0.0):
            raise ValueError(f"ScanMemory seconds must be >= 0, got {seconds!r}")
        self.steps = int(round(seconds / dt_s))
        self.stride = stride
        self._sizes: deque[int] = deque()  # points of each kept scan, oldest first ...
        self._points = np.zeros((0, 2))  # ... and all of them, joined in that order

    def reset(self) -> None:
        self._sizes.clear()
        self._points = np.zeros((0, 2))

    def add(self, points: FloatArray, odom: Pose) -> None:
        """Keep a scan's robot-frame end points (those within `REACH_M`), taken at `odom`."""
        if self.steps == 0:
            return
        pts = points[:: self.stride]
        pts = pts[np.hypot(pts[:, 0], pts[:, 1]) < REACH_M]
        c, s = math.cos(odom.theta), math.sin(odom.theta)
        kept = np.column_stack([odom.x + c * pts[:, 0] - s * pts[:, 1], odom.y + s * pts[:, 0] + c * pts[:, 1]])
        drop = self._sizes.popleft() if len(self._sizes) == self.steps else 0
        self._points = np.concatenate([self._points[drop:], kept])
        self._sizes.append(len(kept))

    def recent(self, odom: Pose) -> FloatArray:
        """The kept points within `REACH_M` (a square) of the robot at `odom`, robot frame."""
        if not self._sizes:
            return np.zeros((0, 2))
        d = self._points - np.array([odom.x, odom.y])
        d = d[(np.abs(d[:, 0]) < REACH_M) & (np.abs(d[:, 1]) < REACH_M)]
        c, s = math.cos(odom.theta), math.sin(odom.theta)
        return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])


class SeenFree:
    """Where the last `seconds` of scans saw free space, and where the robot itself was: a point
    is seen free when a kept scan had a beam through it that ended beyond it (by
    `SEEN_FREE_SLACK_M`), or when it lies in the footprint at a kept pose (what the robot just
    drove through; the rear corners' sweep mostly lies there). Scans are kept every `every`
    steps with their odometry pose, poses every step.

    With `walk_in_mps` > 0, what was seen free `a` seconds ago vouches only for points a person
    walking at that speed could not have reached since: a beam's free stretch is shortened by
    `walk_in_mps * a` and a kept pose's footprint shrunk by as much. A person who walks after the
    robot steps into the footprint it has just left and into space its scans saw free a moment
    ago; undecayed, that memory let the robot back into people it had never seen.

    Args:
        seconds: how long a scan is kept.
        dt_s: the control period (one scan per step).
        angle_min_rad, angle_max_rad, range_min_m, range_max_m: the LRF's.
        half_depth_m, half_width_m: the footprint, a rectangle round the robot's origin.
        every: keep every `every`-th scan.
        walk_in_mps: the speed at which free space is taken back (0: never).
    """

    def __init__(
        self,
        seconds: float,
        dt_s: float,
        angle_min_rad: float,
        angle_max_rad: float,
        range_min_m: float,
        range_max_m: float,
        half_depth_m: float,
        half_width_m: float,
        every: int = 2,
        walk_in_mps: float = 0.0,
    ) -> None:
        if not (math.isfinite(seconds) and seconds >= 0.0):
            raise ValueError(f"SeenFree seconds must be >= 0, got {seconds!r}")
        if not (math.isfinite(walk_in_mps) and walk_in_mps >= 0.0):
            raise ValueError(f"SeenFree walk_in_mps must be >= 0, got {walk_in_mps!r}")
        self._decay = walk_in_mps * dt_s  # metres of free space taken back per step of age
        self.every = every
        self._lo, self._hi = angle_min_rad, angle_max_rad
        self._rmin, self._rmax = range_min_m, range_max_m
        self._half = (half_depth_m, half_width_m)
        # Ring buffers, oldest overwritten: the kept scans (the beams' free stretches, and the
        # pose x, y, theta and step count each was taken at) and the poses (x, y, cos, sin, count).
        self._n_scans = max(int(round(seconds / dt_s)) // every, 1)
        self._n_poses = max(int(round(seconds / dt_s)), 1)
        self._ranges = np.zeros((self._n_scans, 0))
        self._at = np.zeros((self._n_scans, 4))
        self._poses = np.zeros((self._n_poses, 5))
        self._count = 0

    def reset(self) -> None:
        self._count = 0

    def add(self, ranges: FloatArray, odom: Pose) -> None:
        """Keep a scan (every `every`-th call): a beam without a return is free to the LRF's
        range, one below its minimum range shows nothing."""
        self._count += 1
        self._poses[(self._count - 1) % self._n_poses] = (
            odom.x, odom.y, math.cos(odom.theta), math.sin(odom.theta), self._count,
        )  # fmt: skip
        if (self._count - 1) % self.every:
            return
        r = np.where(np.isfinite(ranges), ranges, self._rmax)
        r = np.where(r < self._rmin, 0.0, np.minimum(r, self._rmax))
        # A beam's neighbours bound what lies between them: keep the nearest of the three.
        near = np.minimum(r, np.minimum(np.roll(r, 1), np.roll(r, -1)))
        near[0], near[-1] = min(r[0], r[1]), min(r[-1], r[-2])
        if self._ranges.shape[1] != len(near):
            self._ranges = np.zeros((self._n_scans, len(near)))
        slot = ((self._count - 1) // self.every) % self._n_scans
        self._ranges[slot] = near
        self._at[slot] = (odom.x, odom.y, odom.theta, self._count)

    def free(self, points: FloatArray, odom: Pose, aged: bool = True) -> FloatArray:
        """For robot-frame points of the robot at `odom`: whether a kept scan saw each free
        (`aged`: with what a walking person may have taken back since, see `walk_in_mps`)."""
        out = np.zeros(len(points), dtype=bool)
        if self._count == 0:
            return out
        c, s = math.cos(odom.theta), math.sin(odom.theta)
        wx = odom.x + c * points[:, 0] - s * points[:, 1]
        wy = odom.y + s * points[:, 0] + c * points[:, 1]
        _seen_free(
            np.ascontiguousarray(wx), np.ascontiguousarray(wy), self._ranges, self._at,
            min((self._count - 1) // self.every + 1, self._n_scans), self._poses, min(self._count, self._n_poses),
            self._lo, self._hi, self._half[0], self._half[1], self._decay if aged else 0.0, self._count, out,
        )  # fmt: skip
        return out


@njit
def _seen_free(
    wx: FloatArray,
    wy: FloatArray,
    ranges: FloatArray,
    at: FloatArray,
    n_scans: int,
    poses: FloatArray,
    n_poses: int,
    lo: float,
    hi: float,
    half_depth: float,
    half_width: float,
    decay: float,
    now: int,
    out: np.ndarray,
) -> None:
    """`SeenFree.free`'s test of the map-frame points (wx, wy) against the first `n_scans` kept
    scans and `n_poses` kept poses; sets `out` where one vouches."""
    n = ranges.shape[1]
    for j in range(n_scans):
        x0, y0, theta, taken = at[j, 0], at[j, 1], at[j, 2], decay * (now - at[j, 3])
        for i in range(wx.shape[0]):
            if out[i]:
                continue
            dx, dy = wx[i] - x0, wy[i] - y0
            bearing = math.atan2(dy, dx) - theta
            bearing = (bearing + math.pi) % (2.0 * math.pi) - math.pi
            k = np.rint((bearing - lo) / (hi - lo) * (n - 1))
            if 0 <= k < n and math.hypot(dx, dy) + SEEN_FREE_SLACK_M + taken < ranges[j, int(k)]:
                out[i] = True
    for j in range(n_poses):
        x0, y0, c, s, taken = poses[j, 0], poses[j, 1], poses[j, 2], poses[j, 3], decay * (now - poses[j, 4])
        for i in range(wx.shape[0]):
            if out[i]:
                continue
            dx, dy = wx[i] - x0, wy[i] - y0
            along, across = c * dx + s * dy, -s * dx + c * dy
            if abs(along) < half_depth - taken and abs(across) < half_width - taken:
                out[i] = True


# A point is seen free when a beam through it ended at least this much beyond it [m].
SEEN_FREE_SLACK_M = 0.05


# A rear point's predicted position may leave the turning circle (`blind_turn`) or the
# footprint (`blind_translation`) by this much: the linear prediction's own error, and the sliver
# a translation at the view's edge sweeps [m].
_RING_SLACK_M = 0.02

# How far behind the footprint's rear edge (beyond the slack above) `behind_seen_free` looks [m].
_BEHIND_M = 0.05


def blind_turn(
    command: tuple[float, float, float],
    cfg: MotionConfig,
    angle_min_rad: float,
    angle_max_rad: float,
    seen_free: Callable[[FloatArray], FloatArray] | None = None,
) -> float:
    """The command's turn rate, cut (to 1/2, 1/4, 0) until no rear part of the footprint moves
    out of the robot's turning circle into the LRF's blind sector within the filter's horizon.

    Translating sideways (at the edge of the LRF's view, where `keep_in_view` lets it go) while
    turning towards that side swings the footprint's rear corner through space the robot has not
    seen: in the robot's frame the world turns the other way, so whatever the corner meets comes
    from behind. Neither the scan nor a memory of it can hold an obstacle that was never seen,
    so the turn waits until the translation is done, unless `seen_free` (robot-frame points ->
    whether each was recently seen free, e.g. `SeenFree.free`) vouches for where the rear goes.
    A turn in place stays inside the turning circle and is left alone (the filter and
    `safe_turn` keep it off what is known).
    """
    vx, vy, w = command
    if w == 0.0 or (vx == 0.0 and vy == 0.0):
        return w
    ring = math.hypot(cfg.half_depth, cfg.half_width) + _RING_SLACK_M

    def outside(x: FloatArray, y: FloatArray) -> np.ndarray:
        return np.hypot(x, y) > ring

    view = (angle_min_rad, angle_max_rad)
    for scale in (1.0, 0.5, 0.25):
        if not _rear_enters_unseen((vx, vy, w * scale), cfg, outside, view, seen_free):
            return w * scale
    return 0.0


def blind_translation(
    command: tuple[float, float, float],
    cfg: MotionConfig,
    angle_min_rad: float,
    angle_max_rad: float,
    seen_free: Callable[[FloatArray], FloatArray] | None = None,
    may_back: bool = True,
) -> tuple[float, float]:
    """The command's translation, cut (to 1/2, 1/4, 0) until no rear part of the footprint
    moves out of the footprint into the LRF's blind sector within the filter's horizon, unless
    `seen_free` vouches for where it goes.

    `keep_in_view` lets the robot translate up to its visible bearing (about 106 degrees): the
    direction of travel is in view, but the rear corner leads and sweeps space behind the view.
    A person who walked up behind a robot that stood still is there and was never seen. The
    turn is left to `blind_turn`.

    With `may_back` false, any backward part is dropped first (the caller decides, e.g. with
    `behind_seen_free`): a slow creep backwards stays within the prediction's slack at every
    step but, kept up, closes on a person standing just behind.
    """
    vx, vy, _ = command
    if vx == 0.0 and vy == 0.0:
        return vx, vy
    hd, hw = cfg.half_depth + _RING_SLACK_M, cfg.half_width + _RING_SLACK_M

    def outside(x: FloatArray, y: FloatArray) -> np.ndarray:
        return (np.abs(x) > hd) | (np.abs(y) > hw)

    view = (angle_min_rad, angle_max_rad)
    if vx < 0.0 and not may_back:
        vx = 0.0  # backing, however slowly, into what no recent scan saw free
    for scale in (1.0, 0.5, 0.25):
        if not _rear_enters_unseen((vx * scale, vy * scale, 0.0), cfg, outside, view, seen_free):
            return vx * scale, vy * scale
    return 0.0, 0.0


def behind_seen_free(cfg: MotionConfig, seen_free: Callable[[FloatArray], FloatArray] | None) -> bool:
    """Whether `seen_free` vouches for the strip just behind the footprint's rear edge.

    A slow backward drift stays within the slack of any one step's prediction, and a person who
    walked up behind stands just there (a paused mover keeps its pause radius, so it is the robot
    that closes the gap)."""
    if seen_free is None:
        return False
    hd, hw = cfg.half_depth, cfg.half_width
    x = -hd - _RING_SLACK_M - _BEHIND_M
    strip = np.array([[x, -hw], [x, -0.5 * hw], [x, 0.0], [x, 0.5 * hw], [x, hw]])
    return bool(seen_free(strip).all())


def _rear_enters_unseen(
    twist: tuple[float, float, float],
    cfg: MotionConfig,
    outside: Callable[[FloatArray, FloatArray], np.ndarray],
    view: tuple[float, float],
    seen_free: Callable[[FloatArray], FloatArray] | None,
) -> bool:
    """Whether a rear footprint point (rear corners, rear middle, side middles), moved by the
    twist for half and all of the filter's horizon (p(t) = R(wt) p + v t), lies `outside` in the
    blind sector (bearing beyond `view`) where `seen_free` does not vouch for it."""
    vx, vy, w = twist
    hd, hw = cfg.half_depth, cfg.half_width
    rear = np.array([[-hd, -hw], [-hd, 0.0], [-hd, hw], [0.0, -hw], [0.0, hw]])
    lo, hi = view
    for f in (0.5, 1.0):
        t = cfg.horizon * f
        c, s = math.cos(w * t), math.sin(w * t)
        x = c * rear[:, 0] - s * rear[:, 1] + vx * t
        y = s * rear[:, 0] + c * rear[:, 1] + vy * t
        bearing = np.arctan2(y, x)
        blind = outside(x, y) & ((bearing < lo) | (bearing > hi))
        if blind.any() and (seen_free is None or not seen_free(np.column_stack([x[blind], y[blind]])).all()):
            return True
    return False
