"""PPO agents: a trained policy acting on an env's raw observations, with numpy (no torch).

A policy is files side by side: `NAME.npz` (the actor's weights as plain arrays, see
`pico_gym.agents.mlp`; what acting needs), `NAME.json` (what the policy sees: the `LearningConfig`
of `pico_gym.wrappers`, the env it was trained on, its evaluation) and, from training, `NAME.zip`
(stable-baselines3's PPO save, needed only to train on). The agent encodes raw observations with
the same `LearningEncoder` the training wrapper uses, so it acts exactly as in training; actions
come back in [-1, 1] and are rescaled to the robot's limits.

Acting from an `.npz` needs numpy only. Given a `.zip` without its `.npz`, the agent loads it with
stable-baselines3 (the `train` extra, torch) and converts the actor. SB3 zips and pickles can run
arbitrary code when loaded: load only files from a source you trust. The `.npz` loads with
pickling off.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium.error import DependencyNotInstalled

from pico_gym.agents.base import Agent, RobotSpec, episode_rng
from pico_gym.agents.mlp import MlpActor, export_actor
from pico_gym.wrappers import LearningConfig, LearningEncoder, rescale_action

# The shipped policy (see agents/models/MODEL_CARD.md): its actor arrays, and SB3's training zip.
SHIPPED_POLICY = Path(__file__).parent / "models" / "ppo_escape.npz"
SHIPPED_MODEL = SHIPPED_POLICY.with_suffix(".zip")
# The end-to-end hospital baseline (privileged point goal, see HOSPITAL_POINTGOAL_CARD.md).
SHIPPED_POINTGOAL_POLICY = Path(__file__).parent / "models" / "ppo_hospital_pointgoal.npz"
TRAIN_EXTRA_HINT = "pip install 'pico-gym[train]' (CPU-only torch: see the README's 'Installing torch')"


def _sb3() -> Any:
    try:
        import stable_baselines3
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise DependencyNotInstalled(
            f"loading a stable-baselines3 .zip policy needs stable-baselines3 and torch: {TRAIN_EXTRA_HINT}; "
            "a policy's .npz file runs without them"
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
    export_actor(model, norm).save(path.with_suffix(".npz"))
    return path


def observation_normalizer(model: Any) -> dict[str, Any] | None:
    """The running observation statistics of a model trained under VecNormalize (else None)."""
    venv = model.get_vec_normalize_env() if hasattr(model, "get_vec_normalize_env") else None
    if venv is None or not venv.norm_obs:
        return None
    rms = venv.obs_rms
    return {"mean": rms.mean.copy(), "var": rms.var.copy(), "clip": float(venv.clip_obs), "epsilon": venv.epsilon}


def _read_metadata(path: Path) -> tuple[LearningConfig, dict[str, Any]]:
    meta_path = policy_metadata_path(path)
    if not meta_path.is_file():
        raise FileNotFoundError(f"{path} has no metadata file {meta_path.name} next to it (see agents/ppo.py)")
    try:
        meta = json.loads(meta_path.read_text())
        learning = LearningConfig(**meta["learning"])
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{meta_path}: bad policy metadata ({exc})") from exc
    return learning, meta


_ZIP_WARNED = False


def _warn_zip_runs_code(path: Path) -> None:
    """Say once per process that loading a stable-baselines3 zip runs code (it holds pickles)."""
    global _ZIP_WARNED
    if not _ZIP_WARNED:
        _ZIP_WARNED = True
        warnings.warn(
            f"{path}: a stable-baselines3 zip holds pickles, and loading one runs code: load only files from a "
            "source you trust (a policy's .npz loads without that risk)",
            UserWarning,
            stacklevel=3,
        )


def load_policy(path: str | Path) -> tuple[Any, LearningConfig, dict[str, Any]]:
    """Load a stable-baselines3 policy saved by `save_policy`: (model, learning config, metadata).

    Needs stable-baselines3 and torch. The zip can run code when loaded: trusted files only.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no PPO policy at {path}")
    learning, meta = _read_metadata(path)
    _warn_zip_runs_code(path)
    sb3 = _sb3()
    import torch

    torch.set_num_threads(1)  # a small MLP, one observation at a time: one thread is fastest
    model = sb3.PPO.load(path, device="cpu")
    return model, learning, meta


