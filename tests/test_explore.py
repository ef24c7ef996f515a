"""PicoExplore-v0: the 2018 generator's rules, rooms and doors, the object placement, parking and
finding on hand cases, coverage, the map score, determinism, bad input."""

from __future__ import annotations

import json
import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import pico_gym  # noqa: F401
from pico_gym.tasks.explore import OccupancyBelief
from pico_gym.types import Pose
from pico_gym.world import geometry
from pico_gym.world.hospital2018 import ExploreHospitalConfig, generate_explore_hospital
from pico_gym.world.map import MapError, map_to_dict

QUIET = {"noise_m": 0.0}


def explore(**kwargs: object) -> gym.Env:
    return gym.make("PicoExplore-v0", **{**QUIET, **kwargs})


def drive(env: gym.Env, twist: tuple[float, float, float], steps: int) -> dict:
    info: dict = {}
    for _ in range(steps):
        _, _, terminated, truncated, info = env.step(np.array(twist))
        if terminated or truncated:
            break
    return info


def inside(rect: tuple[float, float, float, float], x: float, y: float) -> bool:
    return rect[0] <= x <= rect[2] and rect[1] <= y <= rect[3]


# --- the generator ----------------------------------------------------------------------------


def test_generator_follows_the_2018_rules_over_1000_seeds() -> None:
    cfg = ExploreHospitalConfig()
    for seed in range(1000):
        h = generate_explore_hospital(np.random.default_rng(seed), cfg)
        n = len(h.rooms)
        assert 3 <= n <= 6, seed
        for x0, y0, x1, y1 in h.rooms:
            assert 2.0 - 1e-9 <= x1 - x0 <= 4.5 + 1e-9 and 2.0 - 1e-9 <= y1 - y0 <= 4.5 + 1e-9, seed
        # A tree: one door per room, leading from the hallway or from an earlier room.
        assert len(h.doors) == n == len(h.parent) == len(h.depth)
        for i, (p, d) in enumerate(zip(h.parent, h.depth, strict=True)):
            assert p < i
            assert d == (1 if p < 0 else h.depth[p] + 1)
            assert 1 <= d <= cfg.max_depth
        for x0, y0, x1, y1 in h.doors:
            width = max(x1 - x0, y1 - y0)
            assert 0.5 - 1e-9 <= width <= 1.5 + 1e-9, seed
            assert abs(min(x1 - x0, y1 - y0) - 0.2) < 1e-9  # through a 0.2 m wall
        # The parking wall is the hallway's end wall, a wall of the map.
        (ax, ay), (bx, by) = h.parking_wall
        leg = h.hallway[0]
        assert ax == bx == leg[0] and {ay, by} == {leg[1], leg[3]}
        walls = h.map.wall_segments
        assert any(np.allclose(sorted([tuple(w[:2]), tuple(w[2:])]), sorted([(ax, ay), (bx, by)])) for w in walls)


def test_doors_keep_from_the_corners_of_their_wall() -> None:
    for seed in range(200):
        h = generate_explore_hospital(np.random.default_rng(seed))
        for room, door in zip(h.rooms, h.doors, strict=True):
            x0, y0, x1, y1 = door
            horizontal_wall = (x1 - x0) > (y1 - y0)  # the opening runs along x
            lo, hi = (x0, x1) if horizontal_wall else (y0, y1)
            r_lo, r_hi = (room[0], room[2]) if horizontal_wall else (room[1], room[3])
            assert lo >= r_lo + 0.3 - 1e-9 and hi <= r_hi - 0.3 + 1e-9, seed


def test_nesting_happens_and_is_bounded() -> None:
    depths = [max(generate_explore_hospital(np.random.default_rng(s)).depth) for s in range(300)]
    assert max(depths) == 3 and min(depths) == 1
    flat = generate_explore_hospital(np.random.default_rng(0), ExploreHospitalConfig(nested_probability=0.0))
    assert flat.depth == (1,) * len(flat.rooms)


def test_generator_config_is_validated() -> None:
    with pytest.raises(ValueError, match="door_width_m"):
        ExploreHospitalConfig(door_width_m=(0.2, 1.0))
    with pytest.raises(ValueError, match="hallway_shapes"):
        ExploreHospitalConfig(hallway_shapes=("T",))


