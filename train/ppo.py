"""Training PPO (stable-baselines3) on pico-gym envs from a YAML config: the training loop.

The config (`pico_gym.train.config`) has rl-zoo3's layout plus a `pico-gym:` block. A run
directory holds:

    config.yaml        the resolved config (after command-line overrides), versions, machine
    checkpoints/       ppo_<steps>_steps.zip every checkpoint_freq env steps
    tb/                TensorBoard logs (rollout/, escape/ success rate, escape time, bumps; eval/)
    progress.csv       the same figures as CSV
    eval.csv           periodic evaluations on seeds disjoint from training's
    model.zip/.json    the final policy (load with make_agent("ppo", env, path=...))
    best.zip/.json     the policy of the best evaluation
    learning_curve.png success rate vs env steps

`touch RUN/STOP` ends a run cleanly (final save, plot); the same command resumes it. The loop's
parts live by job: the config, the envs (`envs`), the callbacks, behaviour cloning (`cloning`),
checkpoints and resuming (`checkpoints`), the run's records across sessions (`records`).
"""

from __future__ import annotations

import copy
import json
import os
import platform
import time
from pathlib import Path
from typing import Any

import gymnasium as gym

import pico_gym
from pico_gym.agents.ppo import save_policy
from pico_gym.train.callbacks import AtomicCheckpoints, EpisodeStats, PeriodicEval, StopFile
from pico_gym.train.checkpoints import config_changes, latest_checkpoint, record_written, zip_timesteps
from pico_gym.train.cloning import behaviour_clone
from pico_gym.train.config import (
    MIRROR_POLICY,
    ConfigError,
    TrainConfig,
    goal_metadata,
    hyper_parameters,
    normalize_kwargs,
    parse_policy_kwargs,
)
from pico_gym.train.envs import make_training_vec_env
from pico_gym.train.records import join_progress, start_session


