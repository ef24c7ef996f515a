"""Training configs: rl-zoo3's YAML layout plus a `pico-gym:` block, read into a `TrainConfig`.

A config has rl-zoo3's layout for the env's block (n_envs, n_timesteps, policy, env_wrapper,
policy_kwargs and PPO's hyper-parameters) plus a `pico-gym:` block with this pipeline's own
settings (`PICO_DEFAULTS`). Errors name the file and the key, before any training starts.

Training episodes draw their seeds from [TRAIN_SEED_MIN, 2**31), so their worlds never coincide
with evaluation seeds (EVAL_SEED_START.., and the < 1e6 seeds of bench and compare).
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import yaml

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
# The activations a config may name as nn.<Name> in policy_kwargs.
ACTIVATIONS = ("ReLU", "Tanh", "ELU", "LeakyReLU", "GELU", "SiLU", "Sigmoid")


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
            name, kwargs = wrapper_entry(entry)
            if name.endswith("PicoLearningWrapper"):
                return LearningConfig(**(kwargs or {}))
        raise ConfigError(f"{self.source}: env_wrapper must include pico_gym.wrappers.PicoLearningWrapper")

    @property
    def hybrid_kwargs(self) -> dict[str, Any]:
        """The HybridTraining settings of the env_wrapper list (`HybridConfig` fields; {} if none)."""
        for entry in self.zoo.get("env_wrapper") or []:
            name, kwargs = wrapper_entry(entry)
            if name.endswith("HybridTraining"):
                return dict(kwargs or {})
        return {}

    def to_yaml(self, extra: dict[str, Any] | None = None) -> str:
        return yaml.safe_dump({self.env_id: self.zoo, PICO_KEY: self.pico, **(extra or {})}, sort_keys=False)


def wrapper_entry(entry: Any) -> tuple[str, dict[str, Any] | None]:
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
    env_id = _env_block(data, path, env_id)
    zoo = dict(data[env_id])
    for key in ("n_envs", "n_timesteps", "policy", "env_wrapper"):
        if key not in zoo:
            raise ConfigError(f"{path}: {env_id}.{key} is missing")
    pico = _pico_block(data, path)
    config = TrainConfig(env_id, zoo, pico, str(path))
    if zoo["policy"] == MIRROR_POLICY and zoo.get("normalize"):
        raise ConfigError(f"{path}: {env_id}.policy {MIRROR_POLICY} reflects the raw input: it cannot take normalize")
    if config.learning.point_goal and pico["agent"] != "hybrid":
        wrappers = [wrapper_entry(e)[0] for e in zoo["env_wrapper"] or []]
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


def _env_block(data: Any, path: Path, env_id: str | None) -> str:
    """The env block's key: `env_id`, or the file's only block besides `pico-gym:` (and `run:`)."""
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
    return str(env_id)


def _pico_block(data: dict[str, Any], path: Path) -> dict[str, Any]:
    """The `pico-gym:` block with its defaults filled in, each choice checked."""
    pico = dict(PICO_DEFAULTS)
    unknown = set(data.get(PICO_KEY) or {}) - set(PICO_DEFAULTS)
    if unknown:
        raise ConfigError(f"{path}: unknown key(s) {sorted(unknown)} in {PICO_KEY}; known: {sorted(PICO_DEFAULTS)}")
    pico.update(data.get(PICO_KEY) or {})
    for key, allowed in (
        ("agent", POLICY_AGENTS),
        ("bc_announce", ("teacher", "arrival")),
        ("point_goal_source", POINT_GOAL_SOURCES),
        ("vec_env", VEC_ENVS),
    ):
        if pico[key] not in allowed:
            raise ConfigError(f"{path}: {PICO_KEY}.{key} must be one of {allowed}, got {pico[key]!r}")
    arrival = {**(pico["env_kwargs"] or {}), **(pico["train_env_kwargs"] or {})}.get("arrival", "dwell")
    if pico["bc_announce"] == "arrival" and arrival != "announce":
        raise ConfigError(
            f"{path}: {PICO_KEY}.bc_announce 'arrival' labels the announcement, so the env needs arrival: announce "
            f"(got {arrival!r})"
        )
    variants = pico["train_env_variants"]
    if not isinstance(variants, list) or not all(isinstance(v, dict) for v in variants):
        raise ConfigError(f"{path}: {PICO_KEY}.train_env_variants must be a list of env kwargs dicts, got {variants!r}")
    return pico


def check_vector(config: TrainConfig) -> None:
    """Raise ConfigError unless `vec_env: vector` can train this config: the same env kwargs for
    every robot (no train_env_variants) and the learning wrapper alone."""
    wrappers = [wrapper_entry(e)[0] for e in config.zoo["env_wrapper"] or []]
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


def parse_policy_kwargs(text: str | dict[str, Any] | None, source: str) -> dict[str, Any]:
    """rl-zoo3 writes policy_kwargs as a Python expression, e.g. "dict(net_arch=[64, 64])".

    It is parsed as data, never evaluated: literals, `dict(key=value, ...)` and `nn.<Activation>`
    (one of ACTIVATIONS) only.
    """
    if text is None:
        return {}
    if isinstance(text, dict):
        return text
    try:
        parsed = _data(ast.parse(text, mode="eval").body)
    except (SyntaxError, ValueError) as exc:
        raise ConfigError(f"{source}: policy_kwargs {text!r}: {exc}") from None
    if not isinstance(parsed, dict):
        raise ConfigError(f"{source}: policy_kwargs must give a dict, got {parsed!r}")
    return parsed


def _not_data(node: ast.AST) -> ValueError:
    return ValueError(f"{ast.unparse(node)!r} is not data (literals, dict(...), nn.<Activation>)")


def _data(node: ast.AST) -> Any:
    """A node of a policy_kwargs expression as data: literals, `dict(key=value, ...)`,
    `nn.<Activation>`; ValueError for anything else."""
    if isinstance(node, ast.Call):
        if isinstance(node.func, ast.Name) and node.func.id == "dict" and not node.args:
            return {kw.arg: _data(kw.value) for kw in node.keywords if kw.arg is not None}
        raise _not_data(node)
    if isinstance(node, ast.Attribute):
        return _activation(node)
    if isinstance(node, ast.Dict):
        if any(k is None for k in node.keys):
            raise ValueError("a ** inside a dict is not data")
        return {_data(k): _data(v) for k, v in zip(node.keys, node.values, strict=True)}  # type: ignore[arg-type]
    if isinstance(node, (ast.List, ast.Tuple)):
        items = [_data(e) for e in node.elts]
        return items if isinstance(node, ast.List) else tuple(items)
    if isinstance(node, ast.Constant):
        return node.value
    if (
        isinstance(node, ast.UnaryOp)
        and isinstance(node.op, ast.USub)
        and isinstance(node.operand, ast.Constant)
        and isinstance(node.operand.value, (int, float))
    ):
        return -node.operand.value
    raise _not_data(node)


def _activation(node: ast.Attribute) -> Any:
    """`nn.<Activation>`: one of ACTIVATIONS, as torch's class."""
    if not (isinstance(node.value, ast.Name) and node.value.id == "nn"):
        raise _not_data(node)
    if node.attr not in ACTIVATIONS:
        raise ValueError(f"nn.{node.attr} is not one of the allowed activations {ACTIVATIONS}")
    import torch

    return getattr(torch.nn, node.attr)


