"""Stable-Baselines3's `VecEnv` over pico-gym's vector env: SB3 trains from N robots in one process.

`PicoSB3VecEnv(env_id, n)` steps `pico_gym.vector.PicoVectorEnv` in SAME_STEP autoreset mode and
hands SB3 what its `DummyVecEnv` would: the batch of observations (the first of the next episode
where one ended), rewards, dones, and one info dict per env with `terminal_observation` and
`TimeLimit.truncated` (the info of a reset is in `reset_infos`). It carries no per-env gymnasium
wrappers: observations are the env's own (`MultiInputPolicy`), not the learning encoder's.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvObs, VecEnvStepReturn

from pico_gym.vector import PicoVectorEnv


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
