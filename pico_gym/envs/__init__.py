"""Gymnasium environments."""

from pico_gym.envs.escape_env import PicoEscapeEnv

__all__ = ["PicoEscapeEnv"]
