"""What each task tells the layers above it: one `TaskInfo` per env id, registered in one place
(`pico_gym/__init__.py`).

The env core knows nothing of agents or training; the benches, `compare`, the agents' registry
and `pico-gym train` know nothing of any particular task. What they need of one comes from here:
the env id and its entry points, the agent that plays it by default, its suites of episodes, the
metrics its episode records carry beyond the common core, and its `bench-env` rows. A new task
is its env file, its task module, its world module and one `register_task` call.

>>> from pico_gym.registry import task_info
>>> info = task_info("PicoEscape-v0")
>>> info.default_agent, info.suite("generated").groups[0].label
('classic', 'generated')
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from gymnasium.envs.registration import register, registry

from pico_gym.metrics import EpisodeMetrics

# The env the command line plays when none is named.
DEFAULT_ENV_ID = "PicoEscape-v0"


@dataclass(frozen=True)
class SuiteGroup:
    """One group of a suite's episodes: a label (a map's name, a setting) and its env kwargs.

    Attributes:
        label: how tables and plots name the group ("generated" for generated worlds).
        env_kwargs: what `gym.make` gets for its episodes (on top of the user's options).
        fixed_map: the shipped map whose walls the group's figures draw (None: generated worlds).
    """

    label: str
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    fixed_map: str | None = None


@dataclass(frozen=True)
class Suite:
    """A named set of episodes: groups (each with its env kwargs), played on the same seeds.

    Attributes:
        name: what `--suite` takes.
        description: one line for `--help` and the docs.
        groups: the groups, each played on every seed.
        dev_seeds: the first seed of the development split (tune here).
        test_seeds: the first seed of the test split (report here, never tune).
        episodes: episodes per group in a split (what `--split` runs).
    """

    name: str
    description: str
    groups: tuple[SuiteGroup, ...]
    dev_seeds: int = 1000
    test_seeds: int = 100_000
    episodes: int = 100

    def seeds(self, split: str) -> range:
        """The seeds of a split ("dev" or "test")."""
        if split not in ("dev", "test"):
            raise ValueError(f"a split is 'dev' or 'test', got {split!r}")
        start = self.dev_seeds if split == "dev" else self.test_seeds
        return range(start, start + self.episodes)


@dataclass(frozen=True)
class BenchRow:
    """A `pico-gym bench-env --env ID` row: a label and the env kwargs it steps with."""

    label: str
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class TaskInfo:
    """What the layers above the env core need to know of one task.

    Attributes:
        env_id: the id users type.
        entry_point: "module:Class" of the env.
        vector_entry_point: "module:function" of its vector env (None: gymnasium's sync one).
        worlds: what one generated world is called in tables ("rooms", "hospitals").
        map_prefix: the shipped maps whose name starts with this belong to the task.
        map_kwargs: env kwargs that go with a shipped map in a suite (e.g. a drawn start).
        default_agent: the agent `pico-gym run` and `bench` play by default.
        metrics: "module:Class" of the task's `EpisodeMetrics` (what its records carry beyond the
            common core, and how its summaries and tables show it).
        bench_rows: `bench-env --env` rows (empty: the escape env's own benchmark).
        lrf_maps: shipped maps whose scan rate `bench-env --env` measures.
        walls_rows: the worlds `bench-walls --env` drives adversarially in (empty: the escape
            rooms and shipped escape maps).
        suites: the task's own suites; "generated", "maps" and "all" every task has (a suite of
            the task's own by one of those names replaces it, e.g. to fix its seed splits).
    """

    env_id: str
    entry_point: str
    vector_entry_point: str | None = None
    worlds: str = "worlds"
    map_prefix: str = ""
    map_kwargs: Mapping[str, Any] = field(default_factory=dict)
    default_agent: str = "classic"
    metrics: str = "pico_gym.metrics:EpisodeMetrics"
    bench_rows: tuple[BenchRow, ...] = ()
    lrf_maps: tuple[str, ...] = ()
    walls_rows: tuple[BenchRow, ...] = ()
    suites: tuple[Suite, ...] = ()

    def shipped_maps(self) -> list[str]:
        """The names of the shipped maps of this task, sorted."""
        from pico_gym.world.catalog import shipped_maps

        if not self.map_prefix:
            return []
        return sorted(name for name in shipped_maps() if name.startswith(self.map_prefix))

    def suite(self, name: str) -> Suite:
        """A suite by name: the task's own, or "generated" / "maps" / "all".

        Raises:
            ValueError: for a name the task has no suite of, listing those it has.
        """
        for suite in self.suites:
            if suite.name == name:
                return suite
        if name == "generated":
            return Suite("generated", f"generated {self.worlds}", (SuiteGroup("generated"),))
        if name in ("maps", "all"):
            maps = tuple(SuiteGroup(m, {"map": m, **self.map_kwargs}, m) for m in self.shipped_maps())
            if name == "maps":
                return Suite("maps", f"{self.env_id}'s shipped maps", maps)
            return Suite("all", f"generated {self.worlds} and the shipped maps", (SuiteGroup("generated"), *maps))
        raise ValueError(f"{self.env_id} has no suite {name!r}; its suites: {', '.join(self.suite_names())}")

    def suite_names(self) -> tuple[str, ...]:
        own = tuple(s.name for s in self.suites)
        return (*own, *(n for n in ("generated", "maps", "all") if n not in own))

    def load_metrics(self) -> type[EpisodeMetrics]:
        """The task's metrics class (imported on first use)."""
        return load_entry(self.metrics)


_TASKS: dict[str, TaskInfo] = {}
TASKS: Mapping[str, TaskInfo] = MappingProxyType(_TASKS)


def register_task(info: TaskInfo) -> None:
    """Register a task: its env id with Gymnasium (once; a second call does nothing) and its info."""
    if info.env_id not in registry:
        if info.vector_entry_point:
            register(id=info.env_id, entry_point=info.entry_point, vector_entry_point=info.vector_entry_point)
        else:
            register(id=info.env_id, entry_point=info.entry_point)
    _TASKS[info.env_id] = info


def unregister_task(env_id: str) -> None:
    """Remove a task registered by `register_task` (and its Gymnasium id): for tests."""
    _TASKS.pop(env_id, None)
    registry.pop(env_id, None)


def task_info(env_id: str) -> TaskInfo:
    """The registered info of an env id.

    Raises:
        ValueError: for an id no task registered, listing those registered.
    """
    try:
        return _TASKS[env_id]
    except KeyError:
        raise ValueError(f"no pico-gym task is registered as {env_id!r}; tasks: {', '.join(_TASKS)}") from None


def env_id_of(env: Any) -> str:
    """The id an env was made as (its spec's), or its class name for an env made directly."""
    spec = env.unwrapped.spec
    return spec.id if spec is not None else type(env.unwrapped).__name__


def load_entry(entry: str) -> Any:
    """The object a "module:name" string names."""
    module, _, name = entry.partition(":")
    return getattr(importlib.import_module(module), name)
