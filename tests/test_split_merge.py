"""Split-and-merge and features on synthetic scans of known shapes, with and without noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pico_gym.agents.classic.features import extract_features, find_corners
from pico_gym.agents.classic.split_merge import preprocess, split_and_merge
from pico_gym.sensors.lrf import LrfConfig, lrf_ranges
from pico_gym.types import Pose

ANGLES = LrfConfig().beam_angles


def scan_of(segments: list[list[float]], pose: Pose, noise: float, seed: int = 0) -> np.ndarray:
    """A scan as the robot would read it: exact ranges + U(-noise, noise), no hit = 10 m."""
    r = lrf_ranges(pose, np.array(segments, dtype=float), ANGLES, 10.0)
    r = r + np.random.default_rng(seed).uniform(-noise, noise, len(r))
    return np.where(np.isfinite(r), r, 10.0)


def extract(ranges: np.ndarray):
    scan = preprocess(ranges, ANGLES, 0.01, 10.0)
    lines = split_and_merge(scan)
    return scan, lines, extract_features(scan, lines, ranges, ANGLES, 10.0)


def to_robot(points: np.ndarray, pose: Pose) -> np.ndarray:
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    d = np.asarray(points, dtype=float) - [pose.x, pose.y]
    return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])


def line_matches(segment: np.ndarray, a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """Both end points of `segment` lie within `tol` of the infinite line a-b."""
    d = (b - a) / np.linalg.norm(b - a)
    n = np.array([-d[1], d[0]])
    return all(abs(float((p - a) @ n)) < tol for p in (segment[:2], segment[2:]))


RECTANGLE = [[-2, -1.5, 3, -1.5], [3, -1.5, 3, 2], [3, 2, -2, 2], [-2, 2, -2, -1.5]]


@pytest.mark.parametrize("noise", [0.0, 0.01, 0.02])
def test_rectangle_from_inside(noise: float) -> None:
    pose = Pose(0.3, 0.2, 0.4)
    _, lines, features = extract(scan_of(RECTANGLE, pose, noise))
    walls = [to_robot(np.array(w).reshape(2, 2), pose) for w in RECTANGLE]
    # every extracted line lies on one of the walls, and every wall in view is found once
    scan = preprocess(scan_of(RECTANGLE, pose, 0.0), ANGLES, 0.01, 10.0)
    in_view = [w for w in walls if sum(line_matches(np.r_[p, p], w[0], w[1], 1e-6) for p in scan.points) >= 12]
    matched = [sum(line_matches(seg, w[0], w[1], 0.03) for seg in lines.segments) for w in in_view]
    assert matched == [1] * len(in_view) and len(lines) == len(in_view)
    concave = [c for c in features.corners if c.concave]
    assert len(concave) >= 2 and len(features.corners) == len(concave)
    assert features.exits == []


def test_l_corner_is_one_concave_corner() -> None:
    corner = [[2.0, -3.0, 2.0, 1.0], [2.0, 1.0, -3.0, 1.0]]
    pose = Pose(0.0, 0.0, 0.0)
    _, lines, features = extract(scan_of(corner, pose, 0.01))
    assert len(lines) == 2
    assert len(features.corners) == 1
    c = features.corners[0]
    assert c.concave and c.point == pytest.approx([2.0, 1.0], abs=0.03)


def test_convex_corner_points_at_the_robot() -> None:
    # A box corner pointing at the robot.
    box = [[2.0, 0.0, 3.0, 1.0], [2.0, 0.0, 3.0, -1.0]]
    _, _, features = extract(scan_of(box, Pose(0.0, 0.0, 0.0), 0.005))
    assert len(features.corners) == 1 and not features.corners[0].concave
    assert features.corners[0].point == pytest.approx([2.0, 0.0], abs=0.03)


@pytest.mark.parametrize("distance", [0.4, 1.0, 2.5])
def test_wall_perpendicular_to_the_heading_gives_no_false_corner(distance: float) -> None:
    wall = [[distance, -4.0, distance, 4.0]]
    for seed in range(5):
        _, lines, features = extract(scan_of(wall, Pose(0.0, 0.0, 0.0), 0.01, seed))
        assert len(lines) == 1 and features.corners == []


def room_with_mouth(width: float, flush: bool) -> list[list[float]]:
    """A 4 x 3 m room with a corridor leaving the top wall (at x = 1.5, or flush with x = 0)."""
    x0 = 0.0 if flush else 1.5
    x1 = x0 + width
    walls = [[0, 0, 4, 0], [4, 0, 4, 3], [4, 3, x1, 3], [x1, 3, x1, 7], [x0, 7, x0, 3], [0, 0, 0, 3]]
    if not flush:
        walls.append([x0, 3, 0, 3])
    return walls


@pytest.mark.parametrize("width,flush", [(0.5, False), (1.0, False), (1.5, False), (0.6, True), (1.2, True)])
@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_corridor_mouth_is_found(width: float, flush: bool, noise: float) -> None:
    pose = Pose(2.0, 1.0, math.pi / 2 + 0.2)
    _, _, features = extract(scan_of(room_with_mouth(width, flush), pose, noise))
    x0 = 0.0 if flush else 1.5
    mouth = to_robot(np.array([[x0, 3.0], [x0 + width, 3.0]]), pose)
    assert len(features.exits) == 1
    ex = features.exits[0]
    assert ex.width == pytest.approx(width, abs=0.06)
    assert ex.centre == pytest.approx(mouth.mean(axis=0), abs=0.05)
    # outward points into the corridor: away from the robot, along the corridor
    corridor_dir = to_robot(np.array([[0.0, 1.0]]), Pose(0, 0, pose.theta))[0]
    assert float(ex.outward @ corridor_dir) > 0.95


def test_mouth_edges_that_do_not_face_each_other() -> None:
    # The wall beyond the mouth is set back by 8 cm and the corridor walls are not parallel:
    # the two open ends are not opposite each other.
    walls = [
        [0, 0, 4, 0],
        [4, 0, 4, 3.08],
        [4, 3.08, 2.2, 3.08],
        [2.2, 3.08, 2.35, 7],
        [1.5, 7, 1.5, 3],
        [1.5, 3, 0, 3],
        [0, 0, 0, 3],
    ]
    pose = Pose(2.8, 0.8, 2.0)
    _, _, features = extract(scan_of(walls, pose, 0.01))
    assert len(features.exits) == 1
    assert features.exits[0].width == pytest.approx(0.7, abs=0.1)


def test_shadow_behind_an_obstacle_is_not_an_exit() -> None:
    # A box in front of a wall hides part of it: the gap in the wall's points is no exit,
    # because the beams through it hit the box, not space beyond the wall.
    walls = RECTANGLE + [[1.1, 1.2, 1.6, 1.2], [1.6, 1.2, 1.6, 1.5], [1.6, 1.5, 1.1, 1.5], [1.1, 1.5, 1.1, 1.2]]
    _, _, features = extract(scan_of(walls, Pose(1.3, -0.5, math.pi / 2), 0.01))
    assert features.exits == []


def test_corners_need_two_lines() -> None:
    from pico_gym.agents.classic.split_merge import Lines

    one = Lines(np.array([[0.0, 0.0, 1.0, 0.0]]), np.array([[0, 10]]), np.array([0]))
    assert find_corners(one) == []


def test_averaging_scans_reduces_noise() -> None:
    wall = [[1.5, -4.0, 1.5, 4.0]]
    pose = Pose(0.0, 0.0, 0.0)
    scans = [scan_of(wall, pose, 0.01, seed) for seed in range(8)]
    single = preprocess(scans[0], ANGLES, 0.01, 10.0)
    averaged = preprocess(scans[0], ANGLES, 0.01, 10.0, history=scans[1:])
    assert np.std(averaged.points[:, 0] - 1.5) < 0.5 * np.std(single.points[:, 0] - 1.5)
