"""The course simulator's own files, as they are (tests/data/emc_simulator, sources in SOURCE.md):
ROS map_server maps read with map_server's and the simulator's semantics, the simulator's config
key by key, and escape rooms without a finish line."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import pico_gym  # noqa: F401
from pico_gym.envs.base import pico_env
from pico_gym.world.finish import FinishError, auto_finish
from pico_gym.world.map import MapError, load_map, map_from_dict
from pico_gym.world.map_server import MapServerSettings, course_grey, occupancy_values, read_metadata
from pico_gym.world.sim_config import SimConfigError, read_sim_config

DATA = Path(__file__).parent / "data" / "emc_simulator"
REFERENCE = Path(__file__).parent / "data"
CONFIGS = sorted(p.name for p in DATA.glob("*.json"))
TWO_ROBOTS = {"config.json", "2021_config.json", "2021_hospitalconfig_taco.json"}


# --- map_server maps -----------------------------------------------------------------------------


def test_the_simulators_default_map_loads_as_the_simulator_places_it() -> None:
    world = load_map(DATA / "heightmap_metadata.yaml")
    x0, y0, x1, y1 = world.bounds
    # 1100 x 569 px at 0.025 m: the lower-left pixel corner at (0, 0), as emc_simulator's pixel2world
    assert 0.0 <= x0 < 0.2 and 0.0 <= y0 < 0.2 and 26.0 < x1 <= 27.5 and 13.5 < y1 <= 14.225
    assert len(world.door_segments) == 4  # its four grey (127) door blobs
    assert world.heightmap.map_server.frame == "simulator"


def test_the_ros_frame_applies_origin_with_its_yaw(tmp_path: Path) -> None:
    sim = load_map(DATA / "heightmap_maze_legacy.yaml")
    for name in ("heightmap_maze_legacy.yaml", "heightmap_maze_legacy.pgm"):
        (tmp_path / name).write_bytes((DATA / name).read_bytes())
    (tmp_path / "ros.json").write_text(
        json.dumps({"map_server": {"yaml": "heightmap_maze_legacy.yaml", "frame": "ros"}})
    )
    ros = load_map(tmp_path / "ros.json")
    # origin yaw -pi/2: the map turned a quarter clockwise about the lower-left corner at (0, 0)
    a, b = sim.wall_segments, ros.wall_segments
    turned = np.column_stack([a[:, 1], -a[:, 0], a[:, 3], -a[:, 2]])

    def canonical(segs: np.ndarray) -> list[tuple[float, ...]]:  # each segment's end points in order, sorted
        ends = np.round(segs, 3).reshape(-1, 2, 2)
        return sorted(tuple(sorted(map(tuple, e))[0] + sorted(map(tuple, e))[1]) for e in ends)

    np.testing.assert_allclose(canonical(turned), canonical(b), atol=2e-3)


def _settings(**kwargs) -> MapServerSettings:
    base = dict(image="x.pgm", resolution=0.05, origin=(0.0, 0.0, 0.0), occupied_thresh=0.65, free_thresh=0.196)
    return MapServerSettings(**{**base, "negate": False, **kwargs})


def test_map_server_occupancy_values_follow_its_image_loader() -> None:
    grey = np.array([[0, 100, 127, 200, 205, 255]], dtype=np.uint8)[:, :, None]
    # occupancy (255 - v) / 255: 1.0, 0.61, 0.50, 0.22, 0.196, 0.0
    np.testing.assert_array_equal(occupancy_values(grey, False, _settings()), [[100, -1, -1, -1, -1, 0]])
    np.testing.assert_array_equal(occupancy_values(grey, False, _settings(negate=True)), [[0, -1, -1, 100, 100, 100]])
    scale = occupancy_values(grey, False, _settings(mode="scale"))
    assert scale[0, 0] == 100 and scale[0, 5] == 0 and all(1 <= v <= 99 for v in scale[0, 1:5])
    np.testing.assert_array_equal(occupancy_values(grey, False, _settings(mode="raw")), [[0, 100, 127, -56, -51, -1]])
    # alpha: scale mode leaves a transparent pixel unknown and averages the colours only
    rgba = np.array([[[128, 128, 128, 0], [128, 128, 128, 255]]], dtype=np.uint8)
    assert occupancy_values(rgba, True, _settings(mode="scale")).tolist()[0][0] == -1
    assert 1 <= occupancy_values(rgba, True, _settings(mode="scale")).tolist()[0][1] <= 99


def test_the_simulator_turns_unknown_cells_into_doors_unless_asked_otherwise() -> None:
    values = np.array([[0, 100, -1, 50]])
    assert course_grey(values).tolist() == [[255, 0, 127, 127]]
    assert course_grey(values, "wall").tolist() == [[255, 0, 0, 0]]
    assert course_grey(values, "free").tolist() == [[255, 0, 255, 255]]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: 0.1\nnegate: 0\n",
            "occupied_thresh: missing",
        ),
        (
            "image: m.pgm\nresolution: -1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.1\nnegate: 0\n",
            "resolution: must be in",
        ),
        (
            "image: m.pgm\nresolution: 0.05\norigin: [0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.1\nnegate: 0\n",
            r"origin: expected \[x, y, yaw\]",
        ),
        (
            "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.1\nfree_thresh: 0.6\nnegate: 0\n",
            "free_thresh: need 0 <= free_thresh <= occupied_thresh",
        ),
        (
            "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.1\nnegate: 2\n",
            "negate: expected 0 or 1",
        ),
        (
            "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.1\nnegate: 0\n"
            "mode: fancy\n",
            "mode: must be one of",
        ),
        (
            "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.1\nnegate: 0\n"
            "colour: red\n",
            "colour: not a map_server key",
        ),
        ("- just\n- a list\n", "a map_server file holds a mapping"),
        ("image: [unclosed\n", "not valid YAML"),
    ],
)
def test_bad_map_server_files_are_refused_naming_the_key(tmp_path: Path, text: str, message: str) -> None:
    (tmp_path / "m.pgm").write_bytes((DATA / "heightmap_maze_legacy.pgm").read_bytes())
    (tmp_path / "m.yaml").write_text(text)
    with pytest.raises(MapError, match=message):
        load_map(tmp_path / "m.yaml")


def test_a_map_server_image_that_is_missing_or_16_bit_is_refused(tmp_path: Path) -> None:
    meta = "image: {}\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.1\nnegate: 0\n"
    (tmp_path / "a.yaml").write_text(meta.format("nowhere.pgm"))
    with pytest.raises(MapError, match="image: file not found"):
        load_map(tmp_path / "a.yaml")
    (tmp_path / "deep.pgm").write_bytes(b"P2\n2 2\n1000\n0 1000\n500 0\n")
    (tmp_path / "b.yaml").write_text(meta.format("deep.pgm"))
    with pytest.raises(MapError, match="16-bit"):
        load_map(tmp_path / "b.yaml")


def test_plain_p2_and_binary_p5_pgm_read_alike(tmp_path: Path) -> None:
    rows = [[0, 0, 0, 0, 0, 0]] + [[0, 255, 255, 255, 255, 0]] * 4 + [[0, 0, 0, 0, 0, 0]]
    text = "P2\n6 6\n255\n" + "\n".join(" ".join(map(str, r)) for r in rows) + "\n"
    (tmp_path / "p2.pgm").write_text(text)
    (tmp_path / "p5.pgm").write_bytes(b"P5\n6 6\n255\n" + bytes(v for r in rows for v in r))
    meta = "image: {}\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.196\nnegate: 0\n"
    for name in ("p2", "p5"):
        (tmp_path / f"{name}.yaml").write_text(meta.format(f"{name}.pgm"))
    a, b = load_map(tmp_path / "p2.yaml"), load_map(tmp_path / "p5.yaml")
    np.testing.assert_array_equal(a.wall_segments, b.wall_segments)
    assert a.bounds == pytest.approx((0.0, 0.0, 0.6, 0.6))


def test_files_a_map_references_stay_in_its_folder(tmp_path: Path) -> None:
    inner = tmp_path / "maps"
    inner.mkdir()
    (tmp_path / "room.pgm").write_bytes((DATA / "heightmap_maze_legacy.pgm").read_bytes())
    for key, value in (
        ("heightmap", {"image": "../room.pgm"}),
        ("map_server", "../elsewhere.yaml"),
        ("movers", {"config": str(DATA / "2021_hospitalconfig.json")}),
    ):
        data = {"heightmap": {"image": "../room.pgm"}} if key == "movers" else {}
        (inner / "m.json").write_text(json.dumps({**data, key: value}))
        with pytest.raises(MapError, match="outside the map file's folder"):
            load_map(inner / "m.json")
    (inner / "m.json").write_text(json.dumps({"heightmap": {"image": "../room.pgm"}}))
    assert len(load_map(inner / "m.json", allow_outside=True).wall_segments) > 0


def test_every_course_image_and_map_loads() -> None:
    for name in ("heightmap.pgm", "heightmap_maze_legacy.pgm", "emc2015-heightmap-example.png", "hospital_2021.png"):
        world = load_map(DATA / name)
        assert len(world.wall_segments) > 10, name
    for name in ("heightmap_metadata.yaml", "heightmap_maze_legacy.yaml"):
        assert len(load_map(DATA / name).wall_segments) > 10, name


def test_read_metadata_reads_the_course_yaml() -> None:
    s = read_metadata(DATA / "heightmap_metadata.yaml")
    assert (s.image, s.resolution, s.origin, s.occupied_thresh, s.free_thresh, s.negate, s.mode) == (
        "heightmap.pgm",
        0.025,
        (0.0, 0.0, 0.0),
        0.9,
        0.1,
        False,
        "trinary",
    )


# --- escape rooms without a finish line ---------------------------------------------------------


@pytest.mark.parametrize("image", ["escape_room_student_2019.png", "er_large2_student_2019.png"])
def test_a_course_escape_image_gets_its_finish_across_the_corridor(image: str) -> None:
    with pytest.warns(UserWarning, match="shorter than the rules' 3 m: the finish line is at its open end"):
        env = gym.make("PicoEscape-v0", map_path=REFERENCE / image)
    finish = pico_env(env).task.fixed_map.finish
    assert finish is not None and 0.4 < float(np.hypot(*(finish[1] - finish[0]))) < 1.7
    _, info = env.reset(seed=0)
    assert math.isfinite(info["shortest_path_length"])


def test_the_auto_finish_of_the_team_room_is_where_the_team_drew_it() -> None:
    from pico_gym.world.catalog import load_shipped

    world = load_shipped("escape_student_2019")  # its finish drawn by hand at the corridor's open end
    x0, y0, x1, y1 = world.bounds
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        line, _ = auto_finish(world.solid_segments(), (0.5 * (x0 + x1), 0.5 * (y0 + y1)), "room")
    assert np.allclose(np.sort(line[:, 1]), np.sort(world.finish[:, 1]), atol=0.15)
    assert abs(line[:, 0].mean() - world.finish[:, 0].mean()) < 0.3


def test_a_long_corridor_gets_the_line_3_m_past_its_mouth() -> None:
    # a 4 x 4 m room, a 1 m corridor 6 m long from the middle of its right wall
    walls = [
        (0, 0, 4, 0), (4, 0, 4, 1.5), (4, 2.5, 4, 4), (4, 4, 0, 4), (0, 4, 0, 0),
        (4, 1.5, 10, 1.5), (4, 2.5, 10, 2.5),
    ]  # fmt: skip
    line, warning = auto_finish(np.array(walls, dtype=float), (2.0, 2.0), "room")
    assert warning is None
    assert 7.0 < line[:, 0].mean() < 7.6 and abs(line[0, 0] - line[1, 0]) < 0.1  # across, 3.2 m past x = 4


def test_rooms_without_one_opening_are_refused_saying_how_to_add_a_finish() -> None:
    closed = np.array([(0, 0, 4, 0), (4, 0, 4, 4), (4, 4, 0, 4), (0, 4, 0, 0)], dtype=float)
    with pytest.raises(FinishError, match='the room is closed.*add "finish"'):
        auto_finish(closed, (2.0, 2.0), "room")
    two = np.array(
        [
            (0, 0, 4, 0), (4, 0, 4, 1.5), (4, 2.5, 4, 4), (4, 4, 0, 4), (0, 4, 0, 2.5), (0, 1.5, 0, 0),
            (4, 1.5, 8, 1.5), (4, 2.5, 8, 2.5), (0, 1.5, -4, 1.5), (0, 2.5, -4, 2.5),
        ],
        dtype=float,
    )  # fmt: skip
    with pytest.raises(FinishError, match="more than one opening"):
        auto_finish(two, (2.0, 2.0), "room")


def test_a_drawn_escape_map_without_a_finish_asks_for_one_or_auto(tmp_path: Path) -> None:
    data = {"points": [[0, 0], [4, 0], [4, 4], [0, 4]], "walls": [[0, 1], [1, 2], [2, 3], [3, 0]]}
    (tmp_path / "m.json").write_text(json.dumps(data))
    with pytest.raises(ValueError, match="needs a 'finish' line.*finish=\"auto\""):
        gym.make("PicoEscape-v0", map_path=tmp_path / "m.json")
    with pytest.raises(ValueError, match="the room is closed"):
        gym.make("PicoEscape-v0", map_path=tmp_path / "m.json", finish="auto")


# --- the simulator's config ----------------------------------------------------------------------


# Each config with the world it was written for: the 2021 hospital's, or the default map of the
# simulator of its branch (2020: the maze image, placed as that simulator places an image).
WORLDS = {
    "2021_hospitalconfig.json": ("PicoHospital-v0", {"map": "hospital_2021"}),
    "2021_hospitalconfig_easy.json": ("PicoHospital-v0", {"map": "hospital_2021"}),
    "2021_hospitalconfig_taco.json": ("PicoHospital-v0", {"map": "hospital_2021"}),
    "2021_defaultconfig.json": ("PicoHospital-v0", {"map": "hospital_2021"}),
    "2021_config.json": ("PicoEscape-v0", {"map_path": DATA / "heightmap_maze_legacy.pgm"}),
    "2020_config.json": ("PicoEscape-v0", {"map_path": DATA / "heightmap_maze_legacy.pgm"}),
    "config.json": ("PicoEscape-v0", {"map_path": DATA / "heightmap_maze_legacy.pgm"}),
    "defaultconfig.json": ("PicoEscape-v0", {"map_path": DATA / "heightmap_maze_legacy.pgm"}),
    "localizationconfig.json": ("PicoEscape-v0", {"map_path": DATA / "heightmap_maze_legacy.pgm"}),
}


def test_every_course_config_is_paired_with_its_world() -> None:
    assert sorted(WORLDS) == CONFIGS


@pytest.mark.parametrize("name", CONFIGS)
def test_every_course_config_loads_or_is_refused_by_name(name: str) -> None:
    config = read_sim_config(DATA / name)
    assert config.enable_taco == (name in TWO_ROBOTS)
    env_id, world = WORLDS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (the maze's auto finish)
        if name in TWO_ROBOTS:
            with pytest.raises(ValueError, match="enable_taco: true asks for two robots.*parallel_env"):
                gym.make(env_id, sim_config=DATA / name, **world)
            return
        env = gym.make(env_id, sim_config=DATA / name, **world)
    obs, info = env.reset(seed=0)
    assert info["sim_config"]["ignored"] == tuple(
        k for k in ("show_full_map", "use_pyro") if k in json.loads((DATA / name).read_text())
    )
    assert len(pico_env(env).episode.scene.movers.records) == len(config.objects)
    assert ("internal_pose" in obs) == config.provide_internal_pose


def test_a_config_written_for_another_world_is_refused_naming_the_object() -> None:
    with pytest.raises(ValueError, match=r"objects\[0\]: its way .* runs through a wall"):
        gym.make("PicoHospital-v0", map="hospital_2021", sim_config=DATA / "2020_config.json")


def test_uncertain_odom_false_gives_exact_odometry() -> None:
    env = gym.make("PicoHospital-v0", map="hospital_2021", sim_config=DATA / "2021_hospitalconfig_easy.json")
    env.reset(seed=0)
    assert pico_env(env).odometry.exact
    noisy = gym.make("PicoHospital-v0", map="hospital_2021", sim_config=DATA / "2021_hospitalconfig.json")
    noisy.reset(seed=0)
    assert not pico_env(noisy).odometry.exact


def test_the_internal_pose_is_the_true_pose(tmp_path: Path) -> None:
    (tmp_path / "c.json").write_text(json.dumps({"provide_internal_pose": True, "uncertain_odom": True}))
    env = gym.make("PicoHospital-v0", map="hospital_2021", sim_config=tmp_path / "c.json")
    obs, info = env.reset(seed=0)
    np.testing.assert_allclose(obs["internal_pose"], info["pose"], atol=1e-5)
    assert env.observation_space.contains(obs)
    obs, *_, info = env.step(np.array([0.2, 0.0, 0.3], dtype=np.float32))
    np.testing.assert_allclose(obs["internal_pose"], info["pose"], atol=1e-5)


def test_spawn_pose_speed_cap_and_objects_are_placed_in_the_map(tmp_path: Path) -> None:
    config = {
        "uncertain_odom": False,
        "provide_internal_pose": False,
        "disable_speedcap": True,
        "initial_pose": [0.0, 0.0, 0.0],  # the course's identity pose: the start of 2021
        "objects": [
            {"length": 0.2, "width": 0.4, "trigger_radius": 10.0, "repeat": True, "velocity": 0.5,
             "init_pose": [6.5, -6.5, 0.0], "final_pose": [0.4, -6.5, 0.0]},
        ],
    }  # fmt: skip
    (tmp_path / "c.json").write_text(json.dumps(config))
    env = gym.make("PicoHospital-v0", map="hospital_2021", sim_config=tmp_path / "c.json")
    _, info = env.reset(seed=0)
    world = pico_env(env).task.fixed_map
    assert tuple(info["pose"]) == pytest.approx(tuple(world.from_simulator((0.0, 0.0, 0.0))))
    assert pico_env(env).config.robot.max_speed_mps == 1.0
    # the person the 2021 config walks, where the shipped map's own mover config puts it
    shipped = gym.make("PicoHospital-v0", map="hospital_2021")
    shipped.reset(seed=0)
    ours = pico_env(env).episode.scene.movers.records[0].init_pose
    theirs = pico_env(shipped).episode.scene.movers.records[1].init_pose
    assert ours == pytest.approx(theirs)


@pytest.mark.parametrize(
    ("config", "message"),
    [
        ({"show_full_map": True, "map_file": "x"}, "map_file: not a key of the course simulator's config"),
        ({"uncertain_odom": "yes"}, "uncertain_odom: expected true or false"),
        ({"initial_pose": [0, 0]}, r"initial_pose: expected \[x, y, theta\]"),
        ({"initial_pose": [0, 0, 0], "pico_pose": [0, 0, 0]}, "give initial_pose .* or pico_pose"),
        ({"objects": [{"length": 1}]}, "objects\\[0\\]"),
        ({"objects": {"a": 1}}, "objects: expected a list"),
        ({"use_pyro": 3}, "use_pyro: expected true or false"),
    ],
)
def test_bad_configs_are_refused_naming_the_key(tmp_path: Path, config: dict, message: str) -> None:
    (tmp_path / "c.json").write_text(json.dumps(config))
    with pytest.raises(SimConfigError, match=message):
        read_sim_config(tmp_path / "c.json")


def test_a_config_needs_a_map_and_a_spawn_off_the_walls(tmp_path: Path) -> None:
    (tmp_path / "c.json").write_text(json.dumps({"initial_pose": [100.0, 100.0, 0.0]}))
    with pytest.raises(ValueError, match="give map= or map_path= with sim_config="):
        gym.make("PicoHospital-v0", sim_config=tmp_path / "c.json")
    from pico_gym.world.catalog import load_shipped

    world = load_shipped("hospital_2021")
    x, y = world.wall_segments[0].reshape(2, 2).mean(axis=0)  # on a wall, map frame
    fx, fy, fth = world.simulator_frame
    sx = math.cos(fth) * (x - fx) + math.sin(fth) * (y - fy)
    sy = -math.sin(fth) * (x - fx) + math.cos(fth) * (y - fy)
    (tmp_path / "wall.json").write_text(json.dumps({"initial_pose": [sx, sy, 0.0]}))
    with pytest.raises(ValueError, match="initial_pose / pico_pose: .*overlaps a wall"):
        gym.make("PicoHospital-v0", map="hospital_2021", sim_config=tmp_path / "wall.json")


def test_a_map_json_may_reference_a_map_server_yaml(tmp_path: Path) -> None:
    for name in ("heightmap_metadata.yaml", "heightmap.pgm"):
        (tmp_path / name).write_bytes((DATA / name).read_bytes())
    data = {"map_server": {"yaml": "heightmap_metadata.yaml", "unknown": "wall"}}
    (tmp_path / "m.json").write_text(json.dumps(data))
    walled = load_map(tmp_path / "m.json")
    assert len(walled.door_segments) == 0  # the grey doors read as walls
    with pytest.raises(MapError, match="map_server.colour: unknown key"):
        map_from_dict({"map_server": {"yaml": "heightmap_metadata.yaml", "colour": 1}}, tmp_path / "x.json")
