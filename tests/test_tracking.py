"""People tracking: clusters in beam order, tracks, what moves and what does not."""

from __future__ import annotations

import numpy as np

from pico_gym.agents.classic.hospital.ghosts import Ghosts
from pico_gym.agents.classic.potential_field import MotionConfig, safety_filter
from pico_gym.agents.classic.tracking import PeopleTracker, Track, TrackerConfig, clusters_in_order
from pico_gym.types import Pose


def _blob(centre: tuple[float, float], n: int = 6, size: float = 0.3) -> np.ndarray:
    """n points along a short segment (what the LRF sees of a person or a box)."""
    xs = np.linspace(-size / 2, size / 2, n)
    return np.column_stack([centre[0] + xs, np.full(n, centre[1])])


def test_clusters_split_at_gaps_and_at_explained_points() -> None:
    pts = np.vstack([_blob((0.0, 0.0)), _blob((2.0, 0.0))])
    keep = np.ones(len(pts), bool)
    assert [len(c.index) for c in clusters_in_order(pts, keep, 0.2, 2)] == [6, 6]
    keep[2] = False  # a point the map explains ends a run
    assert [c.index.tolist() for c in clusters_in_order(pts, keep, 0.2, 3)] == [[3, 4, 5], list(range(6, 12))]


def test_a_walking_cluster_becomes_a_moving_track_and_a_standing_one_does_not() -> None:
    tracker = PeopleTracker(TrackerConfig())
    for k in range(30):  # 3 s at 10 Hz: a person at 0.5 m/s, a box standing still
        t = 0.1 * k
        pts = np.vstack([_blob((1.0 + 0.5 * t, 2.0)), _blob((4.0, -1.0), size=0.5)])
        tracker.update(pts, np.ones(len(pts), bool), t)
    moving = tracker.moving()
    assert len(tracker.tracks) == 2 and len(moving) == 1
    person = moving[0]
    assert abs(person.position[0] - (1.0 + 0.5 * 2.9)) < 0.1
    assert abs(person.velocity[0] - 0.5) < 0.1 and abs(person.velocity[1]) < 0.05
    assert person.pause_radius_m >= 0.2 + 0.3


def test_a_cluster_on_a_door_opening_is_a_door_not_a_person() -> None:
    door = (np.array([0.0, 0.0]), np.array([0.0, 1.0]), 0.5)  # an opening along x, 1 m wide
    tracker = PeopleTracker(TrackerConfig(), [door])
    for k in range(30):  # a door sliding along its opening (the course's doors slide open)
        pts = _blob((-0.3 + 0.02 * k, 0.0), size=0.4)
        tracker.update(pts, np.ones(len(pts), bool), 0.1 * k)
    assert tracker.tracks == []


def test_a_lost_track_is_dropped() -> None:
    tracker = PeopleTracker(TrackerConfig(lost_s=1.0))
    tracker.update(_blob((0.0, 0.0)), np.ones(6, bool), 0.0)
    tracker.update(np.zeros((0, 2)), np.zeros(0, bool), 0.5)
    assert len(tracker.tracks) == 1
    tracker.update(np.zeros((0, 2)), np.zeros(0, bool), 1.2)
    assert tracker.tracks == []


