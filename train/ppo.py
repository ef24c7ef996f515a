"""Training PPO (stable-baselines3) on pico-gym envs from a YAML config.

The config has rl-zoo3's layout for the env's block (n_envs, n_timesteps, policy, env_wrapper,
policy_kwargs and PPO's hyper-parameters) plus a `pico-gym:` block with this pipeline's own
settings. A run directory holds:

    config.yaml        the resolved config (after command-line overrides), versions, machine
    checkpoints/       ppo_<steps>_steps.zip every checkpoint_freq env steps
    tb/                TensorBoard logs (rollout/, escape/ success rate, escape time, bumps; eval/)
    progress.csv       the same figures as CSV
    eval.csv           periodic evaluations on seeds disjoint from training's
    model.zip/.json    the final policy (load with make_agent("ppo", env, path=...))
    best.zip/.json     the policy of the best evaluation
    learning_curve.png success rate vs env steps

`touch RUN/STOP` ends a run cleanly (final save, plot); the same command resumes it.

Training episodes draw their seeds from [TRAIN_SEED_MIN, 2**31), so their rooms never coincide
with evaluation seeds (EVAL_SEED_START.., and the < 1e6 seeds of bench and compare).
"""

from __future__ import annotations

import copy
import csv
import importlib
import json
import math
import os
import platform
import re
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import yaml

import pico_gym
from pico_gym.agents.base import RobotSpec
from pico_gym.agents.evaluation import run_episode, summarize
from pico_gym.agents.ppo import PpoAgent, save_policy
from pico_gym.wrappers import LearningConfig

TRAIN_SEED_MIN = 1_000_000
EVAL_SEED_START = 900_000
PICO_KEY = "pico-gym"
PICO_DEFAULTS: dict[str, Any] = {
    "env_kwargs": {},
    "train_env_kwargs": {},
    "train_env_variants": [],
    "vec_env": "dummy",
    "torch_threads": 1,
    "checkpoint_freq": 250_000,
    "eval_freq": 250_000,
    "eval_episodes": 100,
    "bc_episodes": 0,
    "bc_epochs": 10,
    "bc_log_std": None,
    "bc_announce": "teacher",
    "agent": "ppo",
    "point_goal_source": "privileged",
}
# Where a point-goal policy's `obs["point_goal"]` comes from (a config's `point_goal_source`):
# the env's true state (`pico_gym.wrappers.PrivilegedPointGoal`, the hospital's end-to-end
# baseline) or the escape room's exit as the robot's own perception tracks it
# (`pico_gym.agents.exit_goal.ExitGoalObservation`: not privileged).
POINT_GOAL_SOURCES = ("privileged", "exit")
# What plays a trained policy in evaluations: the policy alone, or the hybrid hospital agent (the
# classic agent with the policy driving between its waypoints; its env_wrapper is
# pico_gym.train.hybrid.HybridTraining).
POLICY_AGENTS = ("ppo", "hybrid")
# The training VecEnv: SB3's DummyVecEnv (in-process) or SubprocVecEnv over wrapped single envs,
# or pico-gym's vector env with the learning encoder (`pico_gym.train.sb3_vec.PicoTrainingVecEnv`:
# the same episodes, bit for bit; its env_wrapper must be PicoLearningWrapper alone, no variants).
VEC_ENVS = ("dummy", "subproc", "vector")
# `policy: MirrorMlpPolicy`: the MLP policy with a mirror-symmetric actor (`pico_gym.train.mirror`).
MIRROR_POLICY = "MirrorMlpPolicy"
# HybridTraining settings a saved hybrid policy carries into its agent (beyond the defaults).
HYBRID_TRAINED_CUTS = ("walk_in_mps", "back_budget_m")
# Keys of the env block that are not PPO constructor arguments (rl-zoo3's meaning).
ZOO_KEYS = {"n_envs", "n_timesteps", "policy", "env_wrapper", "policy_kwargs", "normalize", "frame_stack"}


class ConfigError(ValueError):
    """A training config that cannot be used; the message names the file and key."""


@dataclass
class TrainConfig:
    """A resolved training config."""

    env_id: str
    zoo: dict[str, Any]  # the rl-zoo3 block
    pico: dict[str, Any]  # pico-gym's block, defaults filled in
    source: str = ""

    @property
    def learning(self) -> LearningConfig:
        """The PicoLearningWrapper settings of the env_wrapper list."""
        for entry in self.zoo.get("env_wrapper") or []:
            name, kwargs = _wrapper_entry(entry)
            if name.endswith("PicoLearningWrapper"):
                return LearningConfig(**(kwargs or {}))
        raise ConfigError(f"{self.source}: env_wrapper must include pico_gym.wrappers.PicoLearningWrapper")

    @property
    def hybrid_kwargs(self) -> dict[str, Any]:
        """The HybridTraining settings of the env_wrapper list (`HybridConfig` fields; {} if none)."""
        for entry in self.zoo.get("env_wrapper") or []:
            name, kwargs = _wrapper_entry(entry)
            if name.endswith("HybridTraining"):
                return dict(kwargs or {})
        return {}

    def to_yaml(self, extra: dict[str, Any] | None = None) -> str:
        return yaml.safe_dump({self.env_id: self.zoo, PICO_KEY: self.pico, **(extra or {})}, sort_keys=False)


