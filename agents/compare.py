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
from pico_gym.agents.evaluation import EpisodeRecord, Summary, run_episode, run_episodes, summarize
from pico_gym.agents.registry import AGENT_ENTRIES, make_agent
from pico_gym.envs.base import pico_env
from pico_gym.extras import require
from pico_gym.registry import DEFAULT_ENV_ID, Suite, SuiteGroup, task_info


def colour(agent: str) -> str:
    """An agent's colour in figures (its registration's), fixed so figures read the same across runs."""
    entry = AGENT_ENTRIES.get(agent)
    return entry.colour if entry is not None else "C4"


@dataclass(frozen=True)
class Episodes:
    """Which episodes to run: groups (a label and the env kwargs of its episodes), each on seeds.

    Attributes:
        groups: (group, seeds) pairs.
        env_options: the user's env options, under every group's own.
        env_id: the env.
    """

    groups: tuple[tuple[SuiteGroup, tuple[int, ...]], ...]
    env_options: dict[str, Any] = field(default_factory=dict)
    env_id: str = DEFAULT_ENV_ID

    @staticmethod
    def suite(
        name: str,
        episodes: int,
        seed: int,
        env_options: dict[str, Any] | None = None,
        env_id: str = DEFAULT_ENV_ID,
    ) -> Episodes:
        """A suite of the env's task (`TaskInfo.suite`: "generated", "maps", "all", or the task's
        own), each group on the seeds `seed`.. (`episodes` of them)."""
        return Episodes.of(task_info(env_id).suite(name), range(seed, seed + episodes), env_options, env_id)

    @staticmethod
    def of(
        suite: Suite, seeds: range, env_options: dict[str, Any] | None = None, env_id: str = DEFAULT_ENV_ID
    ) -> Episodes:
        """Every group of a suite on the same seeds."""
        return Episodes(tuple((g, tuple(seeds)) for g in suite.groups), dict(env_options or {}), env_id)

    def env_kwargs(self, group: SuiteGroup) -> dict[str, Any]:
        """What `gym.make` gets for a group's episodes: the user's options, then the group's."""
        return {**self.env_options, **group.env_kwargs}


def run_comparison(
    agents: Sequence[str],
    episodes: Episodes,
    agent_kwargs: dict[str, dict[str, Any]] | None = None,
    workers: int | None = None,
    progress: Callable[[int], Any] | None = None,
    ray_address: str | None = None,
    reset_options: dict[str, Any] | None = None,
) -> dict[str, list[EpisodeRecord]]:
    """Every agent on every episode; records per agent in (group, seed) order."""
    agent_kwargs = agent_kwargs or {}
    results: dict[str, list[EpisodeRecord]] = {}
    for name in agents:
        records: list[EpisodeRecord] = []
        for group, seeds in episodes.groups:
            records += run_episodes(
                name,
                seeds,
                episodes.env_kwargs(group),
                agent_kwargs.get(name),
                workers,
                progress,
                episodes.env_id,
                ray_address,
                reset_options,
            )
        results[name] = records
    return results


def settings_of(
    agents: Sequence[str], episodes: Episodes, agent_kwargs: dict[str, dict[str, Any]] | None = None
) -> dict[str, Any]:
    """What results.json says about how its episodes were run (and `read_results` reads back)."""
    return {
        "agents": list(agents),
        "agent_kwargs": {k: {kk: str(vv) for kk, vv in v.items()} for k, v in (agent_kwargs or {}).items()},
        "env_id": episodes.env_id,
        "env_options": episodes.env_options,
        "episodes": [
            {"group": g.label, "env_kwargs": dict(g.env_kwargs), "seeds": list(s)} for g, s in episodes.groups
        ],
    }


