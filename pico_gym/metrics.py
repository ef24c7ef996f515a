"""A task's own episode metrics: what its records carry beyond the common core.

Every episode record (`pico_gym.agents.evaluation.EpisodeRecord`) has a task-neutral core: the
outcome, time, bumps, path and oracle path, clearance, the agent's compute time and, for agents
that say where they believe they are, their localisation error. What only one task has (the
hospital's legs and announcements, the explore task's parking and coverage) is the task's
`EpisodeMetrics`: a small collector that watches an episode's `info` and returns a block of named
values, and says how a list of such blocks summarises and shows in tables. A task names its class
in its `TaskInfo.metrics`; this base class is the task with nothing of its own (the escape room).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

# A compare table column: its header, and the cell text from a summary's task block.
Column = tuple[str, Callable[[Any], str]]


class EpisodeMetrics:
    """The metrics of one episode of a task with none of its own (and the interface of all).

    The evaluation loop calls `reset` with the reset's info, `step` with every step's info, and
    `finish` once at the end; `progress` and `finish` give what the record carries.
    """

    #: columns `pico-gym compare` adds to its table for this task (header, cell from a `Summary`).
    columns: tuple[Column, ...] = ()
    #: figures `pico-gym compare` draws for this task, by name (see `pico_gym.agents.compare`).
    figures: tuple[str, ...] = ()

    def reset(self, env: Any, info: dict[str, Any]) -> None:
        """Start an episode (`env` is the env as made; privileged state may be read)."""

    def step(self, env: Any, info: dict[str, Any]) -> None:
        """Take in one step's info."""

    def progress(self, info: dict[str, Any]) -> float:
        """The fraction of the task done at the end (1 for a success, else 0, unless the task
        has parts)."""
        return float(bool(info["is_success"]))

    def finish(self, env: Any, info: dict[str, Any], agent: Any) -> dict[str, Any]:
        """The task's block of the record, from the last info (and the agent, for what it hands
        over, e.g. its map)."""
        return {}

    @classmethod
    def summarize(cls, records: list[Any]) -> dict[str, Any]:
        """The task's block of a summary, from the episodes' records (each with the common
        core's fields and the task's block as `metrics`)."""
        return {}

    @classmethod
    def summary_rows(cls, block: dict[str, Any]) -> list[tuple[str, str]]:
        """Rows (label, text) the text summary shows for the task's summary block."""
        return []


def median_of(values: Iterable[float | None]) -> float:
    """The median of the values that are not None (nan when none is)."""
    finite = [v for v in values if v is not None]
    return float(np.median(finite)) if finite else math.nan


def max_of(values: Iterable[float | None]) -> float:
    """The largest of the values that are not None (nan when none is)."""
    finite = [v for v in values if v is not None]
    return float(max(finite)) if finite else math.nan
