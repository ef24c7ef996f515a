"""PPO agents: a stable-baselines3 policy acting on an env's raw observations.

A policy is two files side by side: `NAME.zip` (stable-baselines3's PPO save) and `NAME.json`
(what the policy sees: the `LearningConfig` of `pico_gym.wrappers`, and the env it was trained
on). The agent encodes raw observations with the same `LearningEncoder` the training wrapper uses,
so it acts exactly as in training; actions come back in [-1, 1] and are rescaled to the robot's
limits. Needs the `train` extra (stable-baselines3, torch).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from agents.base import Agent, RobotSpec, episode_rng
from pico_gym.wrappers import LearningConfig, LearningEncoder, rescale_action

# The shipped policy (see agents/models/MODEL_CARD.md).
SHIPPED_MODEL = Path(__file__).parent / "models" / "ppo_escape.zip"


def _sb3() -> Any:
    try:
        import stable_baselines3
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ImportError(
            "the PPO agent needs stable-baselines3 and torch: pip install torch==2.13.0 'pico-gym[train]'"
        ) from exc
    return stable_baselines3


def policy_metadata_path(model_path: str | Path) -> Path:
    """The JSON that goes with a policy's zip (`runs/x/model.zip` -> `runs/x/model.json`)."""
    return Path(model_path).with_suffix(".json")


def save_policy(model: Any, path: str | Path, learning: LearningConfig, **metadata: Any) -> Path:
    """Save an SB3 model as `path` (.zip) with its metadata JSON; returns the zip's path."""
    path = Path(path).with_suffix(".zip")
    path.parent.mkdir(parents=True, exist_ok=True)
    model.save(path)
    meta = {"algo": "ppo", "learning": learning.to_dict(), **metadata}
    norm = observation_normalizer(model)
    if norm is not None:
        meta["obs_norm"] = {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in norm.items()}
    policy_metadata_path(path).write_text(json.dumps(meta, indent=1, default=str) + "\n")
    return path


def observation_normalizer(model: Any) -> dict[str, Any] | None:
    """The running observation statistics of a model trained under VecNormalize (else None)."""
    venv = model.get_vec_normalize_env() if hasattr(model, "get_vec_normalize_env") else None
    if venv is None or not venv.norm_obs:
        return None
    rms = venv.obs_rms
    return {"mean": rms.mean.copy(), "var": rms.var.copy(), "clip": float(venv.clip_obs), "epsilon": venv.epsilon}


def load_policy(path: str | Path) -> tuple[Any, LearningConfig, dict[str, Any]]:
    """Load a policy saved by `save_policy`: (model, learning config, metadata)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no PPO policy at {path}")
    meta_path = policy_metadata_path(path)
    if not meta_path.is_file():
        raise FileNotFoundError(f"{path} has no metadata file {meta_path.name} next to it (see agents/ppo.py)")
    try:
        meta = json.loads(meta_path.read_text())
        learning = LearningConfig(**meta["learning"])
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{meta_path}: bad policy metadata ({exc})") from exc
    import torch

    torch.set_num_threads(1)  # a small MLP, one observation at a time: one thread is fastest
    model = _sb3().PPO.load(path, device="cpu")
    return model, learning, meta


class PpoAgent(Agent):
    """Acts with a trained PPO policy.

    `deterministic=True` (default) takes the policy's mean action; `False` samples from the
    policy's Gaussian with the agent's own generator, re-seeded at each reset from `seed` and the
    episode's first scan (so an episode plays the same wherever it runs).
    """

    name = "ppo"

    def __init__(
        self,
        spec: RobotSpec,
        path: str | Path | None = None,
        model: Any = None,
        learning: LearningConfig | None = None,
        deterministic: bool = True,
        seed: int = 0,
    ) -> None:
        super().__init__(spec)
        if model is None:
            model, learning, meta = load_policy(path or SHIPPED_MODEL)
            norm = meta.get("obs_norm")
        elif learning is None:
            raise ValueError("PpoAgent(model=...) needs the LearningConfig it was trained with")
        else:
            norm = observation_normalizer(model)
        # VecNormalize's transform, if the policy was trained under it: clip((x - mean) / std).
        self._norm = None
        if norm is not None:
            std = np.sqrt(np.asarray(norm["var"], np.float64) + float(norm["epsilon"]))
            self._norm = (np.asarray(norm["mean"], np.float64), std, float(norm["clip"]))
        self.model = model
        self.deterministic = deterministic
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self.encoder = LearningEncoder(spec.lrf, spec.robot, spec.dt_s, learning)
        expected = model.observation_space.shape
        if expected != self.encoder.space.shape:
            raise ValueError(
                f"the policy expects observations of shape {expected}, but {learning} on this robot's "
                f"LRF ({spec.lrf.n_beams} beams) gives {self.encoder.space.shape}"
            )
        self._low, self._high = spec.robot.action_low, spec.robot.action_high
        self._first: np.ndarray | None = None

    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:
        self._first = self.encoder.reset(obs)
        self.rng = episode_rng(self.seed, obs)

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        if self._first is not None:  # the observation reset() already encoded
            x, self._first = self._first, None
        else:
            x = self.encoder.encode(obs)
        if self._norm is not None:
            mean, std, clip = self._norm
            x = np.clip((x - mean) / std, -clip, clip).astype(np.float32)
        if self.deterministic:
            unit, _ = self.model.predict(x, deterministic=True)
        else:
            import torch

            with torch.no_grad():
                obs_tensor, _ = self.model.policy.obs_to_tensor(x)
                dist = self.model.policy.get_distribution(obs_tensor).distribution
                mean, std = dist.mean.numpy()[0], dist.stddev.numpy()[0]
            unit = mean + std * self.rng.standard_normal(mean.shape)
        return rescale_action(unit, self._low, self._high).astype(np.float32)
