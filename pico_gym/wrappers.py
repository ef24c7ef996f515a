"""Gymnasium wrappers for learning on pico-gym envs.

Each step of the usual pipeline is a standard wrapper, usable on its own:

- `MinPoolLrf`: the 1000-beam LRF down-sampled to `n_sectors` sectors by taking each sector's
  minimum (conservative: an obstacle seen by one beam is seen by its sector), normalised to [0, 1].
- `OdomVelocity`: the odometry pose (whose origin means nothing to a policy) replaced by the
  body-frame velocity odometry measured over the last step, normalised by the robot's limits.
- gymnasium's `FlattenObservation`, `FrameStackObservation` and `RescaleAction` (actions in
  [-1, 1], as stable-baselines3 advises) do the rest.

- `PrivilegedPointGoal` (opt-in, PicoHospital-v0): adds `obs["point_goal"]`, the range and
  bearing to the next arrival square and the heading error to facing its cabinet, from the TRUE
  pose (Habitat PointNav's privileged goal sensor): a baseline for RL research, never a course agent.

`PicoLearningWrapper` is that whole pipeline in one wrapper (one line in an rl-zoo3 config), built
on `LearningEncoder`, which turns raw observations into the policy's input outside any env too: the
PPO agent uses it to act on an env's raw observations exactly as in training.

>>> import gymnasium as gym, pico_gym
>>> from pico_gym.wrappers import PicoLearningWrapper
>>> env = PicoLearningWrapper(gym.make("PicoEscape-v0"), n_sectors=64, frame_stack=2)
>>> env.observation_space.shape, env.action_space.low.tolist()
((134,), [-1.0, -1.0, -1.0])
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Literal, SupportsFloat

import gymnasium as gym
import numpy as np

from pico_gym.envs.base import pico_env
from pico_gym.jit import njit
from pico_gym.robot import RobotConfig
from pico_gym.sensors.lrf import LrfConfig


# --- pure functions -------------------------------------------------------------------------
def sector_starts(n_beams: int, n_sectors: int) -> np.ndarray:
    """First beam index of each of `n_sectors` contiguous sectors of (nearly) equal size.

    >>> sector_starts(10, 3).tolist()
    [0, 3, 6]
    """
    if not 1 <= n_sectors <= n_beams:
        raise ValueError(f"n_sectors must be in 1..{n_beams} (the number of beams), got {n_sectors}")
    return (np.arange(n_sectors) * n_beams) // n_sectors


# The log range scale maps this range (and anything nearer) to 0 [m].
LOG_RANGE_MIN_M = 0.1
RANGE_SCALES = ("linear", "log")


def scale_ranges(ranges: np.ndarray, range_max: float, scale: str = "linear") -> np.ndarray:
    """Ranges mapped to [0, 1]: "linear" divides by range_max; "log" is log(r / 0.1 m) /
    log(range_max / 0.1 m), which spreads the near field a policy must resolve to avoid bumps
    (at a 10 m range_max: 0.2 m -> 0.15, 0.5 m -> 0.35, 1 m -> 0.5, where "linear" gives 0.02,
    0.05, 0.1).

    >>> scale_ranges(np.array([0.05, 1.0, 10.0, 20.0]), 10.0, "log").round(3).tolist()
    [0.0, 0.5, 1.0, 1.0]
    """
    r = np.asarray(ranges, np.float64)
    if scale == "linear":
        return np.clip(r / range_max, 0.0, 1.0)
    if scale == "log":
        r0 = LOG_RANGE_MIN_M
        return np.clip(np.log(np.maximum(r, r0) / r0) / math.log(range_max / r0), 0.0, 1.0)
    raise ValueError(f"range scale must be one of {RANGE_SCALES}, got {scale!r}")


def min_pool(
    ranges: np.ndarray,
    starts: np.ndarray,
    range_max: float,
    normalize: bool = True,
    reduce: np.ufunc = np.minimum,
    scale: str = "linear",
) -> np.ndarray:
    """Each sector's minimum range (0 = "no hit" in the legacy convention, so read as range_max);
    `reduce=np.maximum` gives each sector's maximum instead. `normalize` maps to [0, 1] with
    `scale_ranges(..., scale)`.

    >>> min_pool(np.array([3.0, 1.0, 0.0, 5.0, 2.0, 4.0]), np.array([0, 3]), 10.0, normalize=False).tolist()
    [1.0, 2.0]
    """
    r = np.where(ranges > 0.0, ranges, range_max)
    pooled = reduce.reduceat(r, starts)
    if normalize:
        pooled = scale_ranges(pooled, range_max, scale)
    return pooled.astype(np.float32)


def body_velocity(previous: np.ndarray, current: np.ndarray, dt: float, robot: RobotConfig) -> np.ndarray:
    """The body-frame twist that moved odometry from `previous` to `current` in `dt`, normalised
    by the robot's limits (so a full-speed command reads 1).
    """
    dx, dy = float(current[0] - previous[0]), float(current[1] - previous[1])
    c, s = math.cos(float(previous[2])), math.sin(float(previous[2]))
    dtheta = math.remainder(float(current[2] - previous[2]), 2.0 * math.pi)
    v = np.array([c * dx + s * dy, -s * dx + c * dy, 0.0]) / (dt * robot.max_speed_mps)
    v[2] = dtheta / (dt * robot.max_turn_rate_radps)
    return np.clip(v, -1.5, 1.5).astype(np.float32)


def rescale_action(unit: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Map an action in [-1, 1] to [low, high] (gymnasium's RescaleAction, as a function)."""
    unit = np.clip(np.asarray(unit, dtype=np.float64), -1.0, 1.0)
    return low + (unit + 1.0) * 0.5 * (high - low)