# --- rooms, doors and the object -----------------------------------------------------------------


def test_the_building_splits_into_the_generated_rooms_at_their_doors() -> None:
    env = explore().unwrapped
    for seed in range(40):
        env.reset(seed=seed)
        b = env.episode.extra["building"]
        # Regenerate the same hospital from the same seed to compare with the generator's parts.
        h = generate_explore_hospital(np.random.default_rng(seed))
        assert np.allclose(h.map.points, env.episode.map.points)
        assert len(b.region_cells) == len(h.rooms) + 1, seed
        assert sorted(b.depth.tolist()[1:]) == sorted(h.depth), seed
        # Region 0 is the hallway (where the robot starts).
        xs, ys = b.grid.centres()
        hall = b.region == 0
        in_leg = np.zeros_like(hall)
        for leg in h.hallway:
            in_leg |= (xs > leg[0]) & (xs < leg[2]) & (ys > leg[1]) & (ys < leg[3])
        assert (in_leg[hall]).all()


def test_the_object_is_placed_in_the_room_that_needs_the_most_doors() -> None:
    env = explore().unwrapped
    for seed in range(60):
        env.reset(seed=seed)
        h = generate_explore_hospital(np.random.default_rng(seed))
        obj = env.episode.extra["object"]
        centre = obj.mean(axis=0)
        rooms = [i for i, r in enumerate(h.rooms) if inside(r, *centre)]
        assert len(rooms) == 1, seed
        assert h.depth[rooms[0]] == max(h.depth), seed
        sides = obj.max(axis=0) - obj.min(axis=0)
        assert ((sides >= 0.3 - 1e-9) & (sides <= 0.5 + 1e-9)).all()
        walls = env.episode.map.wall_segments
        assert geometry.polygon_clearance(obj, walls) >= 0.3  # room to stand next to it
        assert math.isfinite(env.episode.shortest_path_length_m)


def test_ties_for_the_deepest_room_are_drawn_from_the_seed() -> None:
    env = explore(n_rooms=(6, 6), nested_probability=0.0).unwrapped
    rooms = set()
    for seed in range(20):
        env.reset(seed=seed)
        h = generate_explore_hospital(
            np.random.default_rng(seed), ExploreHospitalConfig(n_rooms=(6, 6), nested_probability=0.0)
        )
        c = env.episode.extra["object"].mean(axis=0)
        rooms.add(next(i for i, r in enumerate(h.rooms) if inside(r, *c)))
    assert len(rooms) > 2  # all rooms tie at one door: the object moves between them


# --- start, parking, finding ---------------------------------------------------------------------


def test_start_is_in_front_of_the_parking_wall_facing_away() -> None:
    env = explore().unwrapped
    for seed in range(50):
        env.reset(seed=seed)
        wall = np.array(env.episode.map.extra["parking_wall"])
        p = env.pose
        distance = geometry.point_segment_distance(p.x, p.y, *wall[0], *wall[1])
        assert 0.35 - 1e-9 <= distance <= 1.0 + 1e-9
        assert abs(geometry.wrap_angle(p.theta - 0.0)) <= math.radians(15) + 1e-9  # the wall is at -x


def reverse_into_the_wall(env: gym.Env, speed: float, theta: float = 0.0, steps: int = 200) -> dict:
    env.reset(seed=1, options={"start_pose": (0.6, 0.6, theta)})
    c, s = math.cos(theta), math.sin(theta)
    info: dict = {}
    for _ in range(steps):
        # Backwards along the map's -x whatever the heading (body frame).
        _, _, terminated, truncated, info = env.step(np.array([-speed * c, speed * s, 0.0]))
        if info["parked"] or terminated or truncated:
            break
    return info