def _wrapper_entry(entry: Any) -> tuple[str, dict[str, Any] | None]:
    if isinstance(entry, str):
        return entry, None
    if isinstance(entry, dict) and len(entry) == 1:
        ((name, kwargs),) = entry.items()
        return name, kwargs
    raise ConfigError(f"env_wrapper entries are 'module.Class' or {{module.Class: {{kwargs}}}}, got {entry!r}")


def load_config(path: str | Path, env_id: str | None = None) -> TrainConfig:
    """Read a training YAML; errors name the file and the key.

    `env_id`: the env block to read; by default the file's only block besides `pico-gym:`.
    """
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"no training config at {path}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML ({exc})") from None
    if env_id is None and isinstance(data, dict):
        blocks = [k for k in data if k not in (PICO_KEY, "run")]
        if len(blocks) != 1:
            raise ConfigError(f"{path}: expected one env block (rl-zoo3 layout, e.g. 'PicoEscape-v0:'), got {blocks}")
        env_id = str(blocks[0])
        if env_id not in gym.registry:
            known = ", ".join(k for k in gym.registry if k.startswith("Pico"))
            raise ConfigError(f"{path}: {env_id!r} is not a registered env id (pico-gym's: {known})")
    if not isinstance(data, dict) or env_id not in data:
        raise ConfigError(f"{path}: no block for {env_id!r} (rl-zoo3 layout: a top-level key per env id)")
    zoo = dict(data[env_id])
    for key in ("n_envs", "n_timesteps", "policy", "env_wrapper"):
        if key not in zoo:
            raise ConfigError(f"{path}: {env_id}.{key} is missing")
    pico = dict(PICO_DEFAULTS)
    unknown = set(data.get(PICO_KEY) or {}) - set(PICO_DEFAULTS)
    if unknown:
        raise ConfigError(f"{path}: unknown key(s) {sorted(unknown)} in {PICO_KEY}; known: {sorted(PICO_DEFAULTS)}")
    pico.update(data.get(PICO_KEY) or {})
    if pico["agent"] not in POLICY_AGENTS:
        raise ConfigError(f"{path}: {PICO_KEY}.agent must be one of {POLICY_AGENTS}, got {pico['agent']!r}")
    if pico["bc_announce"] not in ("teacher", "arrival"):
        raise ConfigError(f"{path}: {PICO_KEY}.bc_announce must be 'teacher' or 'arrival', got {pico['bc_announce']!r}")
    arrival = {**(pico["env_kwargs"] or {}), **(pico["train_env_kwargs"] or {})}.get("arrival", "dwell")
    if pico["bc_announce"] == "arrival" and arrival != "announce":
        raise ConfigError(
            f"{path}: {PICO_KEY}.bc_announce 'arrival' labels the announcement, so the env needs arrival: announce "
            f"(got {arrival!r})"
        )
    if pico["point_goal_source"] not in POINT_GOAL_SOURCES:
        raise ConfigError(
            f"{path}: {PICO_KEY}.point_goal_source must be one of {POINT_GOAL_SOURCES}, "
            f"got {pico['point_goal_source']!r}"
        )
    if pico["vec_env"] not in VEC_ENVS:
        raise ConfigError(f"{path}: {PICO_KEY}.vec_env must be one of {VEC_ENVS}, got {pico['vec_env']!r}")
    variants = pico["train_env_variants"]
    if not isinstance(variants, list) or not all(isinstance(v, dict) for v in variants):
        raise ConfigError(f"{path}: {PICO_KEY}.train_env_variants must be a list of env kwargs dicts, got {variants!r}")
    config = TrainConfig(env_id, zoo, pico, str(path))
    if zoo["policy"] == MIRROR_POLICY and zoo.get("normalize"):
        raise ConfigError(f"{path}: {env_id}.policy {MIRROR_POLICY} reflects the raw input: it cannot take normalize")
    if config.learning.point_goal and pico["agent"] != "hybrid":
        wrappers = [_wrapper_entry(e)[0] for e in zoo["env_wrapper"] or []]
        wanted = {"privileged": "PrivilegedPointGoal", "exit": "ExitGoalObservation"}[pico["point_goal_source"]]
        if not any(w.rsplit(".", 1)[-1] == wanted for w in wrappers):
            raise ConfigError(
                f"{path}: {env_id}.env_wrapper needs {wanted} before the learning wrapper for point_goal with "
                f"{PICO_KEY}.point_goal_source {pico['point_goal_source']!r}; it has {wrappers}"
            )
    if pico["vec_env"] == "vector":
        check_vector(config)
    config.learning  # noqa: B018  (validates the wrapper entry now, not after minutes of setup)
    return config


