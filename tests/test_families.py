"""The named generator families (`gym.make(..., family=NAME)`): each keeps its rules, every
episode is solvable, the counts it asks for are met, and it is seeded like the defaults."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import pico_gym  # noqa: F401
from pico_gym.envs.base import pico_env
from pico_gym.registry import task_info
from pico_gym.robot import RobotConfig
from pico_gym.tasks import escape, explore, hospital
from pico_gym.world import geometry
from pico_gym.world.escape_room import EscapeRoomConfig, generate_escape_room, route_clearance
from pico_gym.world.hospital import HospitalConfig, generate_hospital
from pico_gym.world.hospital2018 import DEEP_FROM, ExploreHospitalConfig, generate_explore_hospital

ROBOT = RobotConfig()
SEEDS = range(200)


def test_every_family_is_a_suite_with_disjoint_seed_splits() -> None:
    for env_id, families in (
        ("PicoEscape-v0", escape.FAMILIES),
        ("PicoHospital-v0", hospital.FAMILIES),
        ("PicoExplore-v0", explore.FAMILIES),
    ):
        info = task_info(env_id)
        splits = [info.suite("generated").seeds("dev"), info.suite("generated").seeds("test")]
        for name in families:
            suite = info.suite(name)
            assert suite.groups[0].env_kwargs == {"family": name}
            splits += [suite.seeds("dev"), suite.seeds("test")]
        for i, a in enumerate(splits):  # no seed in two splits of a task's suites
            for b in splits[i + 1 :]:
                assert a.stop <= b.start or b.stop <= a.start, (env_id, a, b)


def test_an_unknown_family_is_refused_naming_those_there_are() -> None:
    with pytest.raises(ValueError, match="no family 'wide'.*narrow, crowded"):
        gym.make("PicoHospital-v0", family="wide")


# --- escape ------------------------------------------------------------------------------------


def test_escape_cluttered_rooms_hold_3_to_5_boxes_and_stay_solvable() -> None:
    cfg = EscapeRoomConfig(**escape.FAMILIES["cluttered"])
    for seed in SEEDS:
        room = generate_escape_room(np.random.default_rng(seed), cfg, ROBOT)
        assert 3 <= len(room.map.obstacles) <= 5, seed
        assert route_clearance(room.route, room.map.solid_segments()) > ROBOT.circumradius_m, seed


def test_escape_narrow_corridors_are_half_a_metre_to_0_6() -> None:
    cfg = EscapeRoomConfig(**escape.FAMILIES["narrow"])
    for seed in SEEDS:
        room = generate_escape_room(np.random.default_rng(seed), cfg, ROBOT)
        mouth = float(np.linalg.norm(room.mouth[1] - room.mouth[0]))
        assert 0.5 - 1e-9 <= room.corridor_width_min_m and mouth <= 0.6 + 1e-9, seed
        assert route_clearance(room.route, room.map.solid_segments()) > ROBOT.circumradius_m, seed


# --- hospital ----------------------------------------------------------------------------------


def test_hospital_narrow_hallways_and_doors_are_at_the_rules_narrow_end() -> None:
    keys = ("hallway_width_m", "door_width_m")
    cfg = HospitalConfig(**{k: hospital.FAMILIES["narrow"][k] for k in keys})
    for seed in SEEDS:
        built = generate_hospital(np.random.default_rng(seed), cfg)
        for x0, y0, x1, y1 in built.hallway:
            assert 1.0 - 1e-9 <= min(x1 - x0, y1 - y0) <= 1.2 + 1e-9, seed
        for x0, y0, x1, y1 in built.doors:
            assert 0.55 - 1e-9 <= max(x1 - x0, y1 - y0) <= 0.7 + 1e-9, seed


def _episodes(family: str, n: int):
    env = gym.make("PicoHospital-v0", family=family)
    for seed in range(n):
        _, info = env.reset(seed=seed)
        yield seed, pico_env(env), info


def test_hospital_narrow_people_walk_the_hallway_towards_the_start() -> None:
    counts = []
    for seed, env, _ in _episodes("narrow", 60):
        episode = env.episode
        assert all(math.isfinite(leg) for leg in episode.extra["legs"]), seed
        area = episode.map.polygon(episode.map.start_area[0])
        centre = area.mean(axis=0)
        records = episode.scene.movers.records
        counts.append(len(records))
        for m in records:
            assert math.dist(m.init_pose[:2], centre) > math.dist(m.final_pose[:2], centre), seed
            # the lane keeps clear of the start area (the person never walks into the robot's start)
            lane = np.array([m.init_pose[:2], m.final_pose[:2]])
            assert geometry.polygon_clearance(area, np.concatenate([lane[0], lane[1]])[None, :]) > 0.3, seed
    assert min(counts) >= 1 and max(counts) <= 2
    assert set(counts) == {1, 2}  # both counts of the range occur


def test_hospital_crowded_has_2_to_3_people_and_2_to_3_boxes_and_stays_solvable() -> None:
    for seed, env, _ in _episodes("crowded", 60):
        scene = env.episode.scene
        assert 2 <= len(scene.movers.records) <= 3, seed
        assert 2 <= len(scene.boxes) <= 3, seed
        assert all(math.isfinite(leg) for leg in env.episode.extra["legs"]), seed


def test_counts_the_options_ask_for_are_met_or_refused_never_lowered() -> None:
    env = gym.make("PicoHospital-v0", n_movers=(2, 2), n_boxes=(3, 3), n_closed_doors=(1, 1))
    for seed in range(20):
        env.reset(seed=seed)
        scene = pico_env(env).episode.scene
        assert (len(scene.movers.records), len(scene.boxes), len(scene.closed_doors)) == (2, 3, 1), seed
    with pytest.raises(ValueError, match=r"n_movers: 5 asked, at most 2 placed.*straight lane"):
        gym.make("PicoHospital-v0", map="hospital_2019", n_movers=(5, 5)).reset(seed=0)
    with pytest.raises(ValueError, match=r"n_closed_doors: 5 asked.*reachable"):
        gym.make("PicoHospital-v0", map="hospital_2019", n_closed_doors=(5, 5)).reset(seed=0)
    with pytest.raises(ValueError, match=r"n_boxes: 1 asked, at most 0 placed"):
        gym.make("PicoHospital-v0", box_side_m=(5.0, 5.0), n_boxes=(1, 1)).reset(seed=0)
    with pytest.raises(ValueError, match=r"n_closed_doors=\(1, 1\): .*hospital_2021.* has 0 door"):
        gym.make("PicoHospital-v0", map="hospital_2021", n_closed_doors=(1, 1))


@pytest.mark.parametrize("family", list(hospital.FAMILIES))
def test_hospital_family_episodes_are_reproducible(family: str) -> None:
    a, b = gym.make("PicoHospital-v0", family=family), gym.make("PicoHospital-v0", family=family)
    for seed in (5, 6):
        _, ia = a.reset(seed=seed)
        _, ib = b.reset(seed=seed)
        np.testing.assert_array_equal(ia["movers"], ib["movers"])
        np.testing.assert_array_equal(ia["task"].map.wall_segments, ib["task"].map.wall_segments)
        for _ in range(20):
            action = np.array([0.2, 0.0, 0.1], dtype=np.float32)
            oa, *_ = a.step(action)
            ob, *_ = b.step(action)
            np.testing.assert_array_equal(oa["lrf"], ob["lrf"])


# --- explore -----------------------------------------------------------------------------------


def _buildings(family: str):
    cfg = ExploreHospitalConfig(**explore.FAMILIES[family])
    for seed in SEEDS:
        yield seed, generate_explore_hospital(np.random.default_rng(seed), cfg)


def _touches(door: tuple[float, ...], rect: tuple[float, ...]) -> bool:
    e = 1e-9
    return door[0] <= rect[2] + e and door[2] >= rect[0] - e and door[1] <= rect[3] + e and door[3] >= rect[1] - e


def test_explore_comb_rooms_hang_off_the_side_corridor_only() -> None:
    for seed, h in _buildings("comb"):
        assert h.shape == "comb" and len(h.hallway) == 2, seed
        main, side = h.hallway
        assert side[1] >= main[3] - 1e-9, seed  # the side corridor branches off the hallway
        for door, parent in zip(h.doors, h.parent, strict=True):
            if parent < 0:
                assert _touches(door, side) and not _touches(door, main), seed


def test_explore_deep_l_rooms_lie_at_the_far_end_of_the_far_leg() -> None:
    for seed, h in _buildings("deep-L"):
        assert h.shape == "deep-L" and len(h.hallway) == 2, seed
        far = h.hallway[1]
        cut = far[1] + DEEP_FROM * (far[3] - far[1])
        for door, parent in zip(h.doors, h.parent, strict=True):
            if parent < 0:
                assert _touches(door, far) and door[1] >= cut - 0.2 - 1e-9, seed
        # every room is farther along the hallway than the first leg's end
        assert all(room[1] >= far[1] for room in h.rooms), seed


def test_explore_nested_buildings_have_a_room_behind_two_others() -> None:
    for seed, h in _buildings("nested"):
        assert max(h.depth) >= 3, seed
        assert 4 <= len(h.rooms) <= 6, seed


FAMILIES = [
    (env_id, name)
    for env_id, fs in (("PicoEscape-v0", escape.FAMILIES), ("PicoExplore-v0", explore.FAMILIES))
    for name in fs
]


@pytest.mark.parametrize(("env_id", "family"), FAMILIES)
def test_family_episodes_have_a_path_to_the_goal(env_id: str, family: str) -> None:
    """(The hospital's: its legs, checked above.)"""
    env = gym.make(env_id, family=family)
    for seed in range(20):
        _, info = env.reset(seed=seed)
        assert math.isfinite(info["shortest_path_length"]), seed
