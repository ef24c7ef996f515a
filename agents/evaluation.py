"""Running agents on seeded episodes and summarising the results (shared by bench and compare).

An episode is fixed by its seed (room, start pose, sensor noise all come from the env's seeded
generator), so two agents run on the same seeds face the same rooms. Metrics follow the embodied
navigation literature: SPL (Anderson et al., 2018) = success x oracle path / max(path, oracle
path); SCT (Yokoyama et al., 2021) = success x oracle time / max(time, oracle time), with oracle
time = oracle path length / 0.5 m/s.
"""

from __future__ import annotations

import dataclasses
import math
import os
import statistics
import time
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

import pico_gym  # noqa: F401  (registers the env ids)
from pico_gym.agents import make_agent

# The competition's speed limit: the oracle drives its path at this speed [m/s].
ORACLE_SPEED_MPS = 0.5


@dataclass(frozen=True)
class EpisodeRecord:
    """One episode's outcome."""

    agent: str
    seed: int
    map: str
    success: bool
    termination_reason: str
    time_s: float
    bumps: int
    path_length: float
    shortest_path_length: float
    min_clearance: float
    act_ms: float

    @property
    def spl(self) -> float:
        return float(self.success) * self.shortest_path_length / max(self.path_length, self.shortest_path_length)

    @property
    def sct(self) -> float:
        oracle = self.shortest_path_length / ORACLE_SPEED_MPS
        return float(self.success) * oracle / max(self.time_s, oracle)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def run_episode(
    env: gym.Env,
    agent: Any,
    seed: int,
    agent_name: str = "",
    on_step: Callable[[], None] | None = None,
) -> EpisodeRecord:
    """Play one seeded episode to its end."""
    obs, info = env.reset(seed=seed)
    agent.reset(obs, info)
    times = []
    while True:
        t0 = time.perf_counter()
        action = agent.act(obs)
        times.append(time.perf_counter() - t0)
        obs, _, terminated, truncated, info = env.step(action)
        if on_step is not None:
            on_step()
        if terminated or truncated:
            break
    return EpisodeRecord(
        agent=agent_name or getattr(agent, "name", "agent"),
        seed=seed,
        map=env.unwrapped.episode.map.name,
        success=bool(info["is_success"]),
        termination_reason=str(info["termination_reason"]),
        time_s=round(float(info["sim_time"]), 6),
        bumps=int(info["bumps"]),
        path_length=float(info["path_length"]),
        shortest_path_length=float(info["shortest_path_length"]),
        min_clearance=float(info["min_clearance"]),
        act_ms=1e3 * statistics.median(times),
    )


DEFAULT_ENV_ID = "PicoEscape-v0"


def _worker(job: tuple[str, str, dict[str, Any], dict[str, Any], list[int]]) -> list[EpisodeRecord]:
    env_id, agent_name, env_kwargs, agent_kwargs, seeds = job
    env = gym.make(env_id, **env_kwargs)
    agent = make_agent(agent_name, env, **agent_kwargs)
    return [run_episode(env, agent, seed, agent_name) for seed in seeds]


