"""`pico-gym bench-train`: what training costs beyond the policy, measured side by side in one run.

Rows, each the median of interleaved rounds (same load for all):

- SB3's PPO with the config's hyper-parameters on a toy env whose observation has as many floats
  as the learning wrapper's (nothing but a Box and a constant reward: the policy's own cost), and
  the same PPO on `pico-gym train`'s envs (PicoEscape-v0, episode seeds, the learning wrapper, a
  Monitor, SB3's DummyVecEnv): the ratio is what the env and its wrappers cost training.
- The env side inside PPO: the time SB3 waits in each vec env's `step_wait` during those rounds,
  a robot step, against what 0.95x the toy's fps leaves it (the toy's own plus 1/0.95 - 1 of the
  toy's whole step).
- The learning wrapper's cost per step: a wrapped env's step against the bare env's.
- Stepping only (random actions, raw observations): SB3's DummyVecEnv over single envs against
  `PicoSB3VecEnv` (pico-gym's vector env as an SB3 VecEnv).
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from pico_gym.timing import interleaved, machine, versions
from pico_gym.train.config import TrainConfig

DEFAULT_CONFIG = Path(__file__).parent / "configs" / "ppo_escape.yaml"


class ToyObservationEnv(gym.Env):
    """A Box observation of `size` floats, actions like PicoEscape-v0's, episodes of 600 steps."""

    def __init__(self, size: int, action_space: gym.spaces.Box) -> None:
        self.observation_space = gym.spaces.Box(-1.0, 1.0, shape=(size,), dtype=np.float32)
        self.action_space = action_space
        self._obs = np.zeros(size, dtype=np.float32)
        self._t = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self._t = 0
        return self._obs.copy(), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        self._t += 1
        return self._obs.copy(), 0.0, False, self._t >= 600, {}


def _row(label: str, rates: list[float], unit: str, against: tuple[str, list[float]] | None = None) -> None:
    """One line: the median rate, and its median per-round ratio to another row's rates."""
    line = f"{label:<58} {statistics.median(rates):8,.0f} {unit}"
    if against is not None:
        name, reference = against
        ratio = statistics.median(r / q for r, q in zip(rates, reference, strict=True))
        line += f"   {ratio:.2f}x {name}"
    print(line)


def _time_step_wait(venv: Any) -> list[float]:
    """Add up the seconds `venv.step_wait` takes (what SB3's PPO waits for the env to do each
    step), in the list returned, without a wrapper layer around `venv`."""
    spent = [0.0]
    inner = venv.step_wait

    def step_wait() -> Any:
        t0 = time.perf_counter()
        out = inner()
        spent[0] += time.perf_counter() - t0
        return out

    venv.step_wait = step_wait
    return spent


def _ppo(config: Any, vec_env: Any, seed: int) -> Any:
    from stable_baselines3 import PPO

    from pico_gym.train.config import hyper_parameters, parse_policy_kwargs

    zoo = config.zoo
    hyper = hyper_parameters(zoo)
    policy = "MlpPolicy" if isinstance(vec_env.observation_space, gym.spaces.Box) else "MultiInputPolicy"
    return PPO(
        policy,
        vec_env,
        policy_kwargs=parse_policy_kwargs(zoo.get("policy_kwargs"), config.source),
        seed=seed,
        device="cpu",
        **hyper,
    )


def cmd_bench_train(args: argparse.Namespace) -> int:
    import torch

    from pico_gym.train.config import load_config

    config = load_config(args.config)
    torch.set_num_threads(int(config.pico["torch_threads"]))
    n_envs = int(config.zoo["n_envs"])
    per_round = int(config.zoo.get("n_steps", 2048)) * n_envs * args.rollouts
    print(f"machine : {machine()}\nversions: {versions()}")
    print(
        f"method  : {args.rounds} interleaved rounds, medians; PPO as in {Path(args.config).name} "
        f"({n_envs} envs, {per_round:,} steps a round = {args.rollouts} rollouts)\n"
    )
    _ppo_rows(config, args, per_round)
    rng = np.random.default_rng(args.seed)
    low, high = _wrapper_row(config, args, rng)
    _vec_rows(config, args, rng, low, high)
    return 0