def test_a_person_seen_again_after_pausing_out_of_sight_is_still_a_person() -> None:
    """Seen again where it could have walked, a dropped walking track comes back, still moving
    (a new track would have to walk 0.4 m before the robot yields to it); a cluster farther than
    it could have walked, or after `remember_s`, is someone (or something) else."""
    tracker = PeopleTracker(TrackerConfig(lost_s=1.5, remember_s=5.0))
    nothing = (np.zeros((0, 2)), np.zeros(0, bool))
    for k in range(30):  # walks 1.5 m, then leaves the view
        tracker.update(_blob((1.0 + 0.05 * k, 2.0)), np.ones(6, bool), 0.1 * k)
    (person,) = tracker.moving()
    for k in range(30, 60):  # 3 s out of sight: dropped, remembered
        tracker.update(*nothing, 0.1 * k)
    assert tracker.tracks == [] and tracker.dropped == [person]
    tracker.update(_blob((2.9, 2.8)), np.ones(6, bool), 6.0)  # 1 m from where it was last seen
    assert tracker.moving() == [person] and tracker.dropped == []
    assert np.allclose(person.position, (2.9, 2.8)) and np.allclose(person.velocity, 0.0)

    for k in range(61, 100):
        tracker.update(*nothing, 0.1 * k)
    tracker.update(_blob((8.0, 2.8)), np.ones(6, bool), 10.0)  # 5 m away after 4 s: too far
    assert tracker.moving() == [] and tracker.tracks[0].id != person.id
    late = PeopleTracker(TrackerConfig(lost_s=1.5, remember_s=5.0))
    for k in range(30):
        late.update(_blob((1.0 + 0.05 * k, 2.0)), np.ones(6, bool), 0.1 * k)
    late.update(*nothing, 4.0)
    late.update(*nothing, 8.5)  # forgotten 5 s after it was last seen
    assert late.dropped == []
    late.update(_blob((2.6, 2.0)), np.ones(6, bool), 8.6)
    assert late.moving() == []


def test_the_safety_floor_stops_a_slow_creep_into_a_wall() -> None:
    """Without a floor the slack is allowed afresh every step: a slow command creeps into a wall."""
    wall = np.column_stack([np.linspace(-0.5, 0.5, 41), np.full(41, 0.25)])  # 5 cm off the left side

    def creep(cfg: MotionConfig) -> float:
        pts = wall.copy()
        for _ in range(200):
            vx, vy, w = safety_filter(pts, (0.0, 0.03, 0.0), cfg)
            pts = pts - np.array([vx, vy]) * 0.1  # the robot moves: the wall comes closer
        return float(pts[:, 1].min() - 0.2)  # the gap left between the footprint and the wall

    loose = MotionConfig(margin=0.04, slack=0.01)
    assert creep(loose) < 0.01  # the creep: into the 1 cm contact skin
    assert creep(MotionConfig(margin=0.04, slack=0.01, floor=0.035)) >= 0.035 - 1e-9


def _clusters_one_by_one(points: np.ndarray, keep: np.ndarray, gap_m: float, min_points: int) -> list[list[int]]:
    """The runs, grown point by point (what `clusters_in_order` computes array-wise)."""
    out: list[list[int]] = []
    run: list[int] = []
    for i in range(len(points)):
        if not keep[i] or (run and float(np.hypot(*(points[i] - points[run[-1]]))) > gap_m):
            out += [run] if len(run) >= min_points else []
            run = []
        if keep[i]:
            run.append(i)
    return out + ([run] if len(run) >= min_points else [])


def test_clusters_are_the_runs_grown_point_by_point() -> None:
    rng = np.random.default_rng(0)
    for _ in range(500):
        n = int(rng.integers(0, 40))
        pts = np.cumsum(rng.normal(0.0, 0.15, size=(n, 2)), axis=0)
        keep = rng.random(n) < rng.random()
        min_points = int(rng.integers(1, 4))
        got = clusters_in_order(pts, keep, 0.2, min_points)
        assert [c.index.tolist() for c in got] == _clusters_one_by_one(pts, keep, 0.2, min_points)
        assert all(np.array_equal(c.points, pts[c.index]) for c in got)


def _person(track_id: int, position: tuple[float, float], velocity: tuple[float, float], seen_s: float) -> Track:
    return Track(track_id, np.array(position), np.array(velocity), 0.3, seen_s, moving=True)


def _ghosts() -> Ghosts:
    return Ghosts(30.0, 0.1, -2.0, 2.0, 0.2, 0.35)  # PICO-like: a 230-degree view, 0.4 x 0.7 m


