"""`pico-gym compare`: every agent on the same episodes, side by side.

An episode is (map or generated room, seed); the seed fixes the room, the start pose and every
noise draw, so all agents face exactly the same episodes. Default seeds (1000..) are disjoint from
PPO's training seeds (>= 1,000,000) and its evaluation seeds (900,000..). Writes to DIR:

    results.md    the table (also printed)
    results.json  settings, a summary per agent, one record per episode (as `pico-gym bench`)
    results.csv   one row per episode
    success_times.png, success_bumps.png, trajectories.png

Everything but the measured compute time per step (`act_ms`) is a deterministic function of the
seeds: the same command gives the same numbers.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import pico_gym  # noqa: F401
from pico_gym.agents import NEVER_ANNOUNCING, make_agent
from pico_gym.agents.evaluation import (
    DEFAULT_ENV_ID,
    EpisodeRecord,
    Summary,
    run_episode,
    run_episodes,
    summarize,
)
from pico_gym.extras import require
from pico_gym.world.catalog import shipped_maps

SUITES = ("generated", "maps", "all", "hospital")
# The "hospital" suite (PicoHospital-v0): the three settings, each a group of episodes.
HOSPITAL_SUITE: dict[str, dict[str, Any]] = {
    "hospital_2019 busy": {"map": "hospital_2019", "n_boxes": (2, 2), "n_movers": (1, 1), "closed_doors": (1, 1)},
    "hospital_2021": {"map": "hospital_2021"},
}
# Trajectory colours per agent, fixed so figures read the same across runs.
COLOURS = {"classic": "C0", "ppo": "C1", "wall-follow": "C2", "random": "C7", "hybrid": "C3", "ppo-pointgoal": "C4"}


def escape_maps() -> list[str]:
    """The shipped escape-room maps."""
    return sorted(name for name in shipped_maps() if name.startswith("escape"))


def task_maps(env_id: str) -> list[str]:
    """The shipped maps of an env's task (escape rooms, or hospitals)."""
    prefix = "hospital" if "Hospital" in env_id else "escape"
    return sorted(name for name in shipped_maps() if name.startswith(prefix))


@dataclass(frozen=True)
class Episodes:
    """Which episodes to run: (map or None for generated rooms, seeds)."""

    groups: tuple[tuple[str | None, tuple[int, ...]], ...]
    env_options: dict[str, Any] = field(default_factory=dict)
    env_id: str = DEFAULT_ENV_ID
    presets: dict[str, dict[str, Any]] = field(default_factory=dict)  # group name -> its env kwargs

    @staticmethod
    def suite(
        name: str,
        episodes: int,
        seed: int,
        env_options: dict[str, Any] | None = None,
        env_id: str = DEFAULT_ENV_ID,
    ) -> Episodes:
        """`episodes` generated worlds and/or `episodes` starts on each shipped map of the env's task
        (the "hospital" suite: generated hospitals and `HOSPITAL_SUITE`'s settings)."""
        if name not in SUITES:
            raise ValueError(f"suite must be one of {SUITES}, got {name!r}")
        seeds = tuple(range(seed, seed + episodes))
        if name == "hospital":
            if env_id != "PicoHospital-v0":
                raise ValueError(f"the hospital suite is PicoHospital-v0's; got {env_id}")
            groups_h = ((None, seeds), *((k, seeds) for k in HOSPITAL_SUITE))
            return Episodes(groups_h, dict(env_options or {}), env_id, dict(HOSPITAL_SUITE))
        groups: list[tuple[str | None, tuple[int, ...]]] = []
        if name in ("generated", "all"):
            groups.append((None, seeds))
        if name in ("maps", "all"):
            groups += [(m, seeds) for m in task_maps(env_id)]
        return Episodes(tuple(groups), dict(env_options or {}), env_id)

    def env_kwargs(self, map_name: str | None) -> dict[str, Any]:
        if map_name in self.presets:
            return {**self.env_options, **self.presets[map_name]}
        if map_name is None:
            return dict(self.env_options)
        if self.env_id == "PicoEscape-v0":
            return {**self.env_options, "map": map_name, "sample_start": True}
        return {**self.env_options, "map": map_name}


def run_comparison(
    agents: Sequence[str],
    episodes: Episodes,
    agent_kwargs: dict[str, dict[str, Any]] | None = None,
    workers: int | None = None,
    progress: Callable[[int], None] | None = None,
    ray_address: str | None = None,
) -> dict[str, list[EpisodeRecord]]:
    """Every agent on every episode; records per agent in (group, seed) order."""
    agent_kwargs = agent_kwargs or {}
    results: dict[str, list[EpisodeRecord]] = {}
    for name in agents:
        records: list[EpisodeRecord] = []
        for map_name, seeds in episodes.groups:
            records += run_episodes(
                name,
                seeds,
                episodes.env_kwargs(map_name),
                agent_kwargs.get(name),
                workers,
                progress,
                episodes.env_id,
                ray_address,
            )
        results[name] = records
    return results


