"""pico-gym: the Embedded Motion Control course's PICO challenges as Gymnasium environments.

Importing the package registers the environment ids (also registered through the
`gymnasium.envs` entry point, so `gym.make("PicoEscape-v0")` works without the import).
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

ENV_IDS = ("PicoEscape-v0", "PicoHospital-v0", "PicoExplore-v0")
_ENTRY_POINTS = {
    "PicoEscape-v0": "pico_gym.envs.escape_env:PicoEscapeEnv",
    "PicoHospital-v0": "pico_gym.envs.hospital_env:PicoHospitalEnv",
    "PicoExplore-v0": "pico_gym.envs.explore_env:PicoExploreEnv",
}


def register_envs() -> None:
    """Register pico-gym's ids with Gymnasium; a second call does nothing."""
    for env_id, entry_point in _ENTRY_POINTS.items():
        if env_id not in registry:
            register(id=env_id, entry_point=entry_point)


register_envs()
