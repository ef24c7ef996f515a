"""Grids: exact clearance and the geodesic field's accuracy against known shortest paths."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pico_gym.agents.classic.explore.regions import distance_transform
from pico_gym.world.grid import CostGrid, Grid, clearance_grid, descend, geodesic_field


def test_clearance_grid_is_exact_at_cell_centres() -> None:
    grid = Grid(0.0, 0.0, 0.1, (10, 10))
    wall = np.array([[0.0, 0.0, 1.0, 0.0]])
    clearance = clearance_grid(grid, wall, cap=5.0)
    assert clearance[:, 3] == pytest.approx(0.05 + 0.1 * np.arange(10))


@pytest.mark.parametrize("angle_deg", [0, 10, 22.5, 30, 45, 60, 80])
def test_geodesic_in_open_space_is_within_3_percent_of_euclidean(angle_deg: float) -> None:
    # A long goal line along x = 0 (from y = -10 to 10); points at distance 4 m in various directions.
    line = np.array([[0.0, -10.0], [0.0, 10.0]])
    grid = Grid.covering((-1.0, -10.0, 6.0, 10.0), 0.05, margin=0.5)
    field = geodesic_field(grid, np.zeros((0, 4)), line, start_side=(5.0, 0.0))
    a = math.radians(angle_deg)
    # The shortest way to a line is perpendicular to it, whatever direction the point lies in.
    x = 4.0 * math.cos(a)
    value = field.lookup(x, 4.0 * math.sin(a))
    assert value == pytest.approx(x, rel=0.03, abs=0.03)


def test_geodesic_goes_around_a_wall() -> None:
    # Goal: the segment x=0, y in [-0.5, 0.5]. A wall blocks the straight way from (4, 0).
    line = np.array([[0.0, -0.5], [0.0, 0.5]])
    wall = np.array([[2.0, -2.0, 2.0, 2.0]])
    grid = Grid.covering((-1.0, -4.0, 5.0, 4.0), 0.05, margin=0.5)
    field = geodesic_field(grid, wall, line, start_side=(4.0, 0.0), comfort_clearance_m=0.0)
    # The shortest way rounds the wall's end: (4, 0) -> (2, 2) -> (0, 0.5), the line's nearest end.
    expected = math.hypot(2.0, 2.0) + math.hypot(2.0, 1.5)
    assert field.lookup(4.0, 0.0) == pytest.approx(expected, rel=0.03)
    assert field.lookup(-0.5, 0.0) < 0.0  # past the line: negative


def test_distance_at_is_the_full_fields_lookup_bit_for_bit() -> None:
    """The early-stopping search gives exactly what the whole field's lookup gives, near walls too."""
    from pico_gym.world.grid import CostGrid, Grid

    rng = np.random.default_rng(3)
    walls = np.array([[0, 0, 6, 0], [6, 0, 6, 4], [6, 4, 0, 4], [0, 4, 0, 0], [3, 0, 3, 3], [1.5, 1.0, 1.5, 4.0]])
    grid = Grid.covering((0.0, 0.0, 6.0, 4.0), 0.1, margin=0.3)
    costs = CostGrid.of(grid, walls, inflation_m=0.1)
    rows, cols = costs.region_cells(np.array([[4.5, 1.0], [5.0, 1.0], [5.0, 1.5], [4.5, 1.5]]))
    free = np.isfinite(costs.cost[rows, cols])
    rows, cols = rows[free], cols[free]
    field = costs.field_from(rows, cols, np.zeros(len(rows)))
    for x, y in [*rng.uniform((0.05, 0.05), (5.95, 3.95), size=(60, 2)), (1.55, 2.0), (2.95, 1.0), (7.0, 2.0)]:
        expected = field.lookup(float(x), float(y))
        got = costs.distance_at(rows, cols, float(x), float(y))
        assert got == expected or (math.isinf(got) and math.isinf(expected)), (x, y, got, expected)