# --- outputs --------------------------------------------------------------------------------
COLUMNS = [
    ("success", lambda s: f"{100 * s.success_rate:.1f} %"),
    ("bumps", lambda s: f"{100 * s.bump_rate:.1f} %"),
    ("idle", lambda s: f"{s.idle}"),
    ("timeout", lambda s: f"{s.timeout}"),
    ("time median", lambda s: _seconds(s.time_median_s)),
    ("time p90", lambda s: _seconds(s.time_p90_s)),
    ("SPL", lambda s: f"{s.spl:.3f}"),
    ("SCT median", lambda s: f"{s.sct_median:.3f}"),
    ("mean min clearance", lambda s: f"{s.min_clearance_mean:.3f} m"),
    ("compute per step", lambda s: f"{s.act_ms_median:.2f} ms"),
]


def _seconds(value: float) -> str:
    return "-" if math.isnan(value) else f"{value:.1f} s"


# The hospital's columns besides COLUMNS' (task-neutral figures of the hospital issue).
HOSPITAL_COLUMNS = [
    ("progress", lambda s: f"{100 * s.progress_mean:.1f} %"),
    ("bumps by kind", lambda s: ", ".join(f"{k} {n}" for k, n in s.bumps_by_kind.items() if n) or "-"),
    ("s within 0.5 m of a mover", lambda s: f"{s.near_mover_s_mean:.1f}"),
]


def markdown_table(summaries: dict[str, Summary], hospital: bool = False) -> str:
    """A Markdown table, one row per agent (with `hospital`, the hospital's columns too)."""
    columns = COLUMNS + (HOSPITAL_COLUMNS if hospital else [])
    header = "| agent | episodes | " + " | ".join(c for c, _ in columns) + " |"
    rule = "|---|---:|" + "---:|" * len(columns)
    rows = [f"| {a} | {s.episodes} | " + " | ".join(f(s) for _, f in columns) + " |" for a, s in summaries.items()]
    return "\n".join([header, rule, *rows])


def group_tables(results: dict[str, list[EpisodeRecord]], episodes: Episodes) -> str:
    """One table per group of episodes (a map, a setting), for suites of several groups."""
    hospital = episodes.env_id == "PicoHospital-v0"
    parts, start = [], 0
    for name, seeds in episodes.groups:
        stop = start + len(seeds)
        summaries = {agent: summarize(records[start:stop]) for agent, records in results.items()}
        parts += [
            f"### {name or 'generated'} (seeds {seeds[0]}..{seeds[-1]})",
            "",
            markdown_table(summaries, hospital),
            "",
        ]
        start = stop
    return "\n".join(parts)


