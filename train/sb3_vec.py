"""Stable-Baselines3's `VecEnv`s over pico-gym's vector env: SB3 trains from N robots in one process.

`PicoSB3VecEnv(env_id, n)` steps `pico_gym.vector.PicoVectorEnv` in SAME_STEP autoreset mode and
hands SB3 what its `DummyVecEnv` would: the batch of observations (the first of the next episode
where one ended), rewards, dones, and one info dict per env with `terminal_observation` and
`TimeLimit.truncated` (the info of a reset is in `reset_infos`). It carries no per-env gymnasium
wrappers: observations are the env's own (`MultiInputPolicy`), not the learning encoder's.

`PicoTrainingVecEnv(env_id, rngs, learning)` is `pico-gym train`'s fast path (`vec_env: vector`):
what its in-process DummyVecEnv of `EpisodeSeeds` -> `PicoLearningWrapper` envs hands SB3, bit for
bit (tested), from one vector env: each robot's episodes seeded from its own generator, the
learning encoder's inputs, actions in [-1, 1]. Infos are those SB3 reads: a running robot's is
empty, a finished episode's is its final info with `terminal_observation` and
`TimeLimit.truncated` (wrap it in SB3's `VecMonitor` for the episode statistics).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.wrappers.utils import rescale_box
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvObs, VecEnvStepReturn

from pico_gym.agents.base import RobotSpec
from pico_gym.train.config import TRAIN_SEED_MIN
from pico_gym.vector import PicoVectorEnv
from pico_gym.wrappers import BatchedLearningEncoder, LearningConfig


class PicoSB3VecEnv(VecEnv):
    """`num_envs` pico-gym robots as one SB3 `VecEnv`.

    Args:
        env_id: a pico-gym env id.
        num_envs: how many robots.
        **kwargs: the options every env is made with (as `gymnasium.make(env_id, **kwargs)`).
    """

    def __init__(self, env_id: str, num_envs: int, **kwargs: Any) -> None:
        self.venv = PicoVectorEnv(env_id, num_envs, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
        super().__init__(num_envs, self.venv.single_observation_space, self.venv.single_action_space)
        self.metadata = self.venv.metadata
        self.render_mode = self.venv.render_mode
        self._actions: np.ndarray | None = None

    def reset(self) -> VecEnvObs:
        seeds = self._seeds if any(s is not None for s in self._seeds) else None
        options = self._options[0] if self._options and self._options[0] else None
        obs, infos = self.venv.reset_each(seed=seeds, options=options)
        self.reset_infos = [info or {} for info in infos]
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        assert self._actions is not None  # (SB3 calls step_async first)
        obs, rewards, terminated, truncated, infos, final = self.venv.step_each(self._actions)
        dones = terminated | truncated
        out: list[dict[str, Any]] = []
        for i, info in enumerate(infos):
            if i in final:
                final_obs, final_info = final[i]
                self.reset_infos[i] = info
                info = dict(final_info, terminal_observation=final_obs)
            info["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            out.append(info)
        return obs, rewards.astype(np.float32), dones, out

    def close(self) -> None:
        self.venv.close()

    def _targets(self, indices: None | int | Iterable[int]) -> list[Any]:
        return [self.venv.envs[i] for i in self._get_indices(indices)]

    def get_attr(self, attr_name: str, indices: None | int | Iterable[int] = None) -> list[Any]:
        return [getattr(env, attr_name) for env in self._targets(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: None | int | Iterable[int] = None) -> None:
        for env in self._targets(indices):
            setattr(env, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: None | int | Iterable[int] = None, **method_kwargs: Any
    ) -> list[Any]:
        return [getattr(env, method_name)(*method_args, **method_kwargs) for env in self._targets(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices: None | int | Iterable[int] = None) -> list[bool]:
        return [False for _ in self._targets(indices)]  # the robots are bare envs

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [env.render() for env in self.venv.envs]


class _SeededVectorEnv(PicoVectorEnv):
    """A vector env whose robot i starts every episode with a seed drawn from rngs[i] (the
    `EpisodeSeeds` wrapper of a single training env, for N robots)."""

    def __init__(self, env_id: str, rngs: Sequence[np.random.Generator], **kwargs: Any) -> None:
        super().__init__(env_id, len(rngs), autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
        self.rngs = list(rngs)

    def autoreset_seed(self, i: int) -> int:
        return int(self.rngs[i].integers(TRAIN_SEED_MIN, 2**31))


class PicoTrainingVecEnv(PicoSB3VecEnv):
    """`pico-gym train`'s envs (episode seeds, the learning wrapper) as one vector env.

    Args:
        env_id: a pico-gym env id.
        rngs: one generator per robot: robot i's episode seeds are drawn from rngs[i] (as
            `EpisodeSeeds(env, rngs[i])` draws them; the seeds SB3 passes are not used).
        learning: the policy's input (`PicoLearningWrapper`'s settings), encoded for every robot in
            one call (`BatchedLearningEncoder`); a privileged point goal is not supported here.
        **kwargs: the options every env is made with.
    """

    def __init__(
        self, env_id: str, rngs: Sequence[np.random.Generator], learning: LearningConfig, **kwargs: Any
    ) -> None:
        if not rngs:
            raise ValueError("PicoTrainingVecEnv needs one generator per robot, got none")
        n = len(rngs)
        self.venv = _SeededVectorEnv(env_id, rngs, **kwargs)
        first = self.venv.envs[0]
        spec = RobotSpec.of(first)
        self.encoder = BatchedLearningEncoder(spec.lrf, spec.robot, spec.dt_s, learning, n)
        box = first.action_space
        ones = np.ones(box.shape, box.dtype)
        unit_space, _, self._to_env = rescale_box(box, -ones, ones)  # PicoLearningWrapper's RescaleAction
        VecEnv.__init__(self, n, self.encoder.space, unit_space)
        self.metadata = self.venv.metadata
        self.render_mode = self.venv.render_mode
        self._actions = None
        self._all = np.arange(n)

    def reset(self) -> VecEnvObs:
        venv = self.venv
        raw, infos = venv.reset_each(seed=[venv.autoreset_seed(i) for i in range(self.num_envs)])
        self.reset_infos = [info or {} for info in infos]
        self._reset_seeds()
        self._reset_options()
        self.encoder.reset(self._all, raw["lrf"], raw["odom"])
        return self.encoder.stacks.copy()

    def step_wait(self) -> VecEnvStepReturn:
        raw, rewards, terminated, truncated, final = self.venv.step_finals(self._to_env(np.asarray(self._actions)))
        lrf, odom = raw["lrf"], raw["odom"]
        encoder = self.encoder
        out: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if not final:
            encoder.encode(self._all, lrf, odom)
            return encoder.stacks.copy(), rewards.astype(np.float32), terminated | truncated, out
        # An episode ended: its last observation is encoded first (the terminal observation SB3
        # bootstraps a truncation from), then its robot's next episode begins.
        ended = np.array(sorted(final), np.int64)
        last_lrf, last_odom = lrf.copy(), odom.copy()
        for i in ended.tolist():
            last_lrf[i], last_odom[i] = final[i][0]["lrf"], final[i][0]["odom"]
        encoder.encode(self._all, last_lrf, last_odom)
        for i in ended.tolist():
            info = dict(final[i][1], terminal_observation=encoder.stacks[i].copy())
            info["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            out[i] = info
        encoder.reset(ended, lrf[ended], odom[ended])
        return encoder.stacks.copy(), rewards.astype(np.float32), terminated | truncated, out