def read_results(paths: Sequence[str | Path]) -> tuple[dict[str, list[EpisodeRecord]], Episodes]:
    """The records of results.json files (`pico-gym bench --json`, `pico-gym compare`), for a table
    of their agents side by side; they must hold the same env and the same episodes.

    Raises:
        ValueError: naming the file that is not a results file, or whose episodes differ.
    """
    results: dict[str, list[EpisodeRecord]] = {}
    first: tuple[str, Any] | None = None
    episodes: Episodes | None = None
    for path in paths:
        try:
            payload = json.loads(Path(path).read_text())
            settings = payload["settings"]
            key = (settings["env_id"], [(g["group"], g["seeds"]) for g in settings["episodes"]])
            records = [EpisodeRecord.from_dict(r) for r in payload["episodes"]]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"{path}: not a results file of pico-gym bench --json or compare ({exc})") from None
        if first is None:
            first = key
            groups = tuple(
                (SuiteGroup(g["group"], g.get("env_kwargs", {})), tuple(g["seeds"])) for g in settings["episodes"]
            )
            episodes = Episodes(groups, dict(settings.get("env_options") or {}), settings["env_id"])
        elif key != first:
            raise ValueError(f"{path}: other episodes ({key[0]}, {len(key[1])} groups) than {paths[0]}'s")
        for r in records:
            results.setdefault(r.agent, []).append(r)
    assert episodes is not None
    return results, episodes


def protocol_row(suite: str, split: str, agent: str, s: Summary, env_id: str | None = None) -> str:
    """The benchmark protocol's table row of one agent on one suite and split (docs/benchmarks.md),
    with the task's own columns (its `EpisodeMetrics.columns`) when `env_id` is given."""
    kinds = ", ".join(f"{k} {n}" for k, n in s.bumps_by_kind.items() if n) or "-"
    extra = [f(s) for name, f in task_info(env_id).load_metrics().columns if name != "bumps by kind"] if env_id else []
    return (
        f"| {suite} | {split} | {agent} | {s.episodes} | {100 * s.success_rate:.1f} % | {100 * s.bump_rate:.1f} % | "
        f"{kinds} | {s.spl:.3f} | {s.sct_median:.3f} | {_seconds(s.time_median_s)} |"
        + "".join(f" {cell} |" for cell in extra)
    )


def protocol_header(env_id: str | None = None) -> str:
    """The header of `protocol_row`'s table (with the task's columns when `env_id` is given)."""
    extra = [name for name, _ in task_info(env_id).load_metrics().columns if name != "bumps by kind"] if env_id else []
    names = ["suite", "split", "agent", "episodes", "success", "bumps", "bumps by kind", "SPL", "SCT median", "time"]
    names += extra
    return "| " + " | ".join(names) + " |\n|" + "---|" * len(names)


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


def markdown_table(summaries: dict[str, Summary], env_id: str | None = None) -> str:
    """A Markdown table, one row per agent (with `env_id`, its task's columns too)."""
    extra = list(task_info(env_id).load_metrics().columns) if env_id is not None else []
    columns = COLUMNS + extra
    header = "| agent | episodes | " + " | ".join(c for c, _ in columns) + " |"
    rule = "|---|---:|" + "---:|" * len(columns)
    rows = [f"| {a} | {s.episodes} | " + " | ".join(f(s) for _, f in columns) + " |" for a, s in summaries.items()]
    return "\n".join([header, rule, *rows])


def group_tables(results: dict[str, list[EpisodeRecord]], episodes: Episodes) -> str:
    """One table per group of episodes (a map, a setting), for suites of several groups."""
    parts, start = [], 0
    for group, seeds in episodes.groups:
        stop = start + len(seeds)
        summaries = {agent: summarize(records[start:stop], episodes.env_id) for agent, records in results.items()}
        parts += [
            f"### {group.label} (seeds {seeds[0]}..{seeds[-1]})",
            "",
            markdown_table(summaries, episodes.env_id),
            "",
        ]
        start = stop
    return "\n".join(parts)


