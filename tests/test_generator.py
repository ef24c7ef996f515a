"""The escape-room generator follows the challenge's rules, is solvable and is seeded."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pico_gym.robot import RobotConfig
from pico_gym.world import geometry
from pico_gym.world.escape_room import (
    EscapeRoomConfig,
    generate_escape_room,
    route_clearance,
    sample_start_pose,
    translation_is_free,
)
from pico_gym.world.grid import Grid, clearance_grid

ROBOT = RobotConfig()
CFG = EscapeRoomConfig()


def rule_violations(seed: int) -> list[str]:
    """The challenge's rules that the room and start drawn from `seed` break (none, we hope)."""
    rng = np.random.default_rng(seed)
    room = generate_escape_room(rng, CFG, ROBOT)
    start = sample_start_pose(room, rng, ROBOT, 0.05)
    world = room.map
    solid = world.solid_segments()
    broken = []
    # The room: a quadrilateral with sides in range (up to the corner jitter).
    sides = np.linalg.norm(np.roll(room.room, -1, axis=0) - room.room, axis=1)
    if not (np.all(sides > CFG.room_side_m[0] - 0.1) and np.all(sides < CFG.room_side_m[1] + 0.1)):
        broken.append("room side")
    # The corridor: width in range at the mouth and never below the minimum.
    mouth_width = float(np.linalg.norm(room.mouth[1] - room.mouth[0]))
    if not CFG.corridor_width_m[0] - 1e-9 <= mouth_width <= CFG.corridor_width_m[1] + 1e-9:
        broken.append("mouth width")
    if room.corridor_width_min_m < CFG.corridor_width_m[0] - 1e-9:
        broken.append("narrowest corridor width")
    # The finish line is more than 3 m from the mouth, and the corridor walls are longer.
    depth = float(np.linalg.norm(world.finish.mean(axis=0) - room.mouth.mean(axis=0)))
    if not depth > 3.0:
        broken.append("finish depth")
    if not all(np.linalg.norm(wall[2:] - wall[:2]) > depth for wall in room.corridor_walls):
        broken.append("corridor walls longer than the finish depth")
    # Open at the far end: only the two corridor walls touch the line across their far ends.
    far = np.concatenate([room.corridor_walls[0, 2:], room.corridor_walls[1, 2:]])
    if sum(geometry.segment_segment_distance(*far, *s) < 1e-9 for s in solid) != 2:
        broken.append("open far end")
    # The start pose: in the room and clear of the walls.
    footprint = geometry.transform_points(start, ROBOT.outline)
    if not all(geometry.point_in_polygon(x, y, room.room) for x, y in footprint):
        broken.append("start inside the room")
    if geometry.polygon_clearance(footprint, solid) < 0.05:
        broken.append("start clearance")
    # Solvable: from the start a straight move reaches the route, along which a disc holding the
    # footprint in any heading passes the finish line.
    if not route_clearance(room.route, solid) > ROBOT.circumradius_m:
        broken.append("route clearance")
    if not translation_is_free(start, room.route[0], ROBOT, solid):
        broken.append("start reaches the route")
    return broken


def test_rules_hold_over_1000_seeds() -> None:
    violations = {seed: broken for seed in range(1000) if (broken := rule_violations(seed))}
    assert violations == {}


@pytest.mark.slow
def test_solvability_on_an_independent_grid() -> None:
    """Cross-check the exact route with a flood fill of circumradius-clear cells (2 cm grid)."""
    for seed in range(40):
        room = generate_escape_room(np.random.default_rng(seed), CFG, ROBOT)
        world = room.map
        grid = Grid.covering(world.bounds, 0.02, margin=0.5)
        free = clearance_grid(grid, world.solid_segments(), cap=1.0) > ROBOT.circumradius_m
        xs, ys = grid.centres()
        start = np.unravel_index(np.argmin(np.hypot(xs - room.route[0][0], ys - room.route[0][1])), free.shape)
        assert free[start]
        seen = np.zeros_like(free)
        stack = [start]
        seen[start] = True
        while stack:
            r, c = stack.pop()
            for rr, cc in ((r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)):
                if 0 <= rr < free.shape[0] and 0 <= cc < free.shape[1] and free[rr, cc] and not seen[rr, cc]:
                    seen[rr, cc] = True
                    stack.append((rr, cc))
        a, b = world.finish
        n = np.array([-(b - a)[1], (b - a)[0]])
        n = n if (room.route[0] - a) @ n < 0 else -n
        past = ((xs - a[0]) * n[0] + (ys - a[1]) * n[1]) > 0.3
        assert np.any(seen & past), f"seed {seed}: the finish is not reachable on the grid"


def test_same_seed_same_room() -> None:
    a = generate_escape_room(np.random.default_rng(7))
    b = generate_escape_room(np.random.default_rng(7))
    c = generate_escape_room(np.random.default_rng(8))
    assert np.array_equal(a.map.points, b.map.points) and np.array_equal(a.map.finish, b.map.finish)
    assert not np.array_equal(a.map.points, c.map.points)


def test_exits_flush_with_a_corner_occur() -> None:
    flush = 0
    for seed in range(200):
        room = generate_escape_room(np.random.default_rng(seed))
        corners = room.room
        d = min(np.linalg.norm(corners - m, axis=1).min() for m in room.mouth)
        flush += d < 1e-9
    assert 20 < flush < 90  # about a quarter of the rooms


def test_obstacles_keep_rooms_solvable() -> None:
    cfg = EscapeRoomConfig(n_obstacles=4)
    for seed in range(100):
        rng = np.random.default_rng(seed)
        room = generate_escape_room(rng, cfg)
        assert len(room.map.obstacles) == 4
        start = sample_start_pose(room, rng)
        assert route_clearance(room.route, room.map.solid_segments()) > ROBOT.circumradius_m
        assert translation_is_free(start, room.route[0], ROBOT, room.map.solid_segments())


def test_bad_config_is_rejected() -> None:
    with pytest.raises(ValueError, match="0.5"):
        EscapeRoomConfig(corridor_width_m=(0.3, 1.0))
    with pytest.raises(ValueError, match="3 m"):
        EscapeRoomConfig(finish_depth_m=(2.0, 3.5))
    assert math.isfinite(ROBOT.circumradius_m)
