"""PicoExplore-v0: explore an unknown hospital, park backwards, find the object (2018)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from pico_gym.envs.base import EnvConfig, PicoMapEnv
from pico_gym.tasks.explore import FAMILIES, ExploreTask, ExploreTaskConfig, ExploreTaskSpec, OccupancyBelief
from pico_gym.world.map import Map


class PicoExploreEnv(PicoMapEnv):
    """The 2018 hospital challenge of TU/e's Embedded Motion Control course.

    ## Description
    PICO starts in the hallway of a hospital it is not given, 0.35-1.0 m in front of the "parking
    wall" and facing away from it (+-15 deg, so the wall is behind it, out of the LRF's view). It
    must explore every room, park backwards against that wall, and then find an object that
    appears in one of the rooms once it has parked (the room that needs the most doors to reach
    from the start, as the teams were told) and stand still close to it. Without a map every reset
    draws a hospital by the 2018 rules (`pico_gym.world.hospital2018`: an I- or L-shaped hallway,
    3-6 rooms of 2-4.5 m, 0.5-1.5 m doors forming a tree, rooms nested up to three doors deep).

    ## What the agent is given (public)
    Nothing of the building: `info["task"]` at reset (also `env.unwrapped.task_spec`) is a frozen
    `ExploreTaskSpec` with the rules only (the parking and finding rules, the limits, the
    "most doors" hint) and `prior_map=None`; with `options={"phase": "find"}` the episode starts
    parked with `prior_map` = the true building (the 2018 teams could start a second program that
    read their saved map). Every other `info` key is privileged: metrics, never an agent's input.

    ## Observation Space
    As PicoEscape-v0: `Dict(lrf=Box(0, range_max_m, (n_beams,)), odom=Box(3))`. With
    `phase_observation=True` also `phase`: `Discrete(2)`, 0 before parking, 1 while finding (for
    learning; it tells nothing an agent could not know, as the agent itself parks).

    ## Action Space
    `arrival="dwell"` (default): the body-frame twist `Box([-0.5, -0.5, -1.2], [0.5, 0.5, 1.2])`.
    `arrival="announce"`: a fourth component in [-1, 1]; a positive value announces ("I am
    parked!", then "I found the object!"); an announcement whose predicate does not hold is false.

    ## Parking and finding
    Parked: the footprint's rear edge within `touch_m` (0.02 m) of the parking wall, the heading
    within 15 deg of pointing away from it, the speed when the rear edge reached it at most
    `park_speed_mps` (0.1 m/s) (that touch is not a bump), then `park_dwell_s` (0.5 s) standing so
    (or an announcement). Found: still for `find_still_s` (1 s) with the footprint within
    `find_distance_m` (0.5 m) of the object and not touching it (or an announcement after that).

    ## Phases
    `info["phase"]`: "explore" -> "park" (once every room and the hallway is `explore_coverage`
    (95 %) seen) -> "find" (parked; the object is placed) -> "done" (found). Parking is accepted in
    "explore" too (the exploration then counts as incomplete: `info["explored"]` stays False).

    ## Rewards
    Named terms (`info["reward_terms"]`, weights `rewards=`): `coverage` (0.1 per m^2 of the
    building's free area seen for the first time), `park` (+10), `found` (+10), `bump` (-10 per
    bump), `time` (-0.1 per second), `false_announce` (-1 each).

    ## Episode End
    Terminated: `done` (found: success), `bump` (with `collision="terminate"`), `idle` (30 s
    standing still), `false_announcement` (if so configured). Truncated: `timeout` at
    `time_limit_s` = 600 s, or `phase_time_limit_s` after a phase began (S18-4's 300 s; off by
    default).

    ## Info (privileged)
    The escape env's keys, and `phase`, `coverage` (the seen fraction of the building's free area
    on a 0.1 m grid, marked along the LRF beams), `room_coverage` (per region: the hallway first,
    then the rooms), `rooms_entered`, `explored`, `parked`, `time_to_park`, `parking_error`
    (`heading_rad`, `lateral_m` along the wall from the start), `time_to_find`, `object_distance`,
    `false_announcements`. `shortest_path_length` is the oracle's path from the start to within
    `find_distance_m` of the object. `env.unwrapped.belief_iou(belief)` scores an agent's map (an
    `OccupancyBelief` in the odometry frame) against the true free space.

    ## Arguments
    `gym.make("PicoExplore-v0", map=None, map_path=None, config=None, render_mode=None, **options)`:
    a map needs `parking_wall` ([[x1, y1], [x2, y2]]) and may have `object` (a polygon); any
    config field by name, e.g. `arrival="announce"`, `phase_time_limit_s=300`, `n_rooms=(5, 6)`.

    ## Families
    `gym.make("PicoExplore-v0", family=NAME)`: `"comb"`, rooms off a side corridor that branches
    from the hallway, like the teeth of a comb; `"deep-L"`, an L hallway with its rooms at the
    far end of its far leg; `"nested"`, rooms in rows behind one another, one reached through
    two others. Each is a suite of `pico-gym bench` and `compare` with fixed dev and test seeds
    (docs/benchmarks.md).

    ## Version History
    - v0: initial version; `family=` added (default episodes unchanged).
    """

    env_id = "PicoExplore-v0"
    task_config = ExploreTaskConfig
    families = FAMILIES

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.explore_task: ExploreTask = self.task  # type: ignore[assignment]  # (make_task's)
        self._phase_key = self.config.task.phase_observation
        if self._phase_key:
            spaces = dict(self.observation_space.spaces)
            spaces["phase"] = gym.spaces.Discrete(2)
            self.observation_space = gym.spaces.Dict(spaces)

    @classmethod
    def make_task(cls, config: EnvConfig, fixed: Map | None) -> ExploreTask:
        return ExploreTask(config.task, config.robot, config.lrf, fixed)

    def _observation(self) -> dict[str, np.ndarray]:
        obs = super()._observation()
        if self._phase_key:
            obs["phase"] = np.int64(self.explore_task.phase_code())  # type: ignore[assignment]  # Discrete(2)
        return obs

    @property
    def task_spec(self) -> ExploreTaskSpec:
        """What the agent is given for the current episode (public)."""
        if self.episode is None:
            raise RuntimeError("call reset() first")
        return self.episode.public

    def belief_iou(self, belief: OccupancyBelief) -> float:
        """IoU of an agent's map (free cells, odometry frame) with the building's true free area."""
        if self.episode is None:
            raise RuntimeError("call reset() first")
        if not isinstance(belief, OccupancyBelief):
            raise TypeError(f"belief must be an OccupancyBelief, got {type(belief).__name__}")
        return self.explore_task.belief_iou(belief, self._odom_from_map)
