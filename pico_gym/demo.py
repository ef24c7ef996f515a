"""Two tiny observation-only policies for demos, smoke tests and benchmarks.

They are not agents (those live in the repository's agents/ package): `random_policy` samples the
action space, `follow_the_gap` steers towards the most open direction of the scan while keeping
away from close points, the reactive fall-back of many course teams. Both see only the observation.
"""

from __future__ import annotations

import math

import numpy as np

from pico_gym.robot import PICO_MAX_SPEED_MPS, PICO_MAX_TURN_RATE_RADPS

# Beams closer than this push the robot away [m]; the footprint reaches 0.22 m from the origin.
REPULSION_RANGE_M = 0.6
# Width of the sliding window used to find the most open direction [beams of 1000 over 4 rad].
GAP_WINDOW_BEAMS = 60


def follow_the_gap(obs: dict[str, np.ndarray], beam_angles: np.ndarray) -> np.ndarray:
    """Steer to the most open direction; back off sideways from close points.

    Args:
        obs: the env's observation (only "lrf" is used).
        beam_angles: bearings of the beams, radians.

    Returns:
        A twist (vx, vy, w).
    """
    ranges = np.asarray(obs["lrf"], dtype=np.float64)
    valid = ranges > 0.02
    r = np.where(valid, ranges, 0.0)
    window = max(1, min(GAP_WINDOW_BEAMS * len(r) // 1000, len(r)))
    openness = np.convolve(r, np.ones(window) / window, mode="same")
    heading = float(beam_angles[int(np.argmax(openness))])
    # Repulsion from close points, in the robot frame.
    close = valid & (r < REPULSION_RANGE_M)
    push = np.zeros(2)
    if close.any():
        weight = (REPULSION_RANGE_M - r[close]) / REPULSION_RANGE_M
        push = -np.array([np.sum(weight * np.cos(beam_angles[close])), np.sum(weight * np.sin(beam_angles[close]))])
        push /= max(1.0, float(np.count_nonzero(close)) / 20.0)
    front = float(np.min(np.where(valid & (np.abs(beam_angles) < 0.6), r, np.inf)))
    speed = PICO_MAX_SPEED_MPS * min(1.0, max(0.0, (front - 0.3) / 0.7)) * max(0.0, math.cos(heading))
    vx = speed + 0.3 * push[0]
    vy = 0.3 * push[1]
    w = float(np.clip(1.5 * heading, -PICO_MAX_TURN_RATE_RADPS, PICO_MAX_TURN_RATE_RADPS))
    return np.array([vx, vy, w], dtype=np.float32)
