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
from pico_gym.envs.base import pico_env
from pico_gym.metrics import max_of, median_of
from pico_gym.registry import DEFAULT_ENV_ID, env_id_of, task_info

# The competition's speed limit: the oracle drives its path at this speed [m/s].
ORACLE_SPEED_MPS = 0.5


@dataclass(frozen=True)
class EpisodeRecord:
    """One episode's outcome: the common core, and the task's own block (`metrics`: what the
    task's `EpisodeMetrics` collects, e.g. the hospital's legs, the explore task's parking)."""

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
    progress: float = math.nan  # fraction of the task done (the hospital: of the cabinet order)
    bumps_by_kind: dict[str, int] = dataclasses.field(default_factory=dict)
    # None for agents without belief() (None, not nan: records compare equal and write valid JSON)
    localise_time_s: float | None = None  # when the agent's belief() first gave a pose
    localise_error_m: float | None = None  # its error then (position) ...
    localise_error_deg: float | None = None  # ... and heading
    max_localise_error_m: float | None = None  # the worst position error of the belief over the run
    near_mover_s: float = 0.0  # time the robot's centre spent within 0.5 m of a mover's box
    bump_xy: list[tuple[float, float]] = dataclasses.field(default_factory=list)  # where bumps began (x, y)
    metrics: dict[str, Any] = dataclasses.field(default_factory=dict)  # the task's own block

    @property
    def spl(self) -> float:
        return float(self.success) * self.shortest_path_length / max(self.path_length, self.shortest_path_length)

    @property
    def sct(self) -> float:
        oracle = self.shortest_path_length / ORACLE_SPEED_MPS
        return float(self.success) * oracle / max(self.time_s, oracle)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @staticmethod
    def from_dict(data: dict[str, Any]) -> EpisodeRecord:
        """A record from its `to_dict` (as JSON gives it back: pairs as lists)."""
        fields = {f.name for f in dataclasses.fields(EpisodeRecord)}
        unknown = sorted(set(data) - fields)
        if unknown:
            raise ValueError(f"an episode record has no field(s) {unknown}; fields: {sorted(fields)}")
        return EpisodeRecord(**{**data, "bump_xy": [tuple(p) for p in data.get("bump_xy", [])]})


class _Localisation:
    """The agent's belief (if it has one) scored against the truth over an episode."""

    def __init__(self, agent: Any, dt_s: float) -> None:
        self.belief = getattr(agent, "belief", None)
        self.dt_s = dt_s
        self.first: tuple[float, float, float] | None = None  # (time, position error, heading error)
        self.worst: float | None = None

    def score(self, truth: Any, steps: int) -> None:
        estimate = self.belief() if self.belief is not None else None
        if estimate is None:
            return
        error = math.hypot(estimate.x - truth.x, estimate.y - truth.y)
        self.worst = error if self.worst is None else max(self.worst, error)
        if self.first is None:
            heading = abs(math.remainder(estimate.theta - truth.theta, 2 * math.pi))
            self.first = (steps * self.dt_s, error, math.degrees(heading))

    def fields(self) -> dict[str, float | None]:
        first = self.first
        return {
            "localise_time_s": first[0] if first else None,
            "localise_error_m": first[1] if first else None,
            "localise_error_deg": first[2] if first else None,
            "max_localise_error_m": self.worst,
        }