def write_results(
    out: Path, results: dict[str, list[EpisodeRecord]], settings: dict[str, Any], episodes: Episodes | None = None
) -> dict[str, Summary]:
    """results.md, results.json and results.csv; returns the summaries."""
    out.mkdir(parents=True, exist_ok=True)
    summaries = {name: summarize(records) for name, records in results.items()}
    table = markdown_table(summaries, settings.get("env_id") == "PicoHospital-v0")
    if episodes is not None and len(episodes.groups) > 1:
        table += "\n\nBy group:\n\n" + group_tables(results, episodes)
    lines = [
        "# pico-gym compare",
        "",
        f"Episodes: {_describe(settings)}. Same rooms, start poses and noise for every agent.",
        "Escape times are over successful episodes; SCT = success x oracle time / max(time, oracle time).",
        "",
        table,
        "",
        "![escape times](success_times.png) ![success and bumps](success_bumps.png)",
        *(
            ["", "![time per leg](legs.png) ![where the bumps began](bumps.png)"]
            if settings.get("env_id") == "PicoHospital-v0"
            else []
        ),
        "",
        "![trajectories](trajectories.png)",
        "",
    ]
    (out / "results.md").write_text("\n".join(lines))
    payload = {
        "settings": settings,
        "summary": {name: s.to_dict() for name, s in summaries.items()},
        "episodes": [r.to_dict() for records in results.values() for r in records],
    }
    (out / "results.json").write_text(json.dumps(payload, indent=1) + "\n")
    fields = list(EpisodeRecord.__dataclass_fields__) + ["spl", "sct"]
    with (out / "results.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        for records in results.values():
            for r in records:
                writer.writerow({**r.to_dict(), "spl": r.spl, "sct": r.sct})
    return summaries


def _describe(settings: dict[str, Any]) -> str:
    parts = []
    for group in settings["episodes"]:
        where = group["map"] or "generated rooms"
        parts.append(f"{where}, seeds {group['seeds'][0]}..{group['seeds'][-1]}")
    options = settings.get("env_options") or {}
    return "; ".join(parts) + (f"; env options {options}" if options else "")


def _box_figure(path: Path, names: list[str], values: list[list[float]], unit: str, ylabel: str, title: str) -> None:
    """One box (with its points) per agent."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.8), dpi=110)
    positions = [i for i, v in enumerate(values) if v]
    if positions:
        ax.boxplot([values[i] for i in positions], positions=positions, widths=0.5, showfliers=True)
        for i in positions:
            jitter = np.linspace(-0.15, 0.15, len(values[i]))
            ax.scatter(i + jitter, values[i], s=6, alpha=0.4, color=COLOURS.get(names[i], "C4"))
    ax.set_xticks(range(len(names)), [f"{n}\n({len(v)} {unit})" for n, v in zip(names, values, strict=True)])
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_results(out: Path, results: dict[str, list[EpisodeRecord]], summaries: dict[str, Summary]) -> list[Path]:
    """Escape-time distributions and success/bump bars as PNGs."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(results)
    times = [[r.time_s for r in results[n] if r.success] for n in names]
    _box_figure(out / "success_times.png", names, times, "escapes", "time to success [s]",
                "Time to success (successful episodes)")  # fmt: skip

    fig, ax = plt.subplots(figsize=(7, 3.5), dpi=110)
    x = np.arange(len(names))
    success = [100 * summaries[n].success_rate for n in names]
    bumps = [100 * summaries[n].bump_rate for n in names]
    ax.bar(x - 0.2, success, 0.4, label="success", color="C2")
    ax.bar(x + 0.2, bumps, 0.4, label="bumped", color="C3")
    for xi, (s, b) in enumerate(zip(success, bumps, strict=True)):
        ax.text(xi - 0.2, s + 1, f"{s:.0f}", ha="center", fontsize=8)
        ax.text(xi + 0.2, b + 1, f"{b:.0f}", ha="center", fontsize=8)
    ax.set_xticks(x, names)
    ax.set_ylim(0, 110)
    ax.set_ylabel("% of episodes")
    ax.legend()
    ax.set_title("Success and bump rates")
    fig.tight_layout()
    fig.savefig(out / "success_bumps.png")
    plt.close(fig)
    return [out / "success_times.png", out / "success_bumps.png"]


def plot_hospital(out: Path, results: dict[str, list[EpisodeRecord]], episodes: Episodes) -> list[Path]:
    """The hospital's figures: the time each leg of the order took (successful and unfinished
    episodes alike), and where the bumps began on each fixed map of the suite."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pico_gym.world.catalog import load_shipped

    names = list(results)
    legs = [[float(d) for r in results[n] for d in np.diff([0.0, *r.leg_done_s])] for n in names]
    _box_figure(out / "legs.png", names, legs, "legs", "time per leg [s]",
                "Time from one cabinet to the next (the first leg from the start)")  # fmt: skip

    fixed = [(name, kw["map"]) for name, kw in episodes.presets.items() if "map" in kw]
    fig, axes = plt.subplots(1, max(1, len(fixed)), figsize=(5 * max(1, len(fixed)), 5), dpi=110, squeeze=False)
    start = {name: 0 for name in names}
    for group, seeds in episodes.groups:
        index = next((i for i, (g, _) in enumerate(fixed) if g == group), None)
        for n in names:
            chunk = results[n][start[n] : start[n] + len(seeds)]
            start[n] += len(seeds)
            if index is None:
                continue
            xy = np.array([p for r in chunk for p in r.bump_xy]).reshape(-1, 2)
            axes[0, index].plot(
                xy[:, 0], xy[:, 1], "x", color=COLOURS.get(n, "C4"), ms=7, mew=2, label=f"{n} ({len(xy)})"
            )
    for i, (group, map_name) in enumerate(fixed):
        ax = axes[0, i]
        world = load_shipped(map_name)
        for x0, y0, x1, y1 in np.vstack([world.wall_segments, world.cabinet_segments]):
            ax.plot([x0, x1], [y0, y1], color="black", lw=1)
        ax.set_aspect("equal")
        ax.set_title(f"bumps, {group}", fontsize=9)
        ax.legend(fontsize=7, loc="best")
        ax.set_xticks([])
        ax.set_yticks([])
    fig.tight_layout()
    fig.savefig(out / "bumps.png")
    plt.close(fig)
    return [out / "legs.png", out / "bumps.png"]


def plot_trajectories(
    out: Path,
    agents: Sequence[str],
    episodes: Episodes,
    n_rooms: int = 3,
    agent_kwargs: dict[str, dict[str, Any]] | None = None,
) -> Path:
    """Each agent's true path in the first `n_rooms` episodes (replayed: episodes are deterministic)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    agent_kwargs = agent_kwargs or {}
    if episodes.presets:  # a suite of settings: the first episode of each
        picks = [(m, seeds[0]) for m, seeds in episodes.groups][:n_rooms]
    else:
        picks = [(m, s) for m, seeds in episodes.groups for s in seeds][:n_rooms]
    cols = min(3, len(picks))
    rows = -(-len(picks) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 4.4 * rows), dpi=110, squeeze=False)
    for ax in axes.flat[len(picks) :]:
        ax.axis("off")
    for ax, (map_name, seed) in zip(axes.flat, picks, strict=False):
        env = gym.make(episodes.env_id, **episodes.env_kwargs(map_name))
        world = None
        for name in agents:
            agent = make_agent(name, env, **agent_kwargs.get(name, {}))
            record = run_episode(env, agent, seed, name)
            world = env.unwrapped.episode.map
            path = np.array([(p.x, p.y) for p in env.unwrapped.trajectory])
            label = f"{name}: {record.termination_reason} {record.time_s:.0f} s"
            ax.plot(path[:, 0], path[:, 1], lw=1.4, color=COLOURS.get(name, "C4"), label=label)
            if record.bumps:
                ax.plot(*path[-1], "x", color="red", ms=8, mew=2)
        assert world is not None
        for x0, y0, x1, y1 in env.unwrapped.scene.static_seen:
            ax.plot([x0, x1], [y0, y1], color="black", lw=1.5)
        if world.finish is not None:
            f = np.asarray(world.finish)
            ax.plot(f[:, 0], f[:, 1], color="green", lw=1, ls="--")
        start = env.unwrapped.trajectory[0]
        ax.plot(start.x, start.y, "o", color="black", ms=5)
        ax.set_aspect("equal")
        ax.set_title(f"{map_name or 'generated'}, seed {seed}", fontsize=9)
        ax.legend(fontsize=7, loc="best")
        ax.set_xticks([])
        ax.set_yticks([])
        env.close()
    fig.tight_layout()
    fig.savefig(out / "trajectories.png")
    plt.close(fig)
    return out / "trajectories.png"