# The activations a config may name as nn.<Name> in policy_kwargs.
ACTIVATIONS = ("ReLU", "Tanh", "ELU", "LeakyReLU", "GELU", "SiLU", "Sigmoid")


def check_vector(config: TrainConfig) -> None:
    """Raise ConfigError unless `vec_env: vector` can train this config: the same env kwargs for
    every robot (no train_env_variants) and the learning wrapper alone."""
    wrappers = [_wrapper_entry(e)[0] for e in config.zoo["env_wrapper"] or []]
    variants = config.pico["train_env_variants"] or []
    if variants or len(wrappers) != 1 or not wrappers[0].endswith("PicoLearningWrapper"):
        raise ConfigError(
            f"{config.source}: {PICO_KEY}.vec_env 'vector' steps every robot with the same env kwargs and the "
            f"learning wrapper alone; this config has env_wrapper {wrappers} and {len(variants)} "
            "train_env_variants: use vec_env: dummy"
        )
    if config.learning.trail_sectors:
        raise ConfigError(
            f"{config.source}: {PICO_KEY}.vec_env 'vector' encodes every robot in one call without an odometry "
            "trail; this config's PicoLearningWrapper has trail_sectors: use vec_env: dummy"
        )


def _policy_kwargs(text: str | dict[str, Any] | None, source: str) -> dict[str, Any]:
    """rl-zoo3 writes policy_kwargs as a Python expression, e.g. "dict(net_arch=[64, 64])".

    It is parsed as data, never evaluated: literals, `dict(key=value, ...)` and `nn.<Activation>`
    (one of ACTIVATIONS) only.
    """
    if text is None:
        return {}
    if isinstance(text, dict):
        return text
    import ast

    def value(node: ast.AST) -> Any:
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict" and not node.args:
            return {kw.arg: value(kw.value) for kw in node.keywords if kw.arg is not None}
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "nn":
            if node.attr not in ACTIVATIONS:
                raise ValueError(f"nn.{node.attr} is not one of the allowed activations {ACTIVATIONS}")
            import torch

            return getattr(torch.nn, node.attr)
        if isinstance(node, ast.Dict):
            return {value(k): value(v) for k, v in zip(node.keys, node.values, strict=True)}
        if isinstance(node, (ast.List, ast.Tuple)):
            items = [value(e) for e in node.elts]
            return items if isinstance(node, ast.List) else tuple(items)
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub) and isinstance(node.operand, ast.Constant):
            return -node.operand.value
        raise ValueError(f"{ast.unparse(node)!r} is not data (literals, dict(...), nn.<Activation>)")

    try:
        parsed = value(ast.parse(text, mode="eval").body)
    except (SyntaxError, ValueError) as exc:
        raise ConfigError(f"{source}: policy_kwargs {text!r}: {exc}") from None
    if not isinstance(parsed, dict):
        raise ConfigError(f"{source}: policy_kwargs must give a dict, got {parsed!r}")
    return parsed


# --- envs -----------------------------------------------------------------------------------
class EpisodeSeeds(gym.Wrapper):
    """Reset every episode with a fresh seed from [TRAIN_SEED_MIN, 2**31), drawn from `rng`."""

    def __init__(self, env: gym.Env, rng: np.random.Generator) -> None:
        super().__init__(env)
        self.rng = rng

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        return self.env.reset(seed=int(self.rng.integers(TRAIN_SEED_MIN, 2**31)), options=options)


def _apply_wrappers(env: gym.Env, entries: list[Any]) -> gym.Env:
    for entry in entries:
        name, kwargs = _wrapper_entry(entry)
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

            return ExitGoalObservation(env, **_exit_goal_kwargs(config))
        from pico_gym.wrappers import PrivilegedPointGoal

        env = PrivilegedPointGoal(env)
    return env


def goal_metadata(config: TrainConfig) -> dict[str, Any]:
    """What a saved policy's metadata says about its point goal (`PpoAgent` reads it): for a
    policy whose goal is the exit its own perception tracks, the `ExitGoal` arguments too; for a
    hybrid policy, the backing cut of its training loop."""
    if config.pico.get("agent") == "hybrid":
        # The hybrid computes its own goal; what it carries is the cuts it was trained with (the
        # agent drives with them: `HybridAgent` reads this).
        cuts = {k: v for k, v in config.hybrid_kwargs.items() if k in HYBRID_TRAINED_CUTS}
        return {"hybrid": cuts} if cuts else {}
    if not config.learning.point_goal:
        return {}
    source = config.pico.get("point_goal_source", "privileged")
    if source != "exit":
        return {"point_goal_source": source}
    return {"point_goal_source": "exit", "exit_goal": _exit_goal_kwargs(config)}