def test_a_slow_reverse_against_the_parking_wall_parks_and_is_not_a_bump() -> None:
    env = explore().unwrapped
    info = reverse_into_the_wall(env, 0.08)
    assert info["parked"] and info["phase"] == "find"
    assert info["bumps"] == 0 and info["termination_reason"] is None
    assert info["reward_terms"]["park"] == 10.0
    assert info["parking_error"]["heading_rad"] < 0.01 and info["parking_error"]["lateral_m"] < 0.01
    assert info["explored"] is False  # parked before exploring: the exploration is incomplete
    # The object appears once parked: in the scene, solid and seen.
    assert len(env.scene.boxes) == 1
    obj = env.episode.extra["object"]
    assert any(np.allclose(seg, s) for seg in geometry.polygon_to_segments(obj) for s in env.scene.static_seen)
    # Driving off the wall ends the contact without a bump.
    info = drive(env, (0.3, 0.0, 0.0), 10)
    assert info["bumps"] == 0 and info["phase"] == "find"


def test_a_fast_reverse_into_the_parking_wall_is_a_bump() -> None:
    env = explore().unwrapped
    info = reverse_into_the_wall(env, 0.3)
    assert not info["parked"] and info["termination_reason"] == "bump" and info["bumps"] == 1


def test_parking_needs_the_heading_to_point_away_from_the_wall() -> None:
    # Reversing at 40 deg: the rear corner touches the wall (gently: no bump) and stays there; an
    # announcement then is false, as the heading is off.
    env = explore(arrival="announce").unwrapped
    theta = math.radians(40)
    env.reset(seed=1, options={"start_pose": (0.6, 0.6, theta)})
    c, s = math.cos(theta), math.sin(theta)
    for _ in range(100):
        _, _, terminated, _, info = env.step(np.array([-0.08 * c, 0.08 * s, 0.0, 1.0]))
        assert not terminated
    assert not info["parked"] and info["bumps"] == 0 and info["phase"] == "explore"
    assert info["false_announcements"] == 100
    assert env.physics.in_contact  # it does touch the wall
    assert abs(env.pose.theta - theta) < 0.02


def test_finding_the_object_needs_standing_still_close_to_it() -> None:
    env = explore().unwrapped
    env.reset(seed=2, options={"phase": "find"})
    obj = env.episode.extra["object"]
    # Stand 0.3 m in front of the object's left side, facing it.
    x = float(obj[:, 0].min()) - 0.3 - 0.1
    y = float(obj[:, 1].mean())
    obs, info = env.reset(seed=2, options={"phase": "find", "start_pose": (x, y, 0.0)})
    assert info["task"].prior_map is env.episode.map and info["phase"] == "find"
    assert 0.25 < info["object_distance"] < 0.35
    info = drive(env, (0.0, 0.0, 0.0), 9)
    assert info["phase"] == "find"  # 0.9 s: not yet
    info = drive(env, (0.0, 0.0, 0.0), 2)
    assert info["phase"] == "done" and info["is_success"] and info["termination_reason"] == "done"
    assert info["time_to_find"] == pytest.approx(1.0)


def test_standing_still_far_from_the_object_finds_nothing() -> None:
    env = explore(idle_time_s=5.0).unwrapped
    env.reset(seed=2, options={"phase": "find"})
    info = drive(env, (0.0, 0.0, 0.0), 100)
    assert info["termination_reason"] == "idle" and not info["is_success"]


def test_a_find_start_is_parked_against_the_wall() -> None:
    env = explore().unwrapped
    obs, info = env.reset(seed=4, options={"phase": "find"})
    assert info["parked"] and info["time_to_park"] is None and len(env.scene.boxes) == 1
    wall = np.array(env.episode.map.extra["parking_wall"])
    footprint = geometry.transform_points(env.pose, env.config.robot.outline)
    assert 0.0 < geometry.polygon_clearance(footprint, np.hstack([wall[0], wall[1]])[None, :]) <= 0.02


# --- announce mode, limits, phases -------------------------------------------------------------


def test_announce_mode_counts_false_announcements() -> None:
    env = explore(arrival="announce").unwrapped
    assert env.action_space.shape == (4,)
    env.reset(seed=0)
    _, reward, _, _, info = env.step(np.array([0.0, 0.0, 0.0, 1.0]))
    assert info["false_announcements"] == 1 and info["reward_terms"]["false_announce"] == -1.0
    env = explore(arrival="announce", false_announcement="terminate").unwrapped
    env.reset(seed=0)
    _, _, terminated, _, info = env.step(np.array([0.0, 0.0, 0.0, 1.0]))
    assert terminated and info["termination_reason"] == "false_announcement"