def run_episode(
    env: gym.Env,
    agent: Any,
    seed: int,
    agent_name: str = "",
    on_step: Callable[[], None] | None = None,
    options: dict[str, Any] | None = None,
) -> EpisodeRecord:
    """Play one seeded episode to its end (`options`: the env's reset options)."""
    obs, info = env.reset(seed=seed, options=options)
    agent.reset(obs, info)
    metrics = task_info(env_id_of(env)).load_metrics()()
    metrics.reset(env, info)
    base = pico_env(env)
    dt = base.config.dt_s
    localisation = _Localisation(agent, dt)
    times = []
    near_mover = 0.0
    bumps_seen = 0
    bump_xy: list[tuple[float, float]] = []
    while True:
        truth = base.pose  # privileged: scores the agent, never reaches it
        t0 = time.perf_counter()
        action = agent.act(obs)
        times.append(time.perf_counter() - t0)
        localisation.score(truth, len(times))
        obs, _, terminated, truncated, info = env.step(action)
        metrics.step(env, info)
        if info["bumps"] > bumps_seen:
            bumps_seen = int(info["bumps"])
            bump_xy.append((round(float(info["pose"][0]), 4), round(float(info["pose"][1]), 4)))
        movers = info.get("movers")
        if movers is not None and len(movers):
            near_mover += dt * float(_near_a_mover(info["pose"], movers, base.scene.movers))
        if on_step is not None:
            on_step()
        if terminated or truncated:
            break
    return EpisodeRecord(
        agent=agent_name or getattr(agent, "name", "agent"),
        seed=seed,
        map=base.world_name,
        success=bool(info["is_success"]),
        termination_reason=str(info["termination_reason"]),
        time_s=round(float(info["sim_time"]), 6),
        bumps=int(info["bumps"]),
        path_length=float(info["path_length"]),
        shortest_path_length=float(info["shortest_path_length"]),
        min_clearance=float(info["min_clearance"]),
        act_ms=1e3 * statistics.median(times),
        progress=metrics.progress(info),
        bumps_by_kind={k: int(v) for k, v in info.get("bumps_by_kind", {}).items()},
        **localisation.fields(),
        near_mover_s=round(near_mover, 6),
        bump_xy=bump_xy,
        metrics=metrics.finish(env, info, agent),
    )


def _near_a_mover(pose: np.ndarray, poses: np.ndarray, movers: Any, within_m: float = 0.5) -> bool:
    """Whether the robot's centre is within `within_m` of any mover's box."""
    for (mx, my, yaw), record in zip(np.asarray(poses).tolist(), movers.records, strict=True):
        c, s = math.cos(yaw), math.sin(yaw)
        dx, dy = pose[0] - mx, pose[1] - my
        along, across = abs(c * dx + s * dy) - 0.5 * record.length, abs(-s * dx + c * dy) - 0.5 * record.width
        if math.hypot(max(along, 0.0), max(across, 0.0)) < within_m:
            return True
    return False


Job = tuple[str, str, dict[str, Any], dict[str, Any], list[int], dict[str, Any]]


def _worker(job: Job) -> list[EpisodeRecord]:
    env_id, agent_name, env_kwargs, agent_kwargs, seeds, reset_options = job
    env = gym.make(env_id, **env_kwargs)
    agent = make_agent(agent_name, env, **agent_kwargs)
    return [run_episode(env, agent, seed, agent_name, options=reset_options or None) for seed in seeds]


def run_episodes(
    agent_name: str,
    seeds: Iterable[int],
    env_kwargs: dict[str, Any] | None = None,
    agent_kwargs: dict[str, Any] | None = None,
    workers: int | None = None,
    progress: Callable[[int], Any] | None = None,
    env_id: str = DEFAULT_ENV_ID,
    ray_address: str | None = None,
    reset_options: dict[str, Any] | None = None,
) -> list[EpisodeRecord]:
    """Run an agent on seeded episodes of `env_id`; records in seed order.

    `reset_options` go to every episode's `reset` (e.g. the hospital's `cabinet_order`).

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
    options = dict(reset_options or {})
    jobs = [
        (env_id, agent_name, env_kwargs, agent_kwargs, seeds[i : i + chunk], options)
        for i in range(0, len(seeds), chunk)
    ]
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
    jobs: list[Job],
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
            records += [EpisodeRecord.from_dict(d) for d in ray.get(ref)]
            n = pending.pop(ref)
            if progress:
                progress(n)
    return records


def _worker_as_dicts(job: Job) -> list[dict[str, Any]]:
    """`_worker` returning plain dicts: what crosses a cluster does not depend on pico-gym's classes."""
    return [r.to_dict() for r in _worker(job)]