def _dijkstra_heapq(cost, knight_ok, seeds, res):  # noqa: ANN001, ANN202
    """A plain reference: the same search with Python's heapq of (distance, r * cols + c) tuples."""
    import heapq

    from pico_gym.world.grid import _MOVES

    rows, cols = cost.shape
    free = np.isfinite(cost)
    dist = np.full(cost.shape, np.inf)
    heap = []
    for r, c, v in seeds:
        if free[r, c] and v < dist[r, c]:
            dist[r, c] = v
            heapq.heappush(heap, (v, r * cols + c))
    while heap:
        d, k = heapq.heappop(heap)
        r, c = divmod(k, cols)
        if d > dist[r, c]:
            continue
        for m, (dr, dc) in enumerate(_MOVES.tolist()):
            rr, cc = r + dr, c + dc
            if not (0 <= rr < rows and 0 <= cc < cols) or not free[rr, cc]:
                continue
            if m >= 8 and not (knight_ok[r, c] and knight_ok[rr, cc]):
                continue
            if 4 <= m < 8 and not (free[r + dr, c] and free[r, c + dc]):
                continue
            nd = d + math.sqrt(dr * dr + dc * dc) * res * 0.5 * (cost[r, c] + cost[rr, cc])
            if nd < dist[rr, cc]:
                dist[rr, cc] = nd
                heapq.heappush(heap, (nd, rr * cols + cc))
    return dist


@pytest.mark.parametrize("heap_room", [None, 1, 5])
def test_dijkstra_equals_a_heapq_search_bit_for_bit(heap_room: int | None) -> None:
    """The compiled search's array heap settles every cell at exactly the distance Python's heapq
    search gives (pop order is fixed by the unique (distance, cell) pairs), also when its heap
    runs out of room and it starts over with more."""
    from pico_gym.world.grid import CostGrid, _dijkstra

    walls = np.array([[0, 0, 4, 0], [4, 0, 4, 3], [4, 3, 0, 3], [0, 3, 0, 0], [2, 0, 2, 2], [1, 1.5, 1, 3]], float)
    grid = Grid.covering((0.0, 0.0, 4.0, 3.0), 0.1, margin=0.2)
    costs = CostGrid.of(grid, walls, inflation_m=0.15)
    seeds = [(5, 30, 0.0), (6, 30, 0.01), (5, 31, 0.0)]
    rows, cols, values = (np.array(v) for v in zip(*seeds, strict=True))
    got = _dijkstra(
        costs.cost, costs.knight_ok, rows.astype(np.int64), cols.astype(np.int64), values.astype(float),
        grid.resolution, heap_room=heap_room,
    )  # fmt: skip
    expected = _dijkstra_heapq(costs.cost, costs.knight_ok, seeds, grid.resolution)
    assert np.isfinite(expected).sum() > 500  # the search reached round the inner walls
    assert np.array_equal(got, expected)


