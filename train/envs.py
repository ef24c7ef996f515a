"""The envs a training run steps and evaluates on: episode seeds, the config's wrappers, a
Monitor, and the training VecEnv (SB3's DummyVecEnv or SubprocVecEnv, or pico-gym's vector env).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from pico_gym.train.config import TRAIN_SEED_MIN, TrainConfig, exit_goal_kwargs, wrapper_entry


class EpisodeSeeds(gym.Wrapper):
    """Reset every episode with a fresh seed from [TRAIN_SEED_MIN, 2**31), drawn from `rng`."""

    def __init__(self, env: gym.Env, rng: np.random.Generator) -> None:
        super().__init__(env)
        self.rng = rng

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        return self.env.reset(seed=int(self.rng.integers(TRAIN_SEED_MIN, 2**31)), options=options)


def apply_wrappers(env: gym.Env, entries: list[Any]) -> gym.Env:
    for entry in entries:
        name, kwargs = wrapper_entry(entry)
        module, _, cls = name.rpartition(".")
        env = getattr(importlib.import_module(module), cls)(env, **(kwargs or {}))
    return env


def train_env_kwargs(config: TrainConfig, index: int = 0) -> dict[str, Any]:
    """The kwargs of training env `index`: env_kwargs, then train_env_kwargs, then its variant.

    `train_env_variants` (a list of kwargs dicts) is domain randomisation across the vector env:
    env i takes variant i % len(variants), e.g. half the envs with boxes, some with harsher sensors.
    """
    variants = config.pico["train_env_variants"]
    variant = variants[index % len(variants)] if variants else {}
    return {**config.pico["env_kwargs"], **config.pico["train_env_kwargs"], **variant}


def make_plain_env(config: TrainConfig, **kwargs: Any) -> gym.Env:
    """An env for evaluation and demonstrations: `gym.make` with `kwargs`, plus what fills
    `obs["point_goal"]` when the policy sees one (`point_goal_source`: the privileged
    `PrivilegedPointGoal`, or `ExitGoalObservation` with the config's own arguments; the training
    envs get it from the config's env_wrapper list)."""
    env = gym.make(config.env_id, **kwargs)
    if config.learning.point_goal and config.pico["agent"] != "hybrid":  # the hybrid agent computes its own
        if config.pico["point_goal_source"] == "exit":
            from pico_gym.agents.exit_goal import ExitGoalObservation

            return ExitGoalObservation(env, **exit_goal_kwargs(config))
        from pico_gym.wrappers import PrivilegedPointGoal

        env = PrivilegedPointGoal(env)
    return env


def make_training_env(config: TrainConfig, rng: np.random.Generator, index: int = 0) -> gym.Env:
    """One training env: the env, per-episode training seeds, the config's wrappers, a Monitor."""
    from stable_baselines3.common.monitor import Monitor

    env = gym.make(config.env_id, **train_env_kwargs(config, index))
    env = EpisodeSeeds(env, rng)
    return Monitor(apply_wrappers(env, config.zoo["env_wrapper"]))


def make_training_vec_env(config: TrainConfig, seed: int, stream: int = 0) -> Any:
    """The training VecEnv; env i's seeds come from Generator((seed, i, stream))."""
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecMonitor

    n = int(config.zoo["n_envs"])
    if config.pico["vec_env"] == "vector":
        from pico_gym.train.sb3_vec import PicoTrainingVecEnv

        rngs = [np.random.default_rng([seed, i, stream]) for i in range(n)]
        return VecMonitor(PicoTrainingVecEnv(config.env_id, rngs, config.learning, **train_env_kwargs(config)))

    def factory(i: int) -> Callable[[], gym.Env]:
        return lambda: make_training_env(config, np.random.default_rng([seed, i, stream]), i)

    factories = [factory(i) for i in range(n)]
    return SubprocVecEnv(factories) if config.pico["vec_env"] == "subproc" else in_process_vec_env(factories)


def in_process_vec_env(factories: list[Any]) -> Any:
    """SB3's DummyVecEnv without its deep copy of every step's infos: pico-gym envs hand out a new
    info dict each step (as gymnasium asks), so copying it again only costs time (about 10 us an
    env step, measured). What the VecEnv returns is otherwise DummyVecEnv's (tested)."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    class FreshInfoDummyVecEnv(DummyVecEnv):
        def step_wait(self) -> Any:
            for i, env in enumerate(self.envs):
                obs, self.buf_rews[i], terminated, truncated, info = env.step(self.actions[i])
                self.buf_dones[i] = terminated or truncated
                info["TimeLimit.truncated"] = truncated and not terminated
                if self.buf_dones[i]:
                    info["terminal_observation"] = obs
                    obs, self.reset_infos[i] = env.reset()
                self._save_obs(i, obs)
                self.buf_infos[i] = info
            return self._obs_from_buf(), np.copy(self.buf_rews), np.copy(self.buf_dones), list(self.buf_infos)

    return FreshInfoDummyVecEnv(factories)
