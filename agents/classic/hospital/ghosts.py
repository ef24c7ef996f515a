"""People the LRF stopped seeing near the robot: kept as "ghosts" until a scan sees them gone.

The course simulator's people pause while the robot is within their pause radius (its
half-diagonal plus 0.3 m, `tracking.PAUSE_MARGIN_M`). One who walks past the robot into the
LRF's blind sector (about 130 degrees behind it) stops there, 0.3-0.5 m behind, and is in no
scan: the tracker drops it, the scan memory forgets it, and the robot, turning in place or
backing away while it recovers, swings its rear into it: the mover bumps first traced on the
narrow and crowded hospital families (docs/agents/hybrid.md). A ghost covers those the tracker
saw walking; one never seen (walking up from behind a standing robot) it cannot.

A ghost is where such a person would be: the track's last estimate walked on along its velocity
until it comes within its pause radius of the robot (where the simulator's person would stop).
Its points (its centre and a ring of the person's radius), less those the scan sees free, join
what the safety filter keeps the footprint off, so no turn or translation sweeps the rear into
it. A ghost goes when a beam through its centre ends beyond it (the space was seen free), when
its person is seen again, when the robot is far from it, or after `ghost_people_s`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pico_gym.agents.classic.hospital.evidence import to_robot
from pico_gym.agents.classic.tracking import Track
from pico_gym.agents.shield import SEEN_FREE_SLACK_M
from pico_gym.types import FloatArray, Pose

# A ghost within this of the robot is kept; farther, it cannot meet the footprint soon [m].
REACH_M = 1.5
# Ring points per ghost.
RING_POINTS = 12


@dataclass
class Ghost:
    """A person out of sight (map frame): where it is believed to be, how it walks, its size."""

    track_id: int
    centre: FloatArray
    velocity: FloatArray  # zero once it has stopped for the robot
    radius_m: float
    pause_radius_m: float
    born_s: float
    free: np.ndarray  # which of its points (centre, then ring) the last scan saw free

    def points(self) -> FloatArray:
        """Its centre and a ring of its radius (map frame)."""
        return np.vstack([self.centre, self.centre + self.radius_m * _UNIT_RING])


class Ghosts:
    """The ghosts of one episode (see the module docstring).

    Args:
        lifetime_s: a ghost is forgotten this long after it was made.
        dt_s: the control period (a walking ghost walks on this much each step).
        angle_min_rad, angle_max_rad: the LRF's bearings.
        half_depth_m, half_width_m: the footprint (a ghost point inside it is dropped: the robot
            stands there, so the person does not).
    """

    def __init__(
        self,
        lifetime_s: float,
        dt_s: float,
        angle_min_rad: float,
        angle_max_rad: float,
        half_depth_m: float,
        half_width_m: float,
    ) -> None:
        self.lifetime_s, self.dt_s = lifetime_s, dt_s
        self._view = (angle_min_rad, angle_max_rad)
        self._half = (half_depth_m, half_width_m)
        self.ghosts: list[Ghost] = []

    def update(self, pose: Pose, walking: list[Track], now_s: float, ranges: FloatArray, angles: FloatArray) -> None:
        """One step: `walking` are the tracks seen walking (seen this scan or not), `ranges` and
        `angles` this scan's. A ghost walks on until it is within its pause radius of the robot,
        and goes when its centre is in view and seen free, when its person is seen again (a
        walking track seen this scan within its pause radius), far from the robot, or old."""
        here = np.array([pose.x, pose.y])
        seen = [t for t in walking if t.seen_s >= now_s]
        known = {g.track_id for g in self.ghosts}
        for t in walking:
            if t.seen_s >= now_s or t.id in known:
                continue
            centre = _where_it_stops(t.position, t.velocity, now_s - t.seen_s, here, t.pause_radius_m)
            if math.hypot(*(centre - here)) < REACH_M:
                stopped = math.hypot(*(centre - here)) <= t.pause_radius_m + 1e-9
                velocity = np.zeros(2) if stopped else t.velocity.copy()
                g = Ghost(t.id, centre, velocity, t.radius_m, t.pause_radius_m, now_s, np.zeros(RING_POINTS + 1, bool))
                self.ghosts.append(g)
        kept = []
        for g in self.ghosts:
            if now_s - g.born_s > self.lifetime_s or any(
                t.id == g.track_id or math.hypot(*(t.position - g.centre)) < g.pause_radius_m for t in seen
            ):
                continue
            if np.any(g.velocity):  # walking on, until it would pause for the robot
                g.centre = _where_it_stops(g.centre, g.velocity, self.dt_s, here, g.pause_radius_m)
                if math.hypot(*(g.centre - here)) <= g.pause_radius_m + 1e-9:
                    g.velocity = np.zeros(2)
            if math.hypot(*(g.centre - here)) > REACH_M + g.radius_m:
                continue
            g.free = self._seen_free(pose, g.points(), ranges, angles)
            if not g.free[0]:  # its centre is not seen free
                kept.append(g)
        self.ghosts = kept

    def points(self, pose: Pose) -> FloatArray:
        """The ghosts' points in the robot frame: those the last scan did not see free, and not
        inside the footprint."""
        if not self.ghosts:
            return np.zeros((0, 2))
        pts = to_robot(pose, np.vstack([g.points()[~g.free] for g in self.ghosts]))
        inside = (np.abs(pts[:, 0]) < self._half[0]) & (np.abs(pts[:, 1]) < self._half[1])
        return pts[~inside]

    def _seen_free(self, pose: Pose, pts_map: FloatArray, ranges: FloatArray, angles: FloatArray) -> np.ndarray:
        """Which map-frame points this scan saw free (a beam through each ended at least
        `SEEN_FREE_SLACK_M` beyond it, as `SeenFree` judges)."""
        pts = to_robot(pose, pts_map)
        dist = np.hypot(pts[:, 0], pts[:, 1])
        bearing = np.arctan2(pts[:, 1], pts[:, 0])
        lo, hi = self._view
        k = np.rint((bearing - lo) / (hi - lo) * (len(angles) - 1)).astype(np.int64)
        inview = (k >= 0) & (k < len(angles))
        r = ranges[np.clip(k, 0, len(angles) - 1)]
        r = np.where(np.isfinite(r), r, np.inf)
        return inview & (r > dist + SEEN_FREE_SLACK_M)


_RING_ANGLES = np.arange(RING_POINTS) * 2.0 * math.pi / RING_POINTS
_UNIT_RING = np.column_stack([np.cos(_RING_ANGLES), np.sin(_RING_ANGLES)])


def _where_it_stops(
    start: FloatArray, velocity: FloatArray, unseen_s: float, here: FloatArray, pause_m: float
) -> FloatArray:
    """A person last seen at `start` walking at `velocity`, walked on for `unseen_s` but stopped
    where it first comes within `pause_m` of `here` (the robot)."""
    v = velocity
    if math.hypot(*(start - here)) <= pause_m or not np.any(v):
        return start.copy()
    # |start + v s - here| = pause_m: the first root in [0, unseen_s], if any.
    d = start - here
    a, b, c = float(v @ v), 2.0 * float(d @ v), float(d @ d) - pause_m * pause_m
    disc = b * b - 4.0 * a * c
    s = unseen_s
    if disc >= 0.0:
        first = (-b - math.sqrt(disc)) / (2.0 * a)
        if 0.0 <= first < unseen_s:
            s = first
    return start + v * s
