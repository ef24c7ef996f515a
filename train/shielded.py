"""Training a policy in the loop it is played in: its twist through the shield.

A policy shipped shielded (`ship --shield`; `PpoAgent(shield=True)`) has its every command passed
through the classic safety filter on the current scan (`pico_gym.agents.shield.ScanShield`). A
policy trained without it learns to keep off walls by itself, bump penalty and all, and turns out
more careful than it need be once the filter stands between it and the walls. `ShieldedActions`
puts the same filter in the training env: the policy's action is what it commands, the env steps
the filtered twist. List it in a config's `env_wrapper` before the learning wrapper:

    env_wrapper:
      - pico_gym.train.shielded.ShieldedActions
      - pico_gym.wrappers.PicoLearningWrapper: {...}
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from pico_gym.agents.base import RobotSpec
from pico_gym.agents.shield import ScanShield


class ShieldedActions(gym.Wrapper):
    """The env's twist (the action's first three components) through `ScanShield` on the latest
    scan; any further components (an announcement) pass unchanged.

    Args:
        env: a pico-gym env with the raw observations (a dict with "lrf"), not yet wrapped by the
            learning wrapper.
    """

    def __init__(self, env: gym.Env) -> None:
        space = env.observation_space
        if not (isinstance(space, gym.spaces.Dict) and "lrf" in space.spaces):
            raise ValueError(
                "ShieldedActions needs the env's own observations (a dict with 'lrf'); list it before "
                f"PicoLearningWrapper in env_wrapper (got observation space {space})"
            )
        super().__init__(env)
        self.shield = ScanShield(RobotSpec.of(env))
        self._ranges: np.ndarray | None = None

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._ranges = obs["lrf"]
        return obs, info

    def step(self, action: np.ndarray) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        if self._ranges is None:
            raise RuntimeError("ShieldedActions: step() before reset()")
        action = np.asarray(action)
        filtered = self.shield(self._ranges, action[:3]).astype(action.dtype)
        if action.shape[0] > 3:
            filtered = np.concatenate([filtered, action[3:]])
        obs, reward, terminated, truncated, info = self.env.step(filtered)
        self._ranges = obs["lrf"]
        return obs, reward, terminated, truncated, info
