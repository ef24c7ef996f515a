"""The step template shared by pico-gym environments.

`PicoEnv.step` applies the action (clipped to the robot's limits), moves the robot (and the
scene's movers) through the physics for one control period while odometry counts what the wheels
did, reads the LRF against the scene, hands the task a `StepContext` for its verdict (reward
terms, termination, success), and builds `info`. A task (`pico_gym.tasks.base.Task`) supplies what
differs between challenges: the episode's scene and start, success, reward terms, its info keys.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, NamedTuple

import gymnasium as gym
import numpy as np

from pico_gym.config import with_overrides
from pico_gym.extras import require
from pico_gym.jit import njit
from pico_gym.overlay import Overlay
from pico_gym.physics import Physics, PhysicsConfig, StaticShapePool, glide, sweep
from pico_gym.pymath import TWO_PI, hypot, remainder
from pico_gym.pymath import wrap_angle as compiled_wrap
from pico_gym.robot import RobotConfig, checked_twist, clip_limits
from pico_gym.robot import _numbers as action_numbers
from pico_gym.sensors.lrf import Lrf, LrfConfig
from pico_gym.sensors.odometry import Odometry, OdometryConfig, ground_twist, integrate
from pico_gym.tasks.base import BASE_OPTION_KEYS, Episode, IdleTimer, StepContext, Task, timed_out
from pico_gym.types import FloatArray, Pose, Segments
from pico_gym.validate import number
from pico_gym.world import geometry
from pico_gym.world.geometry import compose, footprint_clearance, inverse, wrap_angle
from pico_gym.world.map import Map
from pico_gym.world.movers import glide_movers
from pico_gym.world.scene import KINDS, Scene, SceneSnapshot

# Clearance is computed exactly up to this distance; farther reads as this value [m].
CLEARANCE_CAP_M = 2.0
# A start heading beyond this is refused (modulo 2 pi it has lost its precision).
MAX_HEADING_RAD = 1e6
# info["cost"] (Safety Gym's convention): 1 per bump plus 1 per second closer than this to anything [m].
COST_CLEARANCE_M = 0.1
_NO_EXTRAS = np.zeros(0)


_IDENTITY = np.eye(3)
_NO_MOVERS = (np.zeros((0, 10)), np.zeros((0, 6)), np.zeros((0, 2)), np.zeros((0, 4)), np.zeros((0, 2)))


@njit
def _drive(
    vx: float, vy: float, w: float, vmax: float, wmax: float, ground: FloatArray, exact: bool, dt: float,
    x0: float, y0: float, a0: float, may_glide: bool, room: float,
    circumradius: float, margin: float, substeps: int, substep_s: float,
    odom_x: float, odom_y: float, odom_theta: float, px: float, py: float, ptheta: float,
    outline: FloatArray, solid: Segments, cap: float,
    movers: tuple[FloatArray, FloatArray, FloatArray, Segments, FloatArray], mover_speed: float,
) -> tuple[int, float, float, float, float, float, float, float, float, float,
           float, float, float, float, float, float, float, float, float, float]:  # fmt: skip
    """A step's motion up to the scan, compiled: the command clipped to the limits, the true twist
    (`Odometry.ground`'s matrix, or the command itself when `exact`), odometry, and, when the
    robot may glide (`Physics.step`'s free-space test on the same figures), the glide: the movers'
    sub-steps (`movers` = their state, parameters, velocities and edges, as
    `Movers.glide` takes them; no rows: no movers) and the body's from (x0, y0, a0), with the new
    pose, how far it moved and turned from (px, py, ptheta), its footprint's clearance to
    everything solid and the room the next step has (as `PicoEnv._footprint_clearance`).
    The first value is 0 without the glide (the last ten values are then zeros and the physics
    steps the robot), 1 with it, 2 with it when a mover was walking (its body must stop).
    Each part is the compiled twin of the Python it replaces, to the bit."""
    vx, vy, w = clip_limits(vx, vy, w, vmax, wmax)
    if exact:
        tvx, tvy, tw = vx, vy, w
    else:
        tvx, tvy, tw = ground_twist(ground, vx, vy, w)
    ox, oy, otheta = integrate(odom_x, odom_y, odom_theta, vx, vy, w, dt)
    if not (may_glide and room > sweep(tvx, tvy, tw, dt, circumradius) + margin):
        return 0, vx, vy, w, tvx, tvy, tw, ox, oy, otheta, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    glided = 1
    state, params, velocity, edges, others = movers
    if state.shape[0] > 0 and glide_movers(
        state, params, x0, y0, a0, tvx, tvy, tw, substeps, substep_s, velocity, edges, others
    ):
        glided = 2
    x, y, angle, velocity_x, velocity_y = glide(x0, y0, a0, tvx, tvy, tw, substeps * substep_s)
    theta = remainder(angle, TWO_PI)
    moved = hypot(x - px, y - py)
    turned = abs(compiled_wrap(theta - ptheta))
    clearance, room = _clearance_and_room(x, y, theta, outline, solid, edges, mover_speed * dt, cap)
    pose = (x, y, angle, velocity_x, velocity_y, theta, moved, turned, clearance, room)
    return glided, vx, vy, w, tvx, tvy, tw, ox, oy, otheta, *pose


@njit
def _clearance_and_room(
    x: float, y: float, theta: float, outline: FloatArray, solid: Segments, movers: Segments, reach: float, cap: float
) -> tuple[float, float]:
    """The footprint's clearance to everything solid (capped), and the room the next step has
    before anything can touch it: the clearance to the static geometry, and to the movers' edges
    (no rows: none) less how far they may come in one step (`reach`)."""
    clearance = footprint_clearance(x, y, theta, outline, solid, cap)
    if movers.shape[0] == 0:
        return clearance, clearance
    to_movers = footprint_clearance(x, y, theta, outline, movers, cap)
    return min(clearance, to_movers), min(clearance, to_movers - reach)


class _Moved(NamedTuple):
    """What `PicoEnv.begin_step` hands `PicoEnv.finish_step`: the step's motion before the scan."""

    previous: Pose  # the true pose before the step
    twist: tuple[float, float, float]  # the true twist the ground gave
    new_bumps: int  # contacts that began (before the task excuses any)
    idle_s: float
    previous_clearance: float
    extras: np.ndarray  # the action's components after the twist


class MotionState(NamedTuple):
    """What a step changes of a robot's motion (`PicoEnv.motion_state`): its true pose, the room
    the next step has before anything can touch it, the footprint's clearance now and its least
    over the episode, the path driven, how long it has stood still, and the steps taken."""

    pose: Pose
    room: float
    clearance: float
    min_clearance: float
    path_length: float
    idle_s: float
    steps: int


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
        task: the challenge's rules and rewards: the task's own config dataclass (e.g.
            `EscapeTaskConfig`, `HospitalTaskConfig`); each env supplies its default.
        internal_pose: add the true pose to the observation (`obs["internal_pose"]`, x, y, theta,
            map frame): the course simulator's `provide_internal_pose`. Privileged: the course
            offered it, the challenges did not; off by default.
    """

    dt_s: float = 0.1
    robot: RobotConfig = field(default_factory=RobotConfig)
    lrf: LrfConfig = field(default_factory=LrfConfig)
    odometry: OdometryConfig = field(default_factory=OdometryConfig)
    physics: PhysicsConfig = field(default_factory=PhysicsConfig)
    task: Any = None
    internal_pose: bool = False

    def __post_init__(self) -> None:
        number("dt_s", self.dt_s, 0.0, 1.0, lo_open=True, unit=" s")
        if not isinstance(self.internal_pose, bool):
            raise ValueError(f"internal_pose must be True or False, got {self.internal_pose!r}")
        self.physics.check_solid(self.robot.max_speed_mps, self.robot.max_turn_rate_radps, self.robot.circumradius_m)
        substeps = self.dt_s / self.physics.substep_s
        if abs(substeps - round(substeps)) > 1e-6:
            raise ValueError(
                f"dt_s={self.dt_s} must be a whole number of physics sub-steps ({self.physics.substep_s} s)"
            )

    @staticmethod
    def make(config: EnvConfig | None = None, task: Any = None, **overrides: Any) -> EnvConfig:
        """A config from a base and keyword overrides of any nested field.

        Args:
            config: the base (default: all defaults, with `task` as the task config).
            task: the task config to use when `config` is None or has none.
            **overrides: any field of the config or of a config nested in it, by name.
        """
        if config is not None and not isinstance(config, EnvConfig):
            raise TypeError(
                f"config= takes an EnvConfig (or give its fields by name, e.g. dt_s=0.05), got {type(config).__name__}"
            )
        base = config or EnvConfig(task=task)
        if base.task is None and task is not None:
            base = EnvConfig(base.dt_s, base.robot, base.lrf, base.odometry, base.physics, task, base.internal_pose)
        return with_overrides(base, **overrides)


def pico_env(env: gym.Env) -> PicoEnv:
    """The pico-gym env inside an env's wrappers (its `unwrapped`), typed as one.

    Raises:
        TypeError: for an env that is not a pico-gym env.
    """
    inner = env.unwrapped
    if not isinstance(inner, PicoEnv):
        raise TypeError(f"expected a pico-gym env (gym.make('PicoEscape-v0') and the like), got {type(inner).__name__}")
    return inner


def with_family(env_id: str, families: dict[str, dict[str, Any]], options: dict[str, Any]) -> dict[str, Any]:
    """`gym.make` options with a named family's settings under them (`family=NAME`; what the
    user gives explicitly wins).

    Raises:
        ValueError: for a family the env does not have, listing those it has.
    """
    family = options.pop("family", None)
    if family is None:
        return options
    if not isinstance(family, str) or family not in families:
        known = ", ".join(families) or "(none)"
        raise ValueError(f"{env_id} has no family {family!r}; its families: {known}")
    return {**families[family], **options}


def resolve_map(map_name: str | Map | None, map_path: str | os.PathLike[str] | None) -> Map | None:
    """The fixed map an env was asked for: a shipped map's name (or a `Map`), a file, or None."""
    from pico_gym.world.catalog import load_shipped
    from pico_gym.world.map import load_map

    if map_name is not None and map_path is not None:
        raise ValueError("give map= (a shipped map's name) or map_path= (a file), not both")
    if map_name is not None and not isinstance(map_name, (str, Map)):
        raise TypeError(f"map= takes a shipped map's name (pico-gym maps) or a Map, got {map_name!r:.60}")
    if map_path is not None and not isinstance(map_path, (str, os.PathLike)):
        raise TypeError(f"map_path= takes a file's path, got {type(map_path).__name__} {map_path!r:.60}")
    if map_path is not None:
        return load_map(map_path)
    return load_shipped(map_name) if isinstance(map_name, str) else map_name


def _start_option(sp: Any) -> Pose | None:
    """`reset(options={"start_pose": (x, y, theta)})`, checked; the heading taken modulo 2 pi."""
    if sp is None:
        return None
    try:
        values = [float(v) for v in sp]
    except (TypeError, ValueError):
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ValueError(f"options['start_pose'] must be (x, y, theta) with finite values, got {sp!r}")
    if abs(values[2]) > MAX_HEADING_RAD:
        raise ValueError(
            f"options['start_pose'] heading {values[2]} rad: give it within +-{MAX_HEADING_RAD:.0f} rad "
            "(it is taken modulo 2 pi)"
        )
    return Pose(values[0], values[1], math.remainder(values[2], 2.0 * math.pi))


class PicoEnv(gym.Env[dict[str, np.ndarray], np.ndarray]):
    """Base class: PICO in a world, with LRF and odometry observations and twist actions."""

    metadata: dict[str, Any] = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    def __init__(self, task: Task, config: EnvConfig, render_mode: str | None = None) -> None:
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
        self.observation_space: gym.spaces.Dict = gym.spaces.Dict(  # type: ignore[assignment]
            {
                "lrf": self.lrf.space(),
                "odom": gym.spaces.Box(
                    np.array([-np.inf, -np.inf, -np.pi], dtype=np.float32),
                    np.array([np.inf, np.inf, np.pi], dtype=np.float32),
                    dtype=np.float32,
                ),
            }
        )
        if config.internal_pose:
            spaces = dict(self.observation_space.spaces)
            spaces["internal_pose"] = spaces["odom"]
            self.observation_space = gym.spaces.Dict(spaces)
        extra_low, extra_high = task.action_extras
        self._n_extras = len(extra_low)
        self.action_space: gym.spaces.Box = gym.spaces.Box(
            np.concatenate([config.robot.action_low, extra_low]).astype(np.float32),
            np.concatenate([config.robot.action_high, extra_high]).astype(np.float32),
            dtype=np.float32,
        )
        self._outline = np.ascontiguousarray(config.robot.outline)
        self._limits = (config.robot.max_speed_mps, config.robot.max_turn_rate_radps)
        self._renderer: Any = None
        self._overlay: Overlay | Callable[[], Overlay | None] | None = None
        self._idle = IdleTimer(task.idle_rule)
        self._on_scan = getattr(task, "on_scan", None)
        self.episode: Episode | None = None
        self.physics: Physics = None  # type: ignore[assignment]  # made by reset; a step before it is refused
        self._shape_pool = StaticShapePool()
        self._finished = False
        self._trajectory: list[Pose] = []
        # Poses stepped elsewhere (a vector env's batch), as (n, 3) arrays not yet made Poses.
        self._trajectory_blocks: list[FloatArray] = []
        self._n_others, self._drives_movers = 0, True  # other robots in the world (`expect_other_robots`)
        self._other_poses: list[Pose] = []
        self._room: float = 0.0  # the room the next step has before anything can touch the footprint [m]

    # --- the episode ---------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start an episode.

        Args:
            seed: seeds `self.np_random` (every random draw of the episode comes from it).
            options: {"start_pose": (x, y, theta)} places the robot (map frame) instead of the
                task's own start; the task documents its own options. Unknown keys are refused.
        """
        if options is not None and not isinstance(options, dict):
            raise TypeError(f"reset options must be a dict (e.g. {{'start_pose': (x, y, theta)}}), got {options!r:.60}")
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = sorted(set(options) - BASE_OPTION_KEYS - self.task.option_keys)
        if unknown:
            known = ", ".join(sorted(BASE_OPTION_KEYS | self.task.option_keys))
            raise ValueError(f"unknown reset option(s) {', '.join(map(repr, unknown))}; options are: {known}")
        start = _start_option(options.get("start_pose"))
        self.episode = self.task.new_episode(self.np_random, options, start)
        return self._begin_episode(start)

    def join(
        self, first: PicoEnv, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start an episode as a second robot in `first`'s world (its walls, doors, boxes and
        movers, the same Movers), with a start and task of its own (`Task.join_episode`); the
        other robots are placed with `set_other_robots`. `pico_gym.multi` drives this."""
        if options is not None and not isinstance(options, dict):
            raise TypeError(f"reset options must be a dict, got {options!r:.60}")
        join = getattr(self.task, "join_episode", None)
        if join is None or first.episode is None:
            raise TypeError(f"{type(self.task).__name__} takes no second robot" if join is None else "reset first")
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = sorted(set(options) - BASE_OPTION_KEYS - self.task.option_keys)
        if unknown:
            raise ValueError(f"unknown reset option(s) {', '.join(map(repr, unknown))}")
        start = _start_option(options.get("start_pose"))
        self.episode = join(first.episode, self.np_random, options, start, [first.pose])
        return self._begin_episode(start)

    def expect_other_robots(self, n: int, drives_movers: bool) -> None:
        """From the next episode on, `n` other robots share this robot's world (solid to it, seen
        by its LRF); `drives_movers`: this robot's physics moves the scene's movers (one robot's
        does)."""
        self._n_others, self._drives_movers = n, drives_movers

    def set_other_robots(self, poses: list[Pose]) -> None:
        """Where the other robots stand now (before this robot's step, and before a rescan).

        They stand still through this robot's step, so the step may glide (`Physics`' free-space
        shortcut) when its sweep stays clear of their footprints too: the room the step has is cut
        to the clearance to them. The robot that drives the movers glides them with every robot
        in view (a mover pauses near any robot); another robot's glide leaves them be."""
        self._other_poses = list(poses)
        physics = self.physics
        physics.place_other_robots(poses)
        scene = self.scene
        if scene.has_movers:
            movers = scene.movers
            if self._drives_movers:
                movers.other_robots = np.array([(p.x, p.y) for p in poses], dtype=np.float64).reshape(-1, 2)
                arrays = (movers.state, movers.params, movers.velocity, scene.mover_segments, movers.other_robots)
            else:
                arrays = (*_NO_MOVERS[:3], scene.mover_segments, _NO_MOVERS[4])
            self._mover_arrays = arrays
        self._room = min(self._room, self._clearance_to_others(self._pose))

    def _clearance_to_others(self, pose: Pose) -> float:
        """The footprint's clearance to the other robots' footprints (capped)."""
        return footprint_clearance(pose.x, pose.y, pose.theta, self._outline, self.physics.other_edges, CLEARANCE_CAP_M)

    def rescan(self) -> dict[str, np.ndarray]:
        """Scan again where the robot stands (the other robots placed since): the observation."""
        assert self.episode is not None
        self.last_scan = self.lrf.scan(self._pose, self._seen, self.np_random, self._scan_movers(), self._one_sided)
        return self._observation()

    def _scan_movers(self) -> Segments | None:
        """What moves that the LRF sees: the movers' edges, and the other robots' footprints."""
        if not self._n_others:
            return self._movers
        parts = [self.physics.other_edges]
        if self._movers is not None:
            parts.insert(0, self._movers)
        return np.vstack(parts)

    def _begin_episode(self, start: Pose | None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """The rest of a reset once the task has made the episode (`start`: the one asked for)."""
        ep = self.episode
        assert ep is not None
        scene = ep.scene
        if start is not None:
            footprint = geometry.transform_points(start, self._outline)
            if geometry.polygon_clearance(footprint, scene.solid_segments()) <= 0.0:
                raise ValueError(f"options['start_pose'] {tuple(start)} puts the robot in a wall")
            if not math.isfinite(ep.shortest_path_length_m):
                raise ValueError(f"options['start_pose'] {tuple(start)} has no path to {self.task.goal_name}")
        self._use_scene(scene)
        self._movers = scene.mover_segments if scene.has_movers else None
        self._mover_speed = scene.max_mover_speed_mps
        movers = scene.movers
        self._mover_arrays = (
            (movers.state, movers.params, movers.velocity, scene.mover_segments, movers.other_robots)
            if scene.has_movers
            else _NO_MOVERS
        )
        if self.physics is not None:
            self.physics.release()  # its static shapes, for this episode's physics
        self.physics = Physics.from_scene(scene, self.config.robot, self.config.physics, ep.start, self._shape_pool)
        if self._n_others:
            self.physics.add_other_robots(self._n_others)
            self.physics.drives_movers = self._drives_movers
        self._glide = self.physics.glide_constants(self.config.dt_s)
        self._glide_s = self._glide[2] * self._glide[3]  # the sub-steps' time, as the kernel glides it
        self._excused = [0] * len(KINDS)  # contacts the task's rules excused, by kind
        self._n_excused = 0
        odom0 = self.odometry.reset(self.np_random)
        # The odometry frame in the map: where the robot started, minus where odometry says it is.
        self._map_from_odom = compose(ep.start, inverse(odom0))
        self._odom_from_map = inverse(self._map_from_odom)
        self._odom_from_map_cs = (math.cos(self._odom_from_map.theta), math.sin(self._odom_from_map.theta))
        self._bumps_by_kind: tuple[tuple[int, int], dict[str, int]] | None = None  # (counts it was built at, dict)
        self._pose = ep.start
        self._shortest = ep.shortest_path_length_m
        self.steps = 0
        self.sim_time_s = 0.0
        self._idle.reset()
        self._path_length = 0.0
        self._clearance = self._footprint_clearance(ep.start)
        self._min_clearance = self._clearance
        self._trajectory = [ep.start]
        self._trajectory_blocks.clear()
        self.bump_points: list[Pose] = []
        self._finished = False
        self.last_scan = self.lrf.scan(ep.start, self._seen, self.np_random, self._movers, self._one_sided)
        if self._on_scan is not None:
            self._on_scan(ep.start, self.last_scan)
        info = self._info({}, None, False, 0.0)
        if ep.public is not None:
            info["task"] = ep.public
        if self.render_mode == "human":
            self.render()
        return self._observation(), info

    def step(self, action: np.ndarray) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Advance one control period with the body-frame twist `action` = (vx, vy, w[, extras])."""
        moved = self.begin_step(action)
        self.take_scan(self.lrf.scan(self._pose, self._seen, self.np_random, self._scan_movers(), self._one_sided))
        return self.finish_step(moved)

    # The step in three parts, so that a vector env can scan many robots in one call between them:
    # `begin_step` (action, physics, odometry, clearance), the scan (`take_scan` takes it),
    # `finish_step` (the task's verdict, observation, info). Between them, `scan_inputs` is what the
    # scan reads; a compiled batch of robots (`pico_gym.batched`) takes a robot's state out with
    # `motion_state` and the constants below, and puts it back with `set_motion_state`.
    def begin_step(self, action: np.ndarray) -> _Moved:
        if self.episode is None:
            raise RuntimeError("call reset() before step()")
        if self._finished:
            raise RuntimeError("this episode has ended (terminated or truncated): call reset() before step()")
        dt = self.config.dt_s
        twist, extras = self._split_action(action)
        vx, vy, w = checked_twist(twist)
        physics, odometry = self.physics, self.odometry
        ground = odometry.ground(dt, self.np_random)
        x0, y0, a0, may_glide = physics.glide_inputs()
        # Clip, the true twist, odometry and (when nothing can be touched) the glide with the new
        # pose's motion and clearance, in one compiled call.
        motion = _drive(
            vx, vy, w, *self._limits, _IDENTITY if ground is None else ground, ground is None, dt,
            x0, y0, a0, may_glide, self._room, *self._glide, *odometry.pose, *self._pose,
            self._outline, self._solid, CLEARANCE_CAP_M, self._mover_arrays, self._mover_speed,
        )  # fmt: skip
        return self.apply_motion(motion, extras)

    def apply_motion(self, motion: tuple, extras: np.ndarray) -> _Moved:
        """The rest of `begin_step` from `_drive`'s result: the glide taken, or the physics' step."""
        (glided, vx, vy, w, true_vx, true_vy, true_w, odom_x, odom_y, odom_theta,
         x, y, angle, velocity_x, velocity_y, theta, moved, turned, clearance, room) = motion  # fmt: skip
        dt = self.config.dt_s
        physics = self.physics
        bumps_before = physics.bumps
        previous = self._pose
        self.odometry.pose = Pose(odom_x, odom_y, odom_theta)
        if glided:
            physics.glided(x, y, angle, velocity_x, velocity_y, true_w, self._glide_s, glided == 2)
            pose = Pose(x, y, theta)
            self._room = room
        else:
            # Movers, a possible contact, or the shortcut off: the physics steps it.
            physics.step(true_vx, true_vy, true_w, dt, self._room)
            pose = physics.pose
            moved = math.hypot(pose.x - previous.x, pose.y - previous.y)
            turned = abs(wrap_angle(pose.theta - previous.theta))
            clearance = self._footprint_clearance(pose)
        if self._n_others:
            to_others = self._clearance_to_others(pose)
            clearance = min(clearance, to_others)
            self._room = min(self._room, to_others)
        self._pose = pose
        self.steps += 1
        self.sim_time_s = self.steps * dt
        self._path_length += moved
        idle_s = self._idle.update(moved, turned, dt)
        previous_clearance = self._clearance
        self._clearance = clearance
        self._min_clearance = min(self._min_clearance, clearance)
        self.trajectory.append(pose)
        twist_true = (true_vx, true_vy, true_w)
        return _Moved(previous, twist_true, physics.bumps - bumps_before, idle_s, previous_clearance, extras)

    def take_scan(self, scan: np.ndarray) -> None:
        """Take the step's scan (from the pose `begin_step` left)."""
        self.last_scan = scan
        if self._on_scan is not None:
            self._on_scan(self._pose, scan)

    def finish_step(self, moved: _Moved) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        physics = self.physics
        pose = self._pose
        dt = self.config.dt_s
        new_bumps = moved.new_bumps
        kinds: tuple[str, ...] = ()
        if new_bumps:
            kinds = tuple(physics.bump_log[-new_bumps:])
        ctx = StepContext(
            moved.previous,
            pose,
            moved.twist,
            new_bumps,
            kinds,
            physics.bumps - self._n_excused,
            moved.idle_s,
            dt,
            self.sim_time_s,
            self._clearance,
            moved.previous_clearance,
            moved.extras,
        )
        outcome = self.task.evaluate(ctx)
        if outcome.excused_bumps:
            for kind in outcome.excused_bumps:
                self._excused[KINDS.index(kind)] += 1
            self._n_excused += len(outcome.excused_bumps)
            new_bumps -= len(outcome.excused_bumps)
        if new_bumps:
            self.bump_points.append(pose)
        if outcome.new_scene is not None:
            self._change_scene(outcome.new_scene)
        reason = outcome.termination_reason
        terminated = reason is not None
        truncated = not terminated and timed_out(self.sim_time_s, self.task.time_limit_s)
        if truncated:
            reason = "timeout"
        self._finished = terminated or truncated
        reward = float(sum(outcome.reward_terms.values()))
        cost = float(new_bumps) + (dt if self._clearance < COST_CLEARANCE_M else 0.0)
        if self.render_mode == "human":
            self.render()
        return (
            self._observation(),
            reward,
            terminated,
            truncated,
            self._info(outcome.reward_terms, reason, outcome.is_success, cost),
        )

    def _use_scene(self, scene: Scene) -> None:
        self.scene = scene
        self._seen = scene.lrf_static
        self._one_sided = scene.static_one_sided
        self._solid = scene.static_solid

    def _change_scene(self, scene: Scene) -> None:
        """Switch to a scene with the same movers and more static geometry (from the next step)."""
        if scene.movers is not self.scene.movers:
            raise ValueError("a task's new scene must keep the episode's movers")
        before = {tuple(row) for row in self._solid.tolist()}
        added = np.array([row not in before for row in map(tuple, scene.static_solid.tolist())], dtype=bool)
        if len(before) + int(added.sum()) != len({tuple(row) for row in scene.static_solid.tolist()}):
            raise ValueError("a task's new scene may add static geometry, not remove it")
        self._use_scene(scene)
        self.physics.add_static(scene.static_solid[added], scene.static_kinds[added])
        self._clearance = self._footprint_clearance(self._pose)

    def _split_action(self, action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self._n_extras == 0:
            return action, _NO_EXTRAS  # clip_twist checks the size and names bad components
        n = 3 + self._n_extras
        names = "(vx, vy, w" + "".join(f", extra{i}" for i in range(self._n_extras)) + ")"
        a = action_numbers(action, names).reshape(-1)
        if a.size != n:
            raise ValueError(f"action must have {n} components {names}, got shape {np.shape(action)}")
        extras = a[3:]
        for i, value in enumerate(extras.tolist()):
            if not math.isfinite(value):
                raise ValueError(f"action component {3 + i} (after the twist) is {value}; actions must be finite")
        return a[:3], extras

    def _footprint_clearance(self, pose: Pose) -> float:
        """The footprint's clearance to everything solid (capped); also keeps the room the next
        step has before anything can touch it: the clearance to static geometry, and to the
        movers less how far they may come in one step."""
        x, y, th = pose
        movers = _NO_MOVERS[3] if self._movers is None else self._movers
        reach = self._mover_speed * self.config.dt_s
        clearance, self._room = _clearance_and_room(
            x, y, th, self._outline, self._solid, movers, reach, CLEARANCE_CAP_M
        )
        return clearance

    def _observation(self) -> dict[str, np.ndarray]:
        obs = {"lrf": self.last_scan, "odom": np.array(self.odometry.pose, dtype=np.float32)}
        if self.config.internal_pose:
            obs["internal_pose"] = np.array(self._pose, dtype=np.float32)
        return obs

    def _info(self, reward_terms: dict[str, float], reason: str | None, success: bool, cost: float) -> dict[str, Any]:
        assert reason is None or reason in self.task.termination_reasons
        pose = self._pose
        physics = self.physics
        counts = (physics.bumps, self._n_excused)
        if self._bumps_by_kind is None or self._bumps_by_kind[0] != counts:  # counted anew only when a count changed
            kinds = KINDS if len(physics.bumps_by_kind) == len(KINDS) else (*KINDS, "robot")
            excused = self._excused + [0] * (len(kinds) - len(self._excused))
            by_kind = {k: n - e for k, n, e in zip(kinds, physics.bumps_by_kind, excused, strict=True)}
            self._bumps_by_kind = (counts, by_kind)
        info = {
            "pose": np.array(pose),
            "odom_error": self.odometry_error(),
            "bumps": physics.bumps - self._n_excused,
            "bumps_by_kind": self._bumps_by_kind[1].copy(),  # a new dict per step, as gymnasium asks
            "clearance": self._clearance,
            "min_clearance": self._min_clearance,
            "sim_time": self.sim_time_s,
            "path_length": self._path_length,
            "shortest_path_length": self._shortest,
            "is_success": success,
            "termination_reason": reason,
            "reward_terms": reward_terms,
            "cost": cost,
        }
        info.update(self.task.info())
        return info

    def odometry_error(self) -> np.ndarray:
        """Odometry minus the truth, in the odometry frame: (dx, dy, dtheta)."""
        # compose(self._odom_from_map, self._pose), unrolled with the episode's cos and sin
        a, b = self._odom_from_map, self._pose
        c, s = self._odom_from_map_cs
        truth_x = a.x + c * b.x - s * b.y
        truth_y = a.y + s * b.x + c * b.y
        truth_theta = float(wrap_angle(a.theta + b.theta))
        odom = self.odometry.pose
        return np.array([odom.x - truth_x, odom.y - truth_y, wrap_angle(odom.theta - truth_theta)])

    @property
    def trajectory(self) -> list[Pose]:
        """The episode's true poses so far: the start, then one a step (privileged)."""
        if self._trajectory_blocks:
            for block in self._trajectory_blocks:
                self._trajectory.extend(map(Pose._make, block.tolist()))
            self._trajectory_blocks.clear()
        return self._trajectory

    def add_trajectory(self, block: FloatArray) -> None:
        """Poses (an (n, 3) array) stepped outside `step`, made Poses only when read."""
        self._trajectory_blocks.append(block)

    # --- the interface of a step taken elsewhere (a vector env's scan, a compiled batch) ----------
    def scan_inputs(self) -> tuple[Pose, Any, Segments | None, np.ndarray | None]:
        """What the step's scan reads: the true pose, the static geometry the LRF sees (a segment
        array or a `SegmentGrid`), the movers' segments (None: no movers) and which static
        segments are one-sided (None: none)."""
        return self._pose, self._seen, self._movers, self._one_sided

    def motion_state(self) -> MotionState:
        """What a step changes of the robot's motion, as a value (for a batch that steps it)."""
        return MotionState(
            self._pose, self._room, self._clearance, self._min_clearance, self._path_length, self._idle.idle_s,
            self.steps,
        )  # fmt: skip

    def set_motion_state(self, state: MotionState) -> None:
        """Put back a motion state a batch stepped on (the simulated time follows the steps)."""
        self._pose = state.pose
        self._room, self._clearance, self._min_clearance = state.room, state.clearance, state.min_clearance
        self._path_length, self._idle.idle_s = state.path_length, state.idle_s
        self.steps = state.steps
        self.sim_time_s = self.steps * self.config.dt_s

    def odometry_frame(self) -> tuple[float, float, float, float, float]:
        """The map-to-odometry transform of the episode: (x, y, theta, cos theta, sin theta)."""
        a, (c, s) = self._odom_from_map, self._odom_from_map_cs
        return a.x, a.y, a.theta, c, s

    def counted_bumps(self) -> tuple[int, list[int]]:
        """Bumps so far and by kind (`scene.KINDS`), those the task's rules excused left out."""
        physics = self.physics
        return physics.bumps - self._n_excused, [
            n - e for n, e in zip(physics.bumps_by_kind, self._excused, strict=True)
        ]

    def end_stepped_elsewhere(
        self, reward_terms: dict[str, float], reason: str, success: bool, cost: float
    ) -> dict[str, Any]:
        """End an episode whose last step a batch took (its state put back first): the episode
        is over, and its last info is built from the batch's verdict."""
        self._finished = True
        return self._info(reward_terms, reason, success, cost)

    @property
    def glide_constants(self) -> tuple[float, float, int, float]:
        """The physics' glide constants of a step (`Physics.glide_constants` of `dt_s`)."""
        return self._glide

    @property
    def solid_segments(self) -> Segments:
        """The static geometry the robot's footprint keeps off (and its clearance is to)."""
        return self._solid

    @property
    def n_action_extras(self) -> int:
        """Action components after the twist (the task's)."""
        return self._n_extras

    @property
    def scores_scans(self) -> bool:
        """Whether the task takes in every scan (`Task.on_scan`, e.g. exploration coverage)."""
        return self._on_scan is not None

    @property
    def finished(self) -> bool:
        """Whether the episode has ended (a step needs a reset first)."""
        return self._finished

    @property
    def pose(self) -> Pose:
        """The robot's true pose in the map frame (privileged: for metrics, never observations)."""
        return self._pose

    @property
    def world_name(self) -> str:
        """The name of the episode's world (its map's, or the generator's)."""
        if self.episode is None:
            raise RuntimeError("call reset() first")
        return self.episode.map.name

    @property
    def map_from_odom(self) -> Pose:
        """Where the odometry frame's origin lies in the map frame (privileged)."""
        return self._map_from_odom

    def snapshot(self) -> SceneSnapshot:
        """The current state as a value, for drawing (the renderer reads nothing else)."""
        if self.episode is None:
            raise RuntimeError("call reset() before snapshot()")
        scene = self.scene
        pose = self._pose
        ranges = self.last_scan.astype(float)
        cfg = self.config.lrf
        hit = (ranges > cfg.range_min_m) & (ranges < cfg.range_max_m)
        angles = pose.theta + self.lrf.beam_angles[hit]
        r = ranges[hit]
        records = scene.movers.records
        marks_fn = getattr(self.task, "marks", None)
        return SceneSnapshot(
            map=scene.map,
            closed_doors=scene.closed_doors,
            boxes=scene.boxes,
            movers=scene.mover_poses(),
            mover_sizes=np.array([(r.length, r.width) for r in records]).reshape(-1, 2),
            mover_pause_m=np.array([r.pause_radius_m for r in records]),
            pose=pose,
            outline=self._outline,
            trajectory=np.array([p[:2] for p in self.trajectory]),
            bump_points=np.array([p[:2] for p in self.bump_points]).reshape(-1, 2),
            scan_points=np.column_stack([pose.x + r * np.cos(angles), pose.y + r * np.sin(angles)]),
            map_from_odom=self._map_from_odom,
            sim_time_s=self.sim_time_s,
            bumps=self.physics.bumps - self._n_excused,
            marks=marks_fn() if marks_fn is not None else {},
            others=tuple(self._other_poses),
        )

    # --- rendering -----------------------------------------------------------------------
    def set_overlay(self, overlay: Overlay | Callable[[], Overlay | None] | None) -> None:
        """Let an agent draw its own view (an Overlay, or a callable returning one per frame).

        Raises:
            TypeError: for anything else (said now, not at the next render)."""
        if not (overlay is None or isinstance(overlay, Overlay) or callable(overlay)):
            raise TypeError(f"set_overlay takes an Overlay, a callable returning one, or None; got {overlay!r:.60}")
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
        return self._renderer.draw(self.snapshot(), overlay)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_renderer"] = None  # pygame surfaces and windows do not pickle
        return state


class PicoMapEnv(PicoEnv):
    """A `PicoEnv` whose world is a shipped map, a map file or a generated one: what the shipped
    envs share. A subclass names its id, its task config class and its generator families, and
    builds its task (`make_task`); `gym.make(ID, map=None, map_path=None, config=None,
    render_mode=None, family=None, **options)` is this constructor."""

    env_id: ClassVar[str]
    task_config: ClassVar[type]
    families: ClassVar[dict[str, dict[str, Any]]] = {}

    def __init__(
        self,
        render_mode: str | None = None,
        map: str | Map | None = None,  # noqa: A002  (the name users type)
        map_path: str | os.PathLike[str] | None = None,
        config: EnvConfig | None = None,
        **options: Any,
    ) -> None:
        self.check_options(options)
        robots = options.pop("_robots", 1)  # (pico_gym.multi: robots in the world)
        options = with_family(self.env_id, self.families, options)
        fixed = resolve_map(map, map_path)
        self.sim_config = None
        if options.get("sim_config") is not None:
            from pico_gym.world.sim_config import read_sim_config, with_sim_config

            self.sim_config = read_sim_config(options.pop("sim_config"))
            if self.sim_config.enable_taco and robots < 2:
                raise ValueError(
                    f"{self.sim_config.source}: enable_taco: true asks for two robots; play it with "
                    f'pico_gym.parallel_env("{self.env_id}", sim_config=...) (the multi extra)'
                )
            fixed = with_sim_config(fixed, self.sim_config)
            options = {**self.sim_config.env_options(), **options}
            if not self.sim_config.objects and "n_movers" in {f.name for f in dataclasses.fields(self.task_config)}:
                options.setdefault("n_movers", (0, 0))  # (the config's objects are the world's people: none)
        options.pop("sim_config", None)
        env_config = EnvConfig.make(config, task=self.task_config(), **options)
        if not isinstance(env_config.task, self.task_config):
            needs = self.task_config.__name__
            raise TypeError(f"{self.env_id} needs a {needs}, got {type(env_config.task).__name__}")
        super().__init__(self.make_task(env_config, fixed), env_config, render_mode)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        obs, info = super().reset(seed=seed, options=options)
        if self.sim_config is not None:
            info["sim_config"] = self.sim_config.report()
        return obs, info

    @classmethod
    def check_options(cls, options: dict[str, Any]) -> None:
        """Refuse, before any work, options the env gives another meaning (none by default)."""

    @classmethod
    def make_task(cls, config: EnvConfig, fixed: Map | None) -> Task:
        """The env's task for a config (its `task` an instance of `task_config`) and a fixed map."""
        raise NotImplementedError

    @classmethod
    def default_config(cls) -> EnvConfig:
        """The env's config with every default (what `gym.make` options override)."""
        return EnvConfig(task=cls.task_config())
