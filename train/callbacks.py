"""The callbacks of a training run: episode statistics, periodic evaluations that keep the best
policy, a STOP file that ends the run cleanly, and checkpoints written whole or not at all."""

from __future__ import annotations

import csv
import os
import time
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from pico_gym.agents.base import RobotSpec
from pico_gym.agents.evaluation import run_episode, summarize
from pico_gym.agents.ppo import PpoAgent, save_policy
from pico_gym.train.checkpoints import record_written
from pico_gym.train.config import EVAL_SEED_START, TrainConfig, goal_metadata
from pico_gym.train.envs import make_plain_env


def policy_agent(config: TrainConfig, spec: RobotSpec, model: Any) -> Any:
    """The agent that plays a policy in memory the way the config trains it (`pico-gym.agent`)."""
    if config.pico["agent"] == "hybrid":
        from pico_gym.agents.hybrid import HybridAgent, HybridConfig

        # Evaluated with the cuts it is trained with.
        hybrid = HybridConfig(**config.hybrid_kwargs)
        return HybridAgent(spec, model=model, learning=config.learning, hybrid=hybrid)
    return PpoAgent(spec, model=model, learning=config.learning)


class EpisodeStats(BaseCallback):
    """Logs success rate, time to success and bumps over the last 100 finished training episodes
    (under `escape/`, the name the first task gave them and the learning curves read)."""

    def __init__(self) -> None:
        super().__init__()
        self.episodes: deque[tuple[bool, float, int, str]] = deque(maxlen=100)

    def _on_step(self) -> bool:
        for done, info in zip(self.locals["dones"], self.locals["infos"], strict=True):
            if done:
                self.episodes.append(
                    (
                        bool(info["is_success"]),
                        float(info["sim_time"]),
                        int(info["bumps"]),
                        str(info["termination_reason"]),
                    )
                )
        return True

    def _on_rollout_end(self) -> None:
        if not self.episodes:
            return
        eps = self.episodes
        times = [t for ok, t, _, _ in eps if ok]
        self.logger.record("escape/success_rate", float(np.mean([ok for ok, _, _, _ in eps])))
        self.logger.record("escape/bump_rate", float(np.mean([b > 0 for _, _, b, _ in eps])))
        self.logger.record("escape/timeout_rate", float(np.mean([r == "timeout" for *_, r in eps])))
        self.logger.record("escape/idle_rate", float(np.mean([r == "idle" for *_, r in eps])))
        if times:
            self.logger.record("escape/time_median_s", float(np.median(times)))


class PeriodicEval(BaseCallback):
    """Every `freq` env steps: the deterministic policy on fixed evaluation seeds; keeps the best."""

    def __init__(self, config: TrainConfig, run_dir: Path, freq: int, episodes: int) -> None:
        super().__init__()
        self.config, self.run_dir, self.freq, self.episodes = config, run_dir, freq, episodes
        self.next_at = 0
        self.best = -np.inf
        self.env = make_plain_env(config, **config.pico["env_kwargs"])
        self.csv = run_dir / "eval.csv"
        self.clock_before_s = 0.0  # the run's wall clock before this session (set by train)

    def _on_training_start(self) -> None:
        self.next_at = (self.num_timesteps // self.freq + 1) * self.freq
        if self.csv.exists():
            rows = list(csv.DictReader(self.csv.open()))
            self.best = max((float(r["score"]) for r in rows), default=-np.inf)

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next_at:
            self.next_at += self.freq
            self.evaluate()
        return True

    def evaluate(self) -> dict[str, float]:
        learning = self.config.learning
        agent = policy_agent(self.config, RobotSpec.of(self.env), self.model)
        seeds = range(EVAL_SEED_START, EVAL_SEED_START + self.episodes)
        s = summarize([run_episode(self.env, agent, seed, agent.name) for seed in seeds], self.config.env_id)
        score = s.success_rate - s.bump_rate  # bumps end episodes too; count them twice
        row = {
            "timesteps": self.num_timesteps,
            "wall_clock_s": round(self.clock_before_s + time.time() - self.model.start_time / 1e9, 1),
            "success_rate": s.success_rate,
            "bump_rate": s.bump_rate,
            "timeout": s.timeout,
            "idle": s.idle,
            "time_median_s": s.time_median_s,
            "sct_median": s.sct_median,
            "score": score,
        }
        for key in ("success_rate", "bump_rate", "time_median_s", "sct_median"):
            self.logger.record(f"eval/{key}", row[key])
        new = not self.csv.exists()
        with self.csv.open("a", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(row))
            if new:
                writer.writeheader()
            writer.writerow(row)
        if score > self.best:
            self.best = score
            save_policy(
                self.model,
                self.run_dir / "best",
                learning,
                env_id=self.config.env_id,
                env_kwargs=self.config.pico["env_kwargs"],
                timesteps=self.num_timesteps,
                **goal_metadata(self.config),
            )
        return row


class StopFile(BaseCallback):
    """Ends training cleanly (final save, plots) when `run_dir/STOP` appears."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.path = path

    def _on_step(self) -> bool:
        return self.n_calls % 256 != 0 or not self.path.exists()


class AtomicCheckpoints(BaseCallback):
    """Checkpoints every `save_freq` calls, written to a temporary file and renamed into place,
    so a kill while saving leaves the previous checkpoints intact."""

    def __init__(self, save_freq: int, folder: Path, save_vecnormalize: bool) -> None:
        super().__init__()
        self.save_freq, self.folder, self.save_vecnormalize = save_freq, Path(folder), save_vecnormalize

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq:
            return True
        self.folder.mkdir(parents=True, exist_ok=True)
        steps = self.num_timesteps
        normalizer = self.model.get_vec_normalize_env()
        if self.save_vecnormalize and normalizer is not None:
            tmp = self.folder / f".ppo_vecnormalize_{steps}_steps.pkl.tmp"
            normalizer.save(str(tmp))
            os.replace(tmp, self.folder / f"ppo_vecnormalize_{steps}_steps.pkl")
            record_written(self.folder / f"ppo_vecnormalize_{steps}_steps.pkl")
        tmp = self.folder / f".ppo_{steps}_steps.tmp.zip"
        self.model.save(tmp)
        os.replace(tmp, self.folder / f"ppo_{steps}_steps.zip")  # the zip last: it marks a whole checkpoint
        record_written(self.folder / f"ppo_{steps}_steps.zip")
        return True