def load_actor(path: str | Path) -> tuple[MlpActor, LearningConfig, dict[str, Any]]:
    """Load a policy for acting: (actor, learning config, metadata).

    `path` is a policy's `.npz`, or its `.zip` (then the `.npz` beside it if there is one, else the
    zip through stable-baselines3, which needs torch).
    """
    path = Path(path)
    arrays = path.with_suffix(".npz")
    if arrays.is_file():
        learning, meta = _read_metadata(arrays)
        return MlpActor.load(arrays), learning, meta
    if path.suffix == ".npz" or not path.is_file():
        raise FileNotFoundError(f"no PPO policy at {path}")
    model, learning, meta = load_policy(path)
    return export_actor(model, meta.get("obs_norm")), learning, meta


class PpoAgent(Agent):
    """Acts with a trained PPO policy, evaluated with numpy.

    `deterministic=True` (default) takes the policy's mean action; `False` samples from the
    policy's Gaussian with the agent's own generator, re-seeded at each reset from `seed` and the
    episode's first scan (so an episode plays the same wherever it runs).

    Args:
        spec: the robot's public spec.
        path: a policy file (`.npz`, or an SB3 `.zip`); default: the shipped policy.
        model: an SB3 model in memory instead (training's evaluations), with its `learning` config.
        learning: the observation encoding `model` was trained with.
        deterministic: mean action, or a sample.
        seed: seeds the sampling generator.
        goal: for a policy trained with `point_goal` (privileged), what fills `obs["point_goal"]`
            when the env's observations lack it (`make_agent("ppo-pointgoal", env)` reads the
            env's true state with `pico_gym.wrappers.point_goal`). A policy whose metadata says
            `"point_goal_source": "exit"` needs none: the agent tracks the escape room's exit with
            its own perception (`pico_gym.agents.exit_goal.ExitGoal`, with the metadata's
            `"exit_goal"` arguments), as its training env did.
        shield: pass the policy's twist through the classic agents' safety filter on the current
            scan (`pico_gym.agents.classic.potential_field`: turns cut near corners, the command
            scaled down until the footprint keeps its margin from the scan's points). It knows
            only what the LRF sees now: nothing behind the robot. None (default): as the policy's
            metadata says (`"shield"`, written by the ship script for a policy shipped shielded;
            off when absent).
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
        goal: Callable[[], np.ndarray] | None = None,
        shield: bool | None = None,
    ) -> None:
        super().__init__(spec)
        if shield is not None and not isinstance(shield, bool):
            raise ValueError(f"PpoAgent(shield=...) must be true, false or None, got {shield!r}")
        meta: dict[str, Any] = {}
        if model is None:
            actor, learning, meta = load_actor(path or SHIPPED_POLICY)
        elif learning is None:
            raise ValueError("PpoAgent(model=...) needs the LearningConfig it was trained with")
        else:
            actor = export_actor(model, observation_normalizer(model))
        self.actor = actor
        self.deterministic = deterministic
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self.encoder = LearningEncoder(spec.lrf, spec.robot, spec.dt_s, learning)
        if actor.obs_size != self.encoder.space.shape[0]:
            raise ValueError(
                f"the policy expects observations of length {actor.obs_size}, but {learning} on this robot's "
                f"LRF ({spec.lrf.n_beams} beams) gives {self.encoder.space.shape}"
            )
        if actor.action_low.shape[0] not in (3, 4):
            raise ValueError(
                f"the policy has {actor.action_low.shape[0]} action outputs; a PpoAgent plays a twist (3) or a "
                "twist and an announcement (4, PicoHospital-v0's arrival='announce')"
            )
        self._low, self._high = spec.robot.action_low, spec.robot.action_high
        self._first: np.ndarray | None = None
        self._goal = goal if learning.point_goal else None
        self._exit_goal = None
        if learning.point_goal and meta.get("point_goal_source") == "exit":
            from pico_gym.agents.exit_goal import ExitGoal

            try:
                self._exit_goal = ExitGoal(spec, **(meta.get("exit_goal") or {}))
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{path or SHIPPED_POLICY}: bad policy metadata (exit_goal: {exc})") from exc
        if shield is None:
            shield = meta.get("shield", False)
            if not isinstance(shield, bool):
                raise ValueError(f"{path or SHIPPED_POLICY}: bad policy metadata (shield must be true or false)")
        self.shield = shield
        if shield:
            from pico_gym.agents.shield import ScanShield

            self._shield = ScanShield(spec)

    def _with_goal(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        if self._exit_goal is not None:
            return {**obs, "point_goal": self._exit_goal.update(obs)}
        if self._goal is None or "point_goal" in obs:
            return obs
        return {**obs, "point_goal": self._goal()}

    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:
        if self._exit_goal is not None:  # the first scan seen once, as ExitGoalObservation.reset
            self._first = self.encoder.reset({**obs, "point_goal": self._exit_goal.reset(obs)})
        else:
            self._first = self.encoder.reset(self._with_goal(obs))
        self.rng = episode_rng(self.seed, obs)

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        if self._first is not None:  # the observation reset() already encoded
            x, self._first = self._first, None
        else:
            x = self.encoder.encode(self._with_goal(obs))
        unit = self.actor.act(x, None if self.deterministic else self.rng)
        if unit.shape[0] == 3:
            twist = rescale_action(unit, self._low, self._high)
            return (self._shielded(obs, twist) if self.shield else twist).astype(np.float32)
        # A policy trained with arrival="announce" has a fourth output: the announcement, in [-1, 1].
        twist = rescale_action(unit[:3], self._low, self._high)
        if self.shield:
            twist = self._shielded(obs, twist)
        return np.concatenate([twist, unit[3:]]).astype(np.float32)

    def _shielded(self, obs: dict[str, np.ndarray], twist: np.ndarray) -> np.ndarray:
        """The twist through the safety filter on the current scan (`ScanShield`)."""
        return self._shield(obs["lrf"], twist)


def build(env: Any, **kwargs: Any) -> PpoAgent:
    """The PPO escape agent for an env's robot (`make_agent("ppo", env)`; `path=` another policy)."""
    return PpoAgent(RobotSpec.of(env), **kwargs)


