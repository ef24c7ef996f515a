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

from typing import Any

import gymnasium as gym

from pico_gym.agents.base import Agent, RobotSpec

AGENTS = ("classic", "ppo", "hybrid", "wall-follow", "random", "classic-oracle", "ppo-pointgoal")
# Agents that read privileged state (the true pose) for benchmarks: never a baseline to beat.
PRIVILEGED_AGENTS = ("classic-oracle", "ppo-pointgoal")
# Agents that play the hospital's arrival="announce" mode (a fourth action component); a
# ppo-pointgoal policy plays the mode it was trained in (checked against its outputs).
ANNOUNCING_AGENTS = ("classic", "classic-oracle", "hybrid", "ppo-pointgoal")
# Floor baselines that can play arrival="announce" without announcing (`never_announce=True`).
NEVER_ANNOUNCING = ("wall-follow", "random")
CLASSIC_ENVS = ("PicoEscape-v0", "PicoHospital-v0", "PicoExplore-v0")  # the classic agent has a strategy for these


def make_agent(name: str, env: gym.Env, **kwargs: Any) -> Agent:
    """Build an agent for an env's robot.

    Args:
        name: one of AGENTS.
        env: the env (only its robot's public spec is used).
        **kwargs: passed to the agent (e.g. `seed` for random, `config` for classic, `path` for
            ppo: a policy zip other than the shipped one); `never_announce=True` lets wall-follow
            and random play PicoHospital-v0's arrival="announce" mode without ever announcing.

    Raises:
        ValueError: for an unknown name, listing the known ones.
    """
    spec = RobotSpec.of(env)
    env_spec = env.unwrapped.spec
    env_id = env_spec.id if env_spec is not None else type(env.unwrapped).__name__
    if (name == "ppo" and env_id != "PicoEscape-v0") or (name == "classic" and env_id not in CLASSIC_ENVS):
        plays = "PicoEscape-v0" if name == "ppo" else " and ".join(CLASSIC_ENVS)
        others = "classic, wall-follow, random" if name == "ppo" and env_id in CLASSIC_ENVS else "wall-follow, random"
        raise ValueError(f"the {name} agent plays {plays} only so far; on {env_id} use: {others}")
    announcing = env_id == "PicoHospital-v0" and name in ANNOUNCING_AGENTS
    never_announce = kwargs.pop("never_announce", False)
    if not isinstance(never_announce, bool):
        raise ValueError(f"never_announce must be true or false, got {never_announce!r}")
    if never_announce and name not in NEVER_ANNOUNCING:
        raise ValueError(f"never_announce is for the floor baselines ({', '.join(NEVER_ANNOUNCING)}), not {name}")
    silent = env_id == "PicoHospital-v0" and name in NEVER_ANNOUNCING and never_announce
    if env.action_space.shape != (3,) and not ((announcing or silent) and env.action_space.shape == (4,)):
        raise ValueError(
            f"the {name} agent acts with a twist (vx, vy, w); {env_id} here takes {env.action_space.shape[0]} "
            f"action components (arrival='announce'): use arrival='dwell', or an agent that announces: "
            f"{', '.join(ANNOUNCING_AGENTS)} (PicoHospital-v0)"
            + (", or never_announce=True (it then never announces)" if name in NEVER_ANNOUNCING else "")
        )
    if name == "classic-oracle":
        if env_id != "PicoHospital-v0":
            raise ValueError(
                f"the classic-oracle agent (true pose, privileged) plays PicoHospital-v0 only; got {env_id}"
            )
        from pico_gym.agents.classic.hospital import OraclePoseAgent

        return OraclePoseAgent(spec, env, **kwargs)
    if name == "ppo-pointgoal":
        if env_id != "PicoHospital-v0":
            raise ValueError(
                f"the ppo-pointgoal agent (privileged point goal) plays PicoHospital-v0 only; got {env_id}"
            )
        from pico_gym.agents.ppo import SHIPPED_POINTGOAL_POLICY, PpoAgent
        from pico_gym.wrappers import point_goal

        if kwargs.get("path") is None:
            if not SHIPPED_POINTGOAL_POLICY.exists():
                raise FileNotFoundError(
                    "no ppo-pointgoal policy is shipped (none has reached the bar to ship: 80 % success on "
                    "generated hospitals with 2 cabinets); train one with train/configs/ppo_hospital_pointgoal.yaml "
                    "and pass path=... (--policy)"
                )
            kwargs["path"] = SHIPPED_POINTGOAL_POLICY
        agent = PpoAgent(spec, goal=lambda: point_goal(env), **kwargs)  # privileged: the true pose
        outputs, wanted = agent.actor.action_low.shape[0], env.action_space.shape[0]
        if outputs != wanted:
            trained, here = ("arrival='announce'", "'dwell'") if outputs == 4 else ("arrival='dwell'", "'announce'")
            raise ValueError(
                f"this ppo-pointgoal policy ({kwargs['path']}) has {outputs} action outputs (trained with {trained}); "
                f"the env here takes {wanted} (arrival={here}): make the env with the arrival mode it was trained in"
            )
        return agent
    if name == "hybrid":
        if env_id != "PicoHospital-v0":
            raise ValueError(f"the hybrid agent (classic route, PPO driving) plays PicoHospital-v0 only; got {env_id}")
        from pico_gym.agents.hybrid import HybridAgent

        return HybridAgent(spec, **kwargs)
    if name == "classic" and env_id == "PicoExplore-v0":
        from pico_gym.agents.classic.explore import ExploreAgent

        return ExploreAgent(spec, **kwargs)
    if name == "classic" and env_id == "PicoHospital-v0":
        from pico_gym.agents.classic.hospital import HospitalAgent

        return HospitalAgent(spec, **kwargs)
    if name == "classic":
        from pico_gym.agents.classic.agent import ClassicAgent

        return ClassicAgent(spec, **kwargs)
    if name == "ppo":
        from pico_gym.agents.ppo import PpoAgent

        return PpoAgent(spec, **kwargs)
    if name in NEVER_ANNOUNCING:
        from pico_gym.agents.baselines import NeverAnnounces, RandomAgent, WallFollowAgent

        baseline = (WallFollowAgent if name == "wall-follow" else RandomAgent)(spec, **kwargs)
        return NeverAnnounces(baseline) if env.action_space.shape == (4,) else baseline
    raise ValueError(f"unknown agent {name!r}; agents: {', '.join(AGENTS)}")


__all__ = ["AGENTS", "PRIVILEGED_AGENTS", "Agent", "RobotSpec", "make_agent"]
