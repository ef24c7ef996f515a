"""Behaviour cloning: the classic agent's (or the hybrid's classic part's) commands as the
policy's first targets, before PPO fine-tunes it (a config's `bc_episodes`)."""

from __future__ import annotations

import time
from typing import Any

import gymnasium as gym
import numpy as np

from pico_gym.agents.base import RobotSpec
from pico_gym.envs.base import pico_env
from pico_gym.train.config import MIRROR_POLICY, TRAIN_SEED_MIN, TrainConfig, wrapper_entry
from pico_gym.train.envs import make_plain_env


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
    box = pico_env(envs[0]).action_space
    low, high = box.low, box.high
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
    tolerance = pico_env(env).task.config.facing_tolerance_rad  # type: ignore[attr-defined]  # (a hospital task's)
    return bool(parts["in_square"]) and abs(parts["heading_error"]) <= ANNOUNCE_LABEL_MARGIN * tolerance


def _hybrid_demonstrations(config: TrainConfig, episodes: int) -> tuple[Any, Any, dict]:
    from pico_gym.train.hybrid import HybridTraining
    from pico_gym.wrappers import LearningEncoder

    env = gym.make(config.env_id, **{**config.pico["env_kwargs"], **config.pico["train_env_kwargs"]})
    kwargs = {}
    for entry in config.zoo["env_wrapper"]:
        name, given = wrapper_entry(entry)
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
