"""The LRF: exact ranges in rooms whose answers are known by hand, noise and configuration."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import square_segments

from pico_gym.sensors.lrf import Lrf, LrfConfig, lrf_ranges
from pico_gym.types import Pose
from pico_gym.world.segment_grid import GRID_MIN_SEGMENTS, SegmentGrid


def brute_force(pose: Pose, segments: np.ndarray, angles: np.ndarray, max_range: float) -> np.ndarray:
    """Test every beam against every segment (the reference the broad phase must match)."""
    out = np.full(len(angles), np.inf)
    for i, a in enumerate(angles):
        dx, dy = math.cos(pose.theta + a), math.sin(pose.theta + a)
        for x1, y1, x2, y2 in segments:
            ex, ey = x2 - x1, y2 - y1
            px, py = x1 - pose.x, y1 - pose.y
            den = dx * ey - dy * ex
            if den == 0:
                continue
            t = (px * ey - py * ex) / den
            u = (px * dy - py * dx) / den
            if t > 0 and -1e-9 <= u <= 1 + 1e-9 and t <= max_range:
                out[i] = min(out[i], t)
    return out


def test_square_room_from_centre() -> None:
    angles = np.array([-math.pi / 2, -math.pi / 4, 0.0, math.atan2(1, 2), math.pi / 4, math.pi / 2])
    r = lrf_ranges(Pose(0.0, 0.0, 0.0), square_segments(2.0), angles)
    expected = [2.0, 2 * math.sqrt(2), 2.0, math.hypot(2.0, 1.0), 2 * math.sqrt(2), 2.0]
    assert r == pytest.approx(expected, abs=1e-12)


def test_square_room_off_centre_and_rotated() -> None:
    # Robot at (1, 0.5) facing +y: bearing 0 looks up (to y=2), -pi/2 looks right (to x=2).
    pose = Pose(1.0, 0.5, math.pi / 2)
    angles = np.array([-math.pi / 2, 0.0, math.pi / 4, math.pi / 2])
    r = lrf_ranges(pose, square_segments(2.0), angles)
    # pi/4 from +y is towards (-1, 1)/sqrt2: hits x = -2 after 3*sqrt2 or y = 2 after 1.5*sqrt2.
    assert r == pytest.approx([1.0, 1.5, 1.5 * math.sqrt(2), 3.0], abs=1e-12)
    with pytest.raises(ValueError, match="ascending"):
        lrf_ranges(pose, square_segments(2.0), angles[::-1])


def test_beam_grazing_a_corner() -> None:
    # From the centre, the beam at exactly 45 degrees ends in the corner shared by two walls.
    r = lrf_ranges(Pose(0.0, 0.0, 0.0), square_segments(1.0), np.array([math.pi / 4]))
    assert r[0] == pytest.approx(math.sqrt(2), abs=1e-12)
    # A free-standing wall: a beam through its end point hits, one just beside it misses.
    wall = np.array([[1.0, 0.0, 1.0, 1.0]])
    end = math.pi / 4
    r = lrf_ranges(Pose(0.0, 0.0, 0.0), wall, np.array([end - 1e-6, end, end + 1e-6]))
    assert r[0] == pytest.approx(1 / math.cos(end - 1e-6), rel=1e-9)
    assert r[1] == pytest.approx(math.sqrt(2), rel=1e-9)
    assert math.isinf(r[2])


def test_beam_through_open_corridor_end_reads_range_max() -> None:
    # A corridor along +x with an open far end: the beam along its axis hits nothing.
    corridor = np.array([[0.0, -0.4, 6.0, -0.4], [0.0, 0.4, 6.0, 0.4], [0.0, -0.4, 0.0, 0.4]])
    lrf = Lrf(LrfConfig(n_beams=5, angle_min_rad=-0.1, angle_max_rad=0.1, noise_m=0.0))
    scan = lrf.scan(Pose(1.0, 0.0, 0.0), corridor, np.random.default_rng(0))
    assert scan[2] == pytest.approx(10.0)  # range_max
    legacy = Lrf(LrfConfig(n_beams=5, angle_min_rad=-0.1, angle_max_rad=0.1, noise_m=0.0, no_hit="zero"))
    assert legacy.scan(Pose(1.0, 0.0, 0.0), corridor, np.random.default_rng(0))[2] == 0.0


@pytest.mark.parametrize("n_segments", [5, 40, 300])
def test_broad_phase_matches_brute_force(n_segments: int) -> None:
    rng = np.random.default_rng(n_segments)
    mid = rng.uniform(-6, 6, size=(n_segments, 2))
    half = rng.uniform(-1.5, 1.5, size=(n_segments, 2))
    segments = np.hstack([mid - half, mid + half])
    angles = LrfConfig().beam_angles
    for theta in (-3.0, -0.5, 0.0, 1.7, math.pi):
        pose = Pose(0.2, -0.3, theta)
        fast = lrf_ranges(pose, segments, angles, 10.0)
        slow = brute_force(pose, segments, angles, 10.0)
        assert np.array_equal(np.isinf(fast), np.isinf(slow))
        finite = np.isfinite(slow)
        assert fast[finite] == pytest.approx(slow[finite], abs=1e-9)


def test_fewer_beams_are_computed_directly() -> None:
    lrf = Lrf(LrfConfig(n_beams=64, noise_m=0.0))
    assert lrf.space().shape == (64,)
    scan = lrf.scan(Pose(0.3, 0.2, 0.4), square_segments(2.0), np.random.default_rng(0))
    exact = lrf_ranges(Pose(0.3, 0.2, 0.4), square_segments(2.0), np.linspace(-2, 2, 64))
    assert scan == pytest.approx(exact.astype(np.float32), abs=1e-5)


def test_noise_is_uniform_within_bounds_and_seeded() -> None:
    lrf = Lrf(LrfConfig())
    pose = Pose(0.0, 0.0, 0.0)
    exact = lrf.exact(pose, square_segments(2.0)).copy()
    scans = np.array([lrf.scan(pose, square_segments(2.0), np.random.default_rng(s)) for s in range(20)])
    err = scans - exact
    assert np.all(np.abs(err) <= 0.01 + 1e-6)
    assert err.std() == pytest.approx(0.02 / math.sqrt(12), rel=0.05)  # U(-0.01, 0.01)
    again = lrf.scan(pose, square_segments(2.0), np.random.default_rng(3))
    assert np.array_equal(again, scans[3])


def test_lrf_ranges_on_a_grid_scene_follows_arrays_changed_in_place() -> None:
    """On scenes large enough for the grid, the grid and beams of the last call are reused in one
    compiled call only while the segments, flags and beams are equal to theirs by content."""
    rng = np.random.default_rng(5)
    n = GRID_MIN_SEGMENTS + 40
    room = np.concatenate([square_segments(4.0), rng.uniform(-3.5, 3.5, (n, 4))])
    pose = Pose(0.2, -0.1, 0.4)
    angles = LrfConfig().beam_angles.copy()
    assert lrf_ranges(pose, room, angles) == pytest.approx(brute_force(pose, room, angles, 10.0), abs=1e-9)
    assert lrf_ranges(pose, room, angles) == pytest.approx(brute_force(pose, room, angles, 10.0), abs=1e-9)
    room[7] = [-3.0, 0.5, 3.0, 0.6]  # in place: the same array object, one segment moved
    assert lrf_ranges(pose, room, angles) == pytest.approx(brute_force(pose, room, angles, 10.0), abs=1e-9)
    angles[:] = np.linspace(-0.5, 0.5, angles.size)  # the beams, in place
    assert lrf_ranges(pose, room, angles) == pytest.approx(brute_force(pose, room, angles, 10.0), abs=1e-9)
    # One-sided flags, then the same flags changed in place: a back face is skipped only while flagged.
    flags = np.zeros(len(room), dtype=bool)
    inside = lrf_ranges(pose, room, angles, one_sided=flags)
    flags[:4] = True  # the outer square, directed counter-clockwise: the sensor is on its free side
    assert np.array_equal(lrf_ranges(pose, room, angles, one_sided=flags), inside)
    room[:4] = room[:4, [2, 3, 0, 1]]  # reversed: now the sensor is behind them, and they are skipped
    beyond = lrf_ranges(pose, room, angles, one_sided=flags)
    assert np.array_equal(beyond, lrf_ranges(pose, room[4:], angles))
    flags[:] = False
    assert np.array_equal(lrf_ranges(pose, room, angles, one_sided=flags), inside)


def test_config_validation() -> None:
    with pytest.raises(ValueError, match="n_beams"):
        LrfConfig(n_beams=0)
    with pytest.raises(ValueError, match="no_hit"):
        LrfConfig(no_hit="nan")


def test_lrf_ranges_follows_the_beams_it_is_given_not_the_last_ones() -> None:
    """The beams' cos and sin are kept between calls; a call with other beams, or with the same
    array changed in place, gets its own beams."""
    room = square_segments(2.0)
    pose = Pose(0.3, -0.2, 0.7)
    angles = LrfConfig().beam_angles
    first = lrf_ranges(pose, room, angles)
    assert first == pytest.approx(brute_force(pose, room, angles, 10.0), abs=1e-9)
    other = np.linspace(-1.0, 1.0, 7)
    assert lrf_ranges(pose, room, other) == pytest.approx(brute_force(pose, room, other, 10.0), abs=1e-9)
    angles = angles.copy()
    lrf_ranges(pose, room, angles)
    angles[:] = np.linspace(-0.5, 0.5, angles.size)  # in place: the same array object, new content
    assert lrf_ranges(pose, room, angles) == pytest.approx(brute_force(pose, room, angles, 10.0), abs=1e-9)
    with pytest.raises(ValueError, match=r"\(N, 4\)"):
        lrf_ranges(pose, np.zeros(6), angles)


def test_lrf_ranges_writes_into_out_and_follows_beams_on_a_prebuilt_grid() -> None:
    """`out=` receives the same ranges as a fresh array (and is returned); on a prebuilt
    `SegmentGrid` the kept beams are used only while equal to the beams passed."""
    rng = np.random.default_rng(11)
    room = np.concatenate([square_segments(4.0), rng.uniform(-3.5, 3.5, (GRID_MIN_SEGMENTS + 10, 4))])
    grid = SegmentGrid(room)
    pose = Pose(-0.4, 0.3, 1.1)
    angles = LrfConfig().beam_angles.copy()
    buffer = np.full(angles.size, -1.0)
    for scene in (room, grid, square_segments(2.0)):
        fresh = lrf_ranges(pose, scene, angles)
        assert lrf_ranges(pose, scene, angles, out=buffer) is buffer
        assert np.array_equal(buffer, fresh)
    reference = brute_force(pose, room, angles, 10.0)
    assert lrf_ranges(pose, grid, angles) == pytest.approx(reference, abs=1e-9)
    angles[:] = np.linspace(-0.5, 0.5, angles.size)  # the beams changed in place
    assert lrf_ranges(pose, grid, angles) == pytest.approx(brute_force(pose, room, angles, 10.0), abs=1e-9)
    for bad in (np.empty(angles.size - 1), np.empty(angles.size, np.float32), np.empty((angles.size, 2))[:, 0]):
        with pytest.raises(ValueError, match="out must be"):
            lrf_ranges(pose, room, angles, out=bad)


def test_lrf_ranges_takes_any_array_like_alike_and_names_bad_flags() -> None:
    """The one-call path for small scenes takes float64 C arrays only; lists, float32, read-only
    or strided arrays take the checked path and get the same ranges. Flags of the wrong length
    are refused by name."""
    room = square_segments(2.0)
    pose = Pose(0.3, -0.2, 0.7)
    angles = LrfConfig().beam_angles
    reference = lrf_ranges(pose, room, angles)
    lrf_ranges(pose, room, angles)  # the beams kept: the next calls may take the one-call path
    read_only = room.copy()
    read_only.flags.writeable = False
    strided = np.concatenate([room, room], axis=1)[:, :4]
    for scene in (room.tolist(), room.astype(np.float32), read_only, strided):
        assert np.array_equal(lrf_ranges(pose, scene, angles), reference)
    assert np.array_equal(lrf_ranges((0.3, -0.2, 0.7), room, angles.tolist()), reference)
    for flags in (np.ones(3, bool), np.ones(5, bool)):
        with pytest.raises(ValueError, match="one_sided must hold one flag per segment"):
            lrf_ranges(pose, room, angles, one_sided=flags)
    frozen = np.empty(angles.size)
    frozen.flags.writeable = False
    with pytest.raises(ValueError, match="out must be"):
        lrf_ranges(pose, room, angles, out=frozen)


@pytest.mark.parametrize("n_walls", [1, 40])
def test_hits_beyond_max_range_read_inf_on_every_path(n_walls: int) -> None:
    """A wall that starts within the range and runs out of it: the beams that meet it beyond
    max_range read inf, from the first call and from a loop's kept beams alike (few and many
    segments: the cast's plain and sorted loops), as the env's readings call them no hit."""
    room = np.array([[3.0, -20.0 + 40.0 * k / n_walls, 3.0, -20.0 + 40.0 * (k + 1) / n_walls] for k in range(n_walls)])
    pose = Pose(0.0, 0.0, 0.0)
    angles = np.linspace(-1.5, 1.5, 301)
    reference = brute_force(pose, room, angles, 5.0)
    assert np.isinf(reference).sum() > 50 and np.isfinite(reference).sum() > 50
    for _ in range(2):  # the first call, then the kept beams' one-call path
        np.testing.assert_array_equal(np.isinf(lrf_ranges(pose, room, angles, max_range=5.0)), np.isinf(reference))
        assert lrf_ranges(pose, room, angles, max_range=5.0) == pytest.approx(reference, abs=1e-9)
    lrf = Lrf(LrfConfig(n_beams=301, angle_min_rad=-1.5, angle_max_rad=1.5, range_max_m=5.0, noise_m=0.0))
    scan = lrf.scan(pose, room, np.random.default_rng(0))
    np.testing.assert_array_equal(scan == np.float32(5.0), np.isinf(reference) | (reference == 5.0))


def test_lrf_ranges_refuses_non_finite_input_by_name_on_every_path() -> None:
    """A NaN or infinite pose, segment, beam or max_range (or max_range <= 0) is refused with the
    argument's name, also when the call would otherwise take a one-call path (beams kept)."""
    rng = np.random.default_rng(3)
    small = square_segments(2.0)
    large = np.concatenate([square_segments(4.0), rng.uniform(-3.5, 3.5, (GRID_MIN_SEGMENTS + 10, 4))])
    angles = LrfConfig().beam_angles
    pose = Pose(0.3, -0.2, 0.7)
    for scene in (small, large, SegmentGrid(large)):
        lrf_ranges(pose, scene, angles)  # the beams (and the grid) kept
        for bad_pose in (Pose(math.nan, 0.0, 0.0), Pose(0.0, math.inf, 0.0), Pose(0.0, 0.0, math.nan)):
            with pytest.raises(ValueError, match="pose must be finite"):
                lrf_ranges(bad_pose, scene, angles)
        for bad_range in (0.0, -1.0, math.nan, math.inf):
            with pytest.raises(ValueError, match="max_range must be a finite number > 0"):
                lrf_ranges(pose, scene, angles, max_range=bad_range)
    for scene in (small, large):
        broken = scene.copy()
        broken[1, 2] = math.nan
        with pytest.raises(ValueError, match="segments must be finite"):
            lrf_ranges(pose, broken, angles)
    with pytest.raises(ValueError, match="beam_angles must be finite"):
        lrf_ranges(pose, small, np.array([0.0, math.nan, 1.0]))
