"""The classic hospital agent (2019-2021: visit cabinets in order on a given map), by seam:

config     its settings
given      the given map, prepared once per task
pose       localisation on it (`MapPose`)
evidence   what the map does not show: the evidence grid and the people tracked (`EvidenceMap`)
route      A* on the map and the evidence, string pulled, doors crossed square on
docking    the cabinet's front as the LRF sees it
states     the state machine, a function per state
agent      `HospitalAgent`, which chains them each step; `OraclePoseAgent`
"""

from pico_gym.agents.classic.hospital.agent import HospitalAgent, OraclePoseAgent, build, build_oracle
from pico_gym.agents.classic.hospital.config import HospitalAgentConfig
from pico_gym.agents.classic.hospital.docking import FrontFit, fit_front
from pico_gym.agents.classic.hospital.states import State

__all__ = [
    "FrontFit",
    "HospitalAgent",
    "HospitalAgentConfig",
    "OraclePoseAgent",
    "State",
    "build",
    "build_oracle",
    "fit_front",
]
