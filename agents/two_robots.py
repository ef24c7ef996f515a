"""Two robots in one world, benchmarked: each driven by its own single-robot agent.

`pico-gym bench --robots 2` plays episodes of `pico_gym.multi.PicoParallelEnv` with the same agent
for both robots ("pico" and "taco"), each agent seeing only its own robot's observation (its
env, `robot_env`, is what it was built for), and reports both: success (both done), each robot's
success and time, and the bumps of one robot into the other.
"""

from __future__ import annotations

import statistics
from dataclasses import asdict, dataclass
from typing import Any

from pico_gym.agents.registry import make_agent


@dataclass(frozen=True)
class TwoRobotRecord:
    """One two-robot episode: per robot, success, time, reason and bumps by kind."""

    seed: int
    success: dict[str, bool]
    time_s: dict[str, float]
    reason: dict[str, str]
    bumps: dict[str, dict[str, int]]

    @property
    def both(self) -> bool:
        return all(self.success.values())

    @property
    def robot_bumps(self) -> int:
        return sum(b.get("robot", 0) for b in self.bumps.values())

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "both": self.both, "robot_bumps": self.robot_bumps}


def run_two_robots(
    env_id: str,
    agent: str,
    seeds: range,
    env_options: dict[str, Any],
    agent_kwargs: dict[str, Any] | None = None,
    progress: Any = None,
) -> list[TwoRobotRecord]:
    """Play the seeds' episodes with `agent` driving each robot."""
    from pico_gym.multi import parallel_env, robot_env

    env = parallel_env(env_id, n_robots=2, **env_options)
    agents = {name: make_agent(agent, robot_env(env, name), **(agent_kwargs or {})) for name in env.possible_agents}
    records = []
    for seed in seeds:
        obs, infos = env.reset(seed=seed)
        for name, a in agents.items():
            a.reset(obs[name], infos[name])
        last = dict(infos)
        while env.agents:
            actions = {name: agents[name].act(obs[name]) for name in env.agents}
            obs, _, _, _, infos = env.step(actions)
            last.update(infos)
        records.append(
            TwoRobotRecord(
                seed,
                {n: bool(i["is_success"]) for n, i in last.items()},
                {n: float(i["sim_time"]) for n, i in last.items()},
                {n: str(i["termination_reason"]) for n, i in last.items()},
                {n: dict(i["bumps_by_kind"]) for n, i in last.items()},
            )
        )
        if progress is not None:
            progress(1)
    env.close()
    return records


def summary_table(agent: str, records: list[TwoRobotRecord]) -> str:
    """The bench's table: both done, per robot success and median time, robot-robot bumps."""
    n = len(records)
    names = list(records[0].success) if records else []
    rows = [
        "| agent | episodes | both done | "
        + " | ".join(f"{r} success | {r} time median" for r in names)
        + " | episodes with a robot-robot bump | other bumps |",
        "|---|---:|---:|" + "---:|---:|" * len(names) + "---:|---:|",
    ]
    cells = [agent, str(n), f"{100 * sum(r.both for r in records) / max(n, 1):.1f} %"]
    for name in names:
        times = [r.time_s[name] for r in records if r.success[name]]
        cells.append(f"{100 * sum(r.success[name] for r in records) / max(n, 1):.1f} %")
        cells.append(f"{statistics.median(times):.1f} s" if times else "-")
    cells.append(f"{sum(r.robot_bumps > 0 for r in records)}")
    other = sum(sum(v for k, v in b.items() if k != "robot") for r in records for b in r.bumps.values())
    cells.append(f"{other}")
    rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows)


def failures(records: list[TwoRobotRecord]) -> str:
    bad = [r for r in records if not r.both]
    return ", ".join(f"{r.seed}:" + "/".join(f"{n}={r.reason[n]}" for n in r.reason) for r in bad[:20]) or "-"
