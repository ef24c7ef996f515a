"""The LRF's grid broad phase is exact: it gives what testing every beam against every segment gives."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pico_gym.bench import clutter_scene
from pico_gym.sensors.lrf import Lrf, LrfConfig, lrf_ranges
from pico_gym.types import Pose
from pico_gym.world.segment_grid import GRID_MIN_SEGMENTS, SegmentGrid

ANGLES = LrfConfig().beam_angles
TOL = 1e-9


def brute_force(
    pose: tuple[float, float, float], segments: np.ndarray, angles: np.ndarray, max_range: float
) -> np.ndarray:
    """Every beam against every segment (numpy), nearest hit or inf."""
    x, y, th = pose
    d = np.stack([np.cos(th + angles), np.sin(th + angles)], axis=1)[:, None, :]  # (B, 1, 2)
    p = segments[None, :, :2] - np.array([x, y])
    e = segments[None, :, 2:] - segments[None, :, :2]
    denom = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        r = (p[..., 0] * e[..., 1] - p[..., 1] * e[..., 0]) / denom
        u = (p[..., 0] * d[..., 1] - p[..., 1] * d[..., 0]) / denom
    hit = (denom != 0) & (r > 0) & (u >= -TOL) & (u <= 1 + TOL) & (r <= max_range)
    return np.where(hit, r, np.inf).min(axis=1)


def grid_ranges(
    grid: SegmentGrid, pose: tuple[float, float, float], angles: np.ndarray, max_range: float
) -> np.ndarray:
    out = np.empty(len(angles))
    grid.cast(*pose, np.cos(angles), np.sin(angles), max_range, out)
    return out


def assert_same(a: np.ndarray, b: np.ndarray) -> None:
    assert np.array_equal(np.isfinite(a), np.isfinite(b)), np.flatnonzero(np.isfinite(a) != np.isfinite(b))
    both = np.isfinite(a)
    assert np.allclose(a[both], b[both], rtol=0, atol=1e-9)


@pytest.mark.parametrize("n", [20, 100, 400, 1000, 2000])
def test_exact_on_random_scenes_of_every_size(n: int) -> None:
    scene = clutter_scene(n, seed=n)
    grid = SegmentGrid(scene)
    rng = np.random.default_rng(n)
    for _ in range(20):
        pose = (float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5)), float(rng.uniform(-math.pi, math.pi)))
        assert_same(grid_ranges(grid, pose, ANGLES, 10.0), brute_force(pose, scene, ANGLES, 10.0))


@pytest.mark.parametrize("cell_m", [0.15, 0.5, 1.0, 3.0])
def test_exact_whatever_the_cell_size(cell_m: float) -> None:
    scene = clutter_scene(400, seed=1)
    grid = SegmentGrid(scene, cell_m=cell_m)
    pose = (0.3, -0.2, 0.7)
    assert_same(grid_ranges(grid, pose, ANGLES, 10.0), brute_force(pose, scene, ANGLES, 10.0))


def test_grazing_beams_through_end_points_and_corners() -> None:
    # A staircase of short segments sharing end points; beams aimed exactly at every end point.
    xs = np.arange(0.0, 4.01, 0.5)
    stairs = [[x, 1.0 + 0.5 * k, x + 0.5, 1.0 + 0.5 * k] for k, x in enumerate(xs[:-1])]
    stairs += [[x + 0.5, 1.0 + 0.5 * k, x + 0.5, 1.5 + 0.5 * k] for k, x in enumerate(xs[:-1])]
    scene = np.array(stairs)
    pose = (0.0, 0.0, 0.0)
    ends = scene.reshape(-1, 2)
    angles = np.unique(np.arctan2(ends[:, 1], ends[:, 0]))
    angles = np.sort(np.concatenate([angles, np.nextafter(angles, 10), np.nextafter(angles, -10)]))
    for cell_m in (0.25, 0.5, 1.0):
        grid = SegmentGrid(scene, cell_m=cell_m)
        ranges = grid_ranges(grid, pose, angles, 10.0)
        assert_same(ranges, brute_force(pose, scene, angles, 10.0))
        assert np.isfinite(ranges).all()  # no beam slips between two segments sharing a corner


def test_beams_along_grid_lines_and_along_segments() -> None:
    # A 4 x 4 m box; the sensor sits on cell boundaries and shoots along them and along the walls.
    box = np.array([[0, 0, 4, 0], [4, 0, 4, 4], [4, 4, 0, 4], [0, 4, 0, 0], [1, 1, 3, 1], [2, 1, 2, 3]], float)
    grid = SegmentGrid(box, cell_m=0.5)
    axis = np.array([-math.pi / 2, 0.0, math.pi / 2])
    diagonal = np.array([-math.pi / 4, math.pi / 4, 3 * math.pi / 4])
    for pose in [(1.0, 2.0, 0.0), (0.5, 0.5, 0.0), (2.0, 0.5, math.pi / 2), (1.5, 1.0, 0.0), (0.0, 2.0, 0.0)]:
        for angles in (axis, diagonal):
            assert_same(grid_ranges(grid, pose, angles, 10.0), brute_force(pose, box, angles, 10.0))


def test_sensor_outside_the_grid_and_max_range() -> None:
    scene = clutter_scene(400, seed=3)
    grid = SegmentGrid(scene)
    for pose in [(-20.0, 0.0, 0.0), (0.0, 30.0, -math.pi / 2), (50.0, 50.0, 0.0)]:
        assert_same(grid_ranges(grid, pose, ANGLES, 30.0), brute_force(pose, scene, ANGLES, 30.0))
    pose = (0.0, 0.0, 0.3)
    short = grid_ranges(grid, pose, ANGLES, 0.8)
    assert_same(short, brute_force(pose, scene, ANGLES, 0.8))
    assert (short[np.isfinite(short)] <= 0.8).all()


def test_lrf_ranges_picks_the_grid_on_large_scenes_and_agrees_with_the_angular_cast() -> None:
    scene = clutter_scene(1000, seed=4)
    assert len(scene) >= GRID_MIN_SEGMENTS
    from pico_gym.sensors.lrf import _cast  # the angular broad phase, called directly

    pose = Pose(0.2, -0.1, 1.0)
    angular = np.empty(len(ANGLES))
    flags = np.zeros(0, dtype=bool)
    _cast(*pose, scene, ANGLES, np.cos(ANGLES), np.sin(ANGLES), 10.0, angular, True, flags)
    angular[angular > 10.0] = np.inf
    assert_same(lrf_ranges(pose, scene, ANGLES), angular)
    # A changed array is a new scene (found by content, not identity).
    scene[:, :2] += 0.05
    assert_same(lrf_ranges(pose, scene, ANGLES), brute_force(tuple(pose), scene, ANGLES, 10.0))


def test_one_sided_culling_gives_the_same_scan() -> None:
    import gymnasium as gym

    import pico_gym  # noqa: F401

    env = gym.make("PicoHospital-v0", map="hospital_2021")
    env.reset(seed=0)
    scene = env.unwrapped.scene
    assert isinstance(scene.lrf_static, SegmentGrid)
    lrf = Lrf(LrfConfig())
    # Without flags the cast is compiled without the back-face test; both give the same scan.
    unflagged = SegmentGrid(scene.static_seen)
    assert scene.lrf_static._one_sided is not None and unflagged._one_sided is None
    rng = np.random.default_rng(0)
    for _ in range(10):
        pose = env.unwrapped.pose
        pose = Pose(pose.x + rng.normal(0, 0.3), pose.y + rng.normal(0, 0.3), float(rng.uniform(-3, 3)))
        culled = lrf.exact(pose, scene.lrf_static).copy()
        np.testing.assert_array_equal(culled, lrf.exact(pose, unflagged))
        culled[culled > 10.0] = np.inf
        assert_same(culled, brute_force(tuple(pose), scene.static_seen, lrf.beam_angles, 10.0))
    env.close()


def test_bad_input_is_refused() -> None:
    with pytest.raises(ValueError, match="finite"):
        SegmentGrid(np.array([[0.0, 0.0, np.nan, 1.0]]))
    with pytest.raises(ValueError, match="one_sided"):
        SegmentGrid(np.zeros((3, 4)) + np.arange(4), one_sided=np.ones(2, bool))
