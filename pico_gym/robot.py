"""PICO the robot: its footprint, velocity limits and how a command is clipped to them.

Facts from docs/facts/pico-facts.md: a holonomic base with three omni-wheels 0.1 m from the centre,
commanded with a body-frame twist (vx, vy, w); competition limits 0.5 m/s translational (norm) and
1.2 rad/s; outline 0.20 m deep x 0.40 m wide with a 0.05 m notch at the front centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pico_gym.jit import njit
from pico_gym.pymath import hypot
from pico_gym.types import FloatArray
from pico_gym.validate import number

# The PICO outline in the robot frame (x forward, y left), counter-clockwise, metres
# (docs/facts/pico-facts.md, "footprint"). The front notch makes it concave.
PICO_OUTLINE = np.array(
    [
        (0.1, -0.2),
        (0.1, -0.1),
        (0.05, -0.1),
        (0.05, 0.1),
        (0.1, 0.1),
        (0.1, 0.2),
        (-0.1, 0.2),
        (-0.1, -0.2),
    ]
)
PICO_RECTANGLE = np.array([(0.1, -0.2), (0.1, 0.2), (-0.1, 0.2), (-0.1, -0.2)])
# The outline as convex parts (for the physics engine, which needs convex shapes).
PICO_OUTLINE_PARTS = (
    np.array([(0.05, -0.2), (0.05, 0.2), (-0.1, 0.2), (-0.1, -0.2)]),
    np.array([(0.1, -0.2), (0.1, -0.1), (0.05, -0.1), (0.05, -0.2)]),
    np.array([(0.1, 0.1), (0.1, 0.2), (0.05, 0.2), (0.05, 0.1)]),
)
# Competition rules (docs/facts/pico-facts.md): |(vx, vy)| <= 0.5 m/s, |w| <= 1.2 rad/s.
PICO_MAX_SPEED_MPS = 0.5
PICO_MAX_TURN_RATE_RADPS = 1.2
# Three omni-wheels 0.1 m from the centre.
PICO_WHEEL_RADIUS_FROM_CENTRE_M = 0.1


@dataclass(frozen=True)
class RobotConfig:
    """The robot's shape and limits.

    Attributes:
        footprint: "outline" (the real outline with its front notch) or "rectangle".
        max_speed_mps: cap on the norm of the translational velocity [m/s].
        max_turn_rate_radps: cap on |w| [rad/s].
        max_accel_mps2: optional translational acceleration limit [m/s^2]; None means a command
            takes effect at once, as in the course simulator.
        max_angular_accel_radps2: optional angular acceleration limit [rad/s^2]; None = instant.
        wheel_angles_rad: mounting bearings of the three omni-wheels.
        wheel_distance_m: distance of each wheel from the centre.
    """

    footprint: str = "outline"
    max_speed_mps: float = PICO_MAX_SPEED_MPS
    max_turn_rate_radps: float = PICO_MAX_TURN_RATE_RADPS
    max_accel_mps2: float | None = None
    max_angular_accel_radps2: float | None = None
    wheel_angles_rad: tuple[float, float, float] = field(default=(math.pi / 3.0, math.pi, -math.pi / 3.0))
    wheel_distance_m: float = PICO_WHEEL_RADIUS_FROM_CENTRE_M

    def __post_init__(self) -> None:
        if self.footprint not in ("outline", "rectangle"):
            raise ValueError(f"RobotConfig.footprint must be 'outline' or 'rectangle', got {self.footprint!r}")
        number("RobotConfig.max_speed_mps", self.max_speed_mps, 0.0, lo_open=True, unit=" m/s")
        number("RobotConfig.max_turn_rate_radps", self.max_turn_rate_radps, 0.0, lo_open=True, unit=" rad/s")
        for name in ("max_accel_mps2", "max_angular_accel_radps2"):
            if getattr(self, name) is not None:
                number(f"RobotConfig.{name}", getattr(self, name), 0.0, lo_open=True)
        number("RobotConfig.wheel_distance_m", self.wheel_distance_m, 0.0, lo_open=True, unit=" m")
        if not (isinstance(self.wheel_angles_rad, (tuple, list)) and len(self.wheel_angles_rad) == 3):
            raise ValueError(f"RobotConfig.wheel_angles_rad must be 3 angles, got {self.wheel_angles_rad!r}")
        for i, a in enumerate(self.wheel_angles_rad):
            number(f"RobotConfig.wheel_angles_rad[{i}]", a)

    @property
    def outline(self) -> FloatArray:
        """The footprint polygon in the robot frame."""
        return PICO_OUTLINE if self.footprint == "outline" else PICO_RECTANGLE

    @property
    def convex_parts(self) -> tuple[FloatArray, ...]:
        """The footprint as convex polygons (their union is the outline)."""
        return PICO_OUTLINE_PARTS if self.footprint == "outline" else (PICO_RECTANGLE,)

    @property
    def circumradius_m(self) -> float:
        """Radius of the smallest origin-centred disc that holds the footprint in any heading."""
        return float(np.max(np.hypot(self.outline[:, 0], self.outline[:, 1])))

    @property
    def action_low(self) -> FloatArray:
        """Lower bounds of the action (vx, vy, w)."""
        return np.array([-self.max_speed_mps, -self.max_speed_mps, -self.max_turn_rate_radps])

    @property
    def action_high(self) -> FloatArray:
        """Upper bounds of the action (vx, vy, w)."""
        return -self.action_low


ACTION_NAMES = ("vx", "vy", "w")


def checked_twist(action: np.ndarray) -> tuple[float, float, float]:
    """The twist (vx, vy, w) of an action, as floats.

    Raises:
        ValueError: when the action has the wrong size or a component is NaN or infinite; the
            message names the component.
    """
    if type(action) is np.ndarray and action.shape == (3,) and action.dtype.kind == "f":
        vx, vy, w = action.tolist()  # the common case, without a conversion (float32 -> float exactly)
    else:
        a = _numbers(action, "(vx, vy, w)")
        if a.size != 3:
            raise ValueError(f"action must have 3 components (vx, vy, w), got shape {np.shape(action)}")
        vx, vy, w = a.ravel().tolist()
    if not math.isfinite(vx + vy + w):  # a NaN or an infinity in any component (inf - inf is NaN)
        for name, value in zip(ACTION_NAMES, (vx, vy, w), strict=True):
            if not math.isfinite(value):
                raise ValueError(f"action component {name} is {value}; actions must be finite")
    return vx, vy, w


def _numbers(action: object, names: str) -> np.ndarray:
    """An action as a float64 array, or ValueError saying what an action is."""
    if isinstance(action, (dict, str, bytes, set)) or action is None:
        raise ValueError(f"an action is an array of numbers {names}, got {type(action).__name__} {action!r:.60}")
    try:
        return np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"an action is an array of numbers {names}, got {action!r:.60}") from None


@njit
def clip_limits(vx: float, vy: float, w: float, vmax: float, wmax: float) -> tuple[float, float, float]:
    """`clip_twist` of a finite twist, compiled (the step's kernel calls it)."""
    vx = min(vmax, max(-vmax, vx))
    vy = min(vmax, max(-vmax, vy))
    w = min(wmax, max(-wmax, w))
    speed = hypot(vx, vy)
    if speed > vmax:
        scale = vmax / speed
        vx *= scale
        vy *= scale
    return vx, vy, w


def clip_twist(action: np.ndarray, config: RobotConfig) -> tuple[float, float, float]:
    """Clip a commanded twist to the robot's limits.

    Each component is clipped to its box, then (vx, vy) is scaled down so its norm is at most
    max_speed_mps, keeping its direction.

    Raises:
        ValueError: when the action has the wrong size or a component is NaN or infinite; the
            message names the component.

    >>> clip_twist(np.array([0.5, 0.5, 2.0]), RobotConfig())
    (0.35355339059327373, 0.35355339059327373, 1.2)
    """
    vx, vy, w = checked_twist(action)
    return clip_limits(vx, vy, w, config.max_speed_mps, config.max_turn_rate_radps)
