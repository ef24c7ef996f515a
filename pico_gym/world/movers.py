"""Moving objects ("walking people"), exactly as the course simulator moves them.

emc_simulator src/moving_object.cpp and src/main.cpp (docs/facts/hospital-facts.md 1.6): a box of `length` x
`width` keeping its initial yaw, travelling straight from `init_pose` to `final_pose` at
`velocity`; it starts (once) when the robot's origin comes within `trigger_radius` of its centre,
pauses while the centre distance is below r_pause = hypot(w/2, l/2) + 0.3 m, stops within 0.1 m of
`final_pose`, or with `repeat` swaps the two poses and goes back (ping-pong). The simulator does not
stop them at walls; a standing robot is never hit (contact needs a centre distance of at most the
half-diagonal plus the robot's circumradius, 0.224 m, which is less than r_pause).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from pico_gym.jit import njit
from pico_gym.types import FloatArray, Segments

# emc_simulator moving_object.cpp: a paused object resumes when the robot is farther than its
# half-diagonal plus this margin; a non-repeating object stops within this distance of its goal.
MOVER_PAUSE_MARGIN_M = 0.3
MOVER_ARRIVE_M = 0.1
MOVER_RECORD_KEYS = ("length", "width", "trigger_radius", "velocity", "init_pose", "final_pose", "repeat")


@dataclass(frozen=True)
class MoverRecord:
    """A course moving-object record (emc_simulator config format), in the map frame.

    Attributes:
        length: extent along the object's own x [m].
        width: extent along its y [m].
        trigger_radius: it starts when the robot comes this close to its centre [m].
        velocity: its speed [m/s].
        init_pose: (x, y, yaw) where it stands at the start.
        final_pose: (x, y, yaw) where it goes (its yaw stays the initial one).
        repeat: ping-pong between the two poses instead of stopping.
    """

    length: float
    width: float
    trigger_radius: float
    velocity: float
    init_pose: tuple[float, float, float]
    final_pose: tuple[float, float, float]
    repeat: bool = False

    def __post_init__(self) -> None:
        for name in ("length", "width", "velocity"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")
        if not (math.isfinite(self.trigger_radius) and self.trigger_radius >= 0):
            raise ValueError(f"trigger_radius must be a number >= 0, got {self.trigger_radius!r}")

    @property
    def pause_radius_m(self) -> float:
        """The robot's centre distance under which the object waits."""
        return math.hypot(0.5 * self.width, 0.5 * self.length) + MOVER_PAUSE_MARGIN_M

    @property
    def half_diagonal_m(self) -> float:
        return math.hypot(0.5 * self.width, 0.5 * self.length)

    def to_dict(self) -> dict[str, Any]:
        return {
            "length": self.length,
            "width": self.width,
            "trigger_radius": self.trigger_radius,
            "velocity": self.velocity,
            "init_pose": list(self.init_pose),
            "final_pose": list(self.final_pose),
            "repeat": self.repeat,
        }


# Bounds of a mover record: a person or a cart (the course's are 0.2-1.0 m, 0.5-0.6 m/s).
MAX_MOVER_SIDE_M = 3.0
MAX_MOVER_SPEED_MPS = 2.0
MAX_TRIGGER_RADIUS_M = 100.0


def mover_problem(m: MoverRecord, static: Segments, bounds: tuple[float, float, float, float]) -> str | None:
    """Why a mover cannot walk on a map (None when it can): it starts or ends outside the map, or
    its way runs through a wall, a cabinet or an obstacle: its centre's path from `init_pose` to
    `final_pose` comes closer to one than half the box's narrow side (the course's own cart ends
    with its box against a wall: touching is allowed, crossing is not)."""
    from pico_gym.world import geometry

    x0, y0, x1, y1 = bounds
    for key, (x, y, _) in (("init_pose", m.init_pose), ("final_pose", m.final_pose)):
        if not (x0 <= x <= x1 and y0 <= y <= y1):
            return f"{key} ({x:.2f}, {y:.2f}) is outside the map ({x0:.2f}..{x1:.2f}, {y0:.2f}..{y1:.2f})"
    (a, b, _), (c, d, _) = m.init_pose, m.final_pose
    need = 0.5 * min(m.length, m.width) - 0.01
    path = np.array([[a, b], [c, d]]) if (a, b) != (c, d) else np.array([[a, b], [a + 1e-9, b]])
    if len(static) and geometry.polygon_clearance(path, static, need + 0.01) < need:
        return f"its way from ({a:.2f}, {b:.2f}) to ({c:.2f}, {d:.2f}) runs through a wall, a cabinet or an obstacle"
    return None


