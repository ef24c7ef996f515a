"""The compiled twins of the step's Python arithmetic compute what Python computes, to the bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pico_gym import pymath
from pico_gym.robot import RobotConfig, clip_limits
from pico_gym.sensors.odometry import ground_twist, integrate, wheel_matrix
from pico_gym.world.geometry import wrap_angle


def _bits(x: float) -> bytes:
    return np.float64(x).tobytes()


def test_hypot_is_pythons_to_the_bit() -> None:
    rng = np.random.default_rng(0)
    pairs = rng.uniform(-1.0, 1.0, size=(50_000, 2)) * 10.0 ** rng.integers(-12, 4, size=(50_000, 1))
    pairs = np.vstack([pairs, [[0.0, 0.0], [-0.0, 3.0], [3.0, 4.0], [1e-310, 2e-310], [5e-324, 0.0], [1e300, 1e300]]])
    differ = [(x, y) for x, y in pairs.tolist() if _bits(pymath.hypot(x, y)) != _bits(math.hypot(x, y))]
    assert differ == []  # the C library's hypot differs on about 1 in 200 of these


@pytest.mark.parametrize(
    ("x", "y", "expected"),
    [(math.inf, math.nan, math.inf), (math.nan, -math.inf, math.inf), (math.nan, 1.0, math.nan)],
)
def test_hypot_of_infinities_and_nans_is_pythons(x: float, y: float, expected: float) -> None:
    got = pymath.hypot(x, y)
    assert (math.isnan(got) and math.isnan(expected)) or got == expected == math.hypot(x, y)


def test_remainder_and_wrap_angle_are_pythons_to_the_bit() -> None:
    rng = np.random.default_rng(1)
    angles = np.concatenate([rng.uniform(-50.0, 50.0, 20_000), np.arange(-8, 9) * math.pi, [0.0, -0.0]])
    for a in angles.tolist():
        assert _bits(pymath.remainder(a, pymath.TWO_PI)) == _bits(math.remainder(a, 2.0 * math.pi)), a
        assert _bits(pymath.wrap_angle(a)) == _bits(wrap_angle(a)), a
    assert pymath.remainder(3.0, 2.0) == math.remainder(3.0, 2.0) == -1.0  # half way: to the even multiple
    assert pymath.remainder(5.0, 2.0) == math.remainder(5.0, 2.0) == 1.0


def test_clip_limits_is_the_python_rule() -> None:
    rng = np.random.default_rng(2)
    robot = RobotConfig()
    vmax, wmax = robot.max_speed_mps, robot.max_turn_rate_radps
    for vx, vy, w in rng.uniform(-1.0, 1.0, size=(5_000, 3)).tolist():
        cx, cy, cw = min(vmax, max(-vmax, vx)), min(vmax, max(-vmax, vy)), min(wmax, max(-wmax, w))
        speed = math.hypot(cx, cy)
        if speed > vmax:
            cx, cy = cx * (vmax / speed), cy * (vmax / speed)
        assert clip_limits(vx, vy, w, vmax, wmax) == (cx, cy, cw)


def test_integrate_is_the_python_formula() -> None:
    rng = np.random.default_rng(3)
    for x, y, th, vx, vy, w in rng.uniform(-2.0, 2.0, size=(2_000, 6)).tolist():
        dth = w * 0.1
        s, c = math.sin(dth), math.cos(dth)
        a, b = s / w, (1.0 - c) / w
        dx, dy = a * vx - b * vy, b * vx + a * vy
        cs, sn = math.cos(th), math.sin(th)
        expected = (x + cs * dx - sn * dy, y + sn * dx + cs * dy, wrap_angle(th + dth))
        assert integrate(x, y, th, vx, vy, w, 0.1) == expected


def test_ground_twist_is_the_matrix_product() -> None:
    # Bit for bit where numpy's BLAS contracts to fused multiply-adds (x86-64 with FMA: measured
    # equal on 200,000 draws); within rounding anywhere.
    j = wheel_matrix(RobotConfig())
    rng = np.random.default_rng(4)
    for _ in range(500):
        m = np.linalg.inv(j) @ np.diag(1.0 + rng.uniform(-0.002, 0.002, 3)) @ j
        v = rng.uniform(-0.6, 0.6, 3)
        np.testing.assert_allclose(ground_twist(m, *v.tolist()), m @ v, rtol=1e-15, atol=1e-17)
