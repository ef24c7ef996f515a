"""pico-gym's agents, all behind one interface: `make_agent(name, env)`.

>>> import gymnasium as gym, pico_gym
>>> from pico_gym.agents import make_agent
>>> env = gym.make("PicoEscape-v0")
>>> agent = make_agent("classic", env)
>>> obs, info = env.reset(seed=0); agent.reset(obs, info)
>>> agent.act(obs).shape
(3,)
"""

from __future__ import annotations

from pico_gym.agents.base import Agent, RobotSpec
from pico_gym.agents.registry import AGENT_ENTRIES, AgentEntry, agent_entry, agents_for, make_agent, register_agent

# The shipped agents' names, and those that read privileged state (the true pose) for benchmarks:
# never a baseline to beat. (The registry, `AGENT_ENTRIES`, holds every registered agent.)
AGENTS = tuple(AGENT_ENTRIES)
PRIVILEGED_AGENTS = tuple(name for name, entry in AGENT_ENTRIES.items() if entry.privileged)

__all__ = [
    "AGENTS",
    "AGENT_ENTRIES",
    "PRIVILEGED_AGENTS",
    "Agent",
    "AgentEntry",
    "RobotSpec",
    "agent_entry",
    "agents_for",
    "make_agent",
    "register_agent",
]