def write_results(
    out: Path, results: dict[str, list[EpisodeRecord]], settings: dict[str, Any], episodes: Episodes | None = None
) -> dict[str, Summary]:
    """results.md, results.json and results.csv; returns the summaries."""
    out.mkdir(parents=True, exist_ok=True)
    env_id = settings.get("env_id")
    summaries = {name: summarize(records, env_id) for name, records in results.items()}
    table = markdown_table(summaries, env_id)
    if episodes is not None and len(episodes.groups) > 1:
        table += "\n\nBy group:\n\n" + group_tables(results, episodes)
    figures = task_info(env_id).load_metrics().figures if env_id is not None else ()
    lines = [
        "# pico-gym compare",
        "",
        f"Episodes: {_describe(settings)}. Same rooms, start poses and noise for every agent.",
        "Escape times are over successful episodes; SCT = success x oracle time / max(time, oracle time).",
        "",
        table,
        "",
        "![escape times](success_times.png) ![success and bumps](success_bumps.png)",
        *(["", "![time per leg](legs.png) ![where the bumps began](bumps.png)"] if "legs" in figures else []),
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
    write_csv(out / "results.csv", [r for records in results.values() for r in records])
    return summaries


def write_csv(path: Path, records: list[EpisodeRecord]) -> None:
    """One row per episode: the core's fields, the task's block (as `metrics.NAME`), SPL and SCT."""
    core = [f for f in EpisodeRecord.__dataclass_fields__ if f != "metrics"]
    task: list[str] = []
    for r in records:
        task += [k for k in r.metrics if k not in task]
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=core + [f"metrics.{k}" for k in task] + ["spl", "sct"])
        writer.writeheader()
        for r in records:
            row = {k: v for k, v in r.to_dict().items() if k != "metrics"}
            row.update({f"metrics.{k}": v for k, v in r.metrics.items()})
            writer.writerow({**row, "spl": r.spl, "sct": r.sct})


def _describe(settings: dict[str, Any]) -> str:
    parts = []
    worlds = task_info(settings["env_id"]).worlds if settings.get("env_id") else "rooms"
    for group in settings["episodes"]:
        where = f"generated {worlds}" if group["group"] == "generated" else group["group"]
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
            ax.scatter(i + jitter, values[i], s=6, alpha=0.4, color=colour(names[i]))
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


def plot_legs(out: Path, results: dict[str, list[EpisodeRecord]]) -> Path:
    """The time each leg of a task's order took (records whose task block has `leg_done_s`),
    successful and unfinished episodes alike."""
    names = list(results)
    legs = [[float(d) for r in results[n] for d in np.diff([0.0, *r.metrics["leg_done_s"]])] for n in names]
    _box_figure(out / "legs.png", names, legs, "legs", "time per leg [s]",
                "Time from one cabinet to the next (the first leg from the start)")  # fmt: skip
    return out / "legs.png"


