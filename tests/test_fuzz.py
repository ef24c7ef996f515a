"""Bad input is refused clearly and early: a fuzz pass over configs, reset options, actions, map
files and training YAML. Each case names the option, key or file; none runs long or eats memory."""

from __future__ import annotations

import json
import math

import gymnasium as gym
import numpy as np
import pytest

import pico_gym  # noqa: F401
from pico_gym.world.map import MapError, load_map

NAN, INF = math.nan, math.inf

BAD_OPTIONS = [
    ({"noise_m": NAN}, "LrfConfig.noise_m must be a finite number"),
    ({"noise_m": -0.1}, "LrfConfig.noise_m"),
    ({"n_beams": 0}, "LrfConfig.n_beams must be >= 1"),
    ({"n_beams": 2.5}, "LrfConfig.n_beams must be an integer"),
    ({"n_beams": 10**7}, "LrfConfig.n_beams must be <= 100000"),
    ({"range_max_m": INF}, "LrfConfig.range_max_m must be a finite number"),
    ({"time_limit_s": NAN}, "time_limit_s must be a finite number"),
    ({"idle_time_s": -1}, "idle_time_s must be > 0"),
    ({"rewards": {"time": NAN}}, "RewardWeights.time must be a finite number"),
    ({"rewards": {"progress": "1"}}, "RewardWeights.progress must be a finite number"),
    ({"contact_skin_m": -0.01}, "PhysicsConfig.contact_skin_m must be > 0"),
    ({"contact_skin_m": 0.0}, "PhysicsConfig.contact_skin_m must be > 0"),
    ({"robot_mass_kg": -30}, "PhysicsConfig.robot_mass_kg must be >= 0.1"),
    ({"drive_force_n": NAN}, "PhysicsConfig.drive_force_n must be a finite number"),
    ({"drive_force_n": 1e5}, "PhysicsConfig.drive_force_n must be <= 10000"),
    ({"substep_s": 0.1}, "PhysicsConfig.substep_s must be <= 0.05"),
    ({"iterations": 0}, "PhysicsConfig.iterations must be >= 1"),
    ({"max_speed_mps": 2.0}, "walls are kept solid only while"),
    ({"max_speed_mps": 20.0}, "walls are kept solid only while"),
    ({"max_speed_mps": -1.0}, "RobotConfig.max_speed_mps must be > 0"),
    ({"slip_std": NAN}, "OdometryConfig.slip_std must be a finite number"),
    ({"room_side_m": (500, 500)}, "EscapeRoomConfig.room_side_m\\[0\\] must be <= 30"),
    ({"room_side_m": (5, 3)}, "EscapeRoomConfig.room_side_m must have low <= high"),
    ({"n_obstacles": -1}, "EscapeRoomConfig.n_obstacles must be >= 0"),
    ({"dt_s": NAN}, "dt_s must be a finite number"),
    ({"dt_s": 0.015}, "whole number of physics sub-steps"),
    ({"n_beam": 10}, "unknown option 'n_beam'"),
    ({"collision": "explode"}, "collision must be 'terminate' or 'continue'"),
]