def test_a_person_walking_out_of_view_is_a_ghost_where_it_would_pause_for_the_robot() -> None:
    ghosts = _ghosts()
    pose = Pose(0.0, 0.0, 0.0)
    angles = np.linspace(-2.0, 2.0, 101)
    ranges = np.full(101, 5.0)  # nothing in view
    # Last seen 1.2 m to the left, behind, walking towards the robot at 0.5 m/s, 2 s ago.
    person = _person(7, (-0.3, 1.2), (0.0, -0.5), 10.0)
    ghosts.update(pose, [person], 12.0, ranges, angles)
    assert len(ghosts.ghosts) == 1
    centre = ghosts.ghosts[0].centre
    # It walks on until within its pause radius (0.2 + 0.3 m) of the robot, and stops there.
    assert abs(np.hypot(*centre) - person.pause_radius_m) < 1e-9 and centre[1] > 0.0
    pts = ghosts.points(pose)
    assert len(pts) > 0 and np.all(np.arctan2(pts[:, 1], pts[:, 0]) > 1.5)  # behind-left, out of view
    # ... and the safety filter will not back the robot into it.
    cfg = MotionConfig(half_depth=0.2, half_width=0.35)
    vx, vy, _ = safety_filter(pts, (-0.3, 0.0, 0.0), cfg)
    assert vx > -0.3


def test_a_ghost_goes_when_a_scan_sees_its_space_free_or_its_person_again() -> None:
    ghosts = _ghosts()
    angles = np.linspace(-2.0, 2.0, 101)
    person = _person(3, (1.0, 0.0), (0.5, 0.0), 0.0)  # walking away ahead, gone from the scan
    ghosts.update(Pose(0.0, 0.0, 0.0), [person], 0.5, np.full(101, 0.5), angles)
    assert len(ghosts.ghosts) == 1  # the beams end short of it: not seen free
    ghosts.update(Pose(0.0, 0.0, 0.0), [person], 0.6, np.full(101, 5.0), angles)
    assert ghosts.ghosts == []  # every beam through it ends beyond it
    ghosts.update(Pose(0.0, 0.0, 0.0), [person], 0.7, np.full(101, 0.5), angles)
    assert len(ghosts.ghosts) == 1
    person.seen_s = 0.8  # the tracker sees it again: the track holds it, not a ghost
    ghosts.update(Pose(0.0, 0.0, 0.0), [person], 0.8, np.full(101, 0.5), angles)
    assert ghosts.ghosts == []


def test_a_ghost_far_from_the_robot_or_old_is_forgotten_and_none_lies_in_the_footprint() -> None:
    ghosts = _ghosts()
    angles = np.linspace(-2.0, 2.0, 101)
    blind = np.full(101, 0.3)
    ghosts.update(Pose(0.0, 0.0, 0.0), [_person(1, (-0.7, 0.0), (0.0, 0.0), 0.0)], 1.0, blind, angles)
    assert len(ghosts.ghosts) == 1
    ghosts.update(Pose(3.0, 0.0, 0.0), [], 2.0, blind, angles)  # the robot drove on
    assert ghosts.ghosts == []
    ghosts.update(Pose(0.0, 0.0, 0.0), [_person(2, (-0.7, 0.0), (0.0, 0.0), 0.0)], 1.0, blind, angles)
    ghosts.update(Pose(0.0, 0.0, 0.0), [], 31.5, blind, angles)  # older than its 30 s
    assert ghosts.ghosts == []
    # A ghost straddling the footprint: the points inside it are left out (the robot stands there).
    ghosts.update(Pose(0.0, 0.0, 0.0), [_person(4, (-0.3, 0.0), (0.0, 0.0), 0.0)], 1.0, blind, angles)
    pts = ghosts.points(Pose(0.0, 0.0, 0.0))
    assert len(pts) and not np.any((np.abs(pts[:, 0]) < 0.2) & (np.abs(pts[:, 1]) < 0.35))