def plot_bumps(out: Path, results: dict[str, list[EpisodeRecord]], episodes: Episodes) -> Path:
    """Where the bumps began, on each group of the suite played on a fixed map."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pico_gym.world.catalog import load_shipped

    names = list(results)
    fixed = [(g.label, g.fixed_map) for g, _ in episodes.groups if g.fixed_map is not None]
    fig, axes = plt.subplots(1, max(1, len(fixed)), figsize=(5 * max(1, len(fixed)), 5), dpi=110, squeeze=False)
    start = {name: 0 for name in names}
    for group, seeds in episodes.groups:
        index = next((i for i, (g, _) in enumerate(fixed) if g == group.label), None)
        for n in names:
            chunk = results[n][start[n] : start[n] + len(seeds)]
            start[n] += len(seeds)
            if index is None:
                continue
            xy = np.array([p for r in chunk for p in r.bump_xy]).reshape(-1, 2)
            axes[0, index].plot(xy[:, 0], xy[:, 1], "x", color=colour(n), ms=7, mew=2, label=f"{n} ({len(xy)})")
    for i, (label, map_name) in enumerate(fixed):
        ax = axes[0, i]
        world = load_shipped(map_name)
        for x0, y0, x1, y1 in np.vstack([world.wall_segments, world.cabinet_segments]):
            ax.plot([x0, x1], [y0, y1], color="black", lw=1)
        ax.set_aspect("equal")
        ax.set_title(f"bumps, {label}", fontsize=9)
        ax.legend(fontsize=7, loc="best")
        ax.set_xticks([])
        ax.set_yticks([])
    fig.tight_layout()
    fig.savefig(out / "bumps.png")
    plt.close(fig)
    return out / "bumps.png"


def plot_trajectories(
    out: Path,
    agents: Sequence[str],
    episodes: Episodes,
    n_rooms: int = 3,
    agent_kwargs: dict[str, dict[str, Any]] | None = None,
) -> Path:
    """Each agent's true path in the first `n_rooms` episodes (replayed: episodes are deterministic);
    in a suite of several groups, the first episode of each."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    agent_kwargs = agent_kwargs or {}
    if len(episodes.groups) > 1:
        picks = [(g, seeds[0]) for g, seeds in episodes.groups][:n_rooms]
    else:
        picks = [(g, s) for g, seeds in episodes.groups for s in seeds][:n_rooms]
    cols = min(3, len(picks))
    rows = -(-len(picks) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 4.4 * rows), dpi=110, squeeze=False)
    for ax in axes.flat[len(picks) :]:
        ax.axis("off")
    for ax, (group, seed) in zip(axes.flat, picks, strict=False):
        env = gym.make(episodes.env_id, **episodes.env_kwargs(group))
        world = None
        for name in agents:
            agent = make_agent(name, env, **agent_kwargs.get(name, {}))
            record = run_episode(env, agent, seed, name)
            base = pico_env(env)
            world = base.scene.map
            path = np.array([(p.x, p.y) for p in base.trajectory])
            label = f"{name}: {record.termination_reason} {record.time_s:.0f} s"
            ax.plot(path[:, 0], path[:, 1], lw=1.4, color=colour(name), label=label)
            if record.bumps:
                ax.plot(*path[-1], "x", color="red", ms=8, mew=2)
        assert world is not None
        base = pico_env(env)
        for x0, y0, x1, y1 in base.scene.static_seen:
            ax.plot([x0, x1], [y0, y1], color="black", lw=1.5)
        if world.finish is not None:
            f = np.asarray(world.finish)
            ax.plot(f[:, 0], f[:, 1], color="green", lw=1, ls="--")
        start = base.trajectory[0]
        ax.plot(start.x, start.y, "o", color="black", ms=5)
        ax.set_aspect("equal")
        ax.set_title(f"{group.label}, seed {seed}", fontsize=9)
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
    progress: Callable[[int], Any] | None = None,
    ray_address: str | None = None,
) -> dict[str, Summary]:
    """Run, write results.{md,json,csv} and the plots into `out`; returns the summaries.

    What could fail after the episodes (matplotlib missing, an output folder that cannot be made,
    an agent that cannot be built) is checked before the first one.
    """
    require("matplotlib", "plots", "pico-gym compare's plots")
    if episodes.env_options.get("arrival") == "announce":
        # The floor baselines play the announcing episodes too, never announcing.
        silent = [n for n in agents if AGENT_ENTRIES[n].may_stay_silent]
        agent_kwargs = {
            **(agent_kwargs or {}),
            **{n: {"never_announce": True, **(agent_kwargs or {}).get(n, {})} for n in silent},
        }
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    probe = gym.make(episodes.env_id, **episodes.env_kwargs(episodes.groups[0][0]))
    for name in agents:
        make_agent(name, probe, **(agent_kwargs or {}).get(name, {}))
    probe.close()
    results = run_comparison(agents, episodes, agent_kwargs, workers, progress, ray_address)
    return report(results, episodes, out, n_rooms, agent_kwargs, settings_of(agents, episodes, agent_kwargs))


def report(
    results: dict[str, list[EpisodeRecord]],
    episodes: Episodes,
    out: Path,
    n_rooms: int = 3,
    agent_kwargs: dict[str, dict[str, Any]] | None = None,
    settings: dict[str, Any] | None = None,
) -> dict[str, Summary]:
    """results.{md,json,csv} and the figures of records already run (`n_rooms` > 0 replays the
    trajectories' episodes); returns the summaries."""
    require("matplotlib", "plots", "pico-gym compare's plots")
    out.mkdir(parents=True, exist_ok=True)
    agents = list(results)
    settings = settings or settings_of(agents, episodes, agent_kwargs)
    summaries = write_results(out, results, settings, episodes)
    plot_results(out, results, summaries)
    figures = task_info(episodes.env_id).load_metrics().figures
    if "legs" in figures:
        plot_legs(out, results)
    if "bumps" in figures:
        plot_bumps(out, results, episodes)
    if n_rooms > 0:
        plot_trajectories(out, agents, episodes, n_rooms, agent_kwargs)
    return summaries