def _ppo_rows(config: TrainConfig, args: argparse.Namespace, per_round: int) -> None:
    """PPO's fps on pico-gym train's two in-process paths (DummyVecEnv over wrapped envs, and the
    vector env) against a toy env, and the env side's share of a step."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    from pico_gym.train.config import ConfigError, check_vector
    from pico_gym.train.envs import make_training_vec_env

    n_envs = int(config.zoo["n_envs"])

    paths = {"dummy": replace(config, pico={**config.pico, "vec_env": "dummy"})}
    vector = replace(config, pico={**config.pico, "vec_env": "vector"})
    try:
        check_vector(vector)
        paths["vector"] = vector
    except ConfigError as exc:
        print(f"(no vec_env: vector row: {exc})")
    pico_vecs = {name: make_training_vec_env(c, args.seed) for name, c in paths.items()}
    first = next(iter(pico_vecs.values()))
    size = int(np.prod(first.observation_space.shape))
    toy_vec = DummyVecEnv([lambda: ToyObservationEnv(size, first.action_space) for _ in range(n_envs)])
    models = [_ppo(config, toy_vec, args.seed)] + [_ppo(config, v, args.seed) for v in pico_vecs.values()]
    for model in models:
        model.learn(per_round // args.rollouts)  # warm-up: JIT caches, allocations
    clocks = [_time_step_wait(v) for v in [toy_vec, *pico_vecs.values()]]
    env_us: list[list[float]] = [[] for _ in models]  # each round's step_wait, us a robot step

    def learn(k: int) -> Callable[[], int]:
        model, clock = models[k], clocks[k]

        def run() -> int:
            before, waited = model.num_timesteps, clock[0]
            model.learn(per_round, reset_num_timesteps=False)
            steps = model.num_timesteps - before
            env_us[k].append((clock[0] - waited) / steps * 1e6)
            return steps

        return run

    toy_fps, *pico_fps = interleaved([learn(k) for k in range(len(models))], args.rounds)
    _row(f"SB3 PPO, toy env ({size}-float Box observation)", toy_fps, "fps")
    for name, fps in zip(pico_vecs, pico_fps, strict=True):
        what = "DummyVecEnv of wrapped envs" if name == "dummy" else "PicoTrainingVecEnv"
        _row(f"SB3 PPO, pico-gym train, vec_env: {name} ({what})", fps, "fps", ("the toy", toy_fps))
    # The env's share: what 0.95x the toy's fps leaves the env side, round by round.
    budget = statistics.median(t + (1.0 / 0.95 - 1.0) * 1e6 / f for t, f in zip(env_us[0], toy_fps, strict=True))
    sides = ", ".join(
        f"vec_env: {name} {statistics.median(us):.1f} us" for name, us in zip(pico_vecs, env_us[1:], strict=True)
    )
    print(
        f"{'env side inside PPO (step_wait, a robot step)':<58} toy {statistics.median(env_us[0]):.1f} us, {sides}; "
        f"0.95x the toy's fps leaves {budget:.1f} us"
    )
    for v in pico_vecs.values():
        v.close()


def _wrapper_row(
    config: TrainConfig, args: argparse.Namespace, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """The learning wrapper's cost per step: a wrapped env against the same bare env; the action
    bounds (for the next rows)."""
    from pico_gym.envs.base import pico_env
    from pico_gym.train.envs import EpisodeSeeds, make_training_env, train_env_kwargs
    from pico_gym.wrappers import PicoLearningWrapper

    steps = 5000
    # The same chain without the learning wrapper and the Monitor: the same rooms (episode seeds
    # from the same generator) and the same actions, so both reset as often.
    wrapped = make_training_env(config, np.random.default_rng(args.seed))
    bare = EpisodeSeeds(gym.make(config.env_id, **train_env_kwargs(config, 0)), np.random.default_rng(args.seed))
    wrapped.reset(seed=args.seed)
    bare.reset(seed=args.seed)
    unit_actions = rng.uniform(-1.0, 1.0, size=(steps, 3)).astype(np.float32)
    box = pico_env(bare).action_space
    low, high = box.low, box.high
    raw_actions = (low + (unit_actions + 1.0) * 0.5 * (high - low)).astype(np.float32)

    def stepping(env: gym.Env, actions: np.ndarray) -> Callable[[], int]:
        def run() -> int:
            for a in actions:
                _, _, terminated, truncated, _ = env.step(a)
                if terminated or truncated:
                    env.reset()
            return len(actions)

        return run

    wrapped_rate, bare_rate = interleaved([stepping(wrapped, unit_actions), stepping(bare, raw_actions)], args.rounds)
    assert any(isinstance(w, PicoLearningWrapper) for w in _chain(wrapped))
    tax_us = statistics.median((1.0 / w - 1.0 / b) * 1e6 for w, b in zip(wrapped_rate, bare_rate, strict=True))
    print(
        f"{'training env step (learning wrapper + Monitor)':<58} {statistics.median(wrapped_rate):8,.0f} steps/s"
        f"   {tax_us:.1f} us a step over the env's {statistics.median(bare_rate):,.0f} steps/s (the wrapper tax)"
    )

    return low, high


def _vec_rows(
    config: Any, args: argparse.Namespace, rng: np.random.Generator, low: np.ndarray, high: np.ndarray
) -> None:
    """Stepping only, raw observations: DummyVecEnv over single envs against the vector env."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    from pico_gym.train.sb3_vec import PicoSB3VecEnv

    n_envs = int(config.zoo["n_envs"])
    steps = 5000
    dummy = DummyVecEnv([lambda: gym.make(config.env_id) for _ in range(n_envs)])
    ours = PicoSB3VecEnv(config.env_id, n_envs)
    for venv in (dummy, ours):
        venv.seed(args.seed)
        venv.reset()
    batches = rng.uniform(low, high, size=(steps // n_envs, n_envs, 3)).astype(np.float32)

    def vec_stepping(venv: Any) -> Callable[[], int]:
        def run() -> int:
            for a in batches:
                venv.step(a)
            return len(batches) * n_envs

        return run

    dummy_rate, ours_rate = interleaved([vec_stepping(dummy), vec_stepping(ours)], args.rounds)
    _row(f"SB3 DummyVecEnv, {n_envs} envs, raw observations", dummy_rate, "steps/s")
    _row(f"PicoSB3VecEnv (pico-gym vector env), {n_envs} envs", ours_rate, "steps/s", ("DummyVecEnv", dummy_rate))


def _chain(env: gym.Env) -> list[gym.Env]:
    out = [env]
    while hasattr(out[-1], "env"):
        out.append(out[-1].env)
    return out


def add_bench_train(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench-train", help="training throughput: PPO on pico-gym's envs against a toy env")
    p.add_argument("--config", default=str(DEFAULT_CONFIG), help="YAML config (rl-zoo3 layout)")
    p.add_argument("--rounds", type=int, default=3, help="interleaved rounds (medians are printed)")
    p.add_argument("--rollouts", type=int, default=4, help="PPO rollouts (and updates) per round")
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=cmd_bench_train)
