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
    progress: float = math.nan  # fraction of the task done (the hospital: of the cabinet order)
    bumps_by_kind: dict[str, int] = dataclasses.field(default_factory=dict)
    false_announcements: int = 0
    # None for agents without belief() (None, not nan: records compare equal and write valid JSON)
    localise_time_s: float | None = None  # when the agent's belief() first gave a pose
    localise_error_m: float | None = None  # its error then (position) ...
    localise_error_deg: float | None = None  # ... and heading
    max_localise_error_m: float | None = None  # the worst position error of the belief over the run
    near_mover_s: float = 0.0  # time the robot's centre spent within 0.5 m of a mover's box
    # the hospital: when each cabinet of the order was counted [s]; where bumps began (x, y)
    leg_done_s: list[float] = dataclasses.field(default_factory=list)
    bump_xy: list[tuple[float, float]] = dataclasses.field(default_factory=list)
    # PicoExplore-v0 (None elsewhere)
    parked: bool | None = None
    explored: bool | None = None  # every room seen to the task's explore_coverage when it parked
    coverage: float | None = None
    min_room_coverage: float | None = None
    time_to_park_s: float | None = None
    parking_heading_deg: float | None = None
    parking_lateral_m: float | None = None
    map_iou: float | None = None  # the agent's map_belief() against the true free space, at the end

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
    options: dict[str, Any] | None = None,
) -> EpisodeRecord:
    """Play one seeded episode to its end (`options`: the env's reset options)."""
    obs, info = env.reset(seed=seed, options=options)
    agent.reset(obs, info)
    order = getattr(info.get("task"), "cabinet_order", None)
    belief = getattr(agent, "belief", None)
    times = []
    localised: tuple[float, float, float] | None = None  # (time, position error, heading error)
    worst: float | None = None
    near_mover = 0.0
    legs: list[float] = []
    bumps_seen = 0
    bump_xy: list[tuple[float, float]] = []
    dt = env.unwrapped.config.dt_s
    while True:
        truth = env.unwrapped.pose  # privileged: scores the agent, never reaches it
        t0 = time.perf_counter()
        action = agent.act(obs)
        times.append(time.perf_counter() - t0)
        estimate = belief() if belief is not None else None
        if estimate is not None:
            error = math.hypot(estimate.x - truth.x, estimate.y - truth.y)
            worst = error if worst is None else max(worst, error)
            if localised is None:
                heading = abs(math.remainder(estimate.theta - truth.theta, 2 * math.pi))
                localised = (len(times) * dt, error, math.degrees(heading))
        obs, _, terminated, truncated, info = env.step(action)
        if info.get("cabinets_done", 0) > len(legs):
            legs.append(round(float(info["sim_time"]), 6))
        if info["bumps"] > bumps_seen:
            bumps_seen = int(info["bumps"])
            bump_xy.append((round(float(info["pose"][0]), 4), round(float(info["pose"][1]), 4)))
        movers = info.get("movers")
        if movers is not None and len(movers):
            near_mover += dt * float(_near_a_mover(info["pose"], movers, env.unwrapped.scene.movers))
        if on_step is not None:
            on_step()
        if terminated or truncated:
            break
    progress = float(info["cabinets_done"]) / len(order) if order else float(bool(info["is_success"]))
    explore = _explore_metrics(env, agent, info) if "parked" in info else {}
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
        progress=progress,
        bumps_by_kind={k: int(v) for k, v in info.get("bumps_by_kind", {}).items()},
        false_announcements=int(info.get("false_announcements", 0)),
        localise_time_s=localised[0] if localised else None,
        localise_error_m=localised[1] if localised else None,
        localise_error_deg=localised[2] if localised else None,
        max_localise_error_m=worst,
        near_mover_s=round(near_mover, 6),
        leg_done_s=legs,
        bump_xy=bump_xy,
        **explore,
    )


def _explore_metrics(env: gym.Env, agent: Any, info: dict[str, Any]) -> dict[str, Any]:
    """PicoExplore-v0's metrics of an ended episode (the map scored if the agent hands one over)."""
    error = info["parking_error"]
    map_belief = getattr(agent, "map_belief", None)
    return {
        "parked": bool(info["parked"]),
        "explored": bool(info["explored"]),
        "coverage": float(info["coverage"]),
        "min_room_coverage": float(min(info["room_coverage"])),
        "time_to_park_s": info["time_to_park"],
        "parking_heading_deg": math.degrees(error["heading_rad"]) if error else None,
        "parking_lateral_m": error["lateral_m"] if error else None,
        "map_iou": float(env.unwrapped.belief_iou(map_belief())) if map_belief is not None else None,
    }


def _near_a_mover(pose: np.ndarray, poses: np.ndarray, movers: Any, within_m: float = 0.5) -> bool:
    """Whether the robot's centre is within `within_m` of any mover's box."""
    for (mx, my, yaw), record in zip(np.asarray(poses).tolist(), movers.records, strict=True):
        c, s = math.cos(yaw), math.sin(yaw)
        dx, dy = pose[0] - mx, pose[1] - my
        along, across = abs(c * dx + s * dy) - 0.5 * record.length, abs(-s * dx + c * dy) - 0.5 * record.width
        if math.hypot(max(along, 0.0), max(across, 0.0)) < within_m:
            return True
    return False


