"""A new task, registered from a test, plays through `pico-gym bench` and `compare` untouched.

This is the worked example of docs/adding-a-task.md: a beacon in a small room (drive to a point
drawn per episode). It touches no file of pico-gym: its env class, task, world and metrics live
here, and one `register_task` call (plus, for an agent of its own, one `register_agent`) makes
the command lines, the comparison and the shipped baseline agents play it.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from pico_gym.agents.base import Agent, RobotSpec
from pico_gym.agents.registry import AgentEntry, register_agent, unregister_agent
from pico_gym.cli import main
from pico_gym.envs.base import EnvConfig, PicoEnv
from pico_gym.metrics import EpisodeMetrics
from pico_gym.registry import Suite, SuiteGroup, TaskInfo, register_task, task_info, unregister_task
from pico_gym.tasks.base import ConfiguredTask, Episode, IdleRule, StepContext, StepOutcome
from pico_gym.types import Pose
from pico_gym.world.map import Map, map_from_dict
from pico_gym.world.scene import Scene

ENV_ID = "PicoBeaconTest-v0"


# --- the world module: a 3 x 2 m room ------------------------------------------------------
def beacon_room() -> Map:
    corners = [[0.0, 0.0], [3.0, 0.0], [3.0, 2.0], [0.0, 2.0]]
    return map_from_dict({"name": "beacon_room", "points": corners, "walls": [[0, 1], [1, 2], [2, 3], [3, 0]]})


# --- the task module ------------------------------------------------------------------------
@dataclass(frozen=True)
class BeaconTaskConfig:
    """Reach within `radius_m` of a beacon drawn per episode, in `time_limit_s`."""

    radius_m: float = 0.3
    time_limit_s: float = 20.0
    idle_rule: IdleRule = field(default_factory=IdleRule)


class BeaconTask(ConfiguredTask):
    termination_reasons = ("reached", "bump", "idle", "timeout")
    option_keys: frozenset[str] = frozenset()
    goal_name = "the beacon"

    def __init__(self, config: BeaconTaskConfig) -> None:
        self.config = config
        self.world = beacon_room()
        self.beacon = (0.0, 0.0)

    def _distance(self, pose: Pose) -> float:
        return math.hypot(pose.x - self.beacon[0], pose.y - self.beacon[1])

    def new_episode(self, rng: np.random.Generator, options: dict[str, Any], start: Pose | None) -> Episode:
        self.beacon = (float(rng.uniform(2.2, 2.6)), float(rng.uniform(0.6, 1.4)))
        if start is None:
            start = Pose(0.6, float(rng.uniform(0.7, 1.3)), float(rng.uniform(-0.3, 0.3)))
        return Episode(Scene(self.world), start, self._distance(start) - self.config.radius_m)

    def evaluate(self, ctx: StepContext) -> StepOutcome:
        before, after = self._distance(ctx.pose_before), self._distance(ctx.pose)
        reached = after <= self.config.radius_m
        reason = "reached" if reached else "bump" if ctx.new_bumps else "idle" if ctx.idle_s >= 30.0 else None
        return StepOutcome({"progress": before - after, "bump": -10.0 * ctx.new_bumps}, reason, reached)

    def info(self) -> dict[str, Any]:
        return {"beacon": self.beacon}


# --- the env file -------------------------------------------------------------------------
class BeaconEnv(PicoEnv):
    """Drive to the beacon (a test task)."""

    def __init__(self, render_mode: str | None = None, config: EnvConfig | None = None, **options: Any) -> None:
        env_config = EnvConfig.make(config, task=BeaconTaskConfig(), **options)
        super().__init__(BeaconTask(env_config.task), env_config, render_mode)


# --- its metrics block ------------------------------------------------------------------------
class BeaconMetrics(EpisodeMetrics):
    """How far from the beacon each episode ended."""

    columns = (("final distance", lambda s: f"{s.metrics['median_final_distance_m']:.2f} m"),)

    def finish(self, env: Any, info: dict[str, Any], agent: Any) -> dict[str, Any]:
        (bx, by), (x, y, _) = info["beacon"], info["pose"]
        return {"final_distance_m": math.hypot(x - bx, y - by)}

    @classmethod
    def summarize(cls, records: list[Any]) -> dict[str, Any]:
        return {"median_final_distance_m": float(np.median([r.metrics["final_distance_m"] for r in records]))}

    @classmethod
    def summary_rows(cls, block: dict[str, Any]) -> list[tuple[str, str]]:
        return [("final distance (median)", f"{block['median_final_distance_m']:.2f} m")]


# --- an agent of its own: drive at the beacon by dead reckoning from where it starts ------------
class StraightAhead(Agent):
    """Drives forward, steering to keep its heading (odometry only: what a robot senses)."""

    name = "straight"

    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:
        self._heading = float(obs["odom"][2])

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        turn = -2.0 * (float(obs["odom"][2]) - self._heading)
        return np.array([0.4, 0.0, max(-1.0, min(1.0, turn))], dtype=np.float32)


def build_straight(env: gym.Env, **kwargs: Any) -> Agent:
    return StraightAhead(RobotSpec.of(env))


# --- the one registration ---------------------------------------------------------------------
BEACON = TaskInfo(
    ENV_ID,
    f"{__name__}:BeaconEnv",
    worlds="rooms",
    default_agent="straight",
    metrics=f"{__name__}:BeaconMetrics",
    suites=(
        Suite("generated", "the beacon room", (SuiteGroup("generated"),), dev_seeds=10, test_seeds=20, episodes=4),
    ),
)


@pytest.fixture
def beacon_task():
    register_task(BEACON)
    register_agent(AgentEntry("straight", {ENV_ID: f"{__name__}:build_straight"}))
    yield
    unregister_agent("straight")
    unregister_task(ENV_ID)


def test_the_task_is_a_gymnasium_env(beacon_task):
    from gymnasium.utils.env_checker import check_env

    env = gym.make(ENV_ID)
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=3)
    assert info["beacon"] and task_info(ENV_ID).default_agent == "straight"


def test_bench_plays_the_new_task(beacon_task, tmp_path: Path, capsys):
    out = tmp_path / "bench.json"
    code = main(["bench", "--env", ENV_ID, "--suite", "generated", "--split", "dev", "--json", str(out), "--quiet"])
    assert code == 0
    text = capsys.readouterr().out
    assert "final distance (median)" in text  # the task's own summary rows
    payload = json.loads(out.read_text())
    episodes = payload["episodes"]
    assert [e["seed"] for e in episodes] == [10, 11, 12, 13]
    assert all("final_distance_m" in e["metrics"] for e in episodes)
    # The straight driver reaches a beacon straight ahead of it; the records say so.
    assert sum(e["success"] for e in episodes) >= 1


def test_compare_plays_the_new_task(beacon_task, tmp_path: Path):
    pytest.importorskip("matplotlib")
    args = ["compare", "--env", ENV_ID, "--agents", "straight,random", "--episodes", "3", "--quiet"]
    code = main([*args, "--out", str(tmp_path)])
    assert code == 0
    table = (tmp_path / "results.md").read_text()
    assert "straight" in table and "random" in table and "final distance" in table
    results = json.loads((tmp_path / "results.json").read_text())
    assert results["settings"]["env_id"] == ENV_ID