def build_pointgoal(env: Any, **kwargs: Any) -> PpoAgent:
    """The privileged point-goal hospital baseline (`make_agent("ppo-pointgoal", env)`): its goal
    comes from the env's true state."""
    from pico_gym.wrappers import point_goal

    if kwargs.get("path") is None:
        if not SHIPPED_POINTGOAL_POLICY.exists():
            raise FileNotFoundError(
                "no ppo-pointgoal policy is shipped (none has reached the bar to ship: 80 % success on "
                "generated hospitals with 2 cabinets); train one with train/configs/ppo_hospital_pointgoal.yaml "
                "and pass path=... (--policy)"
            )
        kwargs["path"] = SHIPPED_POINTGOAL_POLICY
    agent = PpoAgent(RobotSpec.of(env), goal=lambda: point_goal(env), **kwargs)  # privileged: the true pose
    outputs, wanted = agent.actor.action_low.shape[0], env.action_space.shape[0]
    if outputs != wanted:
        trained, here = ("arrival='announce'", "'dwell'") if outputs == 4 else ("arrival='dwell'", "'announce'")
        raise ValueError(
            f"this ppo-pointgoal policy ({kwargs['path']}) has {outputs} action outputs (trained with {trained}); "
            f"the env here takes {wanted} (arrival={here}): make the env with the arrival mode it was trained in"
        )
    return agent
