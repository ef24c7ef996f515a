"""A toy ceiling for benchmarks: the least an env with a pymunk robot and an exact LRF can do.

Not registered and not for users. `pico-gym bench-env` steps it next to PicoEscape-v0 in the same
run: one pymunk body in a square room of 20 wall segments, driven by setting its velocity and
stepping the space once per control period, then an exact numba scan of all 1000 beams against
every segment (no broad phase), and an observation of the same shape as PicoEscape-v0's. It has no
bumps, odometry noise, idle or escape rules, reward terms or info: a research-grade env stripped
to its hot path, so "PicoEscape-v0 / toy" tells how much the real env's extra work costs.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pymunk

from pico_gym.jit import njit


@njit
def _scan_all(
    x: float, y: float, theta: float, segments: np.ndarray, cos: np.ndarray, sin: np.ndarray, out: np.ndarray
) -> None:
    c = math.cos(theta)
    s = math.sin(theta)
    for b in range(cos.shape[0]):
        dx = c * cos[b] - s * sin[b]
        dy = s * cos[b] + c * sin[b]
        best = 10.0
        for k in range(segments.shape[0]):
            ax = segments[k, 0] - x
            ay = segments[k, 1] - y
            ex = segments[k, 2] - segments[k, 0]
            ey = segments[k, 3] - segments[k, 1]
            denom = dx * ey - dy * ex
            if denom == 0.0:
                continue
            r = (ax * ey - ay * ex) / denom
            u = (ax * dy - ay * dx) / denom
            if 0.0 < r < best and 0.0 <= u <= 1.0:
                best = r
        out[b] = best


class ToyCeilingEnv(gym.Env):
    """A pymunk disc in a 20-segment room with an exact 1000-beam scan; actions (vx, vy, w)."""

    def __init__(self, n_beams: int = 1000, dt_s: float = 0.05) -> None:
        self.dt_s = dt_s
        angles = np.linspace(-2.0, 2.0, n_beams)
        self.cos, self.sin = np.cos(angles), np.sin(angles)
        # A 6 x 6 m room whose 4 walls are split into 5 segments each (20 segments).
        corners = [(-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)]
        segs = []
        for k in range(4):
            (x1, y1), (x2, y2) = corners[k], corners[(k + 1) % 4]
            for q in range(5):
                t0, t1 = q / 5, (q + 1) / 5
                segs.append([x1 + t0 * (x2 - x1), y1 + t0 * (y2 - y1), x1 + t1 * (x2 - x1), y1 + t1 * (y2 - y1)])
        self.segments = np.array(segs)
        self.space = pymunk.Space()
        for x1, y1, x2, y2 in segs:
            self.space.add(pymunk.Segment(self.space.static_body, (x1, y1), (x2, y2), 0.0))
        self.body = pymunk.Body(10.0, pymunk.moment_for_circle(10.0, 0.0, 0.3))
        self.space.add(self.body, pymunk.Circle(self.body, 0.3))
        self.observation_space = gym.spaces.Dict(
            {
                "lrf": gym.spaces.Box(0.0, 10.0, shape=(n_beams,), dtype=np.float32),
                "odometry": gym.spaces.Box(-np.inf, np.inf, shape=(3,), dtype=np.float64),
            }
        )
        high = np.array([0.5, 0.5, 1.2], dtype=np.float32)
        self.action_space = gym.spaces.Box(-high, high, dtype=np.float32)
        self._ranges = np.empty(n_beams)

    def _obs(self) -> dict[str, np.ndarray]:
        x, y = self.body.position
        _scan_all(x, y, self.body.angle, self.segments, self.cos, self.sin, self._ranges)
        return {"lrf": self._ranges.astype(np.float32), "odometry": np.array([x, y, self.body.angle])}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[dict, dict]:
        super().reset(seed=seed)
        self.body.position = tuple(self.np_random.uniform(-2.0, 2.0, size=2))
        self.body.angle = float(self.np_random.uniform(-math.pi, math.pi))
        self.body.velocity = (0.0, 0.0)
        self.body.angular_velocity = 0.0
        self.steps = 0
        return self._obs(), {}

    def step(self, action: np.ndarray) -> tuple[dict, float, bool, bool, dict]:
        vx, vy, w = (float(v) for v in action)
        c, s = math.cos(self.body.angle), math.sin(self.body.angle)
        self.body.velocity = (c * vx - s * vy, s * vx + c * vy)
        self.body.angular_velocity = w
        self.space.step(self.dt_s)
        self.steps += 1
        return self._obs(), 0.0, False, self.steps >= 6000, {}