def mover_record(data: Any, where: str) -> MoverRecord:
    """A `MoverRecord` from a course record (dict); ValueError naming `where` and the key."""
    if not isinstance(data, dict):
        raise ValueError(f"{where}: expected an object with keys {', '.join(MOVER_RECORD_KEYS)}, got {data!r}")
    for key in MOVER_RECORD_KEYS:
        if key not in data:
            raise ValueError(f"{where}: missing key '{key}'")
    values = {k: _record_number(data, k, where) for k in ("length", "width", "trigger_radius", "velocity")}
    for k, most in (("length", MAX_MOVER_SIDE_M), ("width", MAX_MOVER_SIDE_M), ("velocity", MAX_MOVER_SPEED_MPS)):
        if not 0 < values[k] <= most:
            raise ValueError(f"{where}.{k}: must be in (0, {most}], got {values[k]}")
    if not 0 <= values["trigger_radius"] <= MAX_TRIGGER_RADIUS_M:
        raise ValueError(
            f"{where}.trigger_radius: must be in [0, {MAX_TRIGGER_RADIUS_M}], got {values['trigger_radius']}"
        )
    if not isinstance(data["repeat"], bool):
        raise ValueError(f"{where}.repeat: expected true or false, got {data['repeat']!r}")
    return MoverRecord(
        init_pose=_record_pose(data, "init_pose", where),
        final_pose=_record_pose(data, "final_pose", where),
        repeat=data["repeat"],
        **values,
    )


