"""Odometry: exact without noise, drifts as the wheel model says, keeps counting against a wall."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import pico_gym  # noqa: F401
from pico_gym.robot import RobotConfig
from pico_gym.sensors.odometry import Odometry, OdometryConfig, integrate_twist, wheel_matrix
from pico_gym.types import Pose


def open_room(write_json, half: float = 20.0) -> str:
    h = half
    return str(
        write_json(
            {
                "points": [[-h, -h], [h, -h], [h, h], [-h, h], [h - 1, -1], [h - 1, 1]],
                "walls": [[0, 1], [1, 2], [2, 3], [3, 0]],
                "finish": [[h - 1, -1], [h - 1, 1]],
                "start_pose": {"x": 0.0, "y": 0.0, "theta": 0.0},
            }
        )
    )


def test_integrate_twist_straight_and_arc() -> None:
    assert integrate_twist(Pose(0, 0, 0), 0.5, 0.0, 0.0, 2.0) == pytest.approx((1.0, 0.0, 0.0))
    # A full circle of radius 1 returns to the start.
    p = Pose(0.0, 0.0, 0.0)
    for _ in range(100):
        p = integrate_twist(p, 1.0, 0.0, 1.0, 2 * math.pi / 100)
    assert p == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)


def test_wheel_matrix_round_trip() -> None:
    j = wheel_matrix(RobotConfig())
    twist = np.array([0.3, -0.2, 0.9])
    assert np.linalg.solve(j, j @ twist) == pytest.approx(twist)


def test_noise_free_odometry_equals_the_truth(write_json) -> None:
    env = gym.make("PicoEscape-v0", map_path=open_room(write_json), wheel_noise=0.0, collision="continue")
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(200):
        _, _, _, _, info = env.step(rng.uniform(-1, 1, 3) * [0.3, 0.3, 1.0])
    assert np.abs(info["odom_error"]).max() < 1e-9


def test_noisy_odometry_error_grows_as_the_wheel_model_says(write_json) -> None:
    """With the wheel factors held, the truth follows the factor-scaled twist, odometry the commanded one."""
    env = gym.make("PicoEscape-v0", map_path=open_room(write_json), collision="continue", wheel_noise_interval_s=1e6)
    command = (0.5, 0.0, 0.0)
    errors = []
    for seed in range(3):
        env.reset(seed=seed)
        odometry = env.unwrapped.odometry
        true_twist = odometry.true_twist(*command, 0.0, np.random.default_rng(0))
        for steps in (100, 200):
            for _ in range(100):
                _, _, _, _, info = env.step(np.array(command))
            expected = integrate_twist(Pose(0.0, 0.0, 0.0), *true_twist, steps * 0.1)
            assert info["pose"] == pytest.approx(expected, abs=1e-9)  # the model, exactly
            errors.append(math.hypot(*info["odom_error"][:2]))
        # A heading-rate error makes the position error grow faster than the distance.
        assert errors[-1] > 2.5 * errors[-2] > 0.0
    # U(-0.002, 0.002) per wheel: a few centimetres over 10 m, not metres.
    assert 1e-4 < max(errors) < 0.5


def test_slip_makes_odometry_worse(write_json) -> None:
    def drift(**kw: float) -> float:
        env = gym.make("PicoEscape-v0", map_path=open_room(write_json), collision="continue", **kw)
        env.reset(seed=1)
        for k in range(300):
            _, _, _, _, info = env.step(np.array([0.4, 0.1, 0.3 if k % 50 < 25 else -0.3]))
        return float(np.abs(info["odom_error"]).sum())

    assert drift(slip_std=0.05) > 1.5 * drift()


def test_pushing_against_a_wall_makes_odometry_drift(write_json) -> None:
    path = write_json(
        {
            "points": [[-1, -3], [1, -3], [1, 3], [-1, 3], [0.5, 2.0], [0.9, 2.0]],
            "walls": [[0, 1], [1, 2], [2, 3], [3, 0]],
            "finish": [[0.5, 2.0], [0.9, 2.0]],
            "start_pose": {"x": 0.0, "y": 0.0, "theta": 0.0},
        }
    )
    env = gym.make("PicoEscape-v0", map_path=str(path), collision="continue", wheel_noise=0.0)
    env.reset(seed=0)
    for _ in range(50):  # 5 s at 0.5 m/s towards a wall 0.9 m ahead
        obs, _, _, _, info = env.step(np.array([0.5, 0.0, 0.0]))
    assert info["pose"][0] < 0.9  # the wall stopped the robot
    assert obs["odom"][0] == pytest.approx(2.5, abs=1e-5)  # the wheels counted 2.5 m
    assert info["odom_error"][0] > 1.5


def test_random_start_odometry_frame() -> None:
    odo = Odometry(OdometryConfig(random_start=True), RobotConfig())
    starts = [odo.reset(np.random.default_rng(s)) for s in range(50)]
    xs = np.array([p.x for p in starts])
    assert np.all(np.abs(xs) <= 2.0) and xs.std() > 0.5
