"""The step template shared by pico-gym environments.

`PicoEnv.step` applies the action (clipped to the robot's limits), moves the robot through the
physics for one control period while odometry counts what the wheels did, reads the LRF, asks the
task for reward terms and termination, and builds `info`. A task supplies what differs between
challenges: the world and start of an episode, success, and the reward terms.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from pico_gym.config import with_overrides
from pico_gym.extras import require
from pico_gym.overlay import Overlay
from pico_gym.physics import Physics, PhysicsConfig
from pico_gym.robot import RobotConfig, clip_twist
from pico_gym.sensors.lrf import Lrf, LrfConfig
from pico_gym.sensors.odometry import Odometry, OdometryConfig
from pico_gym.tasks.escape import TERMINATION_REASONS, Episode, EscapeTask, EscapeTaskConfig
from pico_gym.types import Pose
from pico_gym.world import geometry
from pico_gym.world.geometry import compose, inverse, wrap_angle

# Clearance is computed exactly up to this distance; farther reads as this value [m].
CLEARANCE_CAP_M = 2.0


@dataclass(frozen=True)
class EnvConfig:
    """Everything that configures an env, grouped by the part it configures.

    Attributes:
        dt_s: control period: one env step advances the world by this much [s] (10 Hz is the
            course's usual loop rate).
        robot: footprint and limits.
        lrf: the laser range finder.
        odometry: odometry noise.
        physics: engine settings.
        task: the challenge's rules and rewards.
    """

    dt_s: float = 0.1
    robot: RobotConfig = field(default_factory=RobotConfig)
    lrf: LrfConfig = field(default_factory=LrfConfig)
    odometry: OdometryConfig = field(default_factory=OdometryConfig)
    physics: PhysicsConfig = field(default_factory=PhysicsConfig)
    task: EscapeTaskConfig = field(default_factory=EscapeTaskConfig)

    def __post_init__(self) -> None:
        if self.dt_s <= 0:
            raise ValueError(f"dt_s must be positive, got {self.dt_s}")
        substeps = self.dt_s / self.physics.substep_s
        if abs(substeps - round(substeps)) > 1e-6:
            raise ValueError(
                f"dt_s={self.dt_s} must be a whole number of physics sub-steps ({self.physics.substep_s} s)"
            )

    @staticmethod
    def make(config: EnvConfig | None = None, **overrides: Any) -> EnvConfig:
        """A config from a base (default: all defaults) and keyword overrides of any nested field."""
        return with_overrides(config or EnvConfig(), **overrides)


class PicoEnv(gym.Env[dict[str, np.ndarray], np.ndarray]):
    """Base class: PICO in a world, with LRF and odometry observations and twist actions."""

    metadata: dict[str, Any] = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    def __init__(self, task: EscapeTask, config: EnvConfig, render_mode: str | None = None) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        if render_mode is not None:
            require("pygame", "render", f"render_mode={render_mode!r}")
        self.config = config
        self.task = task
        self.render_mode = render_mode
        self.metadata = dict(self.metadata, render_fps=round(1.0 / config.dt_s))
        self.lrf = Lrf(config.lrf)
        self.odometry = Odometry(config.odometry, config.robot)
        self.observation_space = gym.spaces.Dict(
            {
                "lrf": self.lrf.space(),
                "odom": gym.spaces.Box(
                    np.array([-np.inf, -np.inf, -np.pi], dtype=np.float32),
                    np.array([np.inf, np.inf, np.pi], dtype=np.float32),
                    dtype=np.float32,
                ),
            }
        )
        self.action_space = gym.spaces.Box(
            config.robot.action_low.astype(np.float32), config.robot.action_high.astype(np.float32), dtype=np.float32
        )
        self._outline = np.ascontiguousarray(config.robot.outline)
        self._renderer: Any = None
        self._overlay: Overlay | Callable[[], Overlay] | None = None
        self.episode: Episode | None = None

    # --- the episode ---------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start an episode.

        Args:
            seed: seeds `self.np_random` (every random draw of the episode comes from it).
            options: {"start_pose": (x, y, theta)} places the robot (map frame) instead of the
                task's own start.
        """
        super().reset(seed=seed)
        start = None
        if options and options.get("start_pose") is not None:
            sp = options["start_pose"]
            if len(sp) != 3 or not all(math.isfinite(float(v)) for v in sp):
                raise ValueError(f"options['start_pose'] must be (x, y, theta) with finite values, got {sp!r}")
            start = Pose(*(float(v) for v in sp))
        self.episode = self.task.new_episode(self.np_random, start)
        ep = self.episode
        if start is not None:
            footprint = geometry.transform_points(start, self._outline)
            if geometry.polygon_clearance(footprint, ep.map.solid_segments()) <= 0.0:
                raise ValueError(f"options['start_pose'] {tuple(start)} puts the robot in a wall")
            if not math.isfinite(ep.shortest_path_length_m):
                raise ValueError(f"options['start_pose'] {tuple(start)} has no path to the finish line")
        self._seen = ep.map.seen_segments()
        self._solid = ep.map.solid_segments()
        self.physics = Physics(self._solid, self.config.robot, self.config.physics, ep.start)
        odom0 = self.odometry.reset(self.np_random)
        # The odometry frame in the map: where the robot started, minus where odometry says it is.
        self._map_from_odom = compose(ep.start, inverse(odom0))
        self._odom_from_map = inverse(self._map_from_odom)
        self._pose = ep.start
        self.steps = 0
        self.sim_time_s = 0.0
        self._idle_s = 0.0
        self._path_length = 0.0
        self._geodesic = ep.field.lookup(ep.start.x, ep.start.y)
        self._clearance = self._footprint_clearance(ep.start)
        self._min_clearance = self._clearance
        self.trajectory = [ep.start]
        self.bump_points: list[Pose] = []
        self.last_scan = self.lrf.scan(ep.start, self._seen, self.np_random)
        info = self._info({}, None, False)
        if self.render_mode == "human":
            self.render()
        return self._observation(), info

    def step(self, action: np.ndarray) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Advance one control period with the body-frame twist `action` = (vx, vy, w)."""
        if self.episode is None:
            raise RuntimeError("call reset() before step()")
        cfg = self.config
        dt = cfg.dt_s
        vx, vy, w = clip_twist(action, cfg.robot)
        bumps_before = self.physics.bumps
        true_vx, true_vy, true_w = self.odometry.true_twist(vx, vy, w, dt, self.np_random)
        self.physics.step(true_vx, true_vy, true_w, dt, self._clearance)
        self.odometry.advance(vx, vy, w, dt)
        previous, pose = self._pose, self.physics.pose
        self._pose = pose
        self.steps += 1
        self.sim_time_s = self.steps * dt

        moved = math.hypot(pose.x - previous.x, pose.y - previous.y)
        turned = abs(wrap_angle(pose.theta - previous.theta))
        self._path_length += moved
        task_cfg = cfg.task
        if moved < task_cfg.idle_speed_mps * dt and turned < task_cfg.idle_turn_rate_radps * dt:
            self._idle_s += dt
        else:
            self._idle_s = 0.0
        geodesic = self.episode.field.lookup(pose.x, pose.y)
        progress = self._geodesic - geodesic if math.isfinite(geodesic) and math.isfinite(self._geodesic) else 0.0
        self._geodesic = geodesic
        previous_clearance = self._clearance
        self._clearance = self._footprint_clearance(pose)
        self._min_clearance = min(self._min_clearance, self._clearance)
        new_bumps = self.physics.bumps - bumps_before
        if new_bumps:
            self.bump_points.append(pose)
        self.trajectory.append(pose)

        outcome = self.task.evaluate(
            pose, progress, new_bumps, self.physics.bumps, self._idle_s, dt, self._clearance, previous_clearance
        )
        reason = outcome.termination_reason
        terminated = reason is not None
        truncated = not terminated and self.sim_time_s >= task_cfg.time_limit_s - 1e-9
        if truncated:
            reason = "timeout"
        reward = float(sum(outcome.reward_terms.values()))
        self.last_scan = self.lrf.scan(pose, self._seen, self.np_random)
        if self.render_mode == "human":
            self.render()
        return (
            self._observation(),
            reward,
            terminated,
            truncated,
            self._info(outcome.reward_terms, reason, outcome.is_success),
        )

    def _footprint_clearance(self, pose: Pose) -> float:
        return float(
            geometry.footprint_clearance(pose.x, pose.y, pose.theta, self._outline, self._solid, CLEARANCE_CAP_M)
        )

    def _observation(self) -> dict[str, np.ndarray]:
        return {"lrf": self.last_scan, "odom": np.array(self.odometry.pose, dtype=np.float32)}

    def _info(self, reward_terms: dict[str, float], reason: str | None, success: bool) -> dict[str, Any]:
        assert reason is None or reason in TERMINATION_REASONS
        pose = self._pose
        return {
            "pose": np.array(pose),
            "odom_error": self.odometry_error(),
            "bumps": self.physics.bumps,
            "clearance": self._clearance,
            "min_clearance": self._min_clearance,
            "sim_time": self.sim_time_s,
            "path_length": self._path_length,
            "geodesic_to_finish": self._geodesic,
            "shortest_path_length": self.episode.shortest_path_length_m,
            "is_success": success,
            "termination_reason": reason,
            "reward_terms": reward_terms,
        }

    def odometry_error(self) -> np.ndarray:
        """Odometry minus the truth, in the odometry frame: (dx, dy, dtheta)."""
        truth = compose(self._odom_from_map, self._pose)
        odom = self.odometry.pose
        return np.array([odom.x - truth.x, odom.y - truth.y, wrap_angle(odom.theta - truth.theta)])

    @property
    def pose(self) -> Pose:
        """The robot's true pose in the map frame (privileged: for metrics, never observations)."""
        return self._pose

    @property
    def map_from_odom(self) -> Pose:
        """Where the odometry frame's origin lies in the map frame (privileged)."""
        return self._map_from_odom

    # --- rendering -----------------------------------------------------------------------
    def set_overlay(self, overlay: Overlay | Callable[[], Overlay] | None) -> None:
        """Let an agent draw its own view (an Overlay, or a callable returning one per frame)."""
        self._overlay = overlay

    def render(self) -> np.ndarray | None:
        """Draw the current state: an RGB array for "rgb_array", a window for "human"."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode= to gym.make")
            return None
        if self.episode is None:
            raise RuntimeError("call reset() before render()")
        if self._renderer is None:
            from pico_gym.render import Renderer

            self._renderer = Renderer(self.render_mode, self.metadata["render_fps"])
        overlay = self._overlay() if callable(self._overlay) else self._overlay
        return self._renderer.draw(self, overlay)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_renderer"] = None  # pygame surfaces and windows do not pickle
        return state