def _exit_goal_kwargs(config: TrainConfig) -> dict[str, Any]:
    """The arguments the config's env_wrapper gives ExitGoalObservation ({} when none)."""
    given = [_wrapper_entry(e) for e in config.zoo["env_wrapper"] or []]
    return dict(next((k or {} for name, k in given if name.endswith("ExitGoalObservation")), {}))


def make_env(config: TrainConfig, rng: np.random.Generator, index: int = 0) -> gym.Env:
    """One training env: the env, per-episode training seeds, the config's wrappers, a Monitor."""
    from stable_baselines3.common.monitor import Monitor

    env = gym.make(config.env_id, **train_env_kwargs(config, index))
    env = EpisodeSeeds(env, rng)
    return Monitor(_apply_wrappers(env, config.zoo["env_wrapper"]))


def make_vec_env(config: TrainConfig, seed: int, stream: int = 0) -> Any:
    """The training VecEnv; env i's seeds come from Generator((seed, i, stream))."""
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecMonitor

    n = int(config.zoo["n_envs"])
    if config.pico["vec_env"] == "vector":
        from pico_gym.train.sb3_vec import PicoTrainingVecEnv

        rngs = [np.random.default_rng([seed, i, stream]) for i in range(n)]
        return VecMonitor(PicoTrainingVecEnv(config.env_id, rngs, config.learning, **train_env_kwargs(config)))
    factories = [(lambda i=i: make_env(config, np.random.default_rng([seed, i, stream]), i)) for i in range(n)]
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


# --- callbacks ------------------------------------------------------------------------------
def _callbacks() -> Any:
    from stable_baselines3.common.callbacks import BaseCallback

    class EscapeStats(BaseCallback):
        """Logs success rate, escape time and bumps over the last 100 finished training episodes."""

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
            s = summarize([run_episode(self.env, agent, seed, agent.name) for seed in seeds])
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

    return EscapeStats, PeriodicEval, StopFile


def policy_agent(config: TrainConfig, spec: RobotSpec, model: Any) -> Any:
    """The agent that plays a policy in memory the way the config trains it (`pico-gym.agent`)."""
    if config.pico["agent"] == "hybrid":
        from pico_gym.agents.hybrid import HybridAgent, HybridConfig

        # Evaluated with the cuts it is trained with.
        hybrid = HybridConfig(**config.hybrid_kwargs)
        return HybridAgent(spec, model=model, learning=config.learning, hybrid=hybrid)
    return PpoAgent(spec, model=model, learning=config.learning)


# --- behaviour cloning ---------------------------------------------------------------------
def collect_demonstrations(config: TrainConfig, episodes: int, teacher: str = "classic") -> tuple[Any, Any, dict]:
    """(policy inputs, unit actions) of `teacher` on `episodes` training-seed rooms, spread over
    `train_env_variants` as the training envs are (for a hybrid config: the classic part's own
    commands on the steps the policy is to drive)."""
    if config.pico["agent"] == "hybrid":
        return _hybrid_demonstrations(config, episodes)
    from pico_gym.agents import make_agent
    from pico_gym.wrappers import LearningEncoder, unit_action

    # Episode k in variant k % len (as the training envs): the teacher shows the whole mix.
    base = {**config.pico["env_kwargs"], **config.pico["train_env_kwargs"]}
    envs = [make_plain_env(config, **{**base, **v}) for v in config.pico["train_env_variants"] or [{}]]
    agents = [make_agent(teacher, e) for e in envs]
    spec = RobotSpec.of(envs[0])
    encoder = LearningEncoder(spec.lrf, spec.robot, spec.dt_s, config.learning)
    low, high = envs[0].action_space.low, envs[0].action_space.high
    # bc_announce "arrival": the announcement is labelled by where the robot stands (in the next
    # square and facing its cabinet within `ANNOUNCE_LABEL_MARGIN` of the tolerance), not by the
    # teacher's one announcement per cabinet: a label on every such step, a training signal only.
    by_arrival = config.pico["bc_announce"] == "arrival"
    xs, ys, successes = [], [], 0
    rng = np.random.default_rng([TRAIN_SEED_MIN, episodes])
    for k in range(episodes):
        env, agent = envs[k % len(envs)], agents[k % len(agents)]
        obs, info = env.reset(seed=int(rng.integers(TRAIN_SEED_MIN, 2**31)))
        agent.reset(obs, info)
        x = encoder.reset(obs)
        while True:
            action = np.asarray(agent.act(obs), np.float64)
            xs.append(x)
            y = unit_action(action, low, high)
            if by_arrival:
                y[3] = 1.0 if _announce_label(env, info) else -1.0
            ys.append(y)
            obs, _, terminated, truncated, info = env.step(action)
            if terminated or truncated:
                successes += bool(info["is_success"])
                break
            x = encoder.encode(obs)
    return np.asarray(xs, np.float32), np.asarray(ys, np.float32), {"teacher_success": successes / episodes}


