"""The interface every pico-gym agent implements, and what it may know about the robot.

An agent sees only observations (LRF and odometry) and the robot's public specification (its
sensor and body configuration, the control period); never the true pose or an escape room's map.
"""

from __future__ import annotations

import zlib
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from pico_gym.envs.base import pico_env
from pico_gym.overlay import Overlay
from pico_gym.robot import RobotConfig
from pico_gym.sensors.lrf import LrfConfig


@dataclass(frozen=True)
class RobotSpec:
    """What an agent may know about its robot: the sensor, the body and the control period."""

    lrf: LrfConfig
    robot: RobotConfig
    dt_s: float

    @property
    def beam_angles(self) -> np.ndarray:
        return self.lrf.beam_angles

    @staticmethod
    def of(env: gym.Env) -> RobotSpec:
        """The spec of an env's robot (its public configuration, no world state)."""
        config = pico_env(env).config
        return RobotSpec(config.lrf, config.robot, config.dt_s)


def episode_rng(seed: int, obs: dict[str, np.ndarray]) -> np.random.Generator:
    """A generator for one episode, from an agent's seed and the episode's first scan: the episode
    then plays the same whatever ran before it (in which worker, in which order)."""
    return np.random.default_rng([seed, zlib.crc32(np.ascontiguousarray(obs["lrf"]).tobytes())])


class Agent(ABC):
    """An agent: reset at the start of an episode, then one action per observation."""

    name = "agent"

    def __init__(self, spec: RobotSpec) -> None:
        self.spec = spec

    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:  # noqa: B027
        """Start an episode from its first observation (`info` is for logging only).

        Stateless agents need not override it.
        """

    @abstractmethod
    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        """The twist (vx, vy, w) for this observation."""

    def overlay(self) -> Overlay | None:
        """What the agent wants drawn in the env's renderer (None: nothing)."""
        return None
