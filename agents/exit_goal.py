"""The escape room's exit as a goal a policy can see, from the robot's own senses.

The classic escape agent finds the corridor's mouth in the scan (split-and-merge lines, then the
gaps between them that a corridor's walls continue behind, `pico_gym.agents.classic.features`)
and tracks it in the odometry frame (`WorldModel.update_exits`: seen twice before it counts, a
false one dropped when missed where it should be seen). `ExitGoal` runs that perception and gives
the tracked mouth as a point goal in `pico_gym.wrappers.encode_goal`'s encoding: the range and
bearing from the robot's odometry pose to a point on the corridor's axis, `INTO_CORRIDOR_M` inside
the mouth or `LEAD_M` ahead of the robot's own place along the axis, whichever is farther in (a
carrot that leads down the corridor, never back to the mouth behind), and the heading error to
the corridor's direction. No mouth known yet: `NO_GOAL` (sin and cos both 0, an
encoding no goal has).

Only the LRF and odometry go in: not privileged (unlike `pico_gym.wrappers.PrivilegedPointGoal`,
which reads the true pose). `ExitGoalObservation` adds it to an env's observations as
`obs["point_goal"]` for training (a config's `env_wrapper` entry before the learning wrapper, with
`point_goal_source: exit`); a `PpoAgent` whose policy metadata says `"point_goal_source": "exit"`
runs its own `ExitGoal` when it plays.

Perception costs about 0.7 ms a scan, so it runs every `every` steps (the track is kept in the
odometry frame in between and re-encoded from the newest odometry each step).
"""

from __future__ import annotations

import math
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from pico_gym.agents.base import RobotSpec
from pico_gym.agents.classic.perception import perceive
from pico_gym.agents.classic.world_model import WorldModel
from pico_gym.types import Pose
from pico_gym.wrappers import POINT_GOAL_SIZE, encode_goal

# The goal point lies at least this far inside the mouth, along the corridor [m],
INTO_CORRIDOR_M = 0.3
# and at least this far ahead of the robot's place along the corridor's axis [m].
LEAD_M = 1.0
# No exit known: range 1 (far), bearing and heading error with sin = cos = 0.
NO_GOAL = np.array([1.0, 0.0, 0.0, 0.0, 0.0], np.float32)


class ExitGoal:
    """The tracked exit as an encoded point goal (module docstring); stateful per episode.

    Args:
        spec: the robot's public spec (the LRF's settings).
        every: perceive every this many steps (1: every step); the first scan of an episode always.
    """

    def __init__(self, spec: RobotSpec, every: int = 3) -> None:
        if not isinstance(every, int) or isinstance(every, bool) or every < 1:
            raise ValueError(f"ExitGoal(every=...) must be a whole number of steps >= 1, got {every!r}")
        self.spec = spec
        self.every = every
        self.model = WorldModel()
        self._steps = 0

    def reset(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        """Forget the last episode; the goal seen from its first observation."""
        self.model = WorldModel()
        self._steps = 0
        return self.update(obs)

    def update(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        """The goal after this observation (`obs["lrf"]`, `obs["odom"]`), float32 (POINT_GOAL_SIZE,)."""
        x, y, theta = (float(v) for v in obs["odom"])
        pose = Pose(x, y, theta)
        if self._steps % self.every == 0:
            features = perceive(obs["lrf"], self.spec.beam_angles, self.spec.lrf).features
            self.model.update_exits(pose, features.exits)
        self._steps += 1
        track = self.model.best_exit()
        if track is None:
            return NO_GOAL.copy()
        direction = track.outward / np.linalg.norm(track.outward)
        centre = track.centre
        along = (x - centre[0]) * direction[0] + (y - centre[1]) * direction[1]
        gx, gy = centre + max(INTO_CORRIDOR_M, along + LEAD_M) * direction
        return encode_goal(x, y, theta, float(gx), float(gy), math.atan2(direction[1], direction[0]))


class ExitGoalObservation(gym.Wrapper):
    """Adds `obs["point_goal"]`, the exit `ExitGoal` tracks from the env's own LRF and odometry.

    Not privileged: what the robot senses only. A training env's wrapper, before the learning
    wrapper (`env_wrapper: [pico_gym.agents.exit_goal.ExitGoalObservation, ...]`).

    Args:
        env: an env with `lrf` and `odom` observations (PicoEscape-v0).
        every: perceive every this many steps (see `ExitGoal`).
    """

    def __init__(self, env: gym.Env, every: int = 3) -> None:
        spaces = getattr(env.observation_space, "spaces", None)
        if spaces is None or "lrf" not in spaces or "odom" not in spaces:
            raise ValueError(
                "ExitGoalObservation needs an env with dict observations 'lrf' and 'odom' (place it before "
                f"PicoLearningWrapper); got observation space {env.observation_space}"
            )
        super().__init__(env)
        self.goal = ExitGoal(RobotSpec.of(env), every)
        low = np.array([0.0, -1.0, -1.0, -1.0, -1.0], np.float32)
        self.observation_space = gym.spaces.Dict(
            {**spaces, "point_goal": gym.spaces.Box(low, np.ones(POINT_GOAL_SIZE, np.float32), dtype=np.float32)}
        )

    def reset(self, **kwargs: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        return {**obs, "point_goal": self.goal.reset(obs)}, info

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        return {**obs, "point_goal": self.goal.update(obs)}, reward, terminated, truncated, info
