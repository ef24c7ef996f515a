"""Training the hybrid hospital agent's local policy in the loop it will drive in.

`HybridTraining` wraps PicoHospital-v0 so that an RL step is one step the policy drives: the
classic part of a `HybridAgent` (without a policy) runs every step, acts by itself in every state
but NAVIGATE (localising, docking, the dwell, yielding, recovering: those steps are taken inside
the wrapper and their rewards summed into the policy's step), and in NAVIGATE hands the policy
`obs["point_goal"]`, the route's waypoint from its own pose estimate. The policy's command goes
through the same shield as at deployment. Nothing privileged enters the observation; the reward is
the env's (geodesic progress, cabinets, bumps, time).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from pico_gym.agents.base import RobotSpec
from pico_gym.agents.hybrid import HybridAgent, HybridConfig
from pico_gym.wrappers import POINT_GOAL_SIZE

# Classic steps one policy step may hold at most (a long RECOVER/YIELD loop ends the episode's
# step instead: the env's own time limit ends the episode).
MAX_CLASSIC_STEPS = 3000


class HybridTraining(gym.Wrapper):
    """PicoHospital-v0 as the hybrid agent's policy sees it (see the module docstring).

    Args:
        env: a PicoHospital-v0 env (arrival="dwell").
        lookahead_m, shield, walk_in_mps, back_budget_m: `HybridConfig` (the cuts the policy
            is trained with should be the ones it is deployed with).
        fallback_after_s: `HybridConfig.fallback_after_s`: a leg stuck this long is driven by
            the classic part, its steps not the policy's (0: the loop the shipped policy was
            trained in).
    """

    def __init__(
        self,
        env: gym.Env,
        lookahead_m: float = 1.0,
        shield: bool = True,
        walk_in_mps: float = 0.0,
        back_budget_m: float = 0.1,
        fallback_after_s: float = 120.0,
    ) -> None:
        if not hasattr(type(getattr(env.unwrapped, "task", None)), "next_target"):
            raise ValueError(f"HybridTraining needs PicoHospital-v0; got {type(env.unwrapped).__name__}")
        super().__init__(env)
        hybrid = HybridConfig(
            lookahead_m, shield, walk_in_mps=walk_in_mps, back_budget_m=back_budget_m, fallback_after_s=fallback_after_s
        )
        self.driver = HybridAgent(RobotSpec.of(env), hybrid=hybrid, driver=True)
        spaces = dict(env.observation_space.spaces)  # type: ignore[attr-defined]
        low = np.array([0.0, -1.0, -1.0, -1.0, -1.0], np.float32)
        spaces["point_goal"] = gym.spaces.Box(low, np.ones(POINT_GOAL_SIZE, np.float32), dtype=np.float32)
        self.observation_space = gym.spaces.Dict(spaces)
        self.classic_steps = 0  # steps the classic part took by itself (since construction)

    def reset(self, **kwargs: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self.driver.reset(obs, info)
        obs, _, terminated, truncated, info = self._until_policy(obs, info)
        if terminated or truncated:  # ended before the policy's first step (rare): the next episode
            seed = None if kwargs.get("seed") is None else int(kwargs["seed"]) + 1
            return self.reset(**{**kwargs, "seed": seed})
        return self._with_goal(obs), info

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        vx, vy, w = (float(v) for v in np.asarray(action, dtype=np.float64)[:3])
        obs, reward, terminated, truncated, info = self.env.step(self.driver.finish((vx, vy, w)))
        if not (terminated or truncated):
            obs, more, terminated, truncated, info = self._until_policy(obs, info)
            reward = float(reward) + more
        return self._with_goal(obs), float(reward), terminated, truncated, info

    def teacher_action(self) -> np.ndarray:
        """What the classic part would have commanded this step ([-1, 1] units): for cloning."""
        return self.driver.teacher()

    def _with_goal(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {**obs, "point_goal": self.driver.goal()}

    def _until_policy(
        self, obs: dict[str, np.ndarray], info: dict[str, Any]
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Let the classic part act until the policy is to drive (or the episode ends)."""
        total = 0.0
        for _ in range(MAX_CLASSIC_STEPS):
            if self.driver.observe(obs):
                return obs, total, False, False, info
            obs, reward, terminated, truncated, info = self.env.step(self.driver.finish(self.driver.command))
            self.classic_steps += 1
            total += float(reward)
            if terminated or truncated:
                return obs, total, terminated, truncated, info
        return obs, total, False, False, info