ANNOUNCE_LABEL_MARGIN = 0.7


def _announce_label(env: gym.Env, info: dict[str, Any]) -> bool:
    """Whether the robot stands in the next arrival square facing its cabinet (with a margin)."""
    parts = info["arrival"]
    tolerance = env.unwrapped.task.config.facing_tolerance_rad
    return bool(parts["in_square"]) and abs(parts["heading_error"]) <= ANNOUNCE_LABEL_MARGIN * tolerance


def _hybrid_demonstrations(config: TrainConfig, episodes: int) -> tuple[Any, Any, dict]:
    from pico_gym.train.hybrid import HybridTraining
    from pico_gym.wrappers import LearningEncoder

    env = gym.make(config.env_id, **{**config.pico["env_kwargs"], **config.pico["train_env_kwargs"]})
    kwargs = {}
    for entry in config.zoo["env_wrapper"]:
        name, given = _wrapper_entry(entry)
        if name.endswith("HybridTraining"):
            kwargs = given or {}
    env = HybridTraining(env, **kwargs)
    spec = RobotSpec.of(env)
    encoder = LearningEncoder(spec.lrf, spec.robot, spec.dt_s, config.learning)
    xs, ys, successes = [], [], 0
    rng = np.random.default_rng([TRAIN_SEED_MIN, episodes])
    for _ in range(episodes):
        obs, info = env.reset(seed=int(rng.integers(TRAIN_SEED_MIN, 2**31)))
        x = encoder.reset(obs)
        while True:
            xs.append(x)
            ys.append(env.teacher_action())
            obs, _, terminated, truncated, info = env.step(np.array(env.driver.command))
            if terminated or truncated:
                successes += bool(info["is_success"])
                break
            x = encoder.encode(obs)
    return np.asarray(xs, np.float32), np.asarray(ys, np.float32), {"teacher_success": successes / episodes}


def behaviour_clone(model: Any, config: TrainConfig, episodes: int, epochs: int) -> dict[str, Any]:
    """Fit the policy's mean action to the classic agent's (MSE), before PPO fine-tunes it."""
    import torch

    started = time.perf_counter()
    xs, ys, report = collect_demonstrations(config, episodes)
    if config.zoo["policy"] == MIRROR_POLICY:  # a mirrored policy: the teacher's reflections too
        from pico_gym.train.mirror import mirrored_demonstrations

        xs, ys = mirrored_demonstrations(xs, ys, config.learning)
    policy = model.policy
    params = list(policy.mlp_extractor.policy_net.parameters()) + list(policy.action_net.parameters())
    params += list(policy.features_extractor.parameters())
    optimizer = torch.optim.Adam(params, lr=1e-3)
    x_all, y_all = torch.as_tensor(xs), torch.as_tensor(ys)
    generator = torch.Generator().manual_seed(0)
    losses = []
    for _ in range(epochs):
        order = torch.randperm(len(x_all), generator=generator)
        total = 0.0
        for i in range(0, len(order), 256):
            idx = order[i : i + 256]
            features = policy.extract_features(x_all[idx], policy.pi_features_extractor)
            mean = policy.action_net(policy.mlp_extractor.forward_actor(features))
            loss = torch.nn.functional.mse_loss(mean, y_all[idx])
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            total += loss.item() * len(idx)
        losses.append(total / len(order))
    report.update(
        samples=len(xs),
        episodes=episodes,
        epochs=epochs,
        mse_per_epoch=losses,
        seconds=round(time.perf_counter() - started, 1),
    )
    return report


# --- the run --------------------------------------------------------------------------------
def _readable_zip(path: Path) -> bool:
    """Whether a checkpoint zip is whole (a kill while writing leaves a partial or empty file)."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as z:
            return z.testzip() is None and "data" in z.namelist()
    except (OSError, zipfile.BadZipFile, EOFError):
        return False


def _zip_timesteps(path: Path) -> int:
    """The env steps a stable-baselines3 policy zip was trained for (its `data` record)."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as z:
            return int(json.loads(z.read("data"))["num_timesteps"])
    except (OSError, zipfile.BadZipFile, EOFError, KeyError, ValueError, TypeError) as err:
        raise ConfigError(f"--init-from {path}: not a stable-baselines3 policy zip ({err})") from None


