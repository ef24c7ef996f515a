"""Wheel odometry of a three-omni-wheel base, with the course simulator's wheel noise and slip.

The wheels turn as commanded and their encoders count exactly that; the ground moves the robot by
each wheel's speed times (1 + e_i), where e_i ~ U(-0.002, 0.002) is redrawn every few seconds
(emc_simulator's model, docs/facts/pico-facts.md), optionally times a per-step slip factor. The env drives the
physics with the resulting true twist and integrates the commanded one for odometry, so odometry
drifts slowly, and keeps counting when a wall stops the robot, as on the real PICO.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pico_gym.jit import njit
from pico_gym.pymath import wrap_angle
from pico_gym.robot import RobotConfig
from pico_gym.types import FloatArray, Pose
from pico_gym.validate import flag, number

# emc_simulator: true wheel speed = commanded * (1 + U(-0.002, 0.002)), factors redrawn every
# few seconds.
COURSE_WHEEL_NOISE = 0.002
COURSE_WHEEL_NOISE_INTERVAL_S = 3.0
# Newer simulator versions start odometry at x, y ~ U(-2, 2), yaw ~ U(0, 2 pi).
COURSE_RANDOM_START_RANGE_M = 2.0


@dataclass(frozen=True)
class OdometryConfig:
    """Odometry noise settings.

    Attributes:
        wheel_noise: half-width of each wheel's multiplicative factor e_i ~ U(-a, a).
        wheel_noise_interval_s: how often the factors are redrawn [s].
        slip_std: standard deviation of an extra per-step, per-wheel multiplicative slip on the
            ground speed (0 = off); the real robot's omni-wheels slip much more than the
            simulator's model.
        random_start: start odometry at a random pose (newer simulators) instead of (0, 0, 0).
    """

    wheel_noise: float = COURSE_WHEEL_NOISE
    wheel_noise_interval_s: float = COURSE_WHEEL_NOISE_INTERVAL_S
    slip_std: float = 0.0
    random_start: bool = False

    def __post_init__(self) -> None:
        number("OdometryConfig.wheel_noise", self.wheel_noise, 0.0, 0.5)
        number("OdometryConfig.slip_std", self.slip_std, 0.0, 0.5)
        number("OdometryConfig.wheel_noise_interval_s", self.wheel_noise_interval_s, 0.0, lo_open=True, unit=" s")
        flag("OdometryConfig.random_start", self.random_start)


def wheel_matrix(robot: RobotConfig) -> FloatArray:
    """The 3x3 matrix J with wheel speeds = J @ (vx, vy, w) (rim speeds, m/s)."""
    rows = [(-math.sin(a), math.cos(a), robot.wheel_distance_m) for a in robot.wheel_angles_rad]
    return np.array(rows)


def integrate_twist(pose: Pose, vx: float, vy: float, w: float, dt: float) -> Pose:
    """Exact pose after moving with a constant body-frame twist for dt seconds.

    >>> p = integrate_twist(Pose(0.0, 0.0, 0.0), 1.0, 0.0, math.pi / 2, 1.0)
    >>> [round(v, 6) for v in p]
    [0.63662, 0.63662, 1.570796]
    """
    return Pose(*integrate(pose[0], pose[1], pose[2], vx, vy, w, dt))


@njit
def integrate(
    x: float, y: float, theta: float, vx: float, vy: float, w: float, dt: float
) -> tuple[float, float, float]:
    """`integrate_twist` on plain floats, compiled (the step's kernel calls it)."""
    dth = w * dt
    if abs(dth) < 1e-9:
        dx, dy = vx * dt, vy * dt
    else:
        s, c = math.sin(dth), math.cos(dth)
        a, b = s / w, (1.0 - c) / w
        dx, dy = a * vx - b * vy, b * vx + a * vy
    cs, sn = math.cos(theta), math.sin(theta)
    return x + cs * dx - sn * dy, y + sn * dx + cs * dy, wrap_angle(theta + dth)


@njit(fastmath={"contract"})
def ground_twist(m: FloatArray, vx: float, vy: float, w: float) -> tuple[float, float, float]:
    """m @ (vx, vy, w): the true twist for a commanded one, through the wheels' factors.

    Contracted to fused multiply-adds, row by row, as numpy's matrix-vector product (BLAS)
    computes it: the episodes stay what they were when numpy computed this."""
    return (
        m[0, 0] * vx + m[0, 1] * vy + m[0, 2] * w,
        m[1, 0] * vx + m[1, 1] * vy + m[1, 2] * w,
        m[2, 0] * vx + m[2, 1] * vy + m[2, 2] * w,
    )


class Odometry:
    """Wheel odometry state: the reported pose and the current wheel factors."""

    def __init__(self, config: OdometryConfig, robot: RobotConfig) -> None:
        self.config = config
        self._j = wheel_matrix(robot)
        self._j_inv = np.linalg.inv(self._j)
        self.pose = Pose(0.0, 0.0, 0.0)
        self.factors = np.ones(3)
        self._until_redraw = 0.0
        self._exact = config.wheel_noise == 0.0 and config.slip_std == 0.0  # the wheels do what they are told

    def reset(self, rng: np.random.Generator) -> Pose:
        """Start a new episode; returns the starting odometry pose."""
        cfg = self.config
        if cfg.random_start:
            r = COURSE_RANDOM_START_RANGE_M
            x, y = rng.uniform(-r, r, size=2)
            self.pose = Pose(float(x), float(y), float(wrap_angle(rng.uniform(0.0, 2.0 * math.pi))))
        else:
            self.pose = Pose(0.0, 0.0, 0.0)
        self._redraw(rng)
        return self.pose

    def _redraw(self, rng: np.random.Generator) -> None:
        a = self.config.wheel_noise
        self.factors = 1.0 + rng.uniform(-a, a, size=3) if a > 0 else np.ones(3)
        self._until_redraw = self.config.wheel_noise_interval_s
        # body twist -> wheels -> scaled -> body twist, as one matrix
        self._true_from_commanded = self._j_inv @ np.diag(self.factors) @ self._j

    @property
    def exact(self) -> bool:
        """Whether the wheels do what they are told (no wheel noise, no slip)."""
        return self._exact

    @property
    def ground_matrix(self) -> FloatArray:
        """The current true-from-commanded twist matrix of the wheel factors (`ground`'s)."""
        return self._true_from_commanded

    @property
    def redraw_countdown(self) -> float:
        """Seconds until the wheel factors are drawn anew (counted down by `ground`)."""
        return self._until_redraw

    @redraw_countdown.setter
    def redraw_countdown(self, seconds: float) -> None:
        self._until_redraw = seconds

    def ground(self, dt: float, rng: np.random.Generator) -> FloatArray | None:
        """The matrix that turns the next dt seconds' commanded twist into the true one (None:
        the wheels do exactly what they are told); draws the wheel factors when they are due."""
        if self._until_redraw <= 0.0:
            self._redraw(rng)
        self._until_redraw -= dt
        slip = self.config.slip_std
        if slip > 0.0:
            factors = self.factors * (1.0 + slip * rng.standard_normal(3))
            return self._j_inv @ np.diag(factors) @ self._j
        if self._exact:
            return None
        return self._true_from_commanded

    def true_twist(
        self, vx: float, vy: float, w: float, dt: float, rng: np.random.Generator
    ) -> tuple[float, float, float]:
        """The twist the ground gives the robot for a commanded twist over the next dt seconds."""
        m = self.ground(dt, rng)
        return (vx, vy, w) if m is None else ground_twist(m, vx, vy, w)

    def advance(self, vx: float, vy: float, w: float, dt: float) -> Pose:
        """Integrate what the encoders counted: the commanded twist."""
        self.pose = integrate_twist(self.pose, vx, vy, w, dt)
        return self.pose
