"""Two robots in one world, as a PettingZoo `ParallelEnv` (the 2021 course's second robot, "taco").

`pico_gym.parallel_env("PicoHospital-v0", n_robots=2, ...)` (or `sim_config=` a course config with
`enable_taco: true`) puts robots "pico" and "taco" into one hospital (or escape room). Each robot
is a full single-robot env of its own (`robot_env(parallel, name)`): its own LRF, which sees the
other robot's true notched footprint, its own odometry and noise stream, its own task (cabinet
order, given per robot in `reset(options={"taco": {"cabinet_order": [...]}})` or drawn), arrival
rule, termination and info. The world is shared: walls, closed doors, boxes and people (one
`Movers`, moved by pico's physics, pausing near either robot). Robot-robot contacts are solid
(each robot is a kinematic body in the other's physics, and a sub-step that would make the
footprints touch is undone) and counted as bumps of kind "robot".

A step moves the robots one after the other, pico first: each robot steps with the other standing
where it is. Every random draw comes from the robots' own generators, seeded from `reset(seed=)`
(pico with the seed, taco with the seed + 1): same seed, same episode, bit for bit.

Needs PettingZoo (the `multi` extra).
"""

from __future__ import annotations

import functools
import warnings
from typing import Any

import gymnasium as gym
import numpy as np

from pico_gym.extras import require

require("pettingzoo", "multi", "pico_gym.parallel_env (two robots)")

from pettingzoo import ParallelEnv  # noqa: E402

from pico_gym.envs.base import PicoEnv, pico_env  # noqa: E402

ROBOT_NAMES = ("pico", "taco")
PLAYS = ("PicoHospital-v0", "PicoEscape-v0")


