"""The agents, each registered by name with the tasks it plays (`make_agent` looks them up).

An `AgentEntry` says which env ids an agent plays and with what ("module:function" builders,
imported on first use), and what the command lines and comparisons need to know of it: whether it
reads privileged state, whether it plays the hospital's announcing mode, whether it loads a
policy file. A builder takes the env (for its public robot spec; a privileged agent may read more)
and the agent's keyword arguments.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import gymnasium as gym

from pico_gym.agents.base import Agent
from pico_gym.registry import env_id_of, load_entry

# A builder that plays any registered task.
ANY_TASK = "*"


def _n_actions(env: gym.Env) -> int:
    """How many components the env's action has (a Box's size)."""
    shape = env.action_space.shape
    if shape is None or len(shape) != 1:
        raise ValueError(f"pico-gym's agents act on a flat Box action space, got {env.action_space}")
    return int(shape[0])


@dataclass(frozen=True)
class AgentEntry:
    """An agent's registration.

    Attributes:
        name: what `make_agent` and `--agent` take.
        builders: env id (or `ANY_TASK`) -> "module:function" building the agent for it.
        privileged: it reads privileged state (the true pose): a benchmark reference, never a
            baseline to beat.
        announces: the env ids whose announcing action mode (a fourth component) it plays.
        may_stay_silent: it can play an announcing mode without ever announcing
            (`never_announce=True`), as a floor baseline.
        policy: it loads a policy file (`path=`, the command line's `--policy`).
        colour: its colour in figures (matplotlib's "C0".."C9").
    """

    name: str
    builders: Mapping[str, str]
    privileged: bool = False
    announces: tuple[str, ...] = ()
    may_stay_silent: bool = False
    policy: bool = False
    colour: str = "C4"

    def plays(self, env_id: str) -> bool:
        return env_id in self.builders or ANY_TASK in self.builders

    def played(self) -> str:
        """The env ids it plays, for messages."""
        return "every task" if ANY_TASK in self.builders else " and ".join(self.builders)


_AGENTS: dict[str, AgentEntry] = {}
AGENT_ENTRIES: Mapping[str, AgentEntry] = MappingProxyType(_AGENTS)


def register_agent(entry: AgentEntry) -> None:
    """Register an agent (a second registration of a name replaces the first)."""
    _AGENTS[entry.name] = entry


def unregister_agent(name: str) -> None:
    """Remove a registered agent: for tests."""
    _AGENTS.pop(name, None)


def agent_entry(name: str) -> AgentEntry:
    """The entry of an agent by name.

    Raises:
        ValueError: for an unknown name, listing the known ones.
    """
    try:
        return _AGENTS[name]
    except KeyError:
        raise ValueError(f"unknown agent {name!r}; agents: {', '.join(_AGENTS)}") from None


def agents_for(env_id: str) -> list[str]:
    """The names of the agents that play an env id, in registration order."""
    return [name for name, entry in _AGENTS.items() if entry.plays(env_id)]


def make_agent(name: str, env: gym.Env, **kwargs: Any) -> Agent:
    """Build an agent for an env's robot.

    Args:
        name: a registered agent (`AGENT_ENTRIES`).
        env: the env (its robot's public spec is what an agent may use; privileged agents read
            more, and say so).
        **kwargs: passed to the agent (e.g. `seed` for random, `config` for classic, `path` for
            the policy agents: a policy file other than the shipped one); `never_announce=True`
            lets an agent that `may_stay_silent` play an announcing mode without announcing.

    Raises:
        ValueError: for an unknown name, an env the agent does not play, or an action space it
            cannot fill; each message says what would work.
    """
    entry = agent_entry(name)
    env_id = env_id_of(env)
    if not entry.plays(env_id):
        others = ", ".join(a for a in agents_for(env_id) if not _AGENTS[a].privileged)
        raise ValueError(f"the {name} agent plays {entry.played()} only so far; on {env_id} use: {others}")
    never_announce = kwargs.pop("never_announce", False)
    if not isinstance(never_announce, bool):
        raise ValueError(f"never_announce must be true or false, got {never_announce!r}")
    silent_ones = [a for a, e in _AGENTS.items() if e.may_stay_silent]
    if never_announce and not entry.may_stay_silent:
        raise ValueError(f"never_announce is for the floor baselines ({', '.join(silent_ones)}), not {name}")
    n_actions = _n_actions(env)
    extras = n_actions - 3
    announcing = env_id in entry.announces
    if extras and not (announcing or never_announce):
        announcers = [a for a, e in _AGENTS.items() if env_id in e.announces]
        raise ValueError(
            f"the {name} agent acts with a twist (vx, vy, w); {env_id} here takes {n_actions} "
            f"action components (arrival='announce'): use arrival='dwell', or an agent that announces: "
            f"{', '.join(announcers)} ({env_id})"
            + (", or never_announce=True (it then never announces)" if entry.may_stay_silent else "")
        )
    build = load_entry(entry.builders.get(env_id) or entry.builders[ANY_TASK])
    agent = build(env, **kwargs)
    if extras and never_announce:
        from pico_gym.agents.baselines import NeverAnnounces

        return NeverAnnounces(agent)
    return agent


# The agents pico-gym ships, registered when `pico_gym.agents` is imported.
BUILTIN_AGENTS = (
    AgentEntry(
        "classic",
        {
            "PicoEscape-v0": "pico_gym.agents.classic.agent:build",
            "PicoHospital-v0": "pico_gym.agents.classic.hospital:build",
            "PicoExplore-v0": "pico_gym.agents.classic.explore:build",
        },
        announces=("PicoHospital-v0",),
        colour="C0",
    ),
    AgentEntry("ppo", {"PicoEscape-v0": "pico_gym.agents.ppo:build"}, policy=True, colour="C1"),
    AgentEntry(
        "hybrid",
        {"PicoHospital-v0": "pico_gym.agents.hybrid:build"},
        announces=("PicoHospital-v0",),
        policy=True,
        colour="C3",
    ),  # fmt: skip
    AgentEntry(
        "wall-follow", {ANY_TASK: "pico_gym.agents.baselines:build_wall_follow"}, may_stay_silent=True, colour="C2"
    ),  # fmt: skip
    AgentEntry("random", {ANY_TASK: "pico_gym.agents.baselines:build_random"}, may_stay_silent=True, colour="C7"),
    AgentEntry(
        "classic-oracle",
        {"PicoHospital-v0": "pico_gym.agents.classic.hospital:build_oracle"},
        privileged=True,
        announces=("PicoHospital-v0",),
    ),  # fmt: skip
    AgentEntry(
        "ppo-pointgoal",
        {"PicoHospital-v0": "pico_gym.agents.ppo:build_pointgoal"},
        privileged=True,
        announces=("PicoHospital-v0",),
        policy=True,
        colour="C4",
    ),  # fmt: skip
)
for _entry in BUILTIN_AGENTS:
    register_agent(_entry)
