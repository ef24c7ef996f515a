"""The timing harness every benchmark shares: which machine, which versions, medians of runs
interleaved round by round (so a slow spell of a shared machine hits every row alike)."""

from __future__ import annotations

import os
import platform
import statistics
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np


def machine() -> str:
    """The CPU model, logical cores and OS of this machine, in one line."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} logical cores, {platform.system()} {platform.release()}"


def versions() -> str:
    """The versions of pico-gym and what it runs on, in one line."""
    import gymnasium
    import numba
    import pymunk

    import pico_gym

    return (
        f"pico-gym {pico_gym.__version__}, Python {platform.python_version()}, numpy {np.__version__}, "
        f"gymnasium {gymnasium.__version__}, pymunk {pymunk.version}, numba {numba.__version__}"
    )


def median_rate(fn: Callable[[], int], repeats: int) -> tuple[float, list[float]]:
    """`fn` (which returns how many things it did) run `repeats` times: the median rate and all rates."""
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        count = fn()
        rates.append(count / (time.perf_counter() - t0))
    return statistics.median(rates), rates


def interleaved(runs: Sequence[Callable[[], int]], repeats: int) -> list[list[float]]:
    """Rates of each run, measured in `repeats` rounds that take every run in turn (same load)."""
    rates: list[list[float]] = [[] for _ in runs]
    for _ in range(repeats):
        for k, run in enumerate(runs):
            t0 = time.perf_counter()
            count = run()
            rates[k].append(count / (time.perf_counter() - t0))
    return rates


class EnvRun:
    """`steps` env steps of fixed random actions (a reset at every episode's end), as one timed run.

    Calling it runs the steps and returns their count; `resets` says how many episodes ended in
    the last run.
    """

    def __init__(self, steps: int, seed: int, env_id: str = "PicoEscape-v0", env: Any = None, **kwargs: Any) -> None:
        import gymnasium as gym

        self.env = gym.make(env_id, **kwargs) if env is None else env
        self.env.reset(seed=seed)
        self.env.action_space.seed(seed)
        self.actions = [self.env.action_space.sample() for _ in range(steps)]
        self.resets = 0
        for a in self.actions[:200]:  # warm-up (JIT caches, allocations)
            if any(self.env.step(a)[2:4]):
                self.env.reset()

    def __call__(self) -> int:
        env, resets = self.env, 0
        for a in self.actions:
            _, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:
                env.reset()
                resets += 1
        self.resets = resets
        return len(self.actions)