def unit_action(action: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """The inverse of `rescale_action`: an action in [low, high] mapped to [-1, 1]."""
    return np.clip(2.0 * (np.asarray(action, np.float64) - low) / (high - low) - 1.0, -1.0, 1.0)


# --- single-purpose wrappers ----------------------------------------------------------------
def _dict_spaces(env: gym.Env) -> dict[str, gym.Space]:
    """The parts of an env's Dict observation space (pico-gym's envs observe a dict)."""
    space = env.observation_space
    if not isinstance(space, gym.spaces.Dict):
        raise TypeError(f"expected an env with a Dict observation space, got {space}")
    return dict(space.spaces)


def _box(space: gym.Space) -> gym.spaces.Box:
    """A Box space (pico-gym's actions are one)."""
    if not isinstance(space, gym.spaces.Box):
        raise TypeError(f"expected a Box action space, got {space}")
    return space


def _env_config(env: gym.Env) -> Any:
    config = getattr(env.unwrapped, "config", None)
    if config is None or not hasattr(config, "lrf"):
        raise TypeError(f"{type(env.unwrapped).__name__} is not a pico-gym env (it has no LRF config)")
    return config


class MinPoolLrf(gym.ObservationWrapper):
    """Down-sample `obs["lrf"]` to `n_sectors` sector minima, normalised to [0, 1] by range_max
    (`scale="log"`: on a log scale, see `scale_ranges`).

    `max_pool=True` adds `obs["lrf_max"]`, the sector maxima: min-pooling is safe but hides a
    narrow far gap (a corridor mouth across a large room) behind its sector's nearer beams.
    """

    def __init__(
        self,
        env: gym.Env,
        n_sectors: int = 64,
        normalize: bool = True,
        max_pool: bool = False,
        scale: str = "linear",
    ) -> None:
        super().__init__(env)
        lrf: LrfConfig = _env_config(env).lrf
        if scale not in RANGE_SCALES:
            raise ValueError(f"range scale must be one of {RANGE_SCALES}, got {scale!r}")
        self.starts = sector_starts(lrf.n_beams, n_sectors)
        self.range_max = lrf.range_max_m
        self.normalize, self.max_pool, self.scale = normalize, max_pool, scale
        high = 1.0 if normalize else lrf.range_max_m
        spaces = _dict_spaces(env)
        spaces["lrf"] = gym.spaces.Box(0.0, high, (n_sectors,), np.float32)
        if max_pool:
            spaces["lrf_max"] = gym.spaces.Box(0.0, high, (n_sectors,), np.float32)
        self.observation_space = gym.spaces.Dict(spaces)

    def observation(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        ranges = observation["lrf"]
        out = {**observation, "lrf": min_pool(ranges, self.starts, self.range_max, self.normalize, scale=self.scale)}
        if self.max_pool:
            out["lrf_max"] = min_pool(ranges, self.starts, self.range_max, self.normalize, np.maximum, self.scale)
        return out


@njit
def _bin(angle, inv_width, n):
    """The bin of an angle in [-4 pi, 4 pi] (cheaper than a float modulo)."""
    b = int((angle + 4.0 * math.pi) * inv_width)  # >= 0
    while b >= n:
        b -= n
    return b


@njit
def _update_memory(memory, ranges, beam_angles, centres, heading, range_max, log_scale):
    n = memory.shape[0]
    inv_width = n / (2.0 * math.pi)
    heading = heading % (2.0 * math.pi)  # [0, 2 pi); beam and centre angles are within [-pi, pi]
    current = np.full(n, -1.0)
    # The beams are sorted, so their raw bin int(x), x = (angle + 4 pi) * inv_width, never
    # decreases: walk the bins along with the beams (bin b holds raw bins ..., edge - 1; x >= edge
    # moves on, the same test as int(x) >= edge for x >= 0) and keep each bin's farthest range in
    # a register, stored once when the walk leaves the bin. (A compare and store per beam into
    # current[b] mispredicts on real scans: this costs a third of it.)
    b = _bin(heading + beam_angles[0], inv_width, n)
    edge = float(int((heading + beam_angles[0] + 4.0 * math.pi) * inv_width) + 1)
    farthest = -1.0
    for i in range(ranges.shape[0]):
        r = ranges[i] if ranges[i] > 0.0 else range_max
        x = (heading + beam_angles[i] + 4.0 * math.pi) * inv_width
        if x >= edge:
            if farthest > current[b]:
                current[b] = farthest
            farthest = -1.0
            while x >= edge:
                edge += 1.0
                b += 1
                if b == n:
                    b = 0
        farthest = r if r > farthest else farthest
    if farthest > current[b]:
        current[b] = farthest
    for b in range(n):
        if current[b] >= 0.0:
            memory[b] = current[b]
    out = np.empty(n, np.float32)
    r0 = LOG_RANGE_MIN_M
    log_span = math.log(range_max / r0)
    for j in range(n):
        r = memory[_bin(heading + centres[j], inv_width, n)]
        v = math.log(max(r, r0) / r0) / log_span if log_scale else r / range_max  # as scale_ranges
        out[j] = min(max(v, 0.0), 1.0)
    return out


@njit
def _pool_into(ranges, starts, range_max, reduce_max, log_scale, out):
    """`min_pool(...)` (or its maximum) of a float32 scan, scaled as `scale_ranges`, into `out`."""
    n = starts.shape[0]
    no_hit = np.float32(range_max)
    r0 = LOG_RANGE_MIN_M
    log_span = math.log(range_max / r0)
    for k in range(n):
        end = starts[k + 1] if k + 1 < n else ranges.shape[0]
        m = ranges[starts[k]] if ranges[starts[k]] > 0.0 else no_hit
        for i in range(starts[k] + 1, end):
            r = ranges[i] if ranges[i] > 0.0 else no_hit
            if (r > m) if reduce_max else (r < m):
                m = r
        v = float(m)
        v = math.log(max(v, r0) / r0) / log_span if log_scale else v / range_max
        out[k] = min(max(v, 0.0), 1.0)


class RangeMemory:
    """The farthest range last seen in each of `n_bins` directions all around, kept in the
    odometry frame and read in the body frame (bin 0 = straight behind, counter-clockwise): a
    360-degree memory of the 229-degree LRF, so a corridor mouth seen once stays known after the
    robot turns away from it. Bins never seen read 0. Ranges are scaled to [0, 1] as
    `scale_ranges(..., scale)` does.
    """

    def __init__(self, beam_angles: np.ndarray, n_bins: int, range_max: float, scale: str = "linear") -> None:
        if n_bins < 4:
            raise ValueError(f"memory_sectors must be >= 4 (or 0 for none), got {n_bins}")
        if scale not in RANGE_SCALES:
            raise ValueError(f"range scale must be one of {RANGE_SCALES}, got {scale!r}")
        self.scale = scale
        self.beam_angles = np.asarray(beam_angles, np.float64)
        self.width = 2.0 * math.pi / n_bins
        self.centres = -math.pi + (np.arange(n_bins) + 0.5) * self.width
        self.range_max = range_max
        self.memory = np.zeros(n_bins)

    def reset(self) -> None:
        self.memory[:] = 0.0

    def update(self, ranges: np.ndarray, heading: float) -> np.ndarray:
        """Store a scan taken at odometry heading `heading`; the memory in the body frame, in [0, 1]."""
        if ranges.dtype not in (np.float32, np.float64):
            ranges = np.asarray(ranges, np.float64)
        return _update_memory(
            self.memory, ranges, self.beam_angles, self.centres, heading, self.range_max, self.scale == "log"
        )


class LrfMemory(gym.Wrapper):
    """Add `obs["lrf_memory"]`: a `RangeMemory` of `n_bins` directions (apply before wrappers that
    replace `obs["lrf"]` or `obs["odom"]`)."""

    def __init__(self, env: gym.Env, n_bins: int = 36, scale: str = "linear") -> None:
        super().__init__(env)
        lrf: LrfConfig = _env_config(env).lrf
        self.memory = RangeMemory(lrf.beam_angles, n_bins, lrf.range_max_m, scale)
        spaces = _dict_spaces(env)
        spaces["lrf_memory"] = gym.spaces.Box(0.0, 1.0, (n_bins,), np.float32)
        self.observation_space = gym.spaces.Dict(spaces)

    def _add(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {**obs, "lrf_memory": self.memory.update(obs["lrf"], float(obs["odom"][2]))}

    def reset(self, **kwargs: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self.memory.reset()
        return self._add(obs), info

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self._add(obs), reward, terminated, truncated, info


class OdomVelocity(gym.Wrapper):
    """Replace `obs["odom"]` (a pose) with the body-frame velocity it implies, in units of the
    robot's limits (vx / v_max, vy / v_max, w / w_max); zero on reset."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        config = _env_config(env)
        self.robot, self.dt = config.robot, config.dt_s
        spaces = _dict_spaces(env)
        spaces["odom"] = gym.spaces.Box(-1.5, 1.5, (3,), np.float32)
        self.observation_space = gym.spaces.Dict(spaces)
        self._previous: np.ndarray | None = None

    def reset(self, **kwargs: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._previous = obs["odom"]
        return {**obs, "odom": np.zeros(3, np.float32)}, info

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        assert self._previous is not None  # (set by reset)
        velocity = body_velocity(self._previous, obs["odom"], self.dt, self.robot)
        self._previous = obs["odom"]
        return {**obs, "odom": velocity}, reward, terminated, truncated, info


# --- the privileged point goal (end-to-end baseline) ---------------------------------------
POINT_GOAL_SIZE = 5
POINT_GOAL_RANGE_M = 20.0  # ranges beyond this read 1


def encode_goal(x: float, y: float, theta: float, gx: float, gy: float, facing_rad: float) -> np.ndarray:
    """A goal point as a policy sees it from pose (x, y, theta): [log-scaled range (0 at it, 1 at
    POINT_GOAL_RANGE_M and beyond: log(1 + d / 0.1) / log(1 + 20 / 0.1)), sin and cos of its
    bearing in the robot's frame, sin and cos of the heading error to `facing_rad`].

    >>> encode_goal(0.0, 0.0, 0.0, 0.0, 0.0, 0.0).tolist()
    [0.0, 0.0, 1.0, 0.0, 1.0]
    """
    dx, dy = gx - x, gy - y
    d = math.hypot(dx, dy)
    bearing = math.atan2(dy, dx) - theta
    error = facing_rad - theta
    r = min(math.log1p(d / 0.1) / math.log1p(POINT_GOAL_RANGE_M / 0.1), 1.0)
    return np.array([r, math.sin(bearing), math.cos(bearing), math.sin(error), math.cos(error)], np.float32)


def point_goal(env: gym.Env) -> np.ndarray:
    """The privileged point goal of a PicoHospital-v0 env, from its TRUE pose and task state:
    `encode_goal` of the next arrival square's centre, facing its cabinet; once every cabinet is
    done, the robot is at its goal: [0, 0, 1, 0, 1].
    """
    base = pico_env(env)
    target = base.task.next_target  # type: ignore[attr-defined]  # (a hospital task's)
    if target is None:
        return np.array([0.0, 0.0, 1.0, 0.0, 1.0], np.float32)
    pose = base.pose
    gx, gy = target.dock_point(0.5 * target.side_m)
    return encode_goal(float(pose.x), float(pose.y), float(pose.theta), float(gx), float(gy), target.facing_rad)


class PrivilegedPointGoal(gym.Wrapper):
    """Adds `obs["point_goal"]` (see `point_goal`) to PicoHospital-v0's observations.

    PRIVILEGED: it reads the true pose and the task's next cabinet, which no course agent was
    given (Habitat PointNav's convention of a privileged GPS+compass goal sensor). It exists for
    the end-to-end RL baseline; agents trained with it are listed in PRIVILEGED_AGENTS.
    """

    def __init__(self, env: gym.Env) -> None:
        task = getattr(env.unwrapped, "task", None)
        if not hasattr(type(task), "next_target"):
            raise ValueError(
                "PrivilegedPointGoal needs a task with a next target (PicoHospital-v0); "
                f"got {type(env.unwrapped).__name__}"
            )
        super().__init__(env)
        spaces = _dict_spaces(env)
        low = np.array([0.0, -1.0, -1.0, -1.0, -1.0], np.float32)
        spaces["point_goal"] = gym.spaces.Box(low, np.ones(POINT_GOAL_SIZE, np.float32), dtype=np.float32)
        self.observation_space = gym.spaces.Dict(spaces)

    def reset(self, **kwargs: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        return {**obs, "point_goal": point_goal(self.env)}, info

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        return {**obs, "point_goal": point_goal(self.env)}, reward, terminated, truncated, info


# The odometry trail (`OdometryTrail`): a position every second, the last minute, within 2 m.
TRAIL_EVERY_S = 1.0
TRAIL_S = 60.0
TRAIL_RADIUS_M = 2.0


class OdometryTrail:
    """Where the robot has been, around it: the odometry positions of the last `TRAIL_S` seconds
    (one every `TRAIL_EVERY_S`), binned by bearing in the body frame into `n_bins` sectors all
    around (bin 0 = straight behind, counter-clockwise, as `RangeMemory`); each bin reads the
    closeness of its nearest kept position, max(0, 1 - distance / TRAIL_RADIUS_M), 0 for none.
    A memory of the path for a reactive policy (it can tell a wall it has followed before from a
    new one); from odometry only, so no privileged input.
    """

    def __init__(self, n_bins: int, dt_s: float) -> None:
        if n_bins < 4:
            raise ValueError(f"trail_sectors must be >= 4 (or 0 for none), got {n_bins}")
        self.n_bins = n_bins
        self.every = max(1, round(TRAIL_EVERY_S / dt_s))
        self.points = np.zeros((max(1, round(TRAIL_S / TRAIL_EVERY_S)), 2))
        self.count = 0  # positions kept so far (the ring holds the last len(points))
        self.calls = 0

    def reset(self) -> None:
        self.count = 0
        self.calls = 0

    def update(self, odom: np.ndarray) -> np.ndarray:
        """Record odometry pose `odom` (x, y, theta) when one is due; the trail in the body frame."""
        x, y, theta = float(odom[0]), float(odom[1]), float(odom[2])
        out = np.zeros(self.n_bins, np.float32)
        if self.count:
            kept = self.points[: min(self.count, len(self.points))]
            dx, dy = kept[:, 0] - x, kept[:, 1] - y
            distance = np.hypot(dx, dy)
            closeness = np.maximum(0.0, 1.0 - distance / TRAIL_RADIUS_M)
            near = closeness > 0.0
            if near.any():
                bearing = np.arctan2(dy[near], dx[near]) - theta
                bins = np.floor((bearing / (2.0 * math.pi) + 0.5) % 1.0 * self.n_bins).astype(np.int64) % self.n_bins
                np.maximum.at(out, bins, closeness[near].astype(np.float32))
        if self.calls % self.every == 0:
            self.points[self.count % len(self.points)] = (x, y)
            self.count += 1
        self.calls += 1
        return out


# --- the whole pipeline ---------------------------------------------------------------------
@dataclass(frozen=True)
class LearningConfig:
    """What a policy sees and does.

    Attributes:
        n_sectors: LRF sectors after min-pooling.
        max_pool: also each sector's maximum (shows narrow far gaps min-pooling hides).
        memory_sectors: bins of a 360-degree `RangeMemory` (0: none).
        frame_stack: how many of the latest frames the policy sees (oldest first).
        odometry: "velocity" (body-frame velocity from odometry) or "none".
        range_scale: how ranges map to [0, 1]: "linear" or "log" (resolves the near field; see
            `scale_ranges`).
        point_goal: the frame ends with `obs["point_goal"]` (POINT_GOAL_SIZE values), which
            `PrivilegedPointGoal` adds (privileged, for the end-to-end hospital baseline only),
            or `pico_gym.agents.exit_goal.ExitGoalObservation` (the escape room's exit as the
            robot's own perception tracks it) or the hybrid agent (its route's next waypoint).
        trail_sectors: bins of an `OdometryTrail` (where the robot has been, around it; 0: none).
    """

    n_sectors: int = 64
    frame_stack: int = 1
    odometry: Literal["velocity", "none"] = "velocity"
    max_pool: bool = False
    memory_sectors: int = 0
    range_scale: Literal["linear", "log"] = "linear"
    point_goal: bool = False
    trail_sectors: int = 0

    def __post_init__(self) -> None:
        if not isinstance(self.trail_sectors, int) or isinstance(self.trail_sectors, bool):
            raise ValueError(f"trail_sectors must be an integer, got {self.trail_sectors!r}")
        if not isinstance(self.point_goal, bool):
            raise ValueError(f"point_goal must be true or false, got {self.point_goal!r}")
        if self.frame_stack < 1:
            raise ValueError(f"frame_stack must be >= 1, got {self.frame_stack}")
        if self.odometry not in ("velocity", "none"):
            raise ValueError(f"odometry must be 'velocity' or 'none', got {self.odometry!r}")
        if self.range_scale not in RANGE_SCALES:
            raise ValueError(f"range_scale must be one of {RANGE_SCALES}, got {self.range_scale!r}")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def mirror_maps(config: LearningConfig) -> tuple[np.ndarray, np.ndarray]:
    """The left-right reflection of `LearningEncoder`'s input: (index, sign) with
    reflected = input[index] * sign.

    The LRF sectors, range memory and trail bins run from the robot's right to its left (or round
    from behind), so each block is reversed; the point goal's bearing and heading error change
    sign (their sines do, `encode_goal`), and so do the odometry velocity's vy and w. An
    involution (index[index] is the identity). The blocks' bins are symmetric to within a beam
    (1000 beams in 64 sectors), so a reflected world encodes to the reflected input to within
    that, not to the bit.
    """
    index: list[int] = []
    sign: list[float] = []
    blocks = [config.n_sectors] * (2 if config.max_pool else 1) + [config.memory_sectors, config.trail_sectors]
    at = 0
    for n in blocks:
        index += range(at + n - 1, at - 1, -1)
        sign += [1.0] * n
        at += n
    if config.point_goal:  # [range, sin, cos of the bearing, sin, cos of the heading error]
        index += range(at, at + POINT_GOAL_SIZE)
        sign += [1.0, -1.0, 1.0, -1.0, 1.0]
        at += POINT_GOAL_SIZE
    if config.odometry == "velocity":
        index += [at, at + 1, at + 2]
        sign += [1.0, -1.0, -1.0]
        at += 3
    frame = np.array(index, np.int64)
    k = config.frame_stack
    return np.concatenate([frame + i * at for i in range(k)]), np.tile(np.array(sign, np.float32), k)


# The reflection of an action (vx, vy, w[, announce]): the robot's left <-> right.
MIRROR_ACTION_SIGN = np.array([1.0, -1.0, -1.0, 1.0], np.float32)


class LearningEncoder:
    """Raw pico-gym observations -> the flat policy input of `PicoLearningWrapper` (stateful:
    call `reset` with an episode's first observation, then `encode` with each next one).

    One frame is [LRF sector minima..., (sector maxima... with max_pool,) (range memory... with
    memory_sectors,) (odometry trail... with trail_sectors,) (the point goal with point_goal,) vx,
    vy, w] (the last three only with odometry="velocity"); the input is the last `frame_stack`
    frames, oldest first, the first frame repeated at a reset (gymnasium's FrameStackObservation
    with padding "reset").
    """

    def __init__(self, lrf: LrfConfig, robot: RobotConfig, dt_s: float, config: LearningConfig) -> None:
        self.config = config
        self.robot, self.dt = robot, dt_s
        self.range_max = lrf.range_max_m
        self.starts = sector_starts(lrf.n_beams, config.n_sectors)
        self.memory = (
            RangeMemory(lrf.beam_angles, config.memory_sectors, lrf.range_max_m, config.range_scale)
            if config.memory_sectors
            else None
        )
        self.trail = OdometryTrail(config.trail_sectors, dt_s) if config.trail_sectors else None
        self.frame_size = (
            config.n_sectors * (2 if config.max_pool else 1)
            + config.memory_sectors
            + config.trail_sectors
            + (POINT_GOAL_SIZE if config.point_goal else 0)
            + (3 if config.odometry == "velocity" else 0)
        )
        low = np.zeros(self.frame_size, np.float32)
        high = np.ones(self.frame_size, np.float32)
        self._trail_at = config.n_sectors * (2 if config.max_pool else 1) + config.memory_sectors
        self._goal_at = self._trail_at + config.trail_sectors
        if config.point_goal:
            low[self._goal_at + 1 : self._goal_at + POINT_GOAL_SIZE] = -1.0
        if config.odometry == "velocity":
            low[-3:], high[-3:] = -1.5, 1.5
        k = config.frame_stack
        self.space = gym.spaces.Box(np.tile(low, k), np.tile(high, k), dtype=np.float32)
        # The stacked input, oldest frame first: a step shifts it one frame and writes the newest.
        self._stack = np.zeros(k * self.frame_size, np.float32)
        self._log = config.range_scale == "log"
        self._velocity_scale = (dt_s * robot.max_speed_mps, dt_s * robot.max_turn_rate_radps)
        self._previous: np.ndarray | None = None

    def _write_frame(self, obs: dict[str, np.ndarray], velocity: tuple[float, float, float]) -> None:
        frame = self._stack[len(self._stack) - self.frame_size :]
        lrf = obs["lrf"]
        if lrf.dtype != np.float32:
            lrf = lrf.astype(np.float32)
        n = self.config.n_sectors
        _pool_into(lrf, self.starts, self.range_max, False, self._log, frame[:n])
        if self.config.max_pool:
            _pool_into(lrf, self.starts, self.range_max, True, self._log, frame[n : 2 * n])
            n *= 2
        if self.memory is not None:
            frame[n : n + self.config.memory_sectors] = self.memory.update(lrf, float(obs["odom"][2]))
        if self.trail is not None:
            frame[self._trail_at : self._goal_at] = self.trail.update(obs["odom"])
        if self.config.point_goal:
            goal = obs.get("point_goal")
            if goal is None:
                raise ValueError(
                    "LearningConfig(point_goal=True) needs obs['point_goal']: wrap the env in "
                    "pico_gym.wrappers.PrivilegedPointGoal or pico_gym.agents.exit_goal.ExitGoalObservation "
                    "(before PicoLearningWrapper)"
                )
            frame[self._goal_at : self._goal_at + POINT_GOAL_SIZE] = goal
        if self.config.odometry == "velocity":
            frame[-3:] = velocity

    def _velocity(self, odom: np.ndarray) -> tuple[float, float, float]:
        """`body_velocity(previous, odom, ...)` without building arrays (the same arithmetic)."""
        dx, dy, dth = (odom - self._previous).tolist()  # in the odometry's own dtype, as body_velocity
        heading = float(self._previous[2])  # type: ignore[index]
        c, s = math.cos(heading), math.sin(heading)
        dtheta = math.remainder(dth, 2.0 * math.pi)
        lin, ang = self._velocity_scale
        return (
            min(max((c * dx + s * dy) / lin, -1.5), 1.5),
            min(max((-s * dx + c * dy) / lin, -1.5), 1.5),
            min(max(dtheta / ang, -1.5), 1.5),
        )

    def reset(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        self._previous = np.array(obs["odom"])
        if self.memory is not None:
            self.memory.reset()
        if self.trail is not None:
            self.trail.reset()
        self._write_frame(obs, (0.0, 0.0, 0.0))
        fs = self.frame_size
        newest = self._stack[len(self._stack) - fs :]
        for k in range(self.config.frame_stack - 1):
            self._stack[k * fs : (k + 1) * fs] = newest
        return self._stack.copy()

    def encode(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        if self._previous is None:
            raise RuntimeError("LearningEncoder.encode called before reset")
        odom = np.array(obs["odom"])
        fs = self.frame_size
        self._stack[: len(self._stack) - fs] = self._stack[fs:]
        self._write_frame(obs, self._velocity(odom))
        self._previous = odom
        return self._stack.copy()


@njit
def _encode_rows(
    rows,
    fresh,
    lrf,
    odom,
    previous,
    memory,
    stacks,
    starts,
    range_max,
    log_scale,
    n_sectors,
    max_pool,
    beam_angles,
    centres,
    velocity,
    lin,
    ang,
    frame_size,
):
    """`LearningEncoder.reset` (fresh[j]) or `.encode` of robot rows[j] from lrf[j], odom[j], in
    place on stacks[rows[j]] (the same arithmetic, one call for every robot)."""
    two_pi = 2.0 * math.pi
    total = stacks.shape[1]
    for j in range(rows.shape[0]):
        i = rows[j]
        stack = stacks[i]
        v0 = v1 = v2 = 0.0
        if fresh[j]:
            memory[i, :] = 0.0
        else:
            for k in range(total - frame_size):
                stack[k] = stack[k + frame_size]
            # Differences rounded to the odometry's float32, as LearningEncoder's array subtraction.
            # (numba's float() of a float32 stays float32: np.float64 widens, as Python's float.)
            dx = np.float64(np.float32(odom[j, 0] - previous[i, 0]))
            dy = np.float64(np.float32(odom[j, 1] - previous[i, 1]))
            dth = np.float64(np.float32(odom[j, 2] - previous[i, 2]))
            heading = np.float64(previous[i, 2])
            c, s = math.cos(heading), math.sin(heading)
            dtheta = dth - two_pi * np.rint(dth / two_pi)  # math.remainder(dth, 2 pi)
            v0 = min(max((c * dx + s * dy) / lin, -1.5), 1.5)
            v1 = min(max((-s * dx + c * dy) / lin, -1.5), 1.5)
            v2 = min(max(dtheta / ang, -1.5), 1.5)
        previous[i, :] = odom[j]
        frame = stack[total - frame_size :]
        n = n_sectors
        _pool_into(lrf[j], starts, range_max, False, log_scale, frame[:n])
        if max_pool:
            _pool_into(lrf[j], starts, range_max, True, log_scale, frame[n : 2 * n])
            n *= 2
        m = centres.shape[0]
        if m:
            frame[n : n + m] = _update_memory(
                memory[i], lrf[j], beam_angles, centres, np.float64(odom[j, 2]), range_max, log_scale
            )
        if velocity:
            frame[frame_size - 3] = v0
            frame[frame_size - 2] = v1
            frame[frame_size - 1] = v2
        if fresh[j]:
            for k in range(0, total - frame_size, frame_size):
                stack[k : k + frame_size] = frame


class BatchedLearningEncoder:
    """`LearningEncoder` for `n` robots at once: one compiled call encodes every robot's newest
    observation into its row of `stacks` (the same numbers, bit for bit: tested). Without a point
    goal (which needs the privileged wrapper's observation)."""

    def __init__(self, lrf: LrfConfig, robot: RobotConfig, dt_s: float, config: LearningConfig, n: int) -> None:
        if config.trail_sectors:
            raise ValueError(
                "BatchedLearningEncoder does not keep an odometry trail (trail_sectors): use LearningEncoder per "
                "robot (in pico-gym train: vec_env: dummy)"
            )
        if config.point_goal:
            raise ValueError(
                "BatchedLearningEncoder does not take a point goal (PrivilegedPointGoal): use LearningEncoder per "
                "robot (in pico-gym train: vec_env: dummy)"
            )
        one = LearningEncoder(lrf, robot, dt_s, config)
        self.config, self.space, self.frame_size = config, one.space, one.frame_size
        self._starts = one.starts.astype(np.int64)
        self._range_max = float(one.range_max)
        if one.memory is not None:
            self._beam_angles, self._centres = one.memory.beam_angles, np.asarray(one.memory.centres, np.float64)
        else:
            self._beam_angles, self._centres = np.zeros(lrf.n_beams), np.zeros(0)
        self._lin, self._ang = one._velocity_scale
        self.stacks = np.zeros((n, self.space.shape[0]), np.float32)
        self._previous = np.zeros((n, 3), np.float32)
        self._memory = np.zeros((n, max(config.memory_sectors, 1)))

    def _run(self, rows: np.ndarray, fresh: np.ndarray, lrf: np.ndarray, odom: np.ndarray) -> None:
        c = self.config
        _encode_rows(
            rows, fresh, np.ascontiguousarray(lrf, np.float32), np.ascontiguousarray(odom, np.float32),
            self._previous, self._memory, self.stacks, self._starts, self._range_max, c.range_scale == "log",
            c.n_sectors, c.max_pool, self._beam_angles, self._centres, c.odometry == "velocity", self._lin,
            self._ang, self.frame_size,
        )  # fmt: skip

    def reset(self, rows: np.ndarray, lrf: np.ndarray, odom: np.ndarray) -> None:
        """Robots `rows` begin episodes with first observations lrf[j], odom[j] (`LearningEncoder.reset`)."""
        rows = np.asarray(rows, np.int64)
        self._run(rows, np.ones(len(rows), np.bool_), lrf, odom)

    def encode(self, rows: np.ndarray, lrf: np.ndarray, odom: np.ndarray) -> None:
        """Robots `rows` observed lrf[j], odom[j] (`LearningEncoder.encode`); read `stacks`."""
        rows = np.asarray(rows, np.int64)
        self._run(rows, np.zeros(len(rows), np.bool_), lrf, odom)


class PicoLearningWrapper(gym.Wrapper):
    """The learning pipeline in one wrapper: min-pooled, normalised LRF, odometry velocity, frame
    stacking, a flat Box observation, and actions in [-1, 1].

    Equivalent to MinPoolLrf -> OdomVelocity -> FlattenObservation -> FrameStackObservation ->
    FlattenObservation -> RescaleAction(-1, 1) (tested), in one pass per step.
    """

    def __init__(
        self,
        env: gym.Env,
        n_sectors: int = 64,
        frame_stack: int = 1,
        odometry: str = "velocity",
        max_pool: bool = False,
        memory_sectors: int = 0,
        range_scale: str = "linear",
        point_goal: bool = False,
        trail_sectors: int = 0,
    ) -> None:
        config = _env_config(env)
        ones = np.ones(_box(env.action_space).shape, np.float32)
        super().__init__(gym.wrappers.RescaleAction(env, -ones, ones))
        self.learning = LearningConfig(
            n_sectors,
            frame_stack,
            odometry,  # type: ignore[arg-type]
            max_pool,
            memory_sectors,
            range_scale,  # type: ignore[arg-type]
            point_goal,
            trail_sectors,
        )
        if point_goal and "point_goal" not in getattr(env.observation_space, "spaces", {}):
            raise ValueError(
                "PicoLearningWrapper(point_goal=True): the env has no 'point_goal' observation; "
                "wrap it in pico_gym.wrappers.PrivilegedPointGoal first"
            )
        self.encoder = LearningEncoder(config.lrf, config.robot, config.dt_s, self.learning)
        self.observation_space = self.encoder.space

    def reset(self, **kwargs: Any) -> tuple[np.ndarray, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        return self.encoder.reset(obs), info

    def step(self, action: Any) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self.encoder.encode(obs), reward, terminated, truncated, info


def learning_env(env_id: str = "PicoEscape-v0", learning: LearningConfig | None = None, **env_kwargs: Any) -> gym.Env:
    """`gym.make(env_id, **env_kwargs)` wrapped in `PicoLearningWrapper` with `learning`."""
    import pico_gym  # noqa: F401  (registers the ids)

    return PicoLearningWrapper(gym.make(env_id, **env_kwargs), **(learning or LearningConfig()).to_dict())
