"""People tracking from the LRF: clusters of unexplained scan points, followed over time.

The LRF scan is split into clusters in beam order (neighbouring end points closer than a gap join,
the usual first step of laser-based people tracking: Arras, Martinez Mozos and Burgard, "Using
Boosted Features for the Detection of People in 2D Range Data", ICRA 2007). Only points the given
map does not explain are clustered, so walls never become tracks; a cluster that lies on one of the
map's door openings is a closed door, not a person. Each cluster is associated with the nearest
predicted track within a gate (greedy, nearest pairs first) and the track is updated with an
alpha-beta filter (constant velocity). A track that has travelled far enough within a short window
is *moving*: the course's people and carts walk at 0.5-0.6 m/s and stop only while the robot is
near them (docs/facts/hospital-facts.md 1.6), boxes and closed doors never move. A walking track that leaves
the view is remembered for a while: seen again where it could have walked, it is the same person,
still moving (a person who paused behind the robot is not a new, standing obstacle).

What the hospital agent does with them: the points of a moving track are not evidence of a static
obstacle (a person walking leaves no wall behind), the cells it walked through are cleared, its
predicted disc is blocked for planning, and it is yielded to outside its pause radius.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from pico_gym.types import FloatArray

# emc_simulator moving_object.cpp (docs/facts/hospital-facts.md 1.6): an object pauses while the robot's
# centre is within its half-diagonal plus this margin.
PAUSE_MARGIN_M = 0.3


@dataclass(frozen=True)
class TrackerConfig:
    """Parameters of the people tracker (SI units).

    Attributes:
        gap_m: neighbouring scan points (in beam order) closer than this join one cluster [m].
        min_points: a cluster needs at least this many points.
        max_extent_m: clusters larger than this are not tracked (a wall the map lacks) [m].
        gate_m: a cluster joins a track whose prediction is within this [m].
        alpha, beta: the alpha-beta filter's position and velocity gains.
        lost_s: a track not seen for this long is dropped [s].
        moving_m, moving_window_s, moving_margin_m: a track that has moved this far, and farther
            than its largest extent seen plus the margin, within this window is moving (and stays
            so) [m, s, m].
        door_margin_m: a cluster whose points lie within this of a door opening of the map is a
            door (closed), not a person [m].
        max_speed_mps: velocity estimates are capped at this (the course's movers walk at 0.5-0.6).
        remember_s, walk_speed_mps, walking_mps: a walking track (moving, or estimated at least
            `walking_mps` fast) that was dropped is remembered for `remember_s` after it was last
            seen; a new cluster within `gate_m` plus how far it could walk since then at
            `walk_speed_mps` (the course's 0.5-0.6) is that person again [s, m/s, m/s].
    """

    gap_m: float = 0.2
    min_points: int = 2
    max_extent_m: float = 1.2
    gate_m: float = 0.5
    alpha: float = 0.5
    beta: float = 0.2
    lost_s: float = 1.5
    moving_m: float = 0.4
    moving_window_s: float = 3.0
    moving_margin_m: float = 0.1
    door_margin_m: float = 0.1
    max_speed_mps: float = 0.8
    remember_s: float = 5.0
    walk_speed_mps: float = 0.6
    walking_mps: float = 0.25


@dataclass
class Track:
    """One tracked cluster, in the map frame."""

    id: int
    position: FloatArray
    velocity: FloatArray
    extent_m: float
    seen_s: float
    history: list[tuple[float, FloatArray]] = field(default_factory=list)  # (time, position)
    moving: bool = False
    moving_since_s: float = math.inf  # when it was first seen to be moving

    @property
    def radius_m(self) -> float:
        """Half the largest extent seen (at least a person's 0.2 m)."""
        return max(0.5 * self.extent_m, 0.2)

    @property
    def pause_radius_m(self) -> float:
        """Where the simulator's object would pause for the robot: its half-diagonal (here from the
        largest extent seen, which is at most the diagonal) plus the margin."""
        return self.radius_m + PAUSE_MARGIN_M

    def predict(self, t_s: float) -> FloatArray:
        """Where it will be `t_s` seconds after it was last seen (constant velocity)."""
        return self.position + self.velocity * t_s


@dataclass(frozen=True)
class Cluster:
    """Scan points (map frame) that belong together, and which of the input points they are."""

    points: FloatArray
    index: np.ndarray

    @property
    def centre(self) -> FloatArray:
        return self.points.mean(axis=0)

    @property
    def extent_m(self) -> float:
        return float(np.hypot(*(self.points.max(axis=0) - self.points.min(axis=0))))


def clusters_in_order(points: FloatArray, keep: np.ndarray, gap_m: float, min_points: int) -> list[Cluster]:
    """Split the kept points into runs of neighbours (beam order; a point not kept ends a run).

    >>> pts = np.array([[0.0, 0.0], [0.1, 0.0], [1.0, 0.0], [1.1, 0.0], [1.15, 0.0]])
    >>> [c.index.tolist() for c in clusters_in_order(pts, np.ones(5, bool), 0.2, 2)]
    [[0, 1], [2, 3, 4]]
    """
    n = len(points)
    if n == 0:
        return []
    keep = np.asarray(keep, dtype=bool)
    step = np.hypot(*(points[1:] - points[:-1]).T)  # from each point to the next
    # A run starts at a kept point whose predecessor is not kept or lies farther than the gap.
    starts = keep.copy()
    starts[1:] &= ~keep[:-1] | (step > gap_m)
    first = np.flatnonzero(starts)
    # ... and ends at a kept point the next one does not continue (not kept, or a start).
    continues = keep & ~starts
    ends = np.flatnonzero(keep & np.append(~continues[1:], True))
    out = []
    for a, b in zip(first.tolist(), ends.tolist(), strict=True):
        if b - a + 1 >= min_points:
            idx = np.arange(a, b + 1)
            out.append(Cluster(points[idx], idx))
    return out


class PeopleTracker:
    """Tracks of unexplained clusters (see the module docstring).

    Args:
        config: the tracker's parameters.
        doors: the given map's door openings as (centre, unit normal, half width) (see the
            hospital agent's `_door_frame`); clusters on them are doors, not people.
    """

    def __init__(
        self, config: TrackerConfig | None = None, doors: Sequence[tuple[FloatArray, FloatArray, float]] = ()
    ) -> None:
        self.config = config or TrackerConfig()
        self.doors = list(doors)
        self.tracks: list[Track] = []
        self.dropped: list[Track] = []  # walking tracks no longer seen, kept for `remember_s`
        self._next_id = 0

    def reset(self) -> None:
        self.tracks = []
        self.dropped = []
        self._next_id = 0

    def _on_door(self, points: FloatArray) -> bool:
        m = self.config.door_margin_m
        for centre, normal, half in self.doors:
            d = points - centre
            across = np.abs(d @ normal)
            along = np.abs(d @ np.array([-normal[1], normal[0]]))
            if bool(np.all((across <= 0.15 + m) & (along <= half + m))):
                return True
        return False

    def update(self, points: FloatArray, unexplained: np.ndarray, time_s: float) -> list[tuple[Cluster, Track]]:
        """One scan: `points` (map frame, beam order) and which the map does not explain.

        Returns the clusters that joined a track, with their track (for the caller to treat the
        points of moving ones differently)."""
        cfg = self.config
        clusters = [
            c
            for c in clusters_in_order(points, unexplained, cfg.gap_m, cfg.min_points)
            if c.extent_m <= cfg.max_extent_m and not self._on_door(c.points)
        ]
        # Greedy association, nearest (cluster, predicted track) pairs first.
        pairs = []
        for i, c in enumerate(clusters):
            centre = c.centre
            for j, t in enumerate(self.tracks):
                d = float(np.hypot(*(centre - t.predict(time_s - t.seen_s))))
                if d <= cfg.gate_m:
                    pairs.append((d, i, j))
        pairs.sort()
        used_c: set[int] = set()
        used_t: set[int] = set()
        joined: list[tuple[Cluster, Track]] = []
        for _, i, j in pairs:
            if i in used_c or j in used_t:
                continue
            used_c.add(i)
            used_t.add(j)
            self._correct(self.tracks[j], clusters[i], time_s)
            joined.append((clusters[i], self.tracks[j]))
        for i, c in enumerate(clusters):
            if i in used_c:
                continue
            revived = self._revive(c, time_s)
            if revived is None:
                t = Track(self._next_id, c.centre, np.zeros(2), c.extent_m, time_s, [(time_s, c.centre)])
                self._next_id += 1
            else:
                t = revived
            self.tracks.append(t)
            joined.append((c, t))
        kept = [t for t in self.tracks if time_s - t.seen_s <= cfg.lost_s]
        self.dropped += [t for t in self.tracks if self._walks(t) and time_s - t.seen_s > cfg.lost_s]
        self.dropped = [t for t in self.dropped if time_s - t.seen_s <= cfg.remember_s]
        self.tracks = kept
        return joined

    def _revive(self, cluster: Cluster, time_s: float) -> Track | None:
        """The dropped walking track a new cluster is, if one could have walked there since it was
        last seen (a person who paused out of sight and is seen again stays a person: a new track
        would have to walk before it counts as moving)."""
        cfg = self.config
        best, best_d = None, math.inf
        for t in self.dropped:
            reach = cfg.gate_m + cfg.walk_speed_mps * (time_s - t.seen_s)
            d = float(np.hypot(*(cluster.centre - t.position)))
            if d <= reach and d < best_d:
                best, best_d = t, d
        if best is None:
            return None
        self.dropped.remove(best)
        best.position = cluster.centre.copy()
        best.velocity = np.zeros(2)
        best.extent_m = max(best.extent_m, cluster.extent_m)
        best.seen_s = time_s
        best.history.append((time_s, best.position.copy()))
        return best

    def _correct(self, track: Track, cluster: Cluster, time_s: float) -> None:
        cfg = self.config
        dt = max(time_s - track.seen_s, 1e-3)
        predicted = track.predict(dt)
        residual = cluster.centre - predicted
        track.position = predicted + cfg.alpha * residual
        velocity = track.velocity + cfg.beta * residual / dt
        speed = float(np.hypot(*velocity))
        if speed > cfg.max_speed_mps:
            velocity = velocity * (cfg.max_speed_mps / speed)
        track.velocity = velocity
        track.extent_m = max(track.extent_m, cluster.extent_m)
        track.seen_s = time_s
        track.history.append((time_s, track.position.copy()))
        track.history = [(t, p) for t, p in track.history if time_s - t <= cfg.moving_window_s + 5.0]
        if not track.moving:
            window = [p for t, p in track.history if time_s - t <= cfg.moving_window_s]
            # Farther than its own size: the centre of a box seen from another side moves too,
            # by up to about its extent (a box taken for a person had its cells cleared).
            needed = max(cfg.moving_m, track.extent_m + cfg.moving_margin_m)
            track.moving = bool(float(np.hypot(*(window[-1] - window[0]))) >= needed)
            if track.moving:
                track.moving_since_s = time_s

    def _walks(self, track: Track) -> bool:
        """Seen moving, or estimated at least `walking_mps` fast."""
        return track.moving or float(np.hypot(*track.velocity)) >= self.config.walking_mps

    def walking(self) -> list[Track]:
        """The tracks that walk (`_walks`), whether the last scan saw them or not, and the walking
        tracks dropped but still remembered."""
        return [t for t in self.tracks if self._walks(t)] + list(self.dropped)

    def moving(self) -> list[Track]:
        """The tracks that have been seen moving."""
        return [t for t in self.tracks if t.moving]
