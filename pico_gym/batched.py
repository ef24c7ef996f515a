"""The escape robots' common step for the vector env: every robot in one compiled call.

`PicoVectorEnv` steps each robot through its own env (`PicoEnv.begin_step`, `finish_step`): a few
microseconds of Python per robot and step, more than the compiled work. For PicoEscape-v0 robots
(no action extras, no movers, a plain segment array) `EscapeBatch` keeps what a step changes in
arrays instead, one row per robot, and steps every such robot in one compiled call
(`_step_escape`): the motion (`pico_gym.envs.base._drive`), the glide, odometry, idle time,
clearance, the scan with its noise, the escape task's verdict (progress, the finish line, the
reward terms, why the episode ends) and the info's values, written straight into the batch's
arrays. What it cannot do there goes back to the robot's own env: a step the physics must take
(a contact is possible), an episode's end, a reset. The env's own state is brought up to date
from the rows first (`sync_out`), and read back after (`sync_in`), through the classes' declared
interface (`PicoEnv.motion_state` / `set_motion_state`, `Physics.pending_glide` / `set_glide`,
`Odometry.redraw_countdown`, `EscapeTask.progress_state` / `set_progress_state`): no private
attribute of theirs is read here.

Bit for bit the same episodes: every random draw still comes from the robot's own `np_random`,
in the order its own step draws (the wheel factors or slip, then the scan's noise), and each
compiled part is the twin of the Python it stands for (the same operations in the same order;
`tests/test_vector.py` checks every observation, reward and info against single envs).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pico_gym.envs.base import CLEARANCE_CAP_M, COST_CLEARANCE_M, MotionState, PicoEnv, _drive
from pico_gym.jit import njit
from pico_gym.pymath import wrap_angle
from pico_gym.sensors.lrf import _cast, _noisy
from pico_gym.tasks.escape import REWARD_TERMS, EscapeTask, _min_signed_distance, weighted_terms
from pico_gym.types import FloatArray, Pose
from pico_gym.world.geometry import segments_intersect
from pico_gym.world.grid import _lookup
from pico_gym.world.scene import KINDS

# Columns of the float state (one row per robot).
_X, _Y, _TH = 0, 1, 2  # true pose
_BX, _BY, _BA, _BVX, _BVY, _BW = 3, 4, 5, 6, 7, 8  # the body: position, unwrapped angle, velocity
_OX, _OY, _OTH = 9, 10, 11  # odometry
_ROOM, _CLEAR, _MIN_CLEAR, _PATH, _IDLE, _VALUE, _OUT, _PTIME = 12, 13, 14, 15, 16, 17, 18, 19
_UNTIL = 20  # the odometry's time until its wheel factors are redrawn
_N_STATE = 21
# Columns of the int state.
_STEPS, _GLIDES, _MAY_GLIDE, _TRAJ = 0, 1, 2, 3
_N_ISTATE = 4
# Per-episode constants: the odometry frame (x, y, theta, cos, sin), the finish line (a, b, point,
# normal), the field's grid (x0, y0, resolution), the shortest path length.
_N_CONST = 5 + 8 + 3 + 1
# The float info values the kernel writes: pose (3), odometry error (3), clearance, min clearance,
# sim time, path length, the six reward terms, cost, geodesic_to_finish, reward.
N_INFO = 3 + 3 + 4 + 6 + 3
# Why an episode ends, by code (0: it goes on).
REASONS = (None, "escaped", "bump", "idle", "timeout")
_TRAJECTORY_ROOM = 256  # poses a robot keeps before they are handed to its env's trajectory


@njit
def _step_escape(  # noqa: C901 (a compiled kernel, one loop nest: docs/compiled-twins.md)
    rows: np.ndarray,
    actions: FloatArray,
    ground: FloatArray,
    exact: np.ndarray,
    state: FloatArray,
    istate: np.ndarray,
    const: FloatArray,
    fields: FloatArray,
    solid: FloatArray,
    seen: FloatArray,
    flags: np.ndarray,
    sizes: np.ndarray,
    outline: FloatArray,
    no_movers: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    bumps: np.ndarray,
    shared: FloatArray,
    ishared: np.ndarray,
    beams: tuple[FloatArray, FloatArray, FloatArray],
    units: FloatArray,
    reading: tuple[float, float, float, float],
    exact_ranges: FloatArray,
    scans: np.ndarray,
    odom32: np.ndarray,
    info: FloatArray,
    ends: np.ndarray,
    motions: FloatArray,
    trajectory: FloatArray,
    grounded: np.ndarray,
    rewards: FloatArray,
    terminated: np.ndarray,
    truncated: np.ndarray,
) -> tuple[int, bool, int, int]:
    """One step of the robots `rows` (see the module's docstring). A robot the physics must step
    gets ends[i, 0] = -1 and its `_drive` result in motions[i] (its row otherwise untouched); the
    others get their new state, scan, odometry observation, info values (info[value, robot]) and
    ends[i] = (reason code, truncated, success), with their reward, terminated and truncated.
    Each robot's odometry countdown moves on unless `grounded` (its `Odometry.ground` ran this
    step). Returns (how many robots need their env: a contact is possible, or the episode ended;
    whether a robot's trajectory buffer is full; how many robots' wheel factors are due next step;
    how many robots this call stepped to the end)."""
    vmax, wmax, dt, circumradius, margin, substep_s = shared[0], shared[1], shared[2], shared[3], shared[4], shared[5]
    idle_speed, idle_turn, idle_time, time_limit = shared[6], shared[7], shared[8], shared[9]
    weights = shared[10:18]  # `RewardWeights.vector()`, `weighted_terms`' table
    substeps, terminate_on_bump = ishared[0], ishared[1] != 0
    beam_angles, beam_cos, beam_sin = beams
    noise, rmin, rmax, no_hit = reading
    glide_s = substeps * substep_s
    events = 0
    full = False
    due_next = 0
    stepped = 0
    room_left = trajectory.shape[1]
    for j in range(rows.shape[0]):
        i = rows[j]
        s = state[i]
        if grounded[i]:
            grounded[i] = False
        else:
            s[_UNTIL] -= dt  # (as `Odometry.ground` counts down)
        if s[_UNTIL] <= 0.0:
            due_next += 1  # (its wheel factors are due next step)
        px, py, ptheta = s[_X], s[_Y], s[_TH]
        motion = _drive(
            float(actions[i, 0]), float(actions[i, 1]), float(actions[i, 2]), vmax, wmax, ground[i], exact[i], dt,
            s[_BX], s[_BY], s[_BA], istate[i, _MAY_GLIDE] != 0, s[_ROOM], circumradius, margin, substeps, substep_s,
            s[_OX], s[_OY], s[_OTH], px, py, ptheta,
            outline, solid[i, : sizes[i, 2]], CLEARANCE_CAP_M, no_movers, 0.0,
        )  # fmt: skip
        (glided, vx, vy, w, tvx, tvy, tw, ox, oy, otheta, x, y, angle, velocity_x, velocity_y, theta, moved, turned,
         clearance, room) = motion  # fmt: skip
        if glided == 0:  # (the other values are zeros)
            m = motions[i]
            m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8], m[9] = 0, vx, vy, w, tvx, tvy, tw, ox, oy, otheta
            m[10:] = 0.0
            ends[i, 0] = -1
            events += 1
            continue
        # The env's `apply_motion`, the glide taken (`Physics.glided`).
        stepped += 1
        s[_BX], s[_BY], s[_BA], s[_BVX], s[_BVY], s[_BW] = x, y, angle, velocity_x, velocity_y, tw
        s[_PTIME] += glide_s
        istate[i, _GLIDES] += 1
        s[_OX], s[_OY], s[_OTH] = ox, oy, otheta
        s[_X], s[_Y], s[_TH] = x, y, theta
        s[_ROOM] = room
        istate[i, _STEPS] += 1
        sim_time = istate[i, _STEPS] * dt
        s[_PATH] += moved
        if moved < idle_speed * dt and turned < idle_turn * dt:  # `IdleTimer.update`
            s[_IDLE] += dt
        else:
            s[_IDLE] = 0.0
        previous_clearance = s[_CLEAR]
        s[_CLEAR] = clearance
        if clearance < s[_MIN_CLEAR]:
            s[_MIN_CLEAR] = clearance
        t = istate[i, _TRAJ]
        trajectory[i, t, 0], trajectory[i, t, 1], trajectory[i, t, 2] = x, y, theta
        istate[i, _TRAJ] = t + 1
        if t + 1 == room_left:
            full = True
        # The scan (`Lrf.scan`: cast, then noise from the drawn uniforms).
        _cast(x, y, theta, seen[i, : sizes[i, 3]], beam_angles, beam_cos, beam_sin, rmax, exact_ranges, True,
              flags[i, : sizes[i, 4]])  # fmt: skip
        _noisy(exact_ranges, units[i], noise, rmin, rmax, no_hit, scans[i])
        # The escape task's verdict (`EscapeTask.evaluate`).
        c = const[i]
        field = fields[i, : sizes[i, 0] * sizes[i, 1]].reshape((sizes[i, 0], sizes[i, 1]))
        value = _lookup(field, (x - c[13]) / c[15] - 0.5, (y - c[14]) / c[15] - 0.5)
        before = s[_VALUE]
        progress = before - value if math.isfinite(value) and math.isfinite(before) else 0.0
        s[_VALUE] = value
        ax, ay, bx, by, lx, ly, nx, ny = c[5], c[6], c[7], c[8], c[9], c[10], c[11], c[12]
        d0 = (px - lx) * nx + (py - ly) * ny
        d1 = (x - lx) * nx + (y - ly) * ny
        if (d0 <= 0.0) != (d1 <= 0.0) and segments_intersect(px, py, x, y, ax, ay, bx, by):
            s[_OUT] = 1.0 if d1 > 0.0 else 0.0
        escaped = s[_OUT] != 0.0 and _min_signed_distance(x, y, theta, outline, lx, ly, nx, ny) > 0.0
        terms = weighted_terms(weights, progress, escaped, 0, dt, clearance, previous_clearance)
        reason = 0
        if escaped:
            reason = 1
        elif bumps[i] > 0 and terminate_on_bump:
            reason = 2
        elif s[_IDLE] >= idle_time:
            reason = 3
        truncated_now = reason == 0 and sim_time >= time_limit - 1e-9
        ends[i, 0], ends[i, 1], ends[i, 2] = reason, truncated_now, escaped
        terminated[i] = reason > 0
        truncated[i] = truncated_now
        if reason > 0 or truncated_now:
            events += 1
        # The info's values (`PicoEnv._info`) and the odometry observation.
        info[0, i], info[1, i], info[2, i] = x, y, theta
        # `PicoEnv.odometry_error`: the truth in the odometry frame, odometry minus it.
        fx, fy, fth, fc, fs = c[0], c[1], c[2], c[3], c[4]
        truth_x = fx + fc * x - fs * y
        truth_y = fy + fs * x + fc * y
        truth_theta = wrap_angle(fth + theta)
        info[3, i], info[4, i], info[5, i] = ox - truth_x, oy - truth_y, wrap_angle(otheta - truth_theta)
        info[6, i], info[7, i], info[8, i], info[9, i] = clearance, s[_MIN_CLEAR], sim_time, s[_PATH]
        total = 0.0
        for k in range(6):
            info[10 + k, i] = terms[k]
            total += terms[k]
        info[16, i] = 0.0 + (dt if clearance < COST_CLEARANCE_M else 0.0)
        info[17, i] = value
        info[18, i] = total
        rewards[i] = total
        odom32[i, 0], odom32[i, 1], odom32[i, 2] = ox, oy, otheta
    return events, full, due_next, stepped


class EscapeBatch:
    """The rows of a vector env's escape robots (see the module's docstring).

    Args:
        envs: the vector env's robots (each an unwrapped `PicoEnv`, all made alike).
    """

    def __init__(self, envs: list[PicoEnv]) -> None:
        self.envs = envs
        n = len(envs)
        first = envs[0]
        cfg = first.config
        tasks = [_escape_task(env) for env in envs]
        task_cfg = tasks[0].config
        rule = task_cfg.idle_rule
        robot = cfg.robot
        self.shared = np.concatenate(
            [[robot.max_speed_mps, robot.max_turn_rate_radps, cfg.dt_s, 0.0, 0.0, cfg.physics.substep_s,
              rule.speed_mps, rule.turn_rate_radps, task_cfg.idle_time_s, task_cfg.time_limit_s],
             tasks[0].weights],
        )  # fmt: skip
        self.ishared = np.array([1, task_cfg.collision == "terminate"], dtype=np.int64)
        self.state = np.zeros((n, _N_STATE))
        self.istate = np.zeros((n, _N_ISTATE), dtype=np.int64)
        self.const = np.zeros((n, _N_CONST))
        self.ground = np.zeros((n, 3, 3))
        self.exact = np.zeros(n, dtype=np.bool_)
        self._ground_of: list[Any] = [None] * n  # the matrix object each row was copied from
        self.bumps = np.zeros(n, dtype=np.int64)
        self.bumps_by_kind = np.zeros((n, len(KINDS)), dtype=np.int64)
        self.trajectory = np.zeros((n, _TRAJECTORY_ROOM, 3))
        self.live = np.zeros(n, dtype=np.bool_)  # the row holds the robot's state (its env is behind)
        self.last_scans = np.zeros((n, first.lrf.config.n_beams), dtype=np.float32)  # of the last `step`
        # Each robot's field and segments, one tuple entry per robot (the kernel indexes them).
        # Each robot's episode: its field and segments, in a slot of room enough for each (grown
        # when an episode needs more), and their sizes (field rows, columns; solid, seen, flags).
        self._fields = np.zeros((n, 1))
        self._solid = np.zeros((n, 1, 4))
        self._seen = np.zeros((n, 1, 4))
        self._flags = np.zeros((n, 1), dtype=np.bool_)
        self._sizes = np.zeros((n, 5), dtype=np.int64)
        self._sources: list[tuple[Any, ...]] = [()] * n  # what each slot was filled from
        self._outline = np.ascontiguousarray(robot.outline, dtype=np.float64)
        lrf = first.lrf
        self._beams = lrf.beams
        self._reading = lrf.reading
        self._draws_noise = lrf.draws_noise
        self._exact_ranges = np.empty(lrf.config.n_beams)
        # The scans' noise: each robot's uniforms for this step (0.5 without noise: no change).
        self.units = np.full((n, lrf.config.n_beams), 0.5)
        self._unit_rows = list(self.units)  # (views, made once)
        self._draw: list[Any] = [None] * n  # each robot's generator's `random`, bound
        self._dt = cfg.dt_s
        self._slips = first.odometry.config.slip_std > 0.0
        self.grounded = np.zeros(n, dtype=np.bool_)  # `Odometry.ground` ran for it this step
        self._maybe_due = True  # some robot's wheel factors may be due (else prepare needs not look)
        self._no_rows = np.zeros(0, dtype=np.int64)
        self.ends = np.zeros((n, 3), dtype=np.int64)  # the last step's (reason code, truncated, success)
        self.motions = np.zeros((n, 20))  # the last step's `_drive` results of robots handed back
        self._no_movers = (np.zeros((0, 10)), np.zeros((0, 6)), np.zeros((0, 2)), np.zeros((0, 4)), np.zeros((0, 2)))
        self.stepped = 0  # robot steps taken in the compiled kernel (the rest went to their envs)

    @staticmethod
    def takes(env: PicoEnv) -> bool:
        """Whether the batch can step this robot's current episode."""
        if not isinstance(env.task, EscapeTask) or env.episode is None or env.finished:
            return False
        _, seen, movers, _ = env.scan_inputs()
        return (
            env.n_action_extras == 0
            and movers is None
            and isinstance(seen, np.ndarray)
            and not env.scores_scans
            and env.render_mode is None
        )

    # --- the rows and the envs ---------------------------------------------------------------
    def sync_in(self, i: int) -> None:
        """Read robot i's state from its env into its row (after a reset or a step of its own)."""
        if self.live[i]:
            return  # the row is ahead of the env: nothing to read
        env = self.envs[i]
        if not self.takes(env):
            return
        physics, odometry, task = env.physics, env.odometry, _escape_task(env)
        x0, y0, a0, may_glide = physics.glide_inputs()
        pending = physics.pending_glide()
        motion = env.motion_state()
        s = self.state[i]
        s[_X], s[_Y], s[_TH] = motion.pose
        s[_BX], s[_BY], s[_BA] = x0, y0, a0
        if pending is not None:
            s[_BVX], s[_BVY] = pending[3]
            s[_BW] = pending[4]
        s[_OX], s[_OY], s[_OTH] = odometry.pose
        s[_ROOM], s[_CLEAR], s[_MIN_CLEAR] = motion.room, motion.clearance, motion.min_clearance
        s[_PATH], s[_IDLE] = motion.path_length, motion.idle_s
        value, out = task.progress_state()
        s[_VALUE], s[_OUT], s[_PTIME] = value, float(out), physics.time_s
        s[_UNTIL] = odometry.redraw_countdown
        self.exact[i] = odometry.exact
        self._draw[i] = env.np_random.random  # (a reset with a seed makes a new generator)
        if not odometry.exact:
            self.ground[i] = self._ground_of[i] = odometry.ground_matrix
        self.istate[i] = (motion.steps, 0, may_glide, 0)
        self._maybe_due = True
        circumradius, margin, substeps, _ = env.glide_constants
        self.shared[3], self.shared[4], self.ishared[0] = circumradius, margin, substeps
        field = task.progress_field
        g = field.grid
        c = self.const[i]
        c[0:5] = env.odometry_frame()
        c[5:13] = task.finish_line
        c[13:16] = (g.x0, g.y0, g.resolution)
        c[16] = motion_shortest(env)
        self.bumps[i], self.bumps_by_kind[i] = env.counted_bumps()
        _, seen, _, one_sided = env.scan_inputs()
        self._join(i, field.distance, env.solid_segments, seen, one_sided)
        self.live[i] = True

    def sync_out(self, i: int) -> None:
        """Bring robot i's env up to date from its row (before it steps on its own, at an
        episode's end, or for anyone who reads the env)."""
        if not self.live[i]:
            return
        env = self.envs[i]
        s, k = self.state[i], self.istate[i]
        if k[_GLIDES]:
            env.physics.set_glide(s[_BX], s[_BY], s[_BA], (s[_BVX], s[_BVY]), s[_BW], s[_PTIME])
        if k[_STEPS] != env.steps:
            env.last_scan = self.last_scans[i]
        self._hand_over_trajectory(i)
        pose = Pose(s[_X], s[_Y], s[_TH])
        env.set_motion_state(MotionState(pose, s[_ROOM], s[_CLEAR], s[_MIN_CLEAR], s[_PATH], s[_IDLE], int(k[_STEPS])))
        env.odometry.pose = Pose(s[_OX], s[_OY], s[_OTH])
        env.odometry.redraw_countdown = s[_UNTIL]
        _escape_task(env).set_progress_state(s[_VALUE], bool(s[_OUT]))
        self.live[i] = False

    def _hand_over_trajectory(self, i: int) -> None:
        t = int(self.istate[i, _TRAJ])
        if t:
            self.envs[i].add_trajectory(self.trajectory[i, :t].copy())
            self.istate[i, _TRAJ] = 0

    def _join(self, i: int, field: FloatArray, solid: FloatArray, seen: FloatArray, flags: np.ndarray | None) -> None:
        """Put robot i's episode's field and segments in its slots (when they are new)."""
        flags = np.zeros(0, dtype=np.bool_) if flags is None else flags
        sources = (field, solid, seen, flags)
        if len(self._sources[i]) == 4 and all(a is b for a, b in zip(sources, self._sources[i], strict=True)):
            return
        self._sources[i] = sources
        self._fields = _room_for(self._fields, field.size)
        self._solid = _room_for(self._solid, len(solid))
        self._seen = _room_for(self._seen, len(seen))
        self._flags = _room_for(self._flags, len(flags))
        self._fields[i, : field.size] = field.ravel()
        self._solid[i, : len(solid)] = solid
        self._seen[i, : len(seen)] = seen
        self._flags[i, : len(flags)] = flags
        self._sizes[i] = (field.shape[0], field.shape[1], len(solid), len(seen), len(flags))

    # --- a step ------------------------------------------------------------------------------
    def prepare(self, rows: np.ndarray, everyone: bool) -> None:
        """The robots' draws before the step, each in its own step's order: the wheel factors (or
        the slip) for the true twist (`Odometry.ground`, where they are due; elsewhere only its
        countdown moves on), then the scan's noise. `everyone`: rows are all the robots."""
        until = self.state[:, _UNTIL]
        if self._slips:
            due = rows
        elif not self._maybe_due:
            due = self._no_rows  # (none was due after the last step, and none came in since)
        elif everyone:
            due = np.flatnonzero(until <= 0.0)
        else:
            due = rows[until[rows] <= 0.0]
        for i in due.tolist():  # (the kernel counts the others down)
            odometry = self.envs[i].odometry
            odometry.redraw_countdown = until[i]
            m = odometry.ground(self._dt, self.envs[i].np_random)
            until[i] = odometry.redraw_countdown
            self.grounded[i] = True
            if m is not None and m is not self._ground_of[i]:  # (new factors, or slip)
                self.ground[i] = m
                self._ground_of[i] = m
        if self._draws_noise:  # the same draws as the robot's own `Lrf.scan`
            units = self._unit_rows
            if everyone:
                for draw, unit in zip(self._draw, units, strict=True):
                    draw(out=unit)
            else:
                draw = self._draw
                for i in rows.tolist():
                    draw[i](out=units[i])

    def unit_row(self, i: int) -> FloatArray:
        """Robot i's uniforms for this step's scan (after `prepare`)."""
        return self._unit_rows[i]

    def step(
        self,
        rows: np.ndarray,
        actions: np.ndarray,
        scans: np.ndarray,
        odom32: np.ndarray,
        info: FloatArray,
        rewards: FloatArray,
        terminated: np.ndarray,
        truncated: np.ndarray,
    ) -> int:
        """Step the live robots `rows` (their draws taken by `prepare`); `ends` and `motions` tell
        what happened to each. Returns how many robots need their own env (see `_step_escape`)."""
        ends = self.ends
        ends[:] = 0
        events, full, due_next, stepped = _step_escape(
            rows, actions, self.ground, self.exact, self.state, self.istate, self.const, self._fields, self._solid,
            self._seen, self._flags, self._sizes, self._outline, self._no_movers, self.bumps, self.shared, self.ishared,
            self._beams, self.units, self._reading, self._exact_ranges, scans, odom32, info, ends, self.motions,
            self.trajectory, self.grounded, rewards, terminated, truncated,
        )  # fmt: skip
        self.last_scans = scans
        self._maybe_due = due_next > 0
        self.stepped += stepped
        if full:
            for i in rows[self.istate[rows, _TRAJ] >= _TRAJECTORY_ROOM].tolist():
                self._hand_over_trajectory(i)
        return events


