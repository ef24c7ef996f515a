"""pico-gym: the Embedded Motion Control course's PICO challenges as Gymnasium environments.

Importing the package registers the environment ids (also registered through the
`gymnasium.envs` entry point, so `gym.make("PicoEscape-v0")` works without the import). Each id
comes with what the layers above the env core need of its task (`pico_gym.registry.TaskInfo`).
"""

from __future__ import annotations

from pico_gym.registry import TASKS, BenchRow, Suite, SuiteGroup, TaskInfo, register_task

__version__ = "0.1.0"

_BUSY_2019 = {"map": "hospital_2019", "n_boxes": (2, 2), "n_movers": (1, 1), "n_closed_doors": (1, 1)}
_DOOR = {"n_closed_doors": (1, 1)}
_CROWDED = {"n_boxes": (2, 2), "n_movers": (2, 2), **_DOOR}


def _family(name: str, description: str, dev: int, test: int) -> Suite:
    """A suite of one generator family (`gym.make(..., family=name)`), its seed splits fixed."""
    return Suite(name, description, (SuiteGroup(name, {"family": name}),), dev_seeds=dev, test_seeds=test)


# Seed splits of the benchmark protocol (docs/benchmarks.md): dev seeds to tune on, test seeds to
# report on, never overlapping (and below PPO's evaluation seeds, 900,000.., and training's, 1e6..).

BUILTIN_TASKS = (
    TaskInfo(
        "PicoEscape-v0",
        "pico_gym.envs.escape_env:PicoEscapeEnv",
        "pico_gym.vector:escape_vector_env",
        worlds="rooms",
        map_prefix="escape",
        map_kwargs={"sample_start": True},
        suites=(
            Suite("generated", "generated rooms", (SuiteGroup("generated"),), dev_seeds=1000, test_seeds=8000),
            _family("cluttered", "rooms with 3-5 boxes", 510_000, 610_000),
            _family("narrow", "corridors 0.5-0.6 m wide", 520_000, 620_000),
        ),
    ),
    TaskInfo(
        "PicoHospital-v0",
        "pico_gym.envs.hospital_env:PicoHospitalEnv",
        "pico_gym.vector:hospital_vector_env",
        worlds="hospitals",
        map_prefix="hospital",
        metrics="pico_gym.tasks.hospital:HospitalMetrics",
        bench_rows=(
            BenchRow(
                "hospital_2019, 2 movers, 2 boxes, 0-1 closed doors",
                {"map": "hospital_2019", "n_movers": (2, 2), "n_boxes": (2, 2)},
            ),
            BenchRow("hospital_2019, defaults", {"map": "hospital_2019"}),
            BenchRow("hospital_2021 (its 2 movers, 0-2 boxes)", {"map": "hospital_2021"}),
            BenchRow("generated hospitals, defaults"),
        ),  # fmt: skip
        lrf_maps=("hospital_2019", "hospital_2021"),
        walls_rows=(
            BenchRow("hospital_2019, 2 people, 2 boxes, a closed door", {"map": "hospital_2019", **_CROWDED}),
            BenchRow("hospital_2021, its cart and person, 2 boxes", {"map": "hospital_2021", "n_boxes": (2, 2)}),
            BenchRow("generated hospitals, 2-3 people, 2-3 boxes, a closed door", {"family": "crowded", **_DOOR}),
            BenchRow("generated narrow hospitals, people walking towards the start", {"family": "narrow"}),
        ),
        suites=(
            Suite("generated", "generated hospitals", (SuiteGroup("generated"),), dev_seeds=200, test_seeds=73_200),
            _family(
                "narrow", "hallway 1.0-1.2 m, doors 0.55-0.7 m, 1-2 people walking towards the start", 530_000, 630_000
            ),  # fmt: skip
            _family("crowded", "2-3 people and 2-3 boxes", 540_000, 640_000),
            Suite(
                "hospital",
                "generated hospitals, hospital_2019 with a closed door, 2 boxes and a person, and hospital_2021",
                (
                    SuiteGroup("generated"),
                    SuiteGroup("hospital_2019 busy", _BUSY_2019, "hospital_2019"),
                    SuiteGroup("hospital_2021", {"map": "hospital_2021"}, "hospital_2021"),
                ),
            ),
        ),
    ),
    TaskInfo(
        "PicoExplore-v0",
        "pico_gym.envs.explore_env:PicoExploreEnv",
        "pico_gym.vector:explore_vector_env",
        worlds="buildings",
        map_prefix="explore",
        metrics="pico_gym.tasks.explore:ExploreMetrics",
        bench_rows=(
            BenchRow("generated 2018 hospitals, defaults"),
            BenchRow("generated 2018 hospitals, collision=continue", {"collision": "continue"}),
        ),
        walls_rows=(
            BenchRow("generated 2018 hospitals"),
            BenchRow("comb buildings", {"family": "comb"}),
            BenchRow("nested buildings", {"family": "nested"}),
        ),
        suites=(
            Suite(
                "generated", "generated 2018 hospitals", (SuiteGroup("generated"),), dev_seeds=1000, test_seeds=74_000
            ),  # fmt: skip
            _family("comb", "rooms off a side corridor, like the teeth of a comb", 550_000, 650_000),
            _family("deep-L", "an L hallway with its rooms at the far end of its far leg", 560_000, 660_000),
            _family("nested", "rooms in rows behind one another, one reached through two others", 570_000, 670_000),
        ),
    ),
)


def register_envs() -> None:
    """Register pico-gym's ids with Gymnasium (each with its vector env, `pico_gym.vector`) and
    their tasks' info (`pico_gym.registry`); a second call does nothing."""
    for info in BUILTIN_TASKS:
        register_task(info)


register_envs()
# The shipped envs' ids (`pico_gym.registry.TASKS` holds every registered task).
ENV_IDS = tuple(info.env_id for info in BUILTIN_TASKS)


def parallel_env(env_id: str = "PicoHospital-v0", **kwargs: object) -> object:
    """Two robots in one world, a PettingZoo ParallelEnv (`pico_gym.multi`; the `multi` extra)."""
    from pico_gym.multi import parallel_env as make

    return make(env_id, **kwargs)


__all__ = ["ENV_IDS", "TASKS", "parallel_env", "register_envs"]