DEFAULT_ENV_ID = "PicoEscape-v0"


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
    progress: Callable[[int], None] | None = None,
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
            records += [EpisodeRecord(**d) for d in ray.get(ref)]
            n = pending.pop(ref)
            if progress:
                progress(n)
    return records


def _worker_as_dicts(job: Job) -> list[dict[str, Any]]:
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
    progress_mean: float = math.nan
    bumps_by_kind: dict[str, int] = dataclasses.field(default_factory=dict)
    no_false_announcement_rate: float = math.nan
    localised_within_rate: float = math.nan  # init error < 0.05 m and 2 deg, of the episodes
    localise_time_median_s: float = math.nan
    localise_error_median_m: float = math.nan
    max_localise_error_median_m: float = math.nan
    max_localise_error_max_m: float = math.nan
    near_mover_s_mean: float = 0.0
    # PicoExplore-v0 (nan elsewhere)
    parked_rate: float = math.nan
    explored_and_parked_rate: float = math.nan
    found_of_parked_rate: float = math.nan
    rooms_covered_rate: float = math.nan  # episodes with every room >= 95 % seen
    parking_heading_max_deg: float = math.nan
    time_to_park_median_s: float = math.nan
    map_iou_median: float = math.nan
    map_iou_min: float = math.nan
    map_iou_at_least_0_9_rate: float = math.nan  # episodes whose map scores 0.9 or more

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
        progress_mean=float(np.mean([r.progress for r in records])),
        bumps_by_kind={k: sum(r.bumps_by_kind.get(k, 0) for r in records) for k in _kinds(records)},
        no_false_announcement_rate=sum(r.false_announcements == 0 for r in records) / n,
        localised_within_rate=_rate(
            records, lambda r: r.localise_error_m < 0.05 and r.localise_error_deg < 2.0, lambda r: r.localise_error_m
        ),
        localise_time_median_s=_median(r.localise_time_s for r in records),
        localise_error_median_m=_median(r.localise_error_m for r in records),
        max_localise_error_median_m=_median(r.max_localise_error_m for r in records),
        max_localise_error_max_m=_max(r.max_localise_error_m for r in records),
        near_mover_s_mean=float(np.mean([r.near_mover_s for r in records])),
        **_explore_summary(records),
    )


def _explore_summary(records: list[EpisodeRecord]) -> dict[str, float]:
    if any(r.parked is None for r in records):
        return {}
    n = len(records)
    parked = [r for r in records if r.parked]
    ious = [r.map_iou for r in records if r.map_iou is not None]
    return {
        "parked_rate": len(parked) / n,
        "explored_and_parked_rate": sum(bool(r.explored) for r in parked) / n,
        "found_of_parked_rate": sum(r.success for r in parked) / len(parked) if parked else math.nan,
        "rooms_covered_rate": sum((r.min_room_coverage or 0.0) >= 0.95 for r in records) / n,
        "parking_heading_max_deg": _max(r.parking_heading_deg for r in parked),
        "time_to_park_median_s": _median(r.time_to_park_s for r in parked),
        "map_iou_median": float(np.median(ious)) if ious else math.nan,
        "map_iou_min": float(min(ious)) if ious else math.nan,
        "map_iou_at_least_0_9_rate": sum(v >= 0.9 for v in ious) / len(ious) if ious else math.nan,
    }


def _kinds(records: list[EpisodeRecord]) -> list[str]:
    kinds: list[str] = []
    for r in records:
        kinds += [k for k in r.bumps_by_kind if k not in kinds]
    return kinds


def _median(values: Iterable[float | None]) -> float:
    finite = [v for v in values if v is not None]
    return float(np.median(finite)) if finite else math.nan


def _max(values: Iterable[float | None]) -> float:
    finite = [v for v in values if v is not None]
    return float(max(finite)) if finite else math.nan


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
    if not math.isnan(s.no_false_announcement_rate) and s.no_false_announcement_rate < 1.0:
        rows.append(("no false announcement", f"{100 * s.no_false_announcement_rate:.1f} % of episodes"))
    if not math.isnan(s.parked_rate):
        rows += [
            ("explored and parked", f"{100 * s.explored_and_parked_rate:.1f} % (parked {100 * s.parked_rate:.1f} %)"),
            ("object found, of the parked", f"{100 * s.found_of_parked_rate:.1f} %"),
            ("every room >= 95 % seen", f"{100 * s.rooms_covered_rate:.1f} % of episodes"),
            ("parking heading error, worst", f"{s.parking_heading_max_deg:.1f} deg"),
            ("time to park, median", f"{s.time_to_park_median_s:.1f} s"),
        ]
        if not math.isnan(s.map_iou_median):
            rows.append(
                (
                    "map IoU (free space) median / worst",
                    f"{s.map_iou_median:.3f} / {s.map_iou_min:.3f} ({100 * s.map_iou_at_least_0_9_rate:.0f} % of "
                    "episodes >= 0.9)",
                )
            )
    if s.near_mover_s_mean > 0.0:
        rows.append(("time within 0.5 m of a mover, mean", f"{s.near_mover_s_mean:.1f} s"))
    width = max(len(k) for k, _ in rows)
    return "\n".join([f"agent: {name}"] + [f"  {k:<{width}}  {v}" for k, v in rows])
