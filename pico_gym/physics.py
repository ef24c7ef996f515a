"""The physical world: a pymunk Space built from a map's segments and the robot's footprint.

Walls are static zero-thickness segments. The robot is a dynamic body driven through a kinematic
control body by a pivot joint (translation) and a gear joint (rotation), both with zero bias and a
bounded force, as in pymunk's top-down "tank" example: the joints pull the robot to the commanded
velocity at once in free space, while contacts with walls, being hard constraints, win. Setting
the body's velocity directly instead would let it tunnel through walls.

A bump is the start of a contact between the robot and anything solid: the collision handler only
counts (by kind: wall, cabinet, door, box, mover); what a bump is worth is the task's business. A
new Space is built for every episode, from the episode's `Scene`: static segments tagged by kind,
and each moving object as a kinematic box moved every sub-step by the scene's mover rules.

Free-space fast path: when the caller knows the footprint is farther from everything than any of
its points can move in the control period (`clearance_m` in `step`), no contact can begin, so the
pose is advanced by exact integration of the twist and written into the pymunk body, skipping the
sub-steps. Near walls every sub-step runs in pymunk.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymunk

from pico_gym.jit import njit
from pico_gym.pymath import hypot
from pico_gym.robot import RobotConfig
from pico_gym.sensors.odometry import integrate
from pico_gym.types import Pose, Segments
from pico_gym.validate import flag, number
from pico_gym.world.geometry import footprint_clearance
from pico_gym.world.scene import KINDS, MOVER, ROBOT_KIND, WALL, Scene

# The free-space shortcut and contact handling assume sub-steps of at most this [s].
MAX_SUBSTEP_S = 0.05

_ROBOT = 1
_TOUCH_M = 1e-6  # the true footprint closer than this to static geometry counts as touching it
_CAP_TOLERANCE = 1e-9
_KIND_BASE = 2  # collision type of kind k is _KIND_BASE + k


@njit
def sweep(vx: float, vy: float, w: float, duration_s: float, circumradius_m: float) -> float:
    """An upper bound on how far any point of a footprint of that circumradius moves with this
    twist [m] (`Physics.sweep_m`, compiled for the step's kernel)."""
    return (hypot(vx, vy) + abs(w) * circumradius_m) * duration_s


@njit
def glide(
    x: float, y: float, angle: float, vx: float, vy: float, w: float, duration_s: float
) -> tuple[float, float, float, float, float]:
    """A glide (no contact): the body's position and unwrapped angle after `duration_s` with the
    body-frame twist, and its map-frame velocity then, as the sub-steps would leave them."""
    x, y, _ = integrate(x, y, angle, vx, vy, w, duration_s)
    angle = angle + w * duration_s  # keep the body's unwrapped angle continuous
    c, s = math.cos(angle), math.sin(angle)
    return x, y, angle, c * vx - s * vy, s * vx + c * vy


@njit
def _place_outline(x: float, y: float, theta: float, outline: np.ndarray, out: Segments, first: int) -> None:
    """The edges of `outline` (k, 2; body frame) placed at (x, y, theta), into rows
    first .. first + k of `out` (each edge from one vertex to the next, closing the polygon)."""
    c, s = math.cos(theta), math.sin(theta)
    k = outline.shape[0]
    for i in range(k):
        j = (i + 1) % k
        out[first + i, 0] = x + c * outline[i, 0] - s * outline[i, 1]
        out[first + i, 1] = y + s * outline[i, 0] + c * outline[i, 1]
        out[first + i, 2] = x + c * outline[j, 0] - s * outline[j, 1]
        out[first + i, 3] = y + s * outline[j, 0] + c * outline[j, 1]


@njit
def _segments_near(segments: Segments, x: float, y: float, reach: float, out: Segments) -> int:
    """Copy the segments whose bounding box comes within `reach` of (x, y) into out[:n]; returns n."""
    n = 0
    for k in range(segments.shape[0]):
        x1, y1, x2, y2 = segments[k, 0], segments[k, 1], segments[k, 2], segments[k, 3]
        if min(x1, x2) - reach <= x <= max(x1, x2) + reach and min(y1, y2) - reach <= y <= max(y1, y2) + reach:
            out[n, 0], out[n, 1], out[n, 2], out[n, 3] = x1, y1, x2, y2
            n += 1
    return n


@dataclass(frozen=True)
class PhysicsConfig:
    """Physics engine settings.

    Attributes:
        substep_s: fixed physics time step [s]; the control period is split into such steps.
        iterations: pymunk solver iterations per step.
        contact_skin_m: the collision shape is the footprint grown by this margin [m]. pymunk
            resolves a contact only after it appears, so shapes overlap by up to about the
            distance a point of the robot moves in one sub-step (7.4 mm measured at 0.01 s);
            the skin absorbs that. A bump is thus the footprint coming within this distance of
            something. What is guaranteed does not rest on the skin alone: see `Physics`.
        bump_debounce_s: a contact that starts within this time after the last one ended is
            the same bump (the solver lets a pushing robot separate and touch again).
        collision_slop_m: overlap pymunk allows before it pushes shapes apart [m].
        robot_mass_kg: mass of the robot [kg].
        drive_force_n: force limit of the translational drive [N].
        drive_torque_nm: torque limit of the rotational drive [N m].
        free_space_shortcut: advance the robot by exact integration when no contact is possible
            (see the module docstring); False sub-steps pymunk every step.
    """

    substep_s: float = 0.01
    iterations: int = 10
    contact_skin_m: float = 0.01
    bump_debounce_s: float = 0.1
    collision_slop_m: float = 0.0005
    robot_mass_kg: float = 30.0
    drive_force_n: float = 1000.0
    drive_torque_nm: float = 100.0
    free_space_shortcut: bool = True

    def __post_init__(self) -> None:
        number("PhysicsConfig.substep_s", self.substep_s, 0.0, MAX_SUBSTEP_S, lo_open=True, unit=" s")
        number("PhysicsConfig.iterations", self.iterations, 1, 1000, integer=True)
        number("PhysicsConfig.contact_skin_m", self.contact_skin_m, 0.0, 0.05, lo_open=True, unit=" m")
        number("PhysicsConfig.bump_debounce_s", self.bump_debounce_s, 0.0, 10.0, unit=" s")
        number("PhysicsConfig.collision_slop_m", self.collision_slop_m, 0.0, 0.01, unit=" m")
        number("PhysicsConfig.robot_mass_kg", self.robot_mass_kg, 0.1, 1000.0, unit=" kg")
        number("PhysicsConfig.drive_force_n", self.drive_force_n, 1.0, 10_000.0, unit=" N")
        number("PhysicsConfig.drive_torque_nm", self.drive_torque_nm, 0.1, 1000.0, unit=" N m")
        flag("PhysicsConfig.free_space_shortcut", self.free_space_shortcut)

    def check_solid(self, max_speed_mps: float, max_turn_rate_radps: float, circumradius_m: float) -> None:
        """Refuse settings under which contacts could leak: within one sub-step no point of the
        robot may move farther than the contact skin absorbs (see `contact_skin_m`).

        Raises:
            ValueError: naming the limit.
        """
        travel = (max_speed_mps + max_turn_rate_radps * circumradius_m) * self.substep_s
        if travel > self.contact_skin_m + 1e-12:
            limit = self.contact_skin_m / self.substep_s - max_turn_rate_radps * circumradius_m
            raise ValueError(
                f"walls are kept solid only while a point of the robot moves at most contact_skin_m = "
                f"{self.contact_skin_m} m per sub-step of {self.substep_s} s; at max_speed_mps = {max_speed_mps} "
                f"and max_turn_rate_radps = {max_turn_rate_radps} it moves {travel:.4f} m. Lower the speed "
                f"(at most {limit:.3f} m/s here), or the sub-step, or raise the skin"
            )


class StaticShapePool:
    """pymunk segments kept from one episode's physics for the next one's.

    Making a pymunk shape costs more than all of chipmunk's own work on it (pymunk's attribute
    checks): on a fixed map most of an episode's static segments are the last episode's, so an
    env hands its physics' shapes back at reset (`Physics.release`) and the next physics takes
    the equal ones (same end points and kind, in the same order, so chipmunk numbers them as it
    would new ones). Shapes not taken again are dropped at the next `give`: the pool never holds
    more than one episode's shapes.
    """

    def __init__(self) -> None:
        self.body = pymunk.Body(body_type=pymunk.Body.STATIC)
        self._free: dict[tuple[float, float, float, float, int], list[pymunk.Segment]] = {}

    def take(self, x1: float, y1: float, x2: float, y2: float, kind: int) -> pymunk.Segment | None:
        shapes = self._free.get((x1, y1, x2, y2, kind))
        return shapes.pop() if shapes else None

    def give(self, shapes: list[pymunk.Segment], keys: list[tuple[float, float, float, float, int]]) -> None:
        """Keep `shapes` (made for the segments and kinds `keys`) for the next `take`s."""
        free: dict[tuple[float, float, float, float, int], list[pymunk.Segment]] = {}
        for shape, key in zip(reversed(shapes), reversed(keys), strict=True):  # take() pops: the first one first
            free.setdefault(key, []).append(shape)
        self._free = free


class Physics:
    """One episode's pymunk world with the robot in it.

    Guaranteed at every accepted setting (`PhysicsConfig.check_solid` refuses the rest): the
    robot's true footprint never touches static geometry (walls, cabinets, closed doors, boxes)
    or a mover (a person or cart, walking or paused) after any sub-step, and no contact drives it
    faster than `max_speed_mps` or turns it faster than `max_turn_rate_radps`. The skin keeps
    pymunk's contacts away from the true footprint; a sub-step after which the footprint would
    still touch something is undone (counted in `held`); a mover that would walk into the robot
    waits instead (counted in `movers_held`), as the course simulator's people pause.

    Args:
        segments: (N, 4) static solid geometry, map frame.
        robot: the robot's shape and limits.
        config: engine settings.
        pose: the robot's start pose.
        kinds: (N,) kind code of each segment (`pico_gym.world.scene.KINDS`); default all walls.
        scene: the episode's scene, whose movers become kinematic boxes moved every sub-step.
    """

    def __init__(
        self,
        segments: Segments,
        robot: RobotConfig,
        config: PhysicsConfig,
        pose: Pose,
        kinds: np.ndarray | None = None,
        scene: Scene | None = None,
        pool: StaticShapePool | None = None,
    ) -> None:
        self.config = config
        self._pool = pool
        self.robot = robot
        self.scene = scene
        self._circumradius_m = robot.circumradius_m  # a property that walks the outline: once
        self._outline = np.ascontiguousarray(robot.outline, dtype=np.float64)
        # The caps a contact may not push the robot past (a hair above them: the drive itself
        # reaches the commanded velocity only up to rounding).
        self._speed_cap = robot.max_speed_mps * (1.0 + _CAP_TOLERANCE)
        self._turn_cap = robot.max_turn_rate_radps * (1.0 + _CAP_TOLERANCE)
        self.held = 0  # sub-steps undone because the true footprint would have touched something
        self.movers_held = 0  # mover sub-steps undone because a mover would have touched the robot
        # The free-space shortcut applies at all (then per step: no contact and enough room).
        self._may_glide = (
            config.free_space_shortcut and robot.max_accel_mps2 is None and robot.max_angular_accel_radps2 is None
        )
        self._glide_margin = 2.0 * config.contact_skin_m
        space = pymunk.Space()
        space.iterations = config.iterations
        space.collision_slop = config.collision_slop_m
        self.space = space
        self._static_shapes: list[pymunk.Segment] = []
        self._static_keys: list[tuple[float, float, float, float, int]] = []
        if pool is not None:
            if pool.body.space is not None:  # a physics that failed to build, or was never released
                pool.body.space.remove(pool.body)
            space.add(pool.body)
        self._segments = np.zeros((0, 4))
        self.add_static(segments, kinds)
        self._mover_bodies: list[pymunk.Body] = []
        self._bodies_stale = False  # the movers moved (gliding) since the bodies were placed
        self._stop_bodies = False  # and walked during a glide: their bodies are to be stopped then
        self._pending: tuple | None = None  # the robot's state after glides, not yet in pymunk
        movers = scene.movers if scene is not None else None
        for i, rec in enumerate(movers.records if movers is not None else ()):
            body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            x, y, yaw = movers.state[i, :3]  # type: ignore[union-attr]  # (records only when movers)
            body.position = (float(x), float(y))
            body.angle = float(yaw)
            shape = pymunk.Poly.create_box(body, (rec.length, rec.width))
            shape.friction = 0.0
            shape.collision_type = _KIND_BASE + MOVER
            space.add(body, shape)
            self._mover_bodies.append(body)
        n_movers = len(self._mover_bodies)
        self._mover_edges = np.zeros((4 * n_movers, 4))  # the movers' edges after a sub-step
        self._mover_before = np.zeros((n_movers, 10))  # their state before it (to undo it)

        parts = [[tuple(v) for v in part] for part in robot.convex_parts]
        skin = config.contact_skin_m
        areas = [pymunk.area_for_poly(part, skin) for part in parts]
        moment = sum(
            pymunk.moment_for_poly(config.robot_mass_kg * area / sum(areas), part, radius=skin)
            for area, part in zip(areas, parts, strict=True)
        )
        body = pymunk.Body(config.robot_mass_kg, moment)
        body.position = (pose.x, pose.y)
        body.angle = pose.theta
        space.add(body)
        for part in parts:
            shape = pymunk.Poly(body, part, radius=skin)
            shape.friction = 0.0
            shape.collision_type = _ROBOT
            space.add(shape)

        control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        control.position = body.position
        control.angle = body.angle
        pivot = pymunk.PivotJoint(control, body, (0.0, 0.0), (0.0, 0.0))
        pivot.max_bias = 0.0
        pivot.max_force = config.drive_force_n
        gear = pymunk.GearJoint(control, body, 0.0, 1.0)
        gear.max_bias = 0.0
        gear.max_force = config.drive_torque_nm
        space.add(control, pivot, gear)
        for k in range(len(KINDS)):
            space.on_collision(_ROBOT, _KIND_BASE + k, begin=self._begin, separate=self._separate, data=k)

        self.body = body
        self.control = control
        self.contacts = 0
        self.bumps = 0
        self.bumps_by_kind = [0] * len(KINDS)
        self._other_bodies: list[pymunk.Body] = []  # other robots in the world (`add_other_robots`)
        self._other_edges = np.zeros((0, 4))
        self._other_poses: list[Pose] | None = None  # placed, not yet written into pymunk
        self.drives_movers = True
        self.bump_log: list[str] = []  # the kind of every bump, in order
        self.time_s = 0.0
        self._contact_ended_s = -math.inf
        self._command = (0.0, 0.0, 0.0)

    def add_static(self, segments: Segments, kinds: np.ndarray | None = None) -> None:
        """Add static geometry (e.g. an object a task places mid-episode); contacts with what is
        already there are left alone.

        Args:
            segments: (N, 4) static solid geometry to add, map frame.
            kinds: (N,) kind code of each segment; default all walls.
        """
        segments = np.ascontiguousarray(segments, dtype=np.float64).reshape(-1, 4)
        self._segments = np.vstack([self._segments, segments]) if len(self._segments) else segments
        self._near = np.empty_like(self._segments)  # the segments a contact step may reach
        self._near_n = 0
        codes = np.full(len(segments), WALL, dtype=np.int8) if kinds is None else kinds
        pool = self._pool
        shapes = []
        keys = [
            (x1, y1, x2, y2, kind) for (x1, y1, x2, y2), kind in zip(segments.tolist(), codes.tolist(), strict=True)
        ]
        for x1, y1, x2, y2, kind in keys:
            wall = pool.take(x1, y1, x2, y2, kind) if pool is not None else None
            if wall is None:
                body = pool.body if pool is not None else self.space.static_body
                wall = pymunk.Segment(body, (x1, y1), (x2, y2), 0.0)  # friction: pymunk's 0
                wall.collision_type = _KIND_BASE + int(kind)
            shapes.append(wall)
        if shapes:
            self.space.add(*shapes)
            self._static_shapes += shapes
            self._static_keys += keys

    def release(self) -> None:
        """Hand the static shapes back to the pool (for the next episode's physics); this physics
        must not step again."""
        if self._pool is None:
            return
        if self._static_shapes:
            self.space.remove(*self._static_shapes)
        if self._pool.body.space is self.space:
            self.space.remove(self._pool.body)
        self._pool.give(self._static_shapes, self._static_keys)
        self._static_shapes, self._static_keys = [], []

    def add_other_robots(self, n: int) -> None:
        """Put `n` other robots into this world as kinematic bodies of the same footprint (placed
        by `place_other_robots` before each step): solid to this robot, counted as bumps of kind
        "robot" (`ROBOT_KIND`), never moved by it."""
        for _ in range(n):
            body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            for part in self.robot.convex_parts:
                shape = pymunk.Poly(body, [tuple(v) for v in part])
                shape.friction = 0.0
                shape.collision_type = _KIND_BASE + ROBOT_KIND
                if body.space is None:
                    self.space.add(body, shape)
                else:
                    self.space.add(shape)
            self._other_bodies.append(body)
        self._other_edges = np.zeros((len(self._other_bodies) * len(self._outline), 4))
        if n and len(self.bumps_by_kind) == len(KINDS):
            self.space.on_collision(
                _ROBOT, _KIND_BASE + ROBOT_KIND, begin=self._begin, separate=self._separate, data=ROBOT_KIND
            )
            self.bumps_by_kind.append(0)

    def place_other_robots(self, poses: list[Pose]) -> None:
        """Where the other robots stand for the next step (they do not move during it). Their
        bodies are written into pymunk only when pymunk steps (a glide needs their edges only)."""
        if len(poses) != len(self._other_bodies):
            raise ValueError(f"{len(self._other_bodies)} other robot(s) in this world, got {len(poses)} poses")
        k = len(self._outline)
        for i, pose in enumerate(poses):
            _place_outline(pose.x, pose.y, pose.theta, self._outline, self._other_edges, i * k)
        self._other_poses = poses

    def _write_other_bodies(self) -> None:
        """Stand the other robots' bodies where they were placed (before pymunk steps)."""
        if self._other_poses is None:
            return
        for body, pose in zip(self._other_bodies, self._other_poses, strict=True):
            body.position = (pose.x, pose.y)
            body.angle = pose.theta
            body.velocity = (0.0, 0.0)
            body.angular_velocity = 0.0
        self._other_poses = None

    @property
    def other_edges(self) -> Segments:
        """The other robots' footprints' edges as placed (`place_other_robots`), map frame."""
        return self._other_edges

    @classmethod
    def from_scene(
        cls, scene: Scene, robot: RobotConfig, config: PhysicsConfig, pose: Pose, pool: StaticShapePool | None = None
    ) -> Physics:
        """The physics of an episode's scene (static geometry by kind, movers as kinematic boxes)."""
        return cls(scene.static_solid, robot, config, pose, scene.static_kinds, scene, pool)

    def _begin(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        if self.contacts == 0 and self.time_s - self._contact_ended_s >= self.config.bump_debounce_s:
            self.bumps += 1
            kind = int(data) if isinstance(data, int) else WALL
            self.bumps_by_kind[kind] += 1
            self.bump_log.append((*KINDS, "robot")[kind])
        self.contacts += 1

    def _separate(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        self.contacts = max(0, self.contacts - 1)
        if self.contacts == 0:
            self._contact_ended_s = self.time_s

    @property
    def pose(self) -> Pose:
        """The robot's true pose in the map frame."""
        x, y, angle = self._xya()
        return Pose(float(x), float(y), float(math.remainder(angle, 2.0 * math.pi)))

    @property
    def in_contact(self) -> bool:
        """True while the robot touches something."""
        return self.contacts > 0

    def sweep_m(self, vx: float, vy: float, w: float, duration_s: float) -> float:
        """An upper bound on how far any point of the footprint moves with this twist [m]."""
        return sweep(vx, vy, w, duration_s, self._circumradius_m)

    def step(self, vx: float, vy: float, w: float, duration_s: float, clearance_m: float = 0.0) -> None:
        """Drive with a body-frame twist for `duration_s` (a whole number of sub-steps).

        Args:
            vx: the twist the ground gives the robot (body frame), forward [m/s] ...
            vy: ... to the left [m/s] ...
            w: ... and turning counter-clockwise [rad/s].
            duration_s: how long.
            clearance_m: the footprint's current distance to the nearest solid geometry; when it
                exceeds the sweep plus the contact skin (and no acceleration limit is set), the
                free-space fast path is taken.
        """
        h = self.config.substep_s
        n = max(1, round(duration_s / h))
        robot = self.robot
        free = (
            self._may_glide
            and self.contacts == 0
            and clearance_m > self.sweep_m(vx, vy, w, duration_s) + self._glide_margin
        )
        if free:
            if self._mover_bodies:
                self._advance_movers_gliding(vx, vy, w, n, h)
            self._glide(vx, vy, w, n * h)
            return
        self._flush()
        self._write_other_bodies()
        if self._mover_bodies and (self._bodies_stale or not self.drives_movers):
            self._place_bodies()  # where the movers went while the robot glided (or another robot's step moved them)
        body = self.body
        # The static segments the footprint can reach in this step (the caps bound its motion).
        x, y = body.position
        reach = self._circumradius_m + (self._speed_cap + self._turn_cap * self._circumradius_m) * n * h + 0.05
        self._near_n = _segments_near(self._segments, x, y, reach, self._near)
        for _ in range(n):
            cvx, cvy, cw = self._ramp(vx, vy, w, h, robot)
            x0, y0 = body.position
            angle = body.angle
            c, s = math.cos(angle), math.sin(angle)
            self.control.velocity = (c * cvx - s * cvy, s * cvx + c * cvy)
            self.control.angular_velocity = cw
            drive = self._mover_bodies and self.drives_movers
            if drive:
                self._mover_before[:] = self._scene().movers.state
                self._move_movers(h)
            self.space.step(h)
            self.time_s += h
            self._hold(x0, y0, angle)
            if self._mover_bodies:
                self._hold_movers(x0, y0, angle)
            if self._other_bodies:
                self._hold_others(x0, y0, angle)
        if self._mover_bodies and self.drives_movers:
            self._place_bodies()
            self._scene().update_movers()

    def _hold_others(self, x0: float, y0: float, angle0: float) -> None:
        """Other robots are solid: a sub-step that would make the footprint touch one is undone."""
        body = self.body
        x, y = body.position
        if footprint_clearance(x, y, body.angle, self._outline, self._other_edges, _TOUCH_M) <= 0.0:
            body.position = (x0, y0)
            body.angle = angle0
            body.velocity = (0.0, 0.0)
            body.angular_velocity = 0.0
            self.held += 1

    def _hold(self, x0: float, y0: float, angle0: float) -> None:
        """Keep the guarantees of a sub-step (see `Physics`) after pymunk has taken it.

        A contact may not move the robot past its caps: the sub-step's rotation and translation
        are clipped to what `max_turn_rate_radps` and `max_speed_mps` allow in one sub-step (the
        solver's penetration correction moves bodies besides their velocities), and so are the
        body's velocities that pymunk integrates the next sub-step from. And the true footprint
        never touches static geometry: a sub-step after which it would is undone (the body back
        where it was, at rest)."""
        body = self.body
        h = self.config.substep_s
        x, y = body.position
        angle = body.angle
        turn_cap, speed_cap = self._turn_cap, self._speed_cap
        da = angle - angle0
        if abs(da) > turn_cap * h:
            angle = angle0 + math.copysign(turn_cap * h, da)
            body.angle = angle
        dx, dy = x - x0, y - y0
        d = math.hypot(dx, dy)
        if d > speed_cap * h:
            x, y = x0 + dx * speed_cap * h / d, y0 + dy * speed_cap * h / d
            body.position = (x, y)
        w = body.angular_velocity
        if abs(w) > turn_cap:
            body.angular_velocity = math.copysign(turn_cap, w)
        vx, vy = body.velocity
        speed = math.hypot(vx, vy)
        if speed > speed_cap:
            body.velocity = (vx * speed_cap / speed, vy * speed_cap / speed)
        near = self._near[: self._near_n]
        if footprint_clearance(x, y, angle, self._outline, near, _TOUCH_M) <= 0.0:
            body.position = (x0, y0)
            body.angle = angle0
            body.velocity = (0.0, 0.0)
            body.angular_velocity = 0.0
            self.held += 1

    def _hold_movers(self, x0: float, y0: float, angle0: float) -> None:
        """Movers are as solid as walls: after a sub-step the true footprint is clear of every
        mover. A robot that touched one is held where it was (its sub-step undone, as against a
        wall); a mover that walked into the robot waits (its sub-step undone, as the course's
        people pause near the robot). Contacts still count as bumps of kind mover."""
        movers = self._scene().movers
        edges = self._mover_edges
        movers.write_segments(edges)
        body = self.body
        x, y = body.position
        angle = body.angle
        if footprint_clearance(x, y, angle, self._outline, edges, _TOUCH_M) > 0.0:
            return
        if (x, y, angle) != (x0, y0, angle0):
            body.position = (x0, y0)
            body.angle = angle0
            body.velocity = (0.0, 0.0)
            body.angular_velocity = 0.0
            self.held += 1
            if footprint_clearance(x0, y0, angle0, self._outline, edges, _TOUCH_M) > 0.0:
                return
        if not self.drives_movers:
            return  # (they moved in another robot's step, which held them)
        for i, mover_body in enumerate(self._mover_bodies):
            one = edges[4 * i : 4 * i + 4]
            if footprint_clearance(x0, y0, angle0, self._outline, one, _TOUCH_M) <= 0.0:
                movers.state[i] = self._mover_before[i]
                movers.velocity[i] = 0.0
                mover_body.position = (float(movers.state[i, 0]), float(movers.state[i, 1]))
                mover_body.velocity = (0.0, 0.0)
                self.movers_held += 1

    def _scene(self) -> Scene:
        """The scene (movers exist only with one)."""
        assert self.scene is not None
        return self.scene

    def _move_movers(self, h: float) -> None:
        """Advance the scene's movers by one sub-step and give their bodies the matching velocity.

        pymunk moves a kinematic body by its velocity, so a body is touched only when its mover's
        velocity changes (most of the time a mover waits, or walks straight at a constant speed)."""
        movers = self._scene().movers
        x, y = self.body.position
        if movers.advance(h, x, y):
            for body, (vx, vy) in zip(self._mover_bodies, movers.velocity.tolist(), strict=True):
                body.velocity = (vx, vy)

    def _place_bodies(self) -> None:
        """Put the kinematic bodies exactly where the scene's movers are (no drift)."""
        for body, (x, y) in zip(self._mover_bodies, self._scene().movers.positions().tolist(), strict=True):
            body.position = (x, y)
            if self._stop_bodies:
                body.velocity = (0.0, 0.0)
        self._bodies_stale = self._stop_bodies = False

    def _advance_movers_gliding(self, vx: float, vy: float, w: float, n: int, h: float) -> None:
        """The movers' sub-steps while the robot glides (no contact possible this step)."""
        x, y, angle = self._xya()
        scene = self._scene()
        # The bodies sleep through a glide (no contact is possible): they are stopped and put where
        # their movers are only when pymunk steps again (`_place_bodies`).
        if scene.movers.glide(x, y, angle, vx, vy, w, n, h, scene.mover_segments):
            self._stop_bodies = True
        self._bodies_stale = True

    def _glide(self, vx: float, vy: float, w: float, duration_s: float) -> None:
        """Move without contacts: exact integration, leaving the body as the sub-steps would.

        The new state is kept here and written into pymunk only when pymunk steps again (one
        write after any number of glides instead of one per step)."""
        x, y, a = self._xya()
        x, y, angle, velocity_x, velocity_y = glide(x, y, a, vx, vy, w, duration_s)
        self._pending = (x, y, angle, (velocity_x, velocity_y), w)
        self.time_s += duration_s

    def glided(
        self, x: float, y: float, angle: float, vx: float, vy: float, w: float, duration_s: float, movers_walked: bool
    ) -> None:
        """Take a step's glide computed in the step's kernel (`step`'s free path, compiled: the
        movers' sub-steps by `glide_movers`, then the body's by `glide`): the body's new position,
        unwrapped angle and map-frame velocity, its angular velocity, the sub-steps' time, and
        whether a mover was walking at the end (its body is then stopped, as `step` stops it)."""
        if self._mover_bodies:
            self._stop_bodies |= movers_walked
            self._bodies_stale = True
        self._pending = (x, y, angle, (vx, vy), w)
        self.time_s += duration_s

    def pending_glide(self) -> tuple[float, float, float, tuple[float, float], float] | None:
        """The body after glides not yet written into pymunk: (x, y, unwrapped angle, velocity,
        turn rate), or None."""
        return self._pending

    def set_glide(
        self, x: float, y: float, angle: float, velocity: tuple[float, float], w: float, time_s: float
    ) -> None:
        """Stand the body where glides taken elsewhere (a compiled batch) left it, at `time_s`."""
        self._pending = (x, y, angle, velocity, w)
        self.time_s = time_s

    def glide_inputs(self) -> tuple[float, float, float, bool]:
        """What the step's kernel needs to glide: the body's position and unwrapped angle, and
        whether a glide may be taken at all now (the shortcut is on and nothing touches)."""
        x, y, a = self._xya()
        return x, y, a, self._may_glide and self.contacts == 0

    def glide_constants(self, duration_s: float) -> tuple[float, float, int, float]:
        """(circumradius, margin, sub-steps, sub-step) of a step of `duration_s`: what `step` tests
        the room against (`sweep` plus the margin) and the sub-steps it glides through."""
        h = self.config.substep_s
        return self._circumradius_m, self._glide_margin, max(1, round(duration_s / h)), h

    def _xya(self) -> tuple[float, float, float]:
        """The body's position and unwrapped angle (a pending glide's, if any)."""
        if self._pending is not None:
            return self._pending[0], self._pending[1], self._pending[2]
        x, y = self.body.position
        return x, y, self.body.angle

    def _flush(self) -> None:
        """Write a pending glide's state into the pymunk bodies, as the glide would have."""
        if self._pending is None:
            return
        x, y, angle, velocity, w = self._pending
        body = self.body
        body.position = (x, y)
        body.angle = angle
        body.velocity = velocity
        body.angular_velocity = w
        self.control.velocity = velocity
        self.control.angular_velocity = w
        self._pending = None

    def _ramp(self, vx: float, vy: float, w: float, h: float, robot: RobotConfig) -> tuple[float, float, float]:
        """The command after the optional acceleration limits."""
        if robot.max_accel_mps2 is None and robot.max_angular_accel_radps2 is None:
            return vx, vy, w
        pvx, pvy, pw = self._command
        if robot.max_accel_mps2 is not None:
            dvx, dvy = vx - pvx, vy - pvy
            dv = math.hypot(dvx, dvy)
            limit = robot.max_accel_mps2 * h
            if dv > limit:
                vx, vy = pvx + dvx * limit / dv, pvy + dvy * limit / dv
        if robot.max_angular_accel_radps2 is not None:
            limit = robot.max_angular_accel_radps2 * h
            w = pw + float(np.clip(w - pw, -limit, limit))
        self._command = (vx, vy, w)
        return vx, vy, w