def _readable_pickle(path: Path) -> bool:
    import pickle

    try:
        with path.open("rb") as f:
            pickle.load(f)  # our own run's statistics file (trusted: written by this trainer)
        return True
    except Exception:  # noqa: BLE001  (truncated or corrupt: any unpickling error)
        return False


def latest_checkpoint(run_dir: Path, needs_stats: bool = False) -> tuple[Path, int] | None:
    """The newest readable checkpoint in `run_dir/checkpoints` (and, with `needs_stats`, with a
    readable VecNormalize file beside it), if any; an unreadable newer one is reported and skipped."""
    found = []
    for p in (run_dir / "checkpoints").glob("ppo_*_steps.zip"):
        m = re.fullmatch(r"ppo_(\d+)_steps\.zip", p.name)
        if m:
            found.append((int(m.group(1)), p))
    for steps, path in sorted(found, reverse=True):
        stats = path.with_name(f"ppo_vecnormalize_{steps}_steps.pkl")
        if not _readable_zip(path):
            print(f"skipping {path.name}: not a whole checkpoint (a run killed while saving?)")
        elif needs_stats and not (stats.exists() and _readable_pickle(stats)):
            print(f"skipping {path.name}: its VecNormalize statistics {stats.name} are missing or unreadable")
        else:
            return path, steps
    return None


# Settings that change the model or what it observes: a resume must not change them silently.
MODEL_KEYS = ("policy", "policy_kwargs", "env_wrapper", "normalize", "frame_stack", "n_envs")
PICO_MODEL_KEYS = ("env_kwargs", "learning")


def _config_changes(run_dir: Path, config: TrainConfig) -> list[str]:
    """Keys that change the model or the observation and differ from the run's stored config."""
    stored_path = run_dir / "config.yaml"
    if not stored_path.exists():
        return []
    stored = yaml.safe_load(stored_path.read_text()) or {}
    zoo, pico = stored.get(config.env_id, {}), stored.get(PICO_KEY, {})
    changed = [k for k in MODEL_KEYS if zoo.get(k) != config.zoo.get(k)]
    changed += [f"{PICO_KEY}.{k}" for k in PICO_MODEL_KEYS if pico.get(k) != config.pico.get(k)]
    return changed


def _atomic_checkpoints() -> Any:
    from stable_baselines3.common.callbacks import BaseCallback

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
            if self.save_vecnormalize and self.model.get_vec_normalize_env() is not None:
                tmp = self.folder / f".ppo_vecnormalize_{steps}_steps.pkl.tmp"
                self.model.get_vec_normalize_env().save(str(tmp))
                os.replace(tmp, self.folder / f"ppo_vecnormalize_{steps}_steps.pkl")
            tmp = self.folder / f".ppo_{steps}_steps.tmp.zip"
            self.model.save(tmp)
            os.replace(tmp, self.folder / f"ppo_{steps}_steps.zip")  # the zip last: it marks a whole checkpoint
            return True

    return AtomicCheckpoints


def _versions() -> dict[str, str]:
    import stable_baselines3
    import torch

    return {
        "pico-gym": pico_gym.__version__,
        "stable-baselines3": str(stable_baselines3.__version__),
        "torch": str(torch.__version__),
        "gymnasium": gym.__version__,
        "python": platform.python_version(),
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
    }


