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
_VECTOR_ENTRY_POINTS = {
    "PicoEscape-v0": "pico_gym.vector:escape_vector_env",
    "PicoHospital-v0": "pico_gym.vector:hospital_vector_env",
    "PicoExplore-v0": "pico_gym.vector:explore_vector_env",
}


def register_envs() -> None:
    """Register pico-gym's ids with Gymnasium (each with its vector env, `pico_gym.vector`); a
    second call does nothing."""
    for env_id, entry_point in _ENTRY_POINTS.items():
        if env_id not in registry:
            register(id=env_id, entry_point=entry_point, vector_entry_point=_VECTOR_ENTRY_POINTS[env_id])


register_envs()