class PicoParallelEnv(ParallelEnv):
    """PICO and taco in one world (see the module docstring).

    Args:
        env_id: "PicoHospital-v0" or "PicoEscape-v0".
        n_robots: 2 (1: pico alone, as the single-robot env).
        sim_config: a course simulator config: its `pico_pose` / `taco_pose` place the robots.
        render_mode: "rgb_array" or "human": pico's view of the world, taco drawn in outline.
        **options: the env's options (`map=`, `n_boxes=`, ...), for both robots.
    """

    metadata: dict[str, Any] = {
        "render_modes": ["human", "rgb_array"],
        "name": "pico_parallel_v0",
        "is_parallelizable": True,
    }

    def __init__(
        self,
        env_id: str = "PicoHospital-v0",
        n_robots: int = 2,
        sim_config: Any = None,
        render_mode: str | None = None,
        **options: Any,
    ) -> None:
        if env_id not in PLAYS:
            raise ValueError(f"two robots play {' and '.join(PLAYS)}, not {env_id!r}")
        if isinstance(n_robots, bool) or n_robots not in (1, 2):
            raise ValueError(f"n_robots must be 1 or 2 (pico and taco), got {n_robots!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        self.render_mode = render_mode
        self.possible_agents = list(ROBOT_NAMES[:n_robots])
        self.agents: list[str] = []
        # Each robot's env (its free-space shortcut keeps clear of the other robot:
        # `PicoEnv.set_other_robots`).
        made = {
            name: gym.make(
                env_id,
                render_mode=render_mode if name == "pico" else None,
                sim_config=sim_config,
                _robots=n_robots,
                **options,
            )
            for name in self.possible_agents
        }
        self.robots: dict[str, PicoEnv] = {name: pico_env(env) for name, env in made.items()}
        self._made = made
        for name, env in self.robots.items():
            env.expect_other_robots(n_robots - 1, drives_movers=name == "pico")
        config = self.robots["pico"].sim_config if hasattr(self.robots["pico"], "sim_config") else None
        self._taco_start = None
        if config is not None and config.taco_pose is not None:
            world = self.robots["pico"].task.fixed_map  # type: ignore[attr-defined]
            self._taco_start = tuple(world.from_simulator(config.taco_pose))

    @functools.cache  # noqa: B019  (the spaces are fixed per robot)
    def observation_space(self, agent: str) -> gym.spaces.Space:
        return self.robots[agent].observation_space

    @functools.cache  # noqa: B019
    def action_space(self, agent: str) -> gym.spaces.Space:
        return self.robots[agent].action_space

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
        """Start an episode: pico's world drawn (or the map), taco joining it.

        Args:
            seed: pico's seed (taco's is seed + 1).
            options: per robot, `{"pico": {...}, "taco": {...}}`: each robot's reset options
                (`start_pose`, `cabinet_order`, ...).
        """
        if options is not None and not isinstance(options, dict):
            raise TypeError(f"reset options must be a dict of per-robot options, got {options!r:.60}")
        options = dict(options or {})
        unknown = sorted(str(k) for k in set(options) - set(self.possible_agents))
        if unknown:  # (PettingZoo's API test passes a key of its own: warned, not refused)
            warnings.warn(
                f"reset options are per robot ({', '.join(self.possible_agents)}); ignored: {', '.join(unknown)}",
                UserWarning,
                stacklevel=2,
            )
        obs, infos = {}, {}
        pico = self.robots["pico"]
        obs["pico"], infos["pico"] = pico.reset(seed=seed, options=options.get("pico"))
        if "taco" in self.robots:
            taco_options = dict(options.get("taco") or {})
            if self._taco_start is not None:
                taco_options.setdefault("start_pose", self._taco_start)
            taco_seed = None if seed is None else seed + 1
            obs["taco"], infos["taco"] = self.robots["taco"].join(pico, seed=taco_seed, options=taco_options)
            for name in self.possible_agents:  # each robot's first scan sees the other
                self.robots[name].set_other_robots(self._others(name))
                obs[name] = self.robots[name].rescan()
        self.agents = list(self.possible_agents)
        return obs, infos

    def _others(self, name: str) -> list:
        return [env.pose for other, env in self.robots.items() if other != name]

    def step(
        self, actions: dict[str, Any]
    ) -> tuple[dict[str, Any], dict[str, float], dict[str, bool], dict[str, bool], dict[str, dict[str, Any]]]:
        """Step every live robot, pico first, each with the other standing where it is. A robot
        whose episode ended stays in the world, standing, and leaves `agents`."""
        missing = [a for a in self.agents if a not in actions]
        extra = [a for a in actions if a not in self.agents]
        if missing or extra:
            raise ValueError(f"actions are for the live robots {self.agents}: missing {missing}, not live {extra}")
        obs, rewards, terminated, truncated, infos = {}, {}, {}, {}, {}
        for name in self.agents:
            env = self.robots[name]
            if len(self.robots) > 1:
                env.set_other_robots(self._others(name))
            obs[name], rewards[name], terminated[name], truncated[name], infos[name] = env.step(actions[name])
        self.agents = [a for a in self.agents if not (terminated[a] or truncated[a])]
        return obs, rewards, terminated, truncated, infos

    def render(self) -> np.ndarray | None:
        """pico's view of the world (the other robot drawn where it stands)."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode")
            return None
        return self.robots["pico"].render()

    def close(self) -> None:
        for env in self._made.values():
            env.close()

    def state(self) -> np.ndarray:
        """The robots' true poses (privileged: for metrics), one row per robot."""
        return np.array([tuple(env.pose) for env in self.robots.values()])


def parallel_env(env_id: str = "PicoHospital-v0", **kwargs: Any) -> PicoParallelEnv:
    """Two robots in one world: see `PicoParallelEnv`."""
    return PicoParallelEnv(env_id, **kwargs)


def robot_env(env: PicoParallelEnv, name: str) -> PicoEnv:
    """One robot's own env (its observation and action spaces, its robot spec): what
    `make_agent(name, robot_env(env, "taco"))` builds a single-robot agent for."""
    if name not in env.robots:
        raise ValueError(f"no robot {name!r}; robots: {', '.join(env.robots)}")
    return env.robots[name]