def test_announcing_when_parked_parks() -> None:
    env = explore(arrival="announce").unwrapped
    env.reset(seed=1, options={"start_pose": (0.6, 0.6, 0.0)})
    info = drive(env, (-0.08, 0.0, 0.0, 0.0), 70)
    assert not info["parked"] and info["false_announcements"] == 0
    info = drive(env, (0.0, 0.0, 0.0, 1.0), 1)
    assert info["parked"] and info["false_announcements"] == 0


def test_the_phase_time_limit_truncates() -> None:
    env = explore(phase_time_limit_s=3.0, idle_time_s=100.0).unwrapped
    env.reset(seed=0)
    steps = 0
    while True:
        _, _, terminated, truncated, info = env.step(np.zeros(3))
        steps += 1
        if terminated or truncated:
            break
    assert truncated and info["termination_reason"] == "timeout" and steps == 30


def test_phase_observation_key() -> None:
    env = explore(phase_observation=True).unwrapped
    obs, _ = env.reset(seed=0, options={"phase": "find"})
    assert obs["phase"] == 1 and env.observation_space.contains(obs)
    obs, _ = env.reset(seed=0)
    assert obs["phase"] == 0


# --- coverage and the map score ------------------------------------------------------------------


def test_coverage_grows_as_the_robot_looks_around() -> None:
    env = explore().unwrapped
    _, info = env.reset(seed=3)
    first = info["coverage"]
    assert 0.0 < first < 1.0 and len(info["room_coverage"]) == len(env.episode.extra["building"].region_cells)
    previous = first
    for _ in range(60):
        _, reward, _, _, info = env.step(np.array([0.0, 0.0, 1.0]))
        assert info["coverage"] >= previous
        assert info["reward_terms"]["coverage"] == pytest.approx(
            0.1 * (info["coverage"] - previous) * env.episode.extra["building"].n_free * 0.01
        )
        previous = info["coverage"]
    assert info["coverage"] > first
    assert all(0.0 <= c <= 1.0 for c in info["room_coverage"])


def exact_belief(env: gym.Env, rects, shift_m: float = 0.0, resolution: float = 0.05) -> OccupancyBelief:
    """A map in the odometry frame drawn from the generator's own rectangles (hallway legs, rooms,
    door openings: their union is the free space, exactly): a cell is free where its centre is in
    one, the whole map shifted by `shift_m` along x (in the map frame)."""
    lo = np.array([-20.0, -20.0])
    n = int(40 / resolution)
    xs, ys = np.meshgrid(lo[0] + (np.arange(n) + 0.5) * resolution, lo[1] + (np.arange(n) + 0.5) * resolution)
    t = env.map_from_odom
    c, s = math.cos(t.theta), math.sin(t.theta)
    mx = t.x + c * xs - s * ys - shift_m
    my = t.y + s * xs + c * ys
    free = np.zeros(xs.shape, dtype=bool)
    for x0, y0, x1, y1 in rects:
        free |= (mx > x0) & (mx < x1) & (my > y0) & (my < y1)
    cells = np.where(free, 0, -1).astype(np.int8)
    return OccupancyBelief(cells, (float(lo[0]), float(lo[1])), resolution)


@pytest.mark.parametrize("seed", [3, 5])
def test_belief_iou_scores_an_exact_map_near_one_a_shifted_one_lower_an_empty_one_zero(tmp_path, seed: int) -> None:
    # The score's truth is the free area itself, not the coverage grid's (whose cells within half
    # a cell of a wall count as wall: an exact map scored 0.92-0.94 against it).
    h = generate_explore_hospital(np.random.default_rng(seed))
    path = tmp_path / "explore.json"
    path.write_text(json.dumps(map_to_dict(h.map)))
    env = explore(map_path=str(path), random_start=True).unwrapped
    env.reset(seed=seed)
    rects = (*h.hallway, *h.rooms, *h.doors)
    exact = env.belief_iou(exact_belief(env, rects))
    assert exact > 0.98
    assert env.belief_iou(exact_belief(env, rects, shift_m=0.1)) < exact - 0.02
    empty = OccupancyBelief(np.full((10, 10), -1, dtype=np.int8), (0.0, 0.0), 0.1)
    assert env.belief_iou(empty) == 0.0
    with pytest.raises(ValueError, match="cells"):
        OccupancyBelief(np.full((3, 3), 7, dtype=np.int8), (0.0, 0.0), 0.1)