def run_episodes(
    agent_name: str,
    seeds: Iterable[int],
    env_kwargs: dict[str, Any] | None = None,
    agent_kwargs: dict[str, Any] | None = None,
    workers: int | None = None,
    progress: Callable[[int], None] | None = None,
    env_id: str = DEFAULT_ENV_ID,
    ray_address: str | None = None,
) -> list[EpisodeRecord]:
    """Run an agent on seeded episodes of `env_id`; records in seed order.

    Episodes run in a local process pool of `workers` (default: one per core), or, with
    `ray_address` ("auto" for the cluster this machine belongs to, "ray://HEAD:10001", or "local"
    to start Ray here), as Ray tasks spread over a cluster. An episode is fixed by its seed, so
    the records are the same either way (but for the measured compute time).
    """
    seeds = list(seeds)
    env_kwargs = env_kwargs or {}
    agent_kwargs = agent_kwargs or {}
    workers = max(1, min(workers or os.cpu_count() or 1, len(seeds)))
    # Small chunks keep the cores busy and the progress bar moving.
    chunk = max(1, min(10, len(seeds) // (4 * workers) or 1))
    jobs = [(env_id, agent_name, env_kwargs, agent_kwargs, seeds[i : i + chunk]) for i in range(0, len(seeds), chunk)]
    records: list[EpisodeRecord] = []
    if ray_address is not None:
        return sorted(_run_on_ray(jobs, ray_address, progress), key=lambda r: r.seed)
    if workers == 1:
        for job in jobs:
            records += _worker(job)
            if progress:
                progress(len(job[4]))
    else:
        with ProcessPoolExecutor(workers) as pool:
            for result in pool.map(_worker, jobs):
                records += result
                if progress:
                    progress(len(result))
    return sorted(records, key=lambda r: r.seed)


def _run_on_ray(
    jobs: list[tuple[str, str, dict[str, Any], dict[str, Any], list[int]]],
    address: str,
    progress: Callable[[int], None] | None,
) -> list[EpisodeRecord]:
    """The jobs as Ray tasks (one per chunk of seeds), gathered as they finish."""
    try:
        import ray
    except ImportError as exc:
        from gymnasium.error import DependencyNotInstalled

        raise DependencyNotInstalled("--ray needs Ray: pip install 'pico-gym[ray]'") from exc
    if not ray.is_initialized():
        ray.init(address=None if address == "local" else address)
    task = ray.remote(_worker_as_dicts)
    pending = {task.remote(job): len(job[4]) for job in jobs}
    records: list[EpisodeRecord] = []
    while pending:
        done, _ = ray.wait(list(pending), num_returns=1)
        for ref in done:
            records += [EpisodeRecord(**d) for d in ray.get(ref)]
            n = pending.pop(ref)
            if progress:
                progress(n)
    return records


def _worker_as_dicts(job: tuple[str, str, dict[str, Any], dict[str, Any], list[int]]) -> list[dict[str, Any]]:
    """`_worker` returning plain dicts: what crosses a cluster does not depend on pico-gym's classes."""
    return [r.to_dict() for r in _worker(job)]


@dataclass(frozen=True)
class Summary:
    """Aggregate figures over episodes."""

    episodes: int
    success_rate: float
    bump_rate: float
    idle: int
    timeout: int
    time_median_s: float
    time_p90_s: float
    spl: float
    sct_mean: float
    sct_median: float
    min_clearance_mean: float
    act_ms_median: float

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def summarize(records: list[EpisodeRecord]) -> Summary:
    """Success and bump rates (fraction of episodes), times of the successful episodes, SPL, SCT."""
    n = len(records)
    times = [r.time_s for r in records if r.success]
    return Summary(
        episodes=n,
        success_rate=sum(r.success for r in records) / n,
        bump_rate=sum(r.bumps > 0 for r in records) / n,
        idle=sum(r.termination_reason == "idle" for r in records),
        timeout=sum(r.termination_reason == "timeout" for r in records),
        time_median_s=float(np.median(times)) if times else math.nan,
        time_p90_s=float(np.percentile(times, 90)) if times else math.nan,
        spl=float(np.mean([r.spl for r in records])),
        sct_mean=float(np.mean([r.sct for r in records])),
        sct_median=float(np.median([r.sct for r in records])),
        min_clearance_mean=float(np.mean([r.min_clearance for r in records])),
        act_ms_median=float(np.median([r.act_ms for r in records])),
    )


def format_summary(name: str, s: Summary) -> str:
    """A small text table of a summary."""
    rows = [
        ("episodes", f"{s.episodes}"),
        ("success rate", f"{100 * s.success_rate:.1f} %"),
        ("bump rate", f"{100 * s.bump_rate:.1f} %"),
        ("idle / timeout", f"{s.idle} / {s.timeout}"),
        ("time median / p90 (successes)", f"{s.time_median_s:.1f} s / {s.time_p90_s:.1f} s"),
        ("SPL", f"{s.spl:.3f}"),
        ("SCT mean / median", f"{s.sct_mean:.3f} / {s.sct_median:.3f}"),
        ("mean min clearance", f"{s.min_clearance_mean:.3f} m"),
        ("act() compute, median", f"{s.act_ms_median:.2f} ms/step"),
    ]
    width = max(len(k) for k, _ in rows)
    return "\n".join([f"agent: {name}"] + [f"  {k:<{width}}  {v}" for k, v in rows])
