"""A* on tiny grids, string pulling, and the local motion layer's safety rules."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pico_gym.agents.classic.astar import astar, line_is_free, string_pull
from pico_gym.agents.classic.potential_field import (
    MotionConfig,
    attract_and_repel,
    footprint_distance,
    keep_in_view,
    safety_filter,
)

CFG = MotionConfig()


def test_astar_straight_and_diagonal() -> None:
    grid = np.zeros((5, 5), dtype=bool)
    assert astar(grid, (0, 0), (0, 4)).length == pytest.approx(4.0)
    assert astar(grid, (0, 0), (4, 4)).length == pytest.approx(4 * math.sqrt(2))


def test_astar_goes_around_a_wall_and_is_optimal() -> None:
    grid = np.zeros((7, 7), dtype=bool)
    grid[1:7, 3] = True  # a wall with a gap at the top row
    path = astar(grid, (6, 0), (6, 6))
    assert path is not None and (0, 3) in path.cells
    # octile to (0, 2), then (0, 3) and (0, 4) straight (no cutting the wall's end), then octile
    assert path.length == pytest.approx(2 * (6 + 2 * (math.sqrt(2) - 1)) + 2)
    assert all(not grid[c] for c in path.cells)


def test_astar_unreachable_and_blocked_ends() -> None:
    grid = np.zeros((5, 5), dtype=bool)
    grid[:, 2] = True
    assert astar(grid, (0, 0), (0, 4)) is None
    assert astar(grid, (0, 2), (0, 0)) is None


def test_astar_does_not_cut_corners() -> None:
    grid = np.zeros((2, 2), dtype=bool)
    grid[0, 1] = grid[1, 0] = True
    assert astar(grid, (0, 0), (1, 1)) is None


def test_string_pulling_keeps_only_needed_turns() -> None:
    grid = np.zeros((10, 10), dtype=bool)
    cells = [(0, i) for i in range(10)]
    assert string_pull(grid, cells) == [(0, 0), (0, 9)]
    grid[0:8, 5] = True
    path = astar(grid, (0, 0), (0, 9))
    pulled = string_pull(grid, path.cells)
    assert len(pulled) < len(path.cells)
    assert all(line_is_free(grid, a, b) for a, b in zip(pulled[:-1], pulled[1:], strict=True))


def test_footprint_distance_of_a_rectangle() -> None:
    d, away = footprint_distance(np.array([[0.5, 0.0], [0.0, 0.5], [0.2, 0.3]]), CFG)
    assert d == pytest.approx([0.4, 0.3, math.hypot(0.1, 0.1)])
    assert away[0] == pytest.approx([1.0, 0.0])


def test_attraction_points_at_the_target_and_saturates() -> None:
    v = attract_and_repel(np.zeros((0, 2)), np.array([3.0, 4.0]), CFG)
    assert v == pytest.approx([0.3, 0.4])
    v = attract_and_repel(np.array([[0.3, 0.0]]), np.array([0.0, 0.0]), CFG)
    assert v[0] < 0  # a point ahead pushes the robot back


def test_keep_in_view_never_translates_blind() -> None:
    for command in ([-0.5, 0.0], [-0.3, -0.4], [-0.1, 0.5], [-0.45, 0.05]):
        v = keep_in_view(np.array(command), CFG)
        if np.hypot(*v) > 1e-9:
            assert abs(math.atan2(v[1], v[0])) <= CFG.visible_bearing + 1e-9
            assert float(v @ np.array(command)) >= 0.0  # never against the command
    assert keep_in_view(np.array([0.3, 0.2]), CFG) == pytest.approx([0.3, 0.2])


def test_safety_filter_stops_short_of_a_wall() -> None:
    wall = np.column_stack([np.full(50, 0.2), np.linspace(-1, 1, 50)])  # 0.1 m in front of the face
    vx, vy, w = safety_filter(wall, (0.5, 0.0, 0.0), CFG)
    assert vx * CFG.horizon <= 0.1 - CFG.margin + 1e-6
    # moving along the wall is allowed
    assert safety_filter(wall, (0.0, 0.5, 0.0), CFG) == pytest.approx((0.0, 0.5, 0.0))
    # turning in place would swing a corner into the wall: slowed down
    assert abs(safety_filter(wall, (0.0, 0.0, 1.2), CFG)[2]) < 1.2


def test_a_point_already_too_close_blocks_only_motion_towards_it() -> None:
    wall_ahead = np.column_stack([np.full(50, 0.2), np.linspace(-1, 1, 50)])
    stale = np.array([[-0.05, 0.1]])  # inside the footprint (e.g. a stale remembered hit)
    points = np.vstack([wall_ahead, stale])
    vx, _, _ = safety_filter(points, (0.5, 0.0, 0.0), CFG)
    assert vx * CFG.horizon <= 0.1 - CFG.margin + 1e-6  # the wall ahead still counts


def test_safety_filter_slides_past_a_corner_instead_of_creeping_into_it() -> None:
    # Driving sideways (+y) into a corridor whose mouth corner overlaps the footprint by 6 cm:
    # the wall beside the mouth runs along y = 0.3 from x = 0.04 outwards.
    corner_wall = np.column_stack([np.linspace(0.04, 1.0, 40), np.full(40, 0.3)])
    vx, vy, w = safety_filter(corner_wall, (-0.135, 0.47, 0.0), CFG)
    assert vx < -0.1  # keeps the step sideways that clears the corner, at its full speed
    assert abs(vy) < 1e-9  # and does not creep towards the wall
    d_now = footprint_distance(corner_wall, CFG)[0].min()
    d_next = footprint_distance(corner_wall - np.array([vx, vy]) * CFG.horizon, CFG)[0].min()
    assert d_next >= min(CFG.margin, d_now - CFG.slack) - 1e-9
    # A command straight at a wall has nothing to slide along: it is only slowed down.
    wall = np.column_stack([np.full(50, 0.2), np.linspace(-1, 1, 50)])
    vx, vy, _ = safety_filter(wall, (0.5, 0.0, 0.0), CFG)
    assert abs(vy) < 1e-9 and 0.0 <= vx < 0.5