# --- maps, determinism, the checker --------------------------------------------------------------


def test_a_map_file_with_a_parking_wall_and_an_object(tmp_path) -> None:
    h = generate_explore_hospital(np.random.default_rng(3))
    data = map_to_dict(h.map)
    room = h.rooms[0]
    cx, cy = 0.5 * (room[0] + room[2]), 0.5 * (room[1] + room[3])
    data["object"] = [[cx - 0.2, cy - 0.2], [cx + 0.2, cy - 0.2], [cx + 0.2, cy + 0.2], [cx - 0.2, cy + 0.2]]
    path = tmp_path / "explore.json"
    path.write_text(json.dumps(data))
    env = explore(map_path=str(path)).unwrapped
    env.reset(seed=0, options={"phase": "find"})
    assert np.allclose(env.episode.extra["object"], data["object"])
    # Without the object key the env places one in the deepest room.
    del data["object"]
    path.write_text(json.dumps(data))
    env = explore(map_path=str(path)).unwrapped
    env.reset(seed=0)
    c = env.episode.extra["object"].mean(axis=0)
    assert h.depth[next(i for i, r in enumerate(h.rooms) if inside(r, *c))] == max(h.depth)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"parking_wall": None}, "needs a 'parking_wall'"),
        ({"parking_wall": [[0, 0]]}, "parking_wall: expected"),
        ({"parking_wall": [[0, 0], [0, 0.1]]}, "shorter than the robot"),
        ({"object": [[0, 0], [1, 1]]}, "object: expected a polygon"),
    ],
)
def test_bad_explore_maps_are_refused_naming_the_key(tmp_path, change: dict, message: str) -> None:
    h = generate_explore_hospital(np.random.default_rng(3))
    data = map_to_dict(h.map)
    for key, value in change.items():
        if value is None:
            data.pop(key, None)
        else:
            data[key] = value
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(MapError, match=message) as error:
        explore(map_path=str(path))
    assert "bad.json" in str(error.value)


def test_bad_options_are_refused() -> None:
    env = explore()
    with pytest.raises(ValueError, match="options\\['phase'\\]"):
        env.reset(seed=0, options={"phase": "park"})
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(seed=0, options={"cabinet_order": [0]})
    with pytest.raises(TypeError, match="unknown option"):
        explore(n_cabinets=3)


def run(env: gym.Env, seed: int, steps: int) -> list:
    obs, info = env.reset(seed=seed)
    out = [obs["lrf"].tobytes(), info["coverage"]]
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(rng.uniform(-0.5, 0.5, 3))
        out += [obs["lrf"].tobytes(), obs["odom"].tobytes(), reward, tuple(info["pose"]), info["coverage"]]
        if terminated or truncated:
            break
    return out


def test_same_seed_same_episode() -> None:
    a = run(gym.make("PicoExplore-v0"), 11, 150)
    b = run(gym.make("PicoExplore-v0"), 11, 150)
    assert a == b
    assert run(gym.make("PicoExplore-v0"), 12, 150) != a


def test_check_env_passes() -> None:
    with pytest.warns(UserWarning):  # gymnasium's advice on unbounded odometry and the twist's range
        check_env(gym.make("PicoExplore-v0").unwrapped)
    with pytest.warns(UserWarning):
        check_env(gym.make("PicoExplore-v0", phase_observation=True, arrival="announce").unwrapped)


def test_pose_is_the_start_pose() -> None:
    env = explore().unwrapped
    _, info = env.reset(seed=0, options={"start_pose": (0.6, 0.6, 0.1)})
    assert Pose(*info["pose"]) == Pose(0.6, 0.6, 0.1)


def test_the_shipped_explore_map_plays() -> None:
    env = explore(map="explore_example").unwrapped
    _, info = env.reset(seed=0)
    b = env.episode.extra["building"]
    assert len(b.region_cells) == 5 and sorted(b.depth.tolist()) == [0, 1, 1, 1, 2]
    assert info["phase"] == "explore" and math.isfinite(info["shortest_path_length"])
