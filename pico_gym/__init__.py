"""pico-gym: the Embedded Motion Control course's PICO challenges as Gymnasium environments.

Importing the package registers the environment ids (also registered through the
`gymnasium.envs` entry point, so `gym.make("PicoEscape-v0")` works without the import).
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

ENV_IDS = ("PicoEscape-v0",)


def register_envs() -> None:
    """Register pico-gym's ids with Gymnasium; a second call does nothing."""
    if "PicoEscape-v0" not in registry:
        register(id="PicoEscape-v0", entry_point="pico_gym.envs.escape_env:PicoEscapeEnv")


register_envs()
