"""Two floor baselines: random actions, and the wall follower several course teams fell back on."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pico_gym.agents.base import Agent, RobotSpec, episode_rng
from pico_gym.agents.classic.potential_field import MotionConfig, keep_in_view, safety_filter
from pico_gym.overlay import Overlay


class RandomAgent(Agent):
    """Uniform random twists within the limits, from its own generator.

    The generator is re-seeded at each reset from `seed` and the episode's first scan, so an
    episode plays the same whatever ran before it (in which worker, in which order).
    """

    name = "random"

    def __init__(self, spec: RobotSpec, seed: int = 0) -> None:
        super().__init__(spec)
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self.high = spec.robot.action_high

    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:
        self.rng = episode_rng(self.seed, obs)

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        return (self.rng.uniform(-1.0, 1.0, 3) * self.high).astype(np.float32)


# Wall following: keep the wall on the right at this distance [m] ...
WALL_DISTANCE_M = 0.45
# ... and turn left when something is closer than this ahead [m].
FRONT_CLEAR_M = 0.6


class WallFollowAgent(Agent):
    """Right-hand wall following: forward along the wall, left at walls ahead, right at gaps."""

    name = "wall-follow"

    def __init__(self, spec: RobotSpec) -> None:
        super().__init__(spec)
        self.angles = spec.beam_angles
        self.motion = MotionConfig()
        self._state = ""

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        r = np.asarray(obs["lrf"], dtype=np.float64)
        valid = (r > self.spec.lrf.range_min_m) & (r < self.spec.lrf.range_max_m - 1e-3)
        r = np.where(valid, r, self.spec.lrf.range_max_m)
        a = self.angles
        front = float(r[np.abs(a) < 0.35].min(initial=10.0))
        right = float(r[(a > -math.pi / 2 - 0.3) & (a < -math.pi / 2 + 0.3)].min(initial=10.0))
        if front < FRONT_CLEAR_M:
            self._state = "turn left"
            command = (0.0, 0.0, 0.8)
        elif right > WALL_DISTANCE_M + 0.4:
            self._state = "find wall"
            command = (0.3, -0.1, -0.6)
        else:
            self._state = "follow"
            error = right - WALL_DISTANCE_M
            command = (0.4, float(np.clip(-error, -0.2, 0.2)), float(np.clip(-1.5 * error, -0.6, 0.6)))
        points = np.column_stack([r[valid] * np.cos(a[valid]), r[valid] * np.sin(a[valid])])
        v = keep_in_view(np.array(command[:2]), self.motion)
        vx, vy, w = safety_filter(points, (float(v[0]), float(v[1]), command[2]), self.motion)
        return np.array([vx, vy, w], dtype=np.float32)

    def overlay(self) -> Overlay:
        return Overlay(frame="robot", text=f"wall-follow: {self._state}")


class NeverAnnounces(Agent):
    """A twist agent playing PicoHospital-v0's arrival="announce" mode: its twist, and an
    announcement component that never announces (-1). For floor baselines in a comparison of
    announcing agents (`make_agent(..., never_announce=True)`): they can then count no cabinet."""

    def __init__(self, agent: Agent) -> None:
        super().__init__(agent.spec)
        self.agent = agent
        self.name = agent.name

    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:
        self.agent.reset(obs, info)

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        return np.append(self.agent.act(obs), np.float32(-1.0)).astype(np.float32)

    def overlay(self) -> Overlay | None:
        return self.agent.overlay()


def build_wall_follow(env: Any, **kwargs: Any) -> WallFollowAgent:
    """The wall follower for an env's robot (`make_agent("wall-follow", env)`)."""
    return WallFollowAgent(RobotSpec.of(env), **kwargs)


def build_random(env: Any, **kwargs: Any) -> RandomAgent:
    """The random agent for an env's robot (`make_agent("random", env)`)."""
    return RandomAgent(RobotSpec.of(env), **kwargs)
