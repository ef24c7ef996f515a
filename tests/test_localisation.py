"""The classic agent's localiser on a given map: global search, scan-to-map registration, health."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import pico_gym  # noqa: F401
from pico_gym.agents.classic.localisation import Localiser, scan_points
from pico_gym.sensors.lrf import Lrf, LrfConfig
from pico_gym.types import Pose
from pico_gym.world import geometry

LRF = LrfConfig()


def _scan(pose: Pose, segments: np.ndarray, seed: int = 0) -> np.ndarray:
    return Lrf(LRF).scan(pose, segments, np.random.default_rng(seed))


def _points(ranges: np.ndarray) -> np.ndarray:
    return scan_points(ranges, LRF.beam_angles, LRF.range_max_m, 90)


def _room(w: float, h: float) -> np.ndarray:
    return geometry.polygon_to_segments(np.array([[0, 0], [w, 0], [w, h], [0, h]], dtype=float))


def _error(a: Pose, b: Pose) -> tuple[float, float]:
    return math.hypot(a.x - b.x, a.y - b.y), abs(math.remainder(a.theta - b.theta, 2 * math.pi))


def test_a_symmetric_room_is_ambiguous_from_one_scan() -> None:
    """A bare 4 x 2 m room looks the same turned by 180 degrees about its centre."""
    walls = _room(4.0, 2.0)
    loc = Localiser(walls)
    true = Pose(1.2, 0.8, 0.3)
    region = np.array([[0.3, 0.3], [3.7, 0.3], [3.7, 1.7], [0.3, 1.7]])
    result = loc.global_search(region, _points(_scan(true, walls)))
    assert result.margin < loc.config.unique_margin  # its mirror image scores as well
    mirror = Pose(4.0 - true.x, 2.0 - true.y, true.theta + math.pi)
    assert min(_error(result.pose, true)[0], _error(result.pose, mirror)[0]) < 0.05


def test_turning_to_see_more_resolves_what_one_scan_cannot() -> None:
    """A room symmetric but for a partition behind the robot: one scan cannot tell the robot's pose
    from its mirror image; joined with a scan after turning half round (the turn known from
    odometry), the pose is unique and found precisely."""
    walls = np.vstack([_room(4.0, 2.0), [[0.6, 0.0, 0.6, 0.8]]])
    loc = Localiser(walls)
    true = Pose(2.6, 1.0, 0.0)
    region = np.array([[0.3, 0.3], [3.7, 0.3], [3.7, 1.7], [0.3, 1.7]])
    first = _points(_scan(true, walls))
    assert loc.global_search(region, first).margin < loc.config.unique_margin
    turned = Pose(0.0, 0.0, math.pi)  # the second scan's pose in the first one's frame
    second = scan_points(_scan(Pose(true.x, true.y, math.pi), walls, 1), LRF.beam_angles, LRF.range_max_m, 90, turned)
    result = loc.global_search(region, np.vstack([first, second]))
    assert result.margin > loc.config.unique_margin
    dxy, dth = _error(result.pose, true)
    assert dxy < 0.02 and dth < math.radians(1.0)


@pytest.mark.parametrize("offset", [(0.1, -0.08, 0.08), (-0.12, 0.05, -0.1)])
def test_scan_to_map_registration_pulls_a_wrong_guess_onto_the_walls(offset: tuple[float, float, float]) -> None:
    walls = np.vstack([_room(5.0, 3.0), [[2.0, 0.0, 2.0, 1.0], [3.5, 3.0, 3.5, 2.2]]])
    loc = Localiser(walls)
    true = Pose(1.0, 1.5, -0.4)
    pts = _points(_scan(true, walls))
    guess = Pose(true.x + offset[0], true.y + offset[1], true.theta + offset[2])
    assert loc.explained(guess, pts) < 0.8
    pose = loc.refine(guess, pts)
    dxy, dth = _error(pose, true)
    assert dxy < 0.01 and dth < math.radians(0.5)
    assert loc.explained(pose, pts) > 0.95


def test_unexplained_points_do_not_move_the_pose() -> None:
    """A box in a corner and a closed door flush with a wall: the walls still hold the pose."""
    walls = np.vstack([_room(5.0, 3.0), [[2.0, 0.0, 2.0, 1.0]]])
    clutter = np.vstack([geometry.polygon_to_segments(np.array([[4.4, 2.4], [4.9, 2.4], [4.9, 2.9], [4.4, 2.9]]))])
    loc = Localiser(walls)
    true = Pose(3.0, 1.5, 0.5)
    pts = _points(_scan(true, np.vstack([walls, clutter])))
    pose = loc.refine(Pose(3.05, 1.45, 0.55), pts)
    dxy, dth = _error(pose, true)
    assert dxy < 0.01 and dth < math.radians(0.5)
    assert loc.explained(pose, pts) < 1.0  # the box is seen, and not explained by the map


@pytest.mark.parametrize(("map_name", "seeds"), [("hospital_2019", range(8)), ("hospital_2021", range(3))])
def test_the_course_hospital_start_is_found_from_one_scan_with_boxes_and_people(map_name: str, seeds: range) -> None:
    """From the start area with any heading, on the given map only (the env's privileged pose is
    used to score the answer, never to find it)."""
    options = {"n_boxes": (2, 2), "n_movers": (1, 1)} if map_name == "hospital_2019" else {}
    env = gym.make("PicoHospital-v0", map=map_name, **options)
    errors = []
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        given = info["task"].map
        loc = Localiser(given.wall_segments)
        result = loc.global_search(given.polygon(given.start_area[0]), _points(obs["lrf"]))
        assert result.margin > loc.config.unique_margin, seed
        errors.append(_error(result.pose, env.unwrapped.pose))
    assert all(dxy < 0.05 and dth < math.radians(2.0) for dxy, dth in errors), errors
