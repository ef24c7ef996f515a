"""The course simulator's config file (emc_simulator `--config`), key by key.

`gym.make(ID, map=..., sim_config="hospitalconfig.json")` reads one of the course's config files as
it is. Every key the simulator knows, on master and on the 2020 and 2021 branches
(`src/jsonconfig.h`), and what pico-gym does with it (the table is in maps/README.md):

- `objects`: movers, placed from the simulator's frame (the map's `simulator_frame`);
- `uncertain_odom`: false (master's default when absent) exact odometry, true the course's noise;
- `provide_internal_pose` (master: on when absent): `obs["internal_pose"]`, the true pose
  (privileged, as the course offered it);
- `disable_speedcap`: the caps raised to 1.0 m/s and 2.4 rad/s, with 5 ms physics sub-steps;
- `initial_pose` (master), `pico_pose` (2021): the start pose; `taco_pose`: the second robot's;
- `enable_taco`: two robots (`pico_gym.parallel_env`); a single-robot env refuses it;
- `show_full_map`, `use_pyro`: accepted, no meaning headless, listed in `info["sim_config"]`.

Any other key is refused, naming it. Without `initial_pose` / `pico_pose` the master simulator
spawns PICO at the map's centre, heading +90 deg, and the 2021 one at the frame's origin; pico-gym
keeps the map's own start then (its `start_area` or `start_pose`), or, for a map that has none,
takes the master simulator's spawn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from pico_gym.jsonfile import JsonError, read_json
from pico_gym.types import Pose
from pico_gym.world.map import Map, MapError, check_movers, check_start_pose
from pico_gym.world.movers import MoverRecord, mover_record

KEYS = (
    "objects",
    "uncertain_odom",
    "provide_internal_pose",
    "disable_speedcap",
    "initial_pose",
    "pico_pose",
    "taco_pose",
    "enable_taco",
    "show_full_map",
    "use_pyro",
)
IGNORED = ("show_full_map", "use_pyro")
MAX_CONFIG_BYTES = 1024 * 1024
MAX_OBJECTS = 100
# disable_speedcap: the highest caps the physics keeps solid with 5 ms sub-steps.
UNCAPPED_SPEED_MPS, UNCAPPED_TURN_RATE_RADPS, UNCAPPED_SUBSTEP_S = 1.0, 2.4, 0.005


class SimConfigError(ValueError):
    """A course simulator config that cannot be read (the message names the file and the key)."""


@dataclass(frozen=True)
class SimConfig:
    """A course simulator config, read.

    Attributes:
        source: the file.
        objects: the moving objects, in the simulator's frame.
        uncertain_odom: wheel noise on (absent: off, as the master simulator).
        provide_internal_pose: the true pose offered to the robot (absent: on, as master).
        disable_speedcap: no speed cap.
        enable_taco: a second robot.
        pico_pose: PICO's spawn pose (`initial_pose` or `pico_pose`), simulator frame, or None.
        taco_pose: the second robot's spawn pose, or None.
        ignored: the keys present that a headless simulator has no use for.
    """

    source: Path
    objects: tuple[MoverRecord, ...] = ()
    uncertain_odom: bool = False
    provide_internal_pose: bool = True
    disable_speedcap: bool = False
    enable_taco: bool = False
    pico_pose: Pose | None = None
    taco_pose: Pose | None = None
    ignored: tuple[str, ...] = ()

    def env_options(self) -> dict[str, Any]:
        """The `gym.make` options the config stands for (an option the user gives wins)."""
        options: dict[str, Any] = {"internal_pose": self.provide_internal_pose}
        if not self.uncertain_odom:
            options.update(wheel_noise=0.0, slip_std=0.0)
        if self.disable_speedcap:
            options.update(
                max_speed_mps=UNCAPPED_SPEED_MPS,
                max_turn_rate_radps=UNCAPPED_TURN_RATE_RADPS,
                substep_s=UNCAPPED_SUBSTEP_S,
            )
        return options

    def report(self) -> dict[str, Any]:
        """What `info["sim_config"]` says at reset: the file and the keys it ignored."""
        return {"file": str(self.source), "ignored": self.ignored}


def _fail(path: Path, key: str, message: str) -> SimConfigError:
    return SimConfigError(f"{path}: {key}: {message}")


def _flag(data: dict[str, Any], key: str, default: bool, path: Path) -> bool:
    value = data.get(key, default)
    if not isinstance(value, bool):
        raise _fail(path, key, f"expected true or false, got {value!r}")
    return value


def _pose(data: dict[str, Any], key: str, path: Path) -> Pose | None:
    if key not in data:
        return None
    value = data[key]
    if not (isinstance(value, list) and len(value) == 3):
        raise _fail(path, key, f"expected [x, y, theta], got {value!r}")
    numbers = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or abs(v) > 1e4:
            raise _fail(path, key, f"expected three finite numbers (metres, radians), got {value!r}")
        numbers.append(float(v))
    return Pose(numbers[0], numbers[1], math.remainder(numbers[2], 2 * math.pi))


def read_sim_config(path: str | Path) -> SimConfig:
    """Read a course simulator config file (JSON).

    Raises:
        SimConfigError: naming the file and the key: not JSON, not an object, an unknown key, a
            value of the wrong type, a bad moving object, both `initial_pose` and `pico_pose`.
    """
    if not isinstance(path, (str, Path)):
        raise SimConfigError(f"sim_config= takes a config file's path, got {type(path).__name__} {path!r:.60}")
    path = Path(path)
    if path.is_file() and path.stat().st_size > MAX_CONFIG_BYTES:
        raise SimConfigError(f"{path}: {path.stat().st_size:,} bytes; a simulator config is a few hundred")
    try:
        data = read_json(path)
    except JsonError as error:
        raise SimConfigError(str(error)) from None
    if not isinstance(data, dict):
        raise SimConfigError(f"{path}: a simulator config is a JSON object of {', '.join(KEYS)}")
    unknown = sorted(k for k in data if k not in KEYS)
    if unknown:
        raise _fail(path, unknown[0], f"not a key of the course simulator's config; the keys are {', '.join(KEYS)}")
    if "initial_pose" in data and "pico_pose" in data:
        raise _fail(path, "pico_pose", "give initial_pose (master) or pico_pose (2021), not both")
    objects = data.get("objects", [])
    if not isinstance(objects, list) or len(objects) > MAX_OBJECTS:
        raise _fail(path, "objects", f"expected a list of at most {MAX_OBJECTS} moving objects, got {objects!r:.80}")
    records = []
    for k, raw in enumerate(objects):
        try:
            records.append(mover_record(raw, f"objects[{k}]"))
        except ValueError as error:
            raise SimConfigError(f"{path}: {error}") from None
    for key in IGNORED:
        _flag(data, key, False, path)  # (checked though unused: a typo'd value is still a mistake)
    return SimConfig(
        source=path,
        objects=tuple(records),
        uncertain_odom=_flag(data, "uncertain_odom", False, path),
        provide_internal_pose=_flag(data, "provide_internal_pose", True, path),
        disable_speedcap=_flag(data, "disable_speedcap", False, path),
        enable_taco=_flag(data, "enable_taco", False, path),
        pico_pose=_pose(data, "initial_pose", path) or _pose(data, "pico_pose", path),
        taco_pose=_pose(data, "taco_pose", path),
        ignored=tuple(k for k in IGNORED if k in data),
    )


def with_sim_config(world: Map | None, config: SimConfig) -> Map:
    """The map as the config sets it up: its movers the config's `objects` (none if it has none),
    its start PICO's spawn pose (`initial_pose` / `pico_pose`), both placed from the simulator's
    frame (the map's `simulator_frame`); a map without a start of its own and no spawn pose gets
    the master simulator's: the map's centre, heading +90 deg.

    Raises:
        ValueError: without a map (the config's poses are in a map's frame).
    """
    if world is None:
        raise ValueError(
            f"{config.source}: a simulator config places its objects and robots in a map's frame: give map= "
            "or map_path= with sim_config="
        )

    def place(p: tuple[float, float, float]) -> tuple[float, float, float]:
        return tuple(world.from_simulator(p))  # type: ignore[return-value]

    movers = tuple(
        MoverRecord(m.length, m.width, m.trigger_radius, m.velocity, place(m.init_pose), place(m.final_pose), m.repeat)
        for m in config.objects
    )
    start, area = world.start_pose, world.start_area
    if config.pico_pose is not None:
        start, area = world.from_simulator(config.pico_pose), ()
    elif start is None and not area:
        x0, y0, x1, y1 = world.bounds
        start = Pose(0.5 * (x1 + x0), 0.5 * (y1 + y0), math.remainder(1.57 + world.simulator_frame[2], 2 * math.pi))
    placed = replace(world, movers=movers, start_pose=start, start_area=area)
    try:
        check_movers(placed, config.source, "objects")
    except MapError as error:
        raise ValueError(str(error)) from None
    if start is not None and start != world.start_pose:
        key = "initial_pose / pico_pose" if config.pico_pose is not None else "(no spawn pose: the map's centre)"
        try:
            check_start_pose(placed, config.source)
        except MapError as error:
            raise ValueError(f"{config.source}: {key}: {str(error).split(': ', 2)[-1]}") from None
    return placed