@pytest.mark.parametrize("kwargs, message", BAD_OPTIONS)
def test_bad_escape_options_are_refused_naming_the_option(kwargs: dict, message: str) -> None:
    with pytest.raises((ValueError, TypeError), match=message):
        gym.make("PicoEscape-v0", **kwargs)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"n_cabinets": 0}, "n_cabinets must be an integer >= 1"),
        ({"n_boxes": (2, 1)}, "n_boxes must be a range"),
        ({"n_boxes": (0, 100)}, "n_boxes\\[1\\] must be <= 20"),
        ({"box_side_m": (0, 1)}, "box_side_m must be a range"),
        ({"dwell_s": NAN}, "HospitalTaskConfig.dwell_s must be a finite number"),
        ({"arrival": "shout"}, "arrival must be 'dwell' or 'announce'"),
        ({"facing_tolerance_rad": 4.0}, "facing_tolerance_rad must be in"),
        ({"geodesic_resolution_m": 0.001}, "geodesic_resolution_m must be >= 0.02"),
    ],
)
def test_bad_hospital_options_are_refused_naming_the_option(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        gym.make("PicoHospital-v0", **kwargs)


@pytest.mark.parametrize(
    "options, message",
    [
        ({"start_pos": (0, 0, 0)}, "unknown reset option"),
        ({"start_pose": (0, 0)}, "must be \\(x, y, theta\\)"),
        ({"start_pose": (NAN, 0, 0)}, "must be \\(x, y, theta\\)"),
        ({"start_pose": "here"}, "must be \\(x, y, theta\\)"),
        ({"start_pose": (0, 0, 0)}, "puts the robot in a wall"),
        ({"start_pose": (-3.0, 2.0, 0.0)}, "outside the walls: not in the room the finish line closes"),
    ],
)
def test_bad_reset_options_are_refused(options: dict, message: str) -> None:
    env = gym.make("PicoEscape-v0", map="escape_2018")
    with pytest.raises(ValueError, match=message):
        env.reset(seed=0, options=options)


@pytest.mark.parametrize("env_id", ["PicoEscape-v0", "PicoHospital-v0"])
def test_an_ended_episode_never_pays_again(env_id: str) -> None:
    env = gym.make(env_id, time_limit_s=0.2)
    env.reset(seed=0)
    env.step(np.zeros(3))
    *_, truncated, _ = env.step(np.zeros(3))
    assert truncated
    for _ in range(3):
        with pytest.raises(RuntimeError, match="has ended"):
            env.step(np.zeros(3))


def _png(tmp_path, grey: np.ndarray, name: str = "m.png"):
    from PIL import Image

    path = tmp_path / name
    Image.fromarray(grey).save(path)
    return path


def test_a_checkerboard_of_door_grey_loads_fast_and_small(tmp_path) -> None:
    """The fuzzing pass's 930-byte PNG that took 3 GB: 900 one-pixel door blobs."""
    grey = np.full((60, 60), 255, dtype=np.uint8)
    grey[::2, ::2] = 127
    world = load_map(_png(tmp_path, grey))
    assert len(world.door_segments) == 900
    grey = np.full((200, 200), 255, dtype=np.uint8)
    grey[::2, ::2] = 127  # 10,000 blobs: over the budget
    with pytest.raises(MapError, match="door blobs.*the limit is 1000"):
        load_map(_png(tmp_path, grey, "many.png"))


def test_an_image_over_the_pixel_budget_is_refused_before_decoding(tmp_path) -> None:
    from PIL import Image

    path = tmp_path / "huge.png"
    Image.new("L", (5000, 4000), 255).save(path)  # 20 M pixels; the PNG itself is tiny
    with pytest.raises(MapError, match="huge.png.*5000 x 4000 pixels; the limit is 16,000,000"):
        load_map(path)


@pytest.mark.parametrize(
    "data, message",
    [
        ([1, 2], "a map file must hold a JSON object"),
        ({"points": [[0, 0]], "walls": [[0, 5]]}, "walls\\[0\\]: point index 5 out of range"),
        ({"points": [[0, "a"]], "walls": []}, "points\\[0\\]\\[1\\]: expected a finite number"),
        ({"points": [[0, 0], [1, 0]], "walls": [[0, 1]], "movers": {"config": 3}}, "movers: expected a list"),
        ({"points": [[0, 0], [1, 0]], "walls": [[0, 1]], "movers": [{"length": 1}]}, "movers\\[0\\]: missing key"),
        ({"heightmap": {"image": "x.png", "simplify_m": -1}}, "heightmap.simplify_m: must be in"),
        (
            {"points": [[0, 0], [1e6, 0]], "walls": [[0, 1]]},
            "points: the map spans 1,000,000.0 x 0.0 m; the limit is 200 m",
        ),
    ],
)
def test_bad_map_files_name_the_file_and_key(tmp_path, data: object, message: str) -> None:
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(MapError, match=message):
        load_map(path)


def test_training_yaml_policy_kwargs_are_data_not_code(tmp_path) -> None:
    pytest.importorskip("torch")
    from pico_gym.train.config import ConfigError
    from pico_gym.train.config import parse_policy_kwargs as _policy_kwargs

    assert _policy_kwargs("dict(net_arch=[64, 64], activation_fn=nn.ReLU)", "c.yaml")["net_arch"] == [64, 64]
    marker = tmp_path / "ran"
    for text in (f"__import__('pathlib').Path({str(marker)!r}).touch()", "dict(a=open('/etc/passwd'))"):
        with pytest.raises(ConfigError, match="is not data"):
            _policy_kwargs(text, "c.yaml")
    assert not marker.exists()


# --- maps checked at load: start and finish ----------------------------------------------------


def _escape_small(**changes: object) -> dict:
    from pico_gym.world.catalog import shipped_maps

    data = json.loads(shipped_maps()["escape_small"].read_text())
    data.update(changes)
    return data


def _make(tmp_path, data: dict, name: str = "m.json"):
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return gym.make("PicoEscape-v0", map_path=path)


@pytest.mark.parametrize(
    "change, message",
    [
        (
            {"start_pose": {"x": 50.0, "y": 50.0, "theta": 0.0}},
            "m.json: start_pose \\(50.000, 50.000\\) is not inside the walls",
        ),
        # a closed 1 x 1 m block of walls with the start in it
        (
            {
                "points": [
                    [0, 0],
                    [4, 0],
                    [4, 3],
                    [2.6, 3],
                    [2.6, 6.5],
                    [1.8, 6.5],
                    [1.8, 3],
                    [0, 3],
                    [0.5, 0.5],
                    [1.5, 0.5],
                    [1.5, 1.5],
                    [0.5, 1.5],
                ],
                "walls": [[0, 1], [1, 2], [2, 3], [3, 4], [5, 6], [6, 7], [7, 0], [8, 9], [9, 10], [10, 11], [11, 8]],
            },
            "start_pose \\(1.000, 1.000\\) is inside an obstacle or has no path to the finish line",
        ),
        # the corridor walled off: the finish cannot be reached
        (
            {
                "points": [[0, 0], [4, 0], [4, 3], [2.6, 3], [2.6, 6.5], [1.8, 6.5], [1.8, 3], [0, 3]],
                "walls": [[0, 1], [1, 2], [2, 3], [3, 4], [5, 6], [6, 7], [7, 0], [3, 6]],
            },
            "start_pose \\(1.000, 1.000\\) is inside an obstacle or has no path to the finish line",
        ),
    ],
)
def test_an_escape_map_with_a_bad_start_or_finish_is_refused_at_load(tmp_path, change: dict, message: str) -> None:
    with pytest.raises(MapError, match=message):
        _make(tmp_path, _escape_small(**change))


def test_a_start_area_without_a_start_that_reaches_the_finish_is_refused(tmp_path) -> None:
    data = _escape_small(start_area=[[[0, 1], [1, 2], [2, 7], [7, 0]]])  # the whole room...
    data["walls"] = data["walls"] + [[3, 6]]  # ...with the corridor walled off
    del data["start_pose"]
    with pytest.raises(MapError, match="m.json: start_area: found no free start pose in it with a path to the finish"):
        _make(tmp_path, data)


def test_a_reset_start_past_the_finish_line_is_refused() -> None:
    env = gym.make("PicoEscape-v0", map="escape_small")
    with pytest.raises(ValueError, match="start_pose.*is past the finish line"):
        env.reset(seed=0, options={"start_pose": (2.2, 6.35, math.pi / 2)})


def test_escaping_means_going_through_the_finish_segment_not_round_it() -> None:
    from pico_gym.tasks.base import StepContext
    from pico_gym.types import Pose

    env = gym.make("PicoEscape-v0", map="escape_small")
    env.reset(seed=0)
    task = env.unwrapped.task

    def judge(before: Pose, after: Pose) -> bool:
        ctx = StepContext(before, after, (0.0, 0.0, 0.0), 0, (), 0, 0.0, 0.1, 1.0, 1.0, 1.0, np.zeros(0))
        return task.evaluate(ctx).is_success

    # Beside the corridor, across the finish line's extension (y = 6.2, x outside [1.8, 2.6]).
    assert not judge(Pose(3.5, 6.1, 0.0), Pose(3.5, 6.5, 0.0))
    assert not judge(Pose(3.5, 6.5, 0.0), Pose(3.5, 6.6, 0.0))
    # Through the segment, inside the corridor.
    assert judge(Pose(2.2, 6.1, 0.0), Pose(2.2, 6.5, 0.0))


def test_a_heightmap_block_is_solid_inside(tmp_path) -> None:
    """A start inside a black block of a heightmap is refused (its interior is not floor); one on
    the floor beside it loads."""
    grey = np.full((100, 100), 255, dtype=np.uint8)
    grey[:2, :] = grey[-2:, :] = grey[:, :2] = grey[:, -2:] = 0  # the room's walls
    grey[40:60, 40:60] = 0  # a 1 x 1 m block in the middle
    _png(tmp_path, grey, "room.png")
    data = {
        "heightmap": {"image": "room.png", "resolution": 0.05, "origin": [0.0, 0.0]},
        "finish": [[0.1, 4.0], [4.9, 4.0]],
        "start_pose": {"x": 2.5, "y": 2.5, "theta": 0.0},
    }
    with pytest.raises(MapError, match="room.json: start_pose \\(2.500, 2.500\\) is inside an obstacle"):
        _make(tmp_path, data, "room.json")
    data["start_pose"] = {"x": 1.0, "y": 2.5, "theta": 0.0}
    _make(tmp_path, data, "room.json").reset(seed=0)


def test_a_grid_over_the_cell_budget_is_refused_before_it_is_allocated() -> None:
    from pico_gym.world.grid import Grid

    with pytest.raises(ValueError, match="a grid of 100,020 x 100,020 cells at 0.01 m.*the limit is 16,000,000"):
        Grid.covering((0.0, 0.0, 1000.0, 1000.0), 0.01, margin=0.1)


def _hospital_example(tmp_path, change) -> str:
    from pico_gym.world.catalog import shipped_maps

    data = json.loads(shipped_maps()["hospital_example"].read_text())
    change(data)
    path = tmp_path / "h.json"
    path.write_text(json.dumps(data))
    return str(path)


def _start_square(cx: float, cy: float, half: float = 0.05):
    """Make the start area (points 20-23 of the example) the square of half side `half` round (cx, cy)."""

    def change(data: dict) -> None:
        for p, (sx, sy) in zip(data["points"][20:24], [(-1, -1), (1, -1), (1, 1), (-1, 1)], strict=True):
            p["x"], p["y"] = cx + sx * half, cy + sy * half

    return change


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d["walls"].append([10, 3]), "h.json: cabinets\\[0\\]: its arrival square cannot be reached"),
        (_start_square(5.8, 0.8, 0.5), "h.json: start_area: \\(5.80, 0.80\\) is not inside the walls"),
        (_start_square(0.1, 2.6), "h.json: start_area: \\(0.10, 2.60\\) is inside a wall or an obstacle"),
    ],
)
def test_a_hospital_map_with_a_bad_start_or_cut_off_cabinet_is_refused_at_load(tmp_path, change, message) -> None:
    with pytest.raises(MapError, match=message):
        gym.make("PicoHospital-v0", map_path=_hospital_example(tmp_path, change))
