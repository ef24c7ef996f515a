"""Gymnasium environments."""

from __future__ import annotations

import importlib
from typing import Any

from pico_gym.envs.escape_env import PicoEscapeEnv
from pico_gym.envs.explore_env import PicoExploreEnv
from pico_gym.envs.hospital_env import PicoHospitalEnv


def env_class(spec: Any) -> Any:
    """The class behind a registered env spec (its `entry_point`), without making an env."""
    entry = spec.entry_point
    if callable(entry):
        return entry
    module, _, name = entry.partition(":")
    return getattr(importlib.import_module(module), name)


__all__ = ["PicoEscapeEnv", "PicoExploreEnv", "PicoHospitalEnv", "env_class"]
