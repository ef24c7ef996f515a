"""Every file format pico-gym reads, fuzzed key by key: each key of each format missing, of the
wrong type, NaN, infinite, huge, negative, empty and nested. A case either loads (the key is
optional, or the value is one it takes) or is refused with the format's own error naming the file;
never another exception, a hang or a crash."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import gymnasium as gym
import pytest

import pico_gym  # noqa: F401
from pico_gym.world.map import Map, MapError, load_map
from pico_gym.world.sim_config import SimConfig, SimConfigError, read_sim_config

DATA = Path(__file__).parent / "data" / "emc_simulator"

MISSING = object()
MUTATIONS: dict[str, Any] = {
    "missing": MISSING,
    "string": "x",
    "dict": {"a": 1},
    "bool": True,
    "nan": math.nan,
    "inf": math.inf,
    "huge": 1e300,
    "negative": -5,
    "empty list": [],
    "nested": [[[[1]]]],
    "null": None,
}


def _mutated(base: dict[str, Any], key: str, value: Any) -> dict[str, Any]:
    data = dict(base)
    if value is MISSING:
        data.pop(key, None)
    else:
        data[key] = value
    return data


def _write(path: Path, data: Any) -> Path:
    # NaN and Infinity written as JSON's non-standard literals: the reader must refuse them
    path.write_text(json.dumps(data, allow_nan=True))
    return path


MAP = {
    "version": 1,
    "name": "room",
    "points": [[0, 0], [4, 0], [4, 3], [0, 3], [1, 1], [1.4, 1], [1.4, 1.2], [1, 1.2]],
    "walls": [[0, 1], [1, 2], [2, 3], [3, 0]],
    "cabinets": [[[4, 5], [5, 6], [6, 7], [7, 4]]],
    "start_area": [[[4, 5], [5, 6], [6, 7], [7, 4]]],
    "doors": [],
    "finish": [[0, 0], [4, 0]],
    "start_pose": {"x": 2.0, "y": 2.0, "theta": 0.0},
    "obstacles": [{"polygon": [[0.5, 2.3], [0.7, 2.3], [0.7, 2.5]]}],
    "movers": [
        {
            "length": 0.2,
            "width": 0.4,
            "trigger_radius": 1,
            "velocity": 0.5,
            "init_pose": [3.0, 1.0, 0.0],
            "final_pose": [3.0, 2.5, 0.0],
            "repeat": True,
        }
    ],
    "simulator_frame": [0, 0, 0],
    "parking_wall": [[0, 0], [0, 3]],
    "object": [[2, 2], [2.3, 2], [2.3, 2.3]],
}
MOVER = MAP["movers"][0]
SIM = {
    "uncertain_odom": True,
    "show_full_map": True,
    "provide_internal_pose": False,
    "disable_speedcap": False,
    "enable_taco": False,
    "use_pyro": True,
    "initial_pose": [2.0, 2.0, 0.0],
    "taco_pose": [2.5, 2.0, 0.0],
    "objects": [MOVER],
}
YAML = {
    "image": "m.pgm",
    "resolution": 0.05,
    "origin": [0.0, 0.0, 0.0],
    "occupied_thresh": 0.65,
    "free_thresh": 0.196,
    "negate": 0,
    "mode": "trinary",
}
CASES = [(k, m) for k in MAP for m in MUTATIONS]
MOVER_CASES = [(k, m) for k in MOVER for m in MUTATIONS]
SIM_CASES = [(k, m) for k in SIM for m in MUTATIONS]
YAML_CASES = [(k, m) for k in YAML for m in MUTATIONS]


def _loads_or_refuses(call: Any, error: type[Exception], file_name: str) -> str:
    """ "refused" (with the format's error naming the file) or "loaded" (a map or config); any
    other exception fails the test."""
    try:
        value = call()
    except error as e:
        assert file_name in str(e), f"the message does not name the file: {e}"
        return "refused"
    assert isinstance(value, (Map, SimConfig)), f"loaded as {type(value).__name__}"
    return "loaded"


@pytest.mark.parametrize(("key", "mutation"), CASES)
def test_map_json_keys(tmp_path: Path, key: str, mutation: str) -> None:
    path = _write(tmp_path / "fz.json", _mutated(MAP, key, MUTATIONS[mutation]))
    assert _loads_or_refuses(lambda: load_map(path), MapError, "fz.json") in ("loaded", "refused")


@pytest.mark.parametrize(("key", "mutation"), MOVER_CASES)
def test_mover_record_keys(tmp_path: Path, key: str, mutation: str) -> None:
    data = dict(MAP, movers=[_mutated(MOVER, key, MUTATIONS[mutation])])
    path = _write(tmp_path / "fz.json", data)
    assert _loads_or_refuses(lambda: load_map(path), MapError, "fz.json") in ("loaded", "refused")


@pytest.mark.parametrize(("key", "mutation"), SIM_CASES)
def test_simulator_config_keys(tmp_path: Path, key: str, mutation: str) -> None:
    path = _write(tmp_path / "sim.json", _mutated(SIM, key, MUTATIONS[mutation]))
    assert _loads_or_refuses(lambda: read_sim_config(path), SimConfigError, "sim.json") in ("loaded", "refused")


@pytest.mark.parametrize(("key", "mutation"), YAML_CASES)
def test_map_server_yaml_keys(tmp_path: Path, key: str, mutation: str) -> None:
    import yaml

    (tmp_path / "m.pgm").write_bytes((DATA / "heightmap_maze_legacy.pgm").read_bytes())
    value = MUTATIONS[mutation]
    data = _mutated(YAML, key, value)
    text = yaml.safe_dump({k: (float("nan") if isinstance(v, float) and math.isnan(v) else v) for k, v in data.items()})
    (tmp_path / "fz.yaml").write_text(text)
    assert _loads_or_refuses(lambda: load_map(tmp_path / "fz.yaml"), MapError, "fz.yaml") in ("loaded", "refused")


@pytest.mark.parametrize(
    "text",
    [
        "",
        "{",
        "[]",
        "null",
        '"a string"',
        "1e999",
        "[" * 5000 + "]" * 5000,
        '{"points": [[1' + "0" * 400 + ", 0]]}",
        '{"walls": NaN}',
        "\x00\x01\x02",
    ],
    ids=["empty", "cut", "list", "null", "string", "overflow", "deep", "huge int", "NaN", "binary"],
)
def test_broken_json_files(tmp_path: Path, text: str) -> None:
    (tmp_path / "fz.json").write_text(text)
    (tmp_path / "sim.json").write_text(text)
    # A broken file never loads.
    assert _loads_or_refuses(lambda: load_map(tmp_path / "fz.json"), MapError, "fz.json") == "refused"
    assert _loads_or_refuses(lambda: read_sim_config(tmp_path / "sim.json"), SimConfigError, "sim.json") == "refused"


@pytest.mark.parametrize(
    "data",
    [
        b"",
        b"P5\n",
        b"P5\n10 10\n255\n",
        b"P5\nabc 10\n255\n" + bytes(100),
        b"P2\n2 2\n255\n0 1 2\n",
        b"\x89PNG\r\n\x1a\n",
    ],
    ids=["empty", "header only", "no pixels", "text in header", "short P2", "png header only"],
)
def test_broken_images(tmp_path: Path, data: bytes) -> None:
    (tmp_path / "fz.pgm").write_bytes(data)
    assert _loads_or_refuses(lambda: load_map(tmp_path / "fz.pgm"), MapError, "fz.pgm") == "refused"


@pytest.mark.parametrize("env_id", ["PicoEscape-v0", "PicoHospital-v0", "PicoExplore-v0"])
@pytest.mark.parametrize("mutation", list(MUTATIONS))
def test_every_reset_option_of_every_env(env_id: str, mutation: str) -> None:
    env = gym.make(env_id)
    env.reset(seed=0)
    keys = {"start_pose"} | set(env.unwrapped.task.option_keys)
    value = MUTATIONS[mutation]
    for key in sorted(keys):
        if value is MISSING:
            continue
        try:
            env.reset(seed=0, options={key: value})
        except (ValueError, TypeError) as e:
            assert key in str(e) or "option" in str(e), f"{key}: {e}"


def test_the_fuzz_covers_every_key_of_every_format() -> None:
    assert len(CASES) + len(MOVER_CASES) + len(SIM_CASES) + len(YAML_CASES) >= 400


def test_the_unmutated_files_load(tmp_path: Path) -> None:
    """(So that each mutation above is what a refusal is about.)"""
    assert load_map(_write(tmp_path / "fz.json", MAP)).name == "room"
    assert read_sim_config(_write(tmp_path / "sim.json", SIM)).taco_pose is not None