def train(
    config: TrainConfig,
    run_dir: str | Path,
    timesteps: int | None = None,
    seed: int = 0,
    progress_bar: bool = True,
    verbose: int = 0,
    command: str = "",
    init_from: str | Path | None = None,
) -> Path:
    """Train (or resume, if `run_dir` has checkpoints) and return the final policy's path.

    `init_from`: a checkpoint (of another run) to start from instead of a new policy, e.g. to
    fine-tune with other rewards; its step count carries on. Ignored when resuming.
    """
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import CallbackList
    from stable_baselines3.common.logger import configure

    started = time.perf_counter()
    run_dir = Path(run_dir)
    torch.set_num_threads(int(config.pico["torch_threads"]))
    total = int(timesteps if timesteps is not None else float(config.zoo["n_timesteps"]))
    normalized = _normalize_kwargs(config.zoo.get("normalize"), config.source) is not None
    resumed = latest_checkpoint(run_dir, needs_stats=normalized)
    if resumed is not None:
        changed = _config_changes(run_dir, config)
        if changed:
            raise ConfigError(
                f"{config.source}: resuming {run_dir} with other {', '.join(changed)} than the run was trained "
                "with; start a new run from its checkpoint with --init-from to change them"
            )
    if resumed is None and init_from is not None:
        init_from = Path(init_from)
        if not init_from.is_file():
            raise FileNotFoundError(f"--init-from: no checkpoint at {init_from}")
        # The step count carries on from the policy's own (a shipped policy or a run's model.zip
        # has no count in its name).
        start = _zip_timesteps(init_from)
        if total <= start:
            raise ConfigError(
                f"--init-from {init_from}: the policy has {start:,} steps already and the step count carries "
                f"on, so --timesteps {total:,} trains nothing; ask for {start:,} + the steps to train"
            )
        (run_dir / "checkpoints").mkdir(parents=True, exist_ok=True)  # (after the checks: a refusal leaves no run)
        first = run_dir / "checkpoints" / f"ppo_{start}_steps.zip"
        first.write_bytes(init_from.read_bytes())
        stats = init_from.with_name(f"ppo_vecnormalize_{start}_steps.pkl")
        if stats.exists():
            (run_dir / "checkpoints" / stats.name).write_bytes(stats.read_bytes())
        (run_dir / "init_from.json").write_text(json.dumps({"checkpoint": str(init_from), "timesteps": start}) + "\n")
        resumed = (first, start)
    run_dir.mkdir(parents=True, exist_ok=True)
    zoo = copy.deepcopy(config.zoo)
    zoo["n_timesteps"] = total
    resolved = TrainConfig(config.env_id, zoo, config.pico, config.source)
    (run_dir / "config.yaml").write_text(
        resolved.to_yaml(
            {"run": {"seed": seed, "command": command, "config_file": config.source, "versions": _versions()}}
        )
    )
    # A resumed run draws fresh training seeds (stream = steps done), not the ones already used.
    vec_env = make_vec_env(config, seed, stream=resumed[1] if resumed else 0)
    norm = _normalize_kwargs(zoo.get("normalize"), config.source)
    if norm is not None:
        from stable_baselines3.common.vec_env import VecNormalize

        stats = resumed and run_dir / "checkpoints" / f"ppo_vecnormalize_{resumed[1]}_steps.pkl"
        if stats and stats.exists():
            vec_env = VecNormalize.load(str(stats), vec_env)
        else:
            vec_env = VecNormalize(vec_env, gamma=float(zoo.get("gamma", 0.99)), **norm)
    hyper = {k: float(v) if isinstance(v, str) and _is_number(v) else v for k, v in zoo.items() if k not in ZOO_KEYS}
    if resumed:
        # The config's hyper-parameters win over the checkpoint's (a fine-tune may lower the
        # learning rate); the network comes from the checkpoint.
        model = PPO.load(resumed[0], env=vec_env, device="cpu", **hyper)
        print(f"resuming {run_dir} from {resumed[0].name} ({resumed[1]:,} of {total:,} steps)")
    else:
        policy, policy_kwargs = zoo["policy"], _policy_kwargs(zoo.get("policy_kwargs"), config.source)
        if policy == MIRROR_POLICY:
            from pico_gym.train.mirror import MirrorPolicy, mirror_policy_kwargs

            policy, policy_kwargs = MirrorPolicy, {**policy_kwargs, **mirror_policy_kwargs(config.learning)}
        model = PPO(
            policy,
            vec_env,
            policy_kwargs=policy_kwargs,
            seed=seed,
            device="cpu",
            verbose=verbose,
            **hyper,
        )
        if int(config.pico["bc_episodes"]) > 0:
            report = behaviour_clone(model, config, int(config.pico["bc_episodes"]), int(config.pico["bc_epochs"]))
            (run_dir / "behaviour_cloning.json").write_text(json.dumps(report, indent=1) + "\n")
            if config.pico["bc_log_std"] is not None:
                with torch.no_grad():
                    model.policy.log_std.fill_(float(config.pico["bc_log_std"]))
    clock_before_s = _start_session(run_dir, resumed[1] if resumed else None)
    model.set_logger(configure(str(run_dir / "tb"), ["csv", "tensorboard"]))
    EscapeStats, PeriodicEval, StopFile = _callbacks()
    (run_dir / "STOP").unlink(missing_ok=True)
    n_envs = int(zoo["n_envs"])
    callbacks = [
        EscapeStats(),
        _atomic_checkpoints()(
            max(int(config.pico["checkpoint_freq"]) // n_envs, 1),
            run_dir / "checkpoints",
            save_vecnormalize=norm is not None,
        ),
        PeriodicEval(config, run_dir, int(config.pico["eval_freq"]), int(config.pico["eval_episodes"])),
        StopFile(run_dir / "STOP"),
    ]
    callbacks[2].clock_before_s = clock_before_s
    remaining = total - model.num_timesteps
    if remaining > 0:
        model.learn(
            remaining, callback=CallbackList(callbacks), reset_num_timesteps=not resumed, progress_bar=progress_bar
        )
    vec_env.close()
    final = save_policy(
        model,
        run_dir / "model",
        config.learning,
        env_id=config.env_id,
        env_kwargs=config.pico["env_kwargs"],
        timesteps=model.num_timesteps,
        seed=seed,
        **goal_metadata(config),
    )
    _join_progress(run_dir)
    try:
        from pico_gym.train.plots import plot_learning_curve

        plot_learning_curve(run_dir, run_dir / "learning_curve.png")
    except ImportError:
        pass
    done = run_dir / "done.json"
    elapsed = round(clock_before_s + time.perf_counter() - started, 1)  # over every session of the run
    done.write_text(json.dumps({"timesteps": model.num_timesteps, "wall_clock_s": elapsed}) + "\n")
    return final


def _normalize_kwargs(value: Any, source: str) -> dict[str, Any] | None:
    """rl-zoo3's `normalize`: true, false, or a dict expression of VecNormalize arguments."""
    if value in (None, False):
        return None
    if value is True:
        return {}
    kwargs = _policy_kwargs(value, source) if isinstance(value, str) else value
    if not isinstance(kwargs, dict):
        raise ConfigError(f"{source}: normalize must be true, false or a dict of VecNormalize arguments")
    return kwargs


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


# --- a run's records across sessions (a resume starts a new session) ----------------------------
# SB3's CSV logger rewrites tb/progress.csv when a session starts, and its clock starts again. So
# each finished or killed session's file is kept as tb/progress.<k>.csv; the run's progress.csv is
# the sessions joined: a session's rows past the step the next one resumed from are dropped (they
# were redone), and its `time/time_elapsed` counts from the start of the run.
_ELAPSED = "time/time_elapsed"
_STEPS = "time/total_timesteps"


def _csv_rows(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    try:
        with path.open(newline="") as f:
            reader = csv.DictReader(f)
            return list(reader.fieldnames or []), list(reader)
    except (OSError, csv.Error):
        return [], []


def _write_csv(path: Path, fields: list[str], rows: list[dict[str, Any]]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    os.replace(tmp, path)


def _number_or(row: dict[str, str], key: str, default: float) -> float:
    try:
        return float(row.get(key) or default)
    except ValueError:
        return default


def _session_files(run_dir: Path) -> list[Path]:
    files = [
        (int(m.group(1)), f)
        for f in (run_dir / "tb").glob("progress.*.csv")
        if (m := re.fullmatch(r"progress\.(\d+)\.csv", f.name))
    ]
    return [f for _, f in sorted(files)]


def _start_session(run_dir: Path, resumed_at: int | None) -> float:
    """Keep the previous session's progress file, drop eval rows that the resume will redo, and
    return the wall clock the run has spent so far [s] (0 for a new run)."""
    tb = run_dir / "tb"
    current = tb / "progress.csv"
    if resumed_at is None:
        for f in _session_files(run_dir):
            f.unlink()
        current.unlink(missing_ok=True)
        return 0.0
    if current.exists():
        os.replace(current, tb / f"progress.{len(_session_files(run_dir))}.csv")
    evals = run_dir / "eval.csv"
    last_eval_s = 0.0
    if evals.exists():
        fields, rows = _csv_rows(evals)
        kept = [r for r in rows if _number_or(r, "timesteps", 0) <= resumed_at]
        if len(kept) != len(rows):
            _write_csv(evals, fields, kept)
        last_eval_s = max((_number_or(r, "wall_clock_s", 0.0) for r in kept), default=0.0)
    # SB3 logs time_elapsed in whole seconds, so the sessions' sum can fall short of the clock
    # an evaluation already wrote down; the run's clock never goes back.
    elapsed = sum(_number_or((_csv_rows(f)[1] or [{}])[-1], _ELAPSED, 0.0) for f in _session_files(run_dir))
    return max(elapsed, last_eval_s)


def _join_progress(run_dir: Path) -> None:
    """Write the run's progress.csv: every session's rows, joined (see above)."""
    sessions = [_csv_rows(f) for f in [*_session_files(run_dir), run_dir / "tb" / "progress.csv"]]
    sessions = [(fields, rows) for fields, rows in sessions if rows]
    if not sessions:
        return
    fields: list[str] = []
    for names, _ in sessions:
        fields += [n for n in names if n not in fields]
    joined: list[dict[str, Any]] = []
    offset = 0.0
    for k, (_, rows) in enumerate(sessions):
        resumed_at = (
            min((_number_or(r, _STEPS, math.inf) for r in sessions[k + 1][1]), default=math.inf)
            if k + 1 < len(sessions)
            else math.inf
        )
        for row in rows:
            if _number_or(row, _STEPS, 0.0) < resumed_at:
                if _ELAPSED in row and row[_ELAPSED] not in ("", None):
                    row = {**row, _ELAPSED: f"{offset + _number_or(row, _ELAPSED, 0.0):g}"}
                joined.append(row)
        offset += _number_or(rows[-1], _ELAPSED, 0.0)
    _write_csv(run_dir / "progress.csv", fields, joined)