@dataclass(frozen=True)
class Summary:
    """Aggregate figures over episodes: the common core, and the task's own block (`metrics`)."""

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
    progress_mean: float = math.nan
    bumps_by_kind: dict[str, int] = dataclasses.field(default_factory=dict)
    localised_within_rate: float = math.nan  # init error < 0.05 m and 2 deg, of the episodes
    localise_time_median_s: float = math.nan
    localise_error_median_m: float = math.nan
    max_localise_error_median_m: float = math.nan
    max_localise_error_max_m: float = math.nan
    near_mover_s_mean: float = 0.0
    metrics: dict[str, Any] = dataclasses.field(default_factory=dict)  # the task's own block
    env_id: str | None = None  # whose task's block `metrics` is (None: the core alone)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def summarize(records: list[EpisodeRecord], env_id: str | None = None) -> Summary:
    """Success and bump rates (fraction of episodes), times of the successful episodes, SPL, SCT,
    and, given the env id, its task's own figures (`EpisodeMetrics.summarize`)."""
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
        progress_mean=float(np.mean([r.progress for r in records])),
        bumps_by_kind={k: sum(r.bumps_by_kind.get(k, 0) for r in records) for k in _kinds(records)},
        localised_within_rate=_rate(records, _localised_within, lambda r: r.localise_error_m),
        localise_time_median_s=median_of(r.localise_time_s for r in records),
        localise_error_median_m=median_of(r.localise_error_m for r in records),
        max_localise_error_median_m=median_of(r.max_localise_error_m for r in records),
        max_localise_error_max_m=max_of(r.max_localise_error_m for r in records),
        near_mover_s_mean=float(np.mean([r.near_mover_s for r in records])),
        metrics=task_info(env_id).load_metrics().summarize(records) if env_id is not None else {},
        env_id=env_id,
    )


def _localised_within(r: EpisodeRecord, metres: float = 0.05, degrees: float = 2.0) -> bool:
    """Whether the agent's first pose was within `metres` and `degrees` of the truth."""
    m, d = r.localise_error_m, r.localise_error_deg
    return m is not None and d is not None and m < metres and d < degrees


def _kinds(records: list[EpisodeRecord]) -> list[str]:
    kinds: list[str] = []
    for r in records:
        kinds += [k for k in r.bumps_by_kind if k not in kinds]
    return kinds


def _rate(
    records: list[EpisodeRecord], ok: Callable[[EpisodeRecord], bool], value: Callable[[EpisodeRecord], float | None]
) -> float:
    """The fraction of records with the value for which `ok` holds (a record without it fails);
    nan when no record has it at all."""
    if all(value(r) is None for r in records):
        return math.nan
    return sum(value(r) is not None and bool(ok(r)) for r in records) / len(records)


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
    if s.bumps_by_kind and any(s.bumps_by_kind.values()):
        rows.insert(3, ("bumps by kind (total)", ", ".join(f"{k} {v}" for k, v in s.bumps_by_kind.items() if v)))
    if not math.isnan(s.progress_mean) and s.progress_mean != s.success_rate:
        rows.insert(2, ("progress (fraction done), mean", f"{100 * s.progress_mean:.1f} %"))
    if not math.isnan(s.localised_within_rate):
        rows += [
            ("localised < 0.05 m and 2 deg at init", f"{100 * s.localised_within_rate:.1f} % of episodes"),
            ("time to localise, median", f"{s.localise_time_median_s:.1f} s"),
            (
                "localisation error: init / run max",
                f"{100 * s.localise_error_median_m:.1f} cm / "
                f"{100 * s.max_localise_error_median_m:.1f} cm median, {100 * s.max_localise_error_max_m:.1f} cm worst",
            ),
        ]
    if s.env_id is not None:
        rows += task_info(s.env_id).load_metrics().summary_rows(s.metrics)
    if s.near_mover_s_mean > 0.0:
        rows.append(("time within 0.5 m of a mover, mean", f"{s.near_mover_s_mean:.1f} s"))
    width = max(len(k) for k, _ in rows)
    return "\n".join([f"agent: {name}"] + [f"  {k:<{width}}  {v}" for k, v in rows])