@pytest.mark.parametrize("near_wall_cost", [3.0, 1.0, 0.4, 0.0])
def test_the_bucket_search_equals_the_heap_search_bit_for_bit(near_wall_cost: float) -> None:
    """Without a window `_dijkstra` searches with buckets: on random walls, costs (below 1 too),
    seeds spread over a metre (one cell seeded twice, one seed blocked) and allowed regions, it
    gives the heap's distances bit for bit, also when its entries run out and it starts over. A
    cost of zero rules buckets out: the heap searches then (and still matches heapq)."""
    from pico_gym.world.grid import CostGrid, _dijkstra, _dijkstra_buckets, _dijkstra_run

    rng = np.random.default_rng(11)
    for trial in range(12):
        walls = rng.uniform(0.0, 6.0, size=(int(rng.integers(1, 25)), 4))
        grid = Grid.covering((0.0, 0.0, 6.0, 6.0), float(rng.choice([0.05, 0.1, 0.13])), margin=0.3)
        costs = CostGrid.of(grid, walls, comfort_clearance_m=0.3, near_wall_cost=near_wall_cost)
        rows, cols = grid.shape
        n = int(rng.integers(1, 40))
        seeds_r = rng.integers(0, rows, n).astype(np.int64)
        seeds_c = rng.integers(0, cols, n).astype(np.int64)
        seeds_v = rng.uniform(-1.0, 0.5, n)
        seeds_r[-1], seeds_c[-1] = seeds_r[0], seeds_c[0]  # a cell seeded twice
        blocked = np.argwhere(~np.isfinite(costs.cost))
        if n > 2 and len(blocked):
            seeds_r[1], seeds_c[1] = blocked[0]
        allowed = np.isfinite(costs.cost) & (rng.random(grid.shape) < 0.97) if trial % 2 else None
        heap, done = _dijkstra_run(
            costs.cost, costs.knight_ok, np.isfinite(costs.cost) if allowed is None else allowed,
            seeds_r, seeds_c, seeds_v, grid.resolution, (0, -1, 0, -1), 8 * costs.cost.size,
        )  # fmt: skip
        assert done
        free = np.isfinite(costs.cost) if allowed is None else allowed
        _, status = _dijkstra_buckets(
            costs.cost, costs.knight_ok, free, seeds_r, seeds_c, seeds_v, grid.resolution, 8 * costs.cost.size
        )
        assert status == (2 if near_wall_cost == 0.0 and (costs.cost[free] == 0.0).any() else 0)
        for room in (None, 7):
            got = _dijkstra(
                costs.cost, costs.knight_ok, seeds_r, seeds_c, seeds_v, grid.resolution, heap_room=room, allowed=allowed
            )
            assert np.array_equal(got, heap), (trial, room)
        assert np.isfinite(heap).sum() > 50
        # Seeds too far apart for buckets (one cell seeded again, 1e12 lower): the heap searches.
        far_r, far_c = np.append(seeds_r, seeds_r[0]), np.append(seeds_c, seeds_c[0])
        far_v = np.append(seeds_v, -1e12)
        if free[seeds_r[0], seeds_c[0]] and (costs.cost[free] > 0.0).all():
            status = _dijkstra_buckets(costs.cost, costs.knight_ok, free, far_r, far_c, far_v, grid.resolution, 10**6)[
                1
            ]
            assert status == 2
        if allowed is None and near_wall_cost == 0.0:
            seeds = list(zip(seeds_r.tolist(), seeds_c.tolist(), seeds_v.tolist(), strict=True))
            assert np.array_equal(heap, _dijkstra_heapq(costs.cost, costs.knight_ok, seeds, grid.resolution))


def test_the_line_seeds_are_the_array_formulas_bit_for_bit() -> None:
    """The field's seeds, computed cell by cell, are those of the whole-grid array formulas: the
    same cells in row-major order, the same values to the bit (-0.0 included)."""
    from pico_gym.world.grid import CostGrid, _line_seeds

    rng = np.random.default_rng(5)
    seeded = 0
    for _ in range(20):
        res = float(rng.choice([0.05, 0.1]))
        grid = Grid.covering((0.0, 0.0, 5.0, 4.0), res, margin=0.5)
        costs = CostGrid.of(grid, rng.uniform(0.0, 5.0, size=(6, 4)))
        (ax, ay), (bx, by) = rng.uniform(0.0, 5.0, size=(2, 2))
        length = math.hypot(bx - ax, by - ay)
        ux, uy = (bx - ax) / length, (by - ay) / length
        nx, ny = (-uy, ux) if rng.random() < 0.5 else (uy, -ux)
        xs, ys = grid.centres()
        along = (xs - ax) * ux + (ys - ay) * uy
        across = (xs - ax) * nx + (ys - ay) * ny
        past = (across >= -0.5 * res) & (along >= -res) & (along <= length + res) & np.isfinite(costs.cost)
        rows, cols = np.nonzero(past)
        values = -np.maximum(across[rows, cols], 0.0)
        seed, got_r, got_c, got_v = _line_seeds(costs.cost, grid.x0, grid.y0, res, ax, ay, ux, uy, nx, ny, length)
        assert np.array_equal(seed, past) and np.array_equal(got_r, rows) and np.array_equal(got_c, cols)
        assert np.array_equal(got_v.view(np.int64), values.view(np.int64))
        seeded += len(rows) > 0
    assert seeded >= 15