def _record_number(data: dict[str, Any], key: str, where: str) -> float:
    v = data[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{where}.{key}: expected a finite number, got {v!r}")
    return float(v)


def _record_pose(data: dict[str, Any], key: str, where: str) -> tuple[float, float, float]:
    v = data[key]
    if not (isinstance(v, list) and len(v) == 3 and all(isinstance(a, (int, float)) for a in v)):
        raise ValueError(f"{where}.{key}: expected [x, y, yaw], got {v!r}")
    if not all(math.isfinite(a) for a in v):
        raise ValueError(f"{where}.{key}: expected finite numbers, got {v!r}")
    return float(v[0]), float(v[1]), float(v[2])


def box_corners(x: float, y: float, yaw: float, length: float, width: float) -> FloatArray:
    """(4, 2) corners of a length x width box centred at (x, y), its length along yaw."""
    return np.array(box_corner_list(x, y, yaw, length, width))


def box_corner_list(x: float, y: float, yaw: float, length: float, width: float) -> list[tuple[float, float]]:
    """`box_corners` as plain floats (for loops over many candidate boxes)."""
    c, s = math.cos(yaw), math.sin(yaw)
    hl, hw = 0.5 * length, 0.5 * width
    return [(x + c * lx - s * ly, y + s * lx + c * ly) for lx, ly in ((hl, -hw), (hl, hw), (-hl, hw), (-hl, -hw))]


# State columns of `Movers.state`.
_X, _Y, _YAW, _GX, _GY, _OX, _OY, _TRIGGERED, _PAUSED, _FINISHED = range(10)
# Parameter columns of `Movers.params`.
_LENGTH, _WIDTH, _TRIGGER, _SPEED, _PAUSE, _REPEAT = range(6)


@njit
def _advance(state: FloatArray, params: FloatArray, robot_xy: FloatArray, h: float, vel: FloatArray) -> None:
    """Run every mover through one sub-step of `h` seconds per row of robot positions."""
    for k in range(robot_xy.shape[0]):
        _advance_one(state, params, robot_xy[k, 0], robot_xy[k, 1], h, vel)


@njit
def _advance_gliding(
    state: FloatArray,
    params: FloatArray,
    x: float,
    y: float,
    theta: float,
    vx: float,
    vy: float,
    w: float,
    n: int,
    h: float,
    vel: FloatArray,
    others: FloatArray,
) -> None:
    """`n` sub-steps while the robot follows a constant body-frame twist from (x, y, theta): its
    position at the start of sub-step k is the exact integral of the twist over k h; other robots
    stand at `others` (k, 2) (none: `_advance_one_near` is `_advance_one`, bit for bit)."""
    c0, s0 = math.cos(theta), math.sin(theta)
    for k in range(n):
        t = k * h
        if abs(w) < 1e-12:
            rx = x + (c0 * vx - s0 * vy) * t
            ry = y + (s0 * vx + c0 * vy) * t
        else:
            a = theta + w * t
            sx = (math.sin(a) - s0) / w
            cx = (c0 - math.cos(a)) / w
            rx = x + vx * sx - vy * cx
            ry = y + vx * cx + vy * sx
        _advance_one_near(state, params, rx, ry, others, h, vel)


@njit
def glide_movers(
    state: FloatArray,
    params: FloatArray,
    x: float,
    y: float,
    theta: float,
    vx: float,
    vy: float,
    w: float,
    n: int,
    h: float,
    vel: FloatArray,
    out: Segments,
    others: FloatArray,
) -> bool:
    """`_advance_gliding`, then the boxes' edges into `out`; True when a mover was moving at the
    end (its velocity is then zeroed: the bodies sleep through a glide)."""
    _advance_gliding(state, params, x, y, theta, vx, vy, w, n, h, vel, others)
    _write_segments(state, params, out)
    moving = False
    for i in range(vel.shape[0]):
        if vel[i, 0] != 0.0 or vel[i, 1] != 0.0:
            moving = True
            vel[i, 0] = 0.0
            vel[i, 1] = 0.0
    return moving


@njit
def _advance_one(state: FloatArray, params: FloatArray, rx: float, ry: float, h: float, vel: FloatArray) -> bool:
    """One sub-step of every mover with the robot at (rx, ry); `vel` gets each one's velocity.
    Returns whether any velocity differs from the one `vel` held."""
    changed = False
    for i in range(state.shape[0]):
        old_x, old_y = vel[i, 0], vel[i, 1]
        _advance_mover(state, params, i, rx, ry, h, vel)
        changed = changed or vel[i, 0] != old_x or vel[i, 1] != old_y
    return changed


@njit
def _advance_one_near(
    state: FloatArray, params: FloatArray, rx: float, ry: float, others: FloatArray, h: float, vel: FloatArray
) -> bool:
    """`_advance_one` with other robots at `others` (k, 2): each mover reacts to the robot nearest it."""
    changed = False
    for i in range(state.shape[0]):
        old_x, old_y = vel[i, 0], vel[i, 1]
        bx, by = rx, ry
        best = math.hypot(rx - state[i, _X], ry - state[i, _Y])
        for k in range(others.shape[0]):
            d = math.hypot(others[k, 0] - state[i, _X], others[k, 1] - state[i, _Y])
            if d < best:
                best, bx, by = d, others[k, 0], others[k, 1]
        _advance_mover(state, params, i, bx, by, h, vel)
        changed = changed or vel[i, 0] != old_x or vel[i, 1] != old_y
    return changed


@njit
def _advance_mover(
    state: FloatArray, params: FloatArray, i: int, rx: float, ry: float, h: float, vel: FloatArray
) -> None:
    vel[i, 0] = 0.0
    vel[i, 1] = 0.0
    if state[i, _FINISHED] != 0.0:
        return
    distance = math.hypot(rx - state[i, _X], ry - state[i, _Y])
    if state[i, _TRIGGERED] == 0.0:
        if distance >= params[i, _TRIGGER]:
            return
        state[i, _TRIGGERED] = 1.0
    if distance < params[i, _PAUSE]:
        state[i, _PAUSED] = 1.0
        return
    state[i, _PAUSED] = 0.0
    dx = state[i, _GX] - state[i, _X]
    dy = state[i, _GY] - state[i, _Y]
    remaining = math.hypot(dx, dy)
    if remaining <= MOVER_ARRIVE_M:
        if params[i, _REPEAT] != 0.0:
            gx, gy = state[i, _GX], state[i, _GY]
            state[i, _GX], state[i, _GY] = state[i, _OX], state[i, _OY]
            state[i, _OX], state[i, _OY] = gx, gy
            dx = state[i, _GX] - state[i, _X]
            dy = state[i, _GY] - state[i, _Y]
            remaining = math.hypot(dx, dy)
        else:
            state[i, _FINISHED] = 1.0
            return
    if remaining <= 0.0:
        return
    speed = min(params[i, _SPEED], remaining / h)
    vel[i, 0] = dx / remaining * speed
    vel[i, 1] = dy / remaining * speed
    state[i, _X] += vel[i, 0] * h
    state[i, _Y] += vel[i, 1] * h


@njit
def _write_segments(state: FloatArray, params: FloatArray, out: Segments) -> None:
    for i in range(state.shape[0]):
        c, s = math.cos(state[i, _YAW]), math.sin(state[i, _YAW])
        hl, hw = 0.5 * params[i, _LENGTH], 0.5 * params[i, _WIDTH]
        x, y = state[i, _X], state[i, _Y]
        for k in range(4):
            lx = hl if k < 2 else -hl
            ly = -hw if k == 0 or k == 3 else hw
            k2 = (k + 1) % 4
            lx2 = hl if k2 < 2 else -hl
            ly2 = -hw if k2 == 0 or k2 == 3 else hw
            out[4 * i + k, 0] = x + c * lx - s * ly
            out[4 * i + k, 1] = y + s * lx + c * ly
            out[4 * i + k, 2] = x + c * lx2 - s * ly2
            out[4 * i + k, 3] = y + s * lx2 + c * ly2


class Movers:
    """The moving objects of an episode and their state (the module docstring's rules).

    The state lives in arrays stepped by one compiled kernel, so many sub-steps of many movers
    cost one call.
    """

    def __init__(self, records: list[MoverRecord] | tuple[MoverRecord, ...]) -> None:
        self.records = tuple(records)
        n = len(self.records)
        self.state = np.zeros((n, 10))
        self.params = np.zeros((n, 6))
        for i, rec in enumerate(self.records):
            x, y, yaw = rec.init_pose
            self.state[i, :7] = (x, y, yaw, rec.final_pose[0], rec.final_pose[1], x, y)
            self.params[i] = (rec.length, rec.width, rec.trigger_radius, rec.velocity, rec.pause_radius_m, rec.repeat)
        self.max_speed_mps = max((r.velocity for r in self.records), default=0.0)
        self.velocity = np.zeros((n, 2))  # each mover's velocity over the last sub-step
        # Other robots in the world (two robots, `pico_gym.multi`): a mover pauses near any robot.
        self.other_robots = np.zeros((0, 2))

    def __len__(self) -> int:
        return len(self.records)

    def advance(self, duration_s: float, robot_x: float, robot_y: float) -> bool:
        """One physics sub-step of `duration_s` with the robot at (robot_x, robot_y); each mover's
        velocity over it is left in `velocity`. Returns whether any velocity changed."""
        if not self.records:
            return False
        if len(self.other_robots):
            return _advance_one_near(
                self.state, self.params, robot_x, robot_y, self.other_robots, duration_s, self.velocity
            )
        return _advance_one(self.state, self.params, robot_x, robot_y, duration_s, self.velocity)

    def advance_along(self, duration_s: float, robot_xy: FloatArray) -> None:
        """Sub-steps of `duration_s`, one per row of robot positions (k, 2)."""
        if self.records:
            xy = np.ascontiguousarray(robot_xy, dtype=np.float64)
            _advance(self.state, self.params, xy, duration_s, self.velocity)

    def glide(
        self, x: float, y: float, theta: float, vx: float, vy: float, w: float, n: int, duration_s: float, out: Segments
    ) -> bool:
        """`n` sub-steps while the robot glides with a constant body-frame twist from (x, y, theta),
        then `write_segments(out)`, in one compiled call; returns whether a
        mover had a velocity, which is then zeroed (see `Physics`: bodies sleep through a glide)."""
        if not self.records:
            return False
        moving = glide_movers(
            self.state, self.params, x, y, theta, vx, vy, w, n, duration_s, self.velocity, out, self.other_robots
        )
        return bool(moving)

    def poses(self) -> FloatArray:
        """(n, 3) true poses (x, y, yaw)."""
        return self.state[:, :3].copy()

    def positions(self) -> FloatArray:
        return self.state[:, :2]

    def write_segments(self, out: Segments) -> None:
        """Write every box's 4 edges into out ((4 n, 4))."""
        if len(self.records):
            _write_segments(self.state, self.params, out)

    def triggered(self, i: int) -> bool:
        return bool(self.state[i, _TRIGGERED])

    def paused(self, i: int) -> bool:
        return bool(self.state[i, _PAUSED])

    def finished(self, i: int) -> bool:
        return bool(self.state[i, _FINISHED])