def compare(
    agents: Sequence[str],
    episodes: Episodes,
    out: str | Path,
    agent_kwargs: dict[str, dict[str, Any]] | None = None,
    workers: int | None = None,
    n_rooms: int = 3,
    progress: Callable[[int], None] | None = None,
    ray_address: str | None = None,
) -> dict[str, Summary]:
    """Run, write results.{md,json,csv} and the plots into `out`; returns the summaries.

    What could fail after the episodes (matplotlib missing, an output folder that cannot be made,
    an agent that cannot be built) is checked before the first one.
    """
    require("matplotlib", "plots", "pico-gym compare's plots")
    if episodes.env_options.get("arrival") == "announce":
        # The floor baselines play the announcing episodes too, never announcing.
        agent_kwargs = {
            **(agent_kwargs or {}),
            **{n: {"never_announce": True, **(agent_kwargs or {}).get(n, {})} for n in agents if n in NEVER_ANNOUNCING},
        }
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    probe = gym.make(episodes.env_id, **episodes.env_kwargs(episodes.groups[0][0]))
    for name in agents:
        make_agent(name, probe, **(agent_kwargs or {}).get(name, {}))
    probe.close()
    results = run_comparison(agents, episodes, agent_kwargs, workers, progress, ray_address)
    settings = {
        "agents": list(agents),
        "agent_kwargs": {k: {kk: str(vv) for kk, vv in v.items()} for k, v in (agent_kwargs or {}).items()},
        "env_id": episodes.env_id,
        "env_options": episodes.env_options,
        "episodes": [{"map": m, "seeds": list(s)} for m, s in episodes.groups],
    }
    summaries = write_results(out, results, settings, episodes)
    plot_results(out, results, summaries)
    if episodes.env_id == "PicoHospital-v0":
        plot_hospital(out, results, episodes)
    if n_rooms > 0:
        plot_trajectories(out, agents, episodes, n_rooms, agent_kwargs)
    return summaries