def test_a_field_from_a_start_is_the_full_field_where_a_robot_can_be_before_the_line() -> None:
    """Escape rooms: the field searched from the start equals the whole field bit for bit on
    every cell it computes, leaves the outside of the building (reached only across the line)
    uncomputed, and gives the same lookups along the way to the exit."""
    import gymnasium as gym

    import pico_gym  # noqa: F401

    env = gym.make("PicoEscape-v0", n_obstacles=2).unwrapped
    for seed in range(4):
        env.reset(seed=seed)
        task, world, start = env.task, env.episode.scene.map, env.episode.start
        grid = Grid.covering(world.bounds, task.config.geodesic_resolution_m, margin=1.0)
        side = tuple(float(v) for v in task._finish_point - task._finish_normal)
        full = geodesic_field(grid, world.solid_segments(), world.finish, side)
        part = geodesic_field(grid, world.solid_segments(), world.finish, side, start=(start.x, start.y))
        computed = np.isfinite(part.distance)
        assert np.array_equal(part.distance[computed], full.distance[computed])
        assert computed.sum() < 0.8 * np.isfinite(full.distance).sum()  # the outside margin is left out
        assert math.isinf(part.distance[0, 0]) and math.isfinite(full.distance[0, 0])  # a corner outside
        assert part.lookup(start.x, start.y) == full.lookup(start.x, start.y)
        rng = np.random.default_rng(seed)
        xmin, ymin, xmax, ymax = world.bounds
        checked = 0
        for x, y in rng.uniform((xmin, ymin), (xmax, ymax), size=(300, 2)):
            c, r = (
                int(math.floor((x - grid.x0) / grid.resolution - 0.5)),
                int(math.floor((y - grid.y0) / grid.resolution - 0.5)),
            )
            if computed[r : r + 2, c : c + 2].all():  # a point a robot from the start can be at
                assert part.lookup(x, y) == full.lookup(x, y)
                checked += 1
        assert checked > 30


def test_the_path_walks_down_the_field_to_the_robot_from_every_cell_it_reached() -> None:
    """A field of `CostGrid.field_from` (Dijkstra with knight moves) can leave a cell whose 8
    neighbours are none lower (the explore agent's planner, nested dev seed 570072: its walk
    stopped 4 m from the robot, the path began there, and the robot drove at it through a wall
    until 600 s). `descend` takes the knight move there: from every such cell of random rooms'
    fields, and from others, it goes strictly down to the robot's cell."""
    rng = np.random.default_rng(0)
    stuck_8 = 0
    for _ in range(20):
        occupied = np.zeros((60, 60), dtype=bool)
        occupied[[0, -1], :] = occupied[:, [0, -1]] = True
        for _ in range(8):
            r, c, n = *rng.integers(5, 55, 2), int(rng.integers(3, 20))
            if rng.random() < 0.5:
                occupied[r, c : c + n] = True
            else:
                occupied[r : r + n, c] = True
        costs = CostGrid.from_clearance(
            Grid(0.0, 0.0, 0.1, occupied.shape), distance_transform(occupied, 0.1, 1.0), 0.4, 4.0, 0.13
        )
        free = np.argwhere(np.isfinite(costs.cost))
        robot = free[rng.integers(len(free))]
        d = costs.field_from(robot[:1], robot[1:], np.zeros(1)).distance
        padded = np.pad(d, 1, constant_values=np.inf)
        lowest_8 = np.min(
            [padded[1 + dr : 61 + dr, 1 + dc : 61 + dc] for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc], axis=0
        )
        stuck = np.isfinite(d) & (d > 0.0) & (lowest_8 >= d)  # where the 8 neighbours have no way down
        stuck_8 += int(stuck.sum())
        reached = np.argwhere(np.isfinite(d))
        for r, c in [*np.argwhere(stuck), *reached[rng.choice(len(reached), 50)]]:
            cells = descend(d, costs.knight_ok, int(r), int(c))
            assert tuple(cells[-1]) == tuple(robot), (r, c)
            assert np.all(np.diff(d[cells[:, 0], cells[:, 1]]) < 0.0)
    assert stuck_8 > 0  # (the case is there: the 8 neighbours alone leave some cells stuck)