def _escape_task(env: PicoEnv) -> EscapeTask:
    """A robot's escape task (the batch takes no other)."""
    task = env.task
    assert isinstance(task, EscapeTask)
    return task


def motion_shortest(env: PicoEnv) -> float:
    """The oracle's path length of a robot's episode."""
    assert env.episode is not None
    return env.episode.shortest_path_length_m


def _room_for(slots: np.ndarray, size: int) -> np.ndarray:
    """`slots` (one row per robot), with at least `size` entries a row (the rows kept)."""
    if slots.shape[1] >= size:
        return slots
    grown = np.zeros((slots.shape[0], max(size, 2 * slots.shape[1]), *slots.shape[2:]), dtype=slots.dtype)
    grown[:, : slots.shape[1]] = slots
    return grown


_MASKS: dict[int, list[np.ndarray]] = {}


def _masks(n: int) -> list[np.ndarray]:
    """25 all-true masks for n robots, read-only (shared by the steps' infos)."""
    masks = _MASKS.get(n)
    if masks is None:
        block = np.ones((25, n), dtype=np.bool_)
        block.flags.writeable = False
        masks = _MASKS[n] = list(block)
    return masks


def escape_infos(
    info: FloatArray, ends: np.ndarray, batch: EscapeBatch, patches: dict[int, dict[str, Any]]
) -> dict[str, Any] | None:
    """The step's infos batched as `SyncVectorEnv` batches them, from the kernel's values (`info`,
    one row per value, one column per robot) and, for the robots in `patches`, from their own info
    dicts; None when a patch has other keys than the kernel's (the caller then batches every
    robot's dict). The value arrays are views of `info` (each a robot per entry, as gymnasium's)."""
    n = info.shape[1]
    # The masks: every robot has every key. Unless a robot's own dict is patched in below, they
    # are the same read-only arrays every step (making 25 of them was a third of this function).
    m = _masks(n) if not patches else np.ones((25, n), dtype=np.bool_)
    by_kind = batch.bumps_by_kind.T.copy()
    terms = {
        "progress": info[10], "_progress": m[0], "success": info[11], "_success": m[1],
        "bump": info[12], "_bump": m[2], "time": info[13], "_time": m[3],
        "proximity": info[14], "_proximity": m[4], "approach": info[15], "_approach": m[5],
    }  # fmt: skip
    kinds = {
        "wall": by_kind[0], "_wall": m[6], "cabinet": by_kind[1], "_cabinet": m[7], "door": by_kind[2],
        "_door": m[8], "box": by_kind[3], "_box": m[9], "mover": by_kind[4], "_mover": m[10],
    }  # fmt: skip
    out = {
        "pose": info[0:3].T, "_pose": m[11],
        "odom_error": info[3:6].T, "_odom_error": m[12],
        "bumps": batch.bumps.copy(), "_bumps": m[13],
        "bumps_by_kind": kinds, "_bumps_by_kind": m[14],
        "clearance": info[6], "_clearance": m[15],
        "min_clearance": info[7], "_min_clearance": m[16],
        "sim_time": info[8], "_sim_time": m[17],
        "path_length": info[9], "_path_length": m[18],
        "shortest_path_length": batch.const[:, 16].copy(), "_shortest_path_length": m[19],
        "is_success": ends[:, 2].astype(np.bool_), "_is_success": m[20],
        # (a robot whose episode ends has its own dict in `patches`)
        "termination_reason": np.full(n, None, dtype=object), "_termination_reason": m[21],
        "reward_terms": terms, "_reward_terms": m[22],
        "cost": info[16], "_cost": m[23],
        "geodesic_to_finish": info[17], "_geodesic_to_finish": m[24],
    }  # fmt: skip
    if not patches:
        return out
    keys = _INFO_KEYS
    for i, patch in patches.items():
        if patch.keys() != keys:
            return None
        for key, value in patch.items():
            if key in ("reward_terms", "bumps_by_kind"):
                nested = out[key]
                for name in REWARD_TERMS if key == "reward_terms" else KINDS:
                    there = name in value
                    nested[name][i] = value[name] if there else 0
                    nested[f"_{name}"][i] = there
            else:
                out[key][i] = value
    if not any(terms[f"_{name}"].any() for name in REWARD_TERMS):
        out["reward_terms"] = {}  # every robot has just been reset (an empty dict each)
    return out


# The keys of an escape robot's info (`PicoEnv._info` and `EscapeTask.info`), as `escape_infos` batches them.
_INFO_KEYS = frozenset(
    ("pose", "odom_error", "bumps", "bumps_by_kind", "clearance", "min_clearance", "sim_time", "path_length",
     "shortest_path_length", "is_success", "termination_reason", "reward_terms", "cost", "geodesic_to_finish")
)  # fmt: skip