def normalize_kwargs(value: Any, source: str) -> dict[str, Any] | None:
    """rl-zoo3's `normalize`: true, false, or a dict expression of VecNormalize arguments."""
    if value in (None, False):
        return None
    if value is True:
        return {}
    kwargs = parse_policy_kwargs(value, source) if isinstance(value, str) else value
    if not isinstance(kwargs, dict):
        raise ConfigError(f"{source}: normalize must be true, false or a dict of VecNormalize arguments")
    return kwargs


def is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def hyper_parameters(zoo: dict[str, Any]) -> dict[str, Any]:
    """PPO's constructor arguments of an env block (rl-zoo3's other keys left out; numbers given
    as strings, such as "3e-4", made floats)."""
    return {k: float(v) if isinstance(v, str) and is_number(v) else v for k, v in zoo.items() if k not in ZOO_KEYS}


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
    return {"point_goal_source": "exit", "exit_goal": exit_goal_kwargs(config)}


def exit_goal_kwargs(config: TrainConfig) -> dict[str, Any]:
    """The arguments the config's env_wrapper gives ExitGoalObservation ({} when none)."""
    given = [wrapper_entry(e) for e in config.zoo["env_wrapper"] or []]
    return dict(next((k or {} for name, k in given if name.endswith("ExitGoalObservation")), {}))