def run_versions() -> dict[str, str]:
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
    resumed = _resume_point(config, run_dir, total, init_from)
    run_dir.mkdir(parents=True, exist_ok=True)
    zoo = copy.deepcopy(config.zoo)
    zoo["n_timesteps"] = total
    resolved = TrainConfig(config.env_id, zoo, config.pico, config.source)
    (run_dir / "config.yaml").write_text(
        resolved.to_yaml(
            {"run": {"seed": seed, "command": command, "config_file": config.source, "versions": run_versions()}}
        )
    )
    vec_env, normalized = _training_vec_env(config, run_dir, resumed, seed)
    if resumed:
        # The config's hyper-parameters win over the checkpoint's (a fine-tune may lower the
        # learning rate); the network comes from the checkpoint.
        model = PPO.load(resumed[0], env=vec_env, device="cpu", **hyper_parameters(zoo))
        print(f"resuming {run_dir} from {resumed[0].name} ({resumed[1]:,} of {total:,} steps)")
    else:
        model = _new_model(config, vec_env, seed, verbose, run_dir)
    clock_before_s = start_session(run_dir, resumed[1] if resumed else None)
    model.set_logger(configure(str(run_dir / "tb"), ["csv", "tensorboard"]))
    (run_dir / "STOP").unlink(missing_ok=True)
    evaluations = PeriodicEval(config, run_dir, int(config.pico["eval_freq"]), int(config.pico["eval_episodes"]))
    evaluations.clock_before_s = clock_before_s
    checkpoints = AtomicCheckpoints(
        max(int(config.pico["checkpoint_freq"]) // int(zoo["n_envs"]), 1), run_dir / "checkpoints", normalized
    )
    callbacks = CallbackList([EpisodeStats(), checkpoints, evaluations, StopFile(run_dir / "STOP")])
    remaining = total - model.num_timesteps
    if remaining > 0:
        model.learn(remaining, callback=callbacks, reset_num_timesteps=not resumed, progress_bar=progress_bar)
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
    _close_run(run_dir, model.num_timesteps, round(clock_before_s + time.perf_counter() - started, 1))
    return final


def _resume_point(
    config: TrainConfig, run_dir: Path, total: int, init_from: str | Path | None
) -> tuple[Path, int] | None:
    """The checkpoint the run goes on from (its path and step count): the run's own newest whole
    one, else `init_from` (copied into the run as its first checkpoint), else None (a new run).

    Raises:
        ConfigError: resuming with settings that change the model, or an `init_from` with as many
            steps as asked for already.
        FileNotFoundError: an `init_from` that is not there.
    """
    normalized = normalize_kwargs(config.zoo.get("normalize"), config.source) is not None
    resumed = latest_checkpoint(run_dir, needs_stats=normalized)
    if resumed is not None:
        changed = config_changes(run_dir, config)
        if changed:
            raise ConfigError(
                f"{config.source}: resuming {run_dir} with other {', '.join(changed)} than the run was trained "
                "with; start a new run from its checkpoint with --init-from to change them"
            )
        return resumed
    if init_from is None:
        return None
    init_from = Path(init_from)
    if not init_from.is_file():
        raise FileNotFoundError(f"--init-from: no checkpoint at {init_from}")
    # The step count carries on from the policy's own (a shipped policy or a run's model.zip has
    # no count in its name).
    start = zip_timesteps(init_from)
    if total <= start:
        raise ConfigError(
            f"--init-from {init_from}: the policy has {start:,} steps already and the step count carries "
            f"on, so --timesteps {total:,} trains nothing; ask for {start:,} + the steps to train"
        )
    (run_dir / "checkpoints").mkdir(parents=True, exist_ok=True)  # (after the checks: a refusal leaves no run)
    first = run_dir / "checkpoints" / f"ppo_{start}_steps.zip"
    first.write_bytes(init_from.read_bytes())
    record_written(first)  # (the file the user named with --init-from: trusted by that command)
    stats = init_from.with_name(f"ppo_vecnormalize_{start}_steps.pkl")
    if stats.exists():
        (run_dir / "checkpoints" / stats.name).write_bytes(stats.read_bytes())
        record_written(run_dir / "checkpoints" / stats.name)
    (run_dir / "init_from.json").write_text(json.dumps({"checkpoint": str(init_from), "timesteps": start}) + "\n")
    return first, start


def _training_vec_env(
    config: TrainConfig, run_dir: Path, resumed: tuple[Path, int] | None, seed: int
) -> tuple[Any, bool]:
    """The training VecEnv (under VecNormalize when the config normalizes: its statistics from the
    checkpoint resumed, if kept); and whether it normalizes."""
    # A resumed run draws fresh training seeds (stream = steps done), not the ones already used.
    vec_env = make_training_vec_env(config, seed, stream=resumed[1] if resumed else 0)
    norm = normalize_kwargs(config.zoo.get("normalize"), config.source)
    if norm is None:
        return vec_env, False
    from stable_baselines3.common.vec_env import VecNormalize

    saved = run_dir / "checkpoints" / f"ppo_vecnormalize_{resumed[1]}_steps.pkl" if resumed else None
    if saved is not None and saved.exists():
        return VecNormalize.load(str(saved), vec_env), True
    return VecNormalize(vec_env, gamma=float(config.zoo.get("gamma", 0.99)), **norm), True


def _new_model(config: TrainConfig, vec_env: Any, seed: int, verbose: int, run_dir: Path) -> Any:
    """A new PPO model of the config's policy, behaviour-cloned first if the config asks."""
    import torch
    from stable_baselines3 import PPO

    zoo = config.zoo
    policy, policy_kwargs = zoo["policy"], parse_policy_kwargs(zoo.get("policy_kwargs"), config.source)
    if policy == MIRROR_POLICY:
        from pico_gym.train.mirror import MirrorPolicy, mirror_policy_kwargs

        policy, policy_kwargs = MirrorPolicy, {**policy_kwargs, **mirror_policy_kwargs(config.learning)}
    model = PPO(
        policy, vec_env, policy_kwargs=policy_kwargs, seed=seed, device="cpu", verbose=verbose,
        **hyper_parameters(zoo),
    )  # fmt: skip
    if int(config.pico["bc_episodes"]) > 0:
        report = behaviour_clone(model, config, int(config.pico["bc_episodes"]), int(config.pico["bc_epochs"]))
        (run_dir / "behaviour_cloning.json").write_text(json.dumps(report, indent=1) + "\n")
        if config.pico["bc_log_std"] is not None:
            with torch.no_grad():
                model.policy.log_std.fill_(float(config.pico["bc_log_std"]))
    return model


def _close_run(run_dir: Path, timesteps: int, wall_clock_s: float) -> None:
    """The run's joined records, its learning curve (with matplotlib) and done.json."""
    join_progress(run_dir)
    try:
        from pico_gym.train.plots import plot_learning_curve

        plot_learning_curve(run_dir, run_dir / "learning_curve.png")
    except ImportError:
        pass
    # (wall_clock_s: over every session of the run)
    (run_dir / "done.json").write_text(json.dumps({"timesteps": timesteps, "wall_clock_s": wall_clock_s}) + "\n")
