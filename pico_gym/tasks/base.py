"""The task interface the step template calls, and the helpers every task shares.

A task (escape, hospital, ...) supplies what differs between challenges: a new episode (its scene,
start pose and per-episode draws), the verdict on one step (reward terms, why the episode ends,
success) from a small `StepContext`, and its own `info` keys. The env's step template
(`pico_gym.envs.base.PicoEnv`) does the rest: actions, physics, sensors, clearance, idle time and
the time limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

import numpy as np

from pico_gym.types import Pose

if TYPE_CHECKING:
    from pico_gym.world.grid import GeodesicField
    from pico_gym.world.scene import Scene

# Competition rule (docs/facts/pico-facts.md, docs/facts/hospital-facts.md 1.9): 30 s without sensible
# movement ends a trial.
IDLE_TIME_S = 30.0

# Reset options the step template itself handles; a task adds its own (`Task.option_keys`).
BASE_OPTION_KEYS = frozenset({"start_pose"})


@dataclass(frozen=True)
class IdleRule:
    """When the robot counts as standing still, and for how long it may.

    Attributes:
        time_s: the episode ends after this long without sensible movement [s].
        speed_mps: true translational speed below which the robot is standing still [m/s].
        turn_rate_radps: true turn rate below which the robot is not turning [rad/s].
    """

    time_s: float = IDLE_TIME_S
    speed_mps: float = 0.02
    turn_rate_radps: float = 0.05


class IdleTimer:
    """Seconds the robot has stood still (by an `IdleRule`), reset by sensible movement."""

    def __init__(self, rule: IdleRule) -> None:
        self.rule = rule
        self.idle_s = 0.0

    def reset(self) -> None:
        self.idle_s = 0.0

    def update(self, moved_m: float, turned_rad: float, dt_s: float) -> float:
        """Account one step (true distance moved and angle turned); returns the idle time."""
        if moved_m < self.rule.speed_mps * dt_s and turned_rad < self.rule.turn_rate_radps * dt_s:
            self.idle_s += dt_s
        else:
            self.idle_s = 0.0
        return self.idle_s

    @property
    def expired(self) -> bool:
        return self.idle_s >= self.rule.time_s


class GeodesicProgress:
    """Progress along a geodesic field: how many metres of path to the goal a step took off."""

    def __init__(self, field: GeodesicField, pose: Pose) -> None:
        self.field = field
        self.value = field.lookup(pose.x, pose.y)

    def update(self, pose: Pose) -> float:
        """Look the new pose up; returns the decrease of the distance (0 where either is unknown)."""
        value = self.field.lookup(pose.x, pose.y)
        progress = self.value - value if math.isfinite(value) and math.isfinite(self.value) else 0.0
        self.value = value
        return progress


def in_a_wall(segments: Any, pose: Pose, outline: np.ndarray) -> bool:
    """Whether the robot's footprint at `pose` touches any of `segments`."""
    from pico_gym.world import geometry

    return geometry.polygon_clearance(geometry.transform_points(pose, outline), segments) <= 0.0


def timed_out(sim_time_s: float, time_limit_s: float) -> bool:
    """Whether an episode has reached its time limit (simulated seconds)."""
    return sim_time_s >= time_limit_s - 1e-9


class StepContext(NamedTuple):
    """What the step template knows about one step, for the task to judge.

    Attributes:
        pose_before: true pose before the step (map frame).
        pose: true pose after it.
        twist: the true body-frame twist the ground gave the robot (vx, vy, w).
        new_bumps: bumps that began during the step.
        new_bump_kinds: the kind of each of them ("wall", "cabinet", "door", "box", "mover").
        bumps: bumps so far in the episode.
        idle_s: how long the robot has stood still, by the task's `IdleRule`.
        dt_s: the step's duration.
        sim_time_s: simulated time at the end of the step.
        clearance_m: footprint clearance to everything solid after the step (capped).
        previous_clearance_m: the same before the step.
        extras: the action's components after the twist (e.g. the hospital's announcement).
    """

    pose_before: Pose
    pose: Pose
    twist: tuple[float, float, float]
    new_bumps: int
    new_bump_kinds: tuple[str, ...]
    bumps: int
    idle_s: float
    dt_s: float
    sim_time_s: float
    clearance_m: float
    previous_clearance_m: float
    extras: np.ndarray


class StepOutcome(NamedTuple):
    """The task's verdict on a step.

    Attributes:
        reward_terms: the named reward terms (the reward is their sum).
        termination_reason: why the episode ends, or None.
        is_success: whether it ended in success.
        new_scene: a scene the world changes into from the next step on (e.g. the explore task's
            object, placed once the robot has parked), or None.
        excused_bumps: the kinds of the step's new contacts the task's rules do not count as bumps
            (e.g. the gentle touch of the parking wall); the template leaves them out of `bumps`.
    """

    reward_terms: dict[str, float]
    termination_reason: str | None
    is_success: bool
    new_scene: Scene | None = None
    excused_bumps: tuple[str, ...] = ()


@dataclass(frozen=True, eq=False)
class Episode:
    """What a task fixes at reset.

    Attributes:
        scene: the episode's world (static geometry, doors, boxes, movers).
        start: the robot's true start pose.
        shortest_path_length_m: the oracle's path length for the whole episode (SPL, SCT).
        public: what the agent is given at reset (`info["task"]`), or None.
        extra: task-specific values (fields, generator output, ...).
    """

    scene: Scene
    start: Pose
    shortest_path_length_m: float
    public: Any = None
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def map(self):  # noqa: ANN201  (the true static world, a Map)
        """The true world's map (walls, cabinets, doors, obstacles), as loaded or generated."""
        return self.scene.map


class ConfiguredTask:
    """What a task whose config carries `idle_rule` and `time_limit_s` shares with every such task."""

    config: Any

    @property
    def idle_rule(self) -> IdleRule:
        return self.config.idle_rule

    @property
    def time_limit_s(self) -> float:
        return self.config.time_limit_s

    @property
    def action_extras(self) -> tuple[np.ndarray, np.ndarray]:
        """No action components beyond the twist (override to add some)."""
        return np.zeros(0), np.zeros(0)


class Task(Protocol):
    """What the step template needs from a challenge."""

    #: every reason `evaluate` may give, plus "timeout" (given by the template).
    termination_reasons: tuple[str, ...]
    #: reset option keys the task reads (beyond the template's "start_pose").
    option_keys: frozenset[str]
    #: what a start pose must have a path to, for messages ("the finish line").
    goal_name: str

    @property
    def idle_rule(self) -> IdleRule:
        """When the robot counts as standing still, and for how long it may."""
        ...

    @property
    def time_limit_s(self) -> float:
        """The episode is truncated at this simulated time [s]."""
        ...

    @property
    def action_extras(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds (low, high) of the action components after the twist (empty arrays: none)."""
        ...

    def new_episode(self, rng: np.random.Generator, options: dict[str, Any], start: Pose | None) -> Episode:
        """Draw (or take from `options`) the episode's world and start; `start` overrides the start pose."""
        ...

    def evaluate(self, ctx: StepContext) -> StepOutcome:
        """Judge one step."""
        ...

    def info(self) -> dict[str, Any]:
        """The task's own `info` keys for the current state (privileged: metrics only)."""
        ...

    # Optional: `on_scan(pose, ranges)`, called with every scan the robot takes (at reset, and in
    # each step before `evaluate`), for tasks that score what the robot has seen.
