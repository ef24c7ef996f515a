"""The hybrid hospital agent: the classic agent's localisation, world model, A* route and state
machine, with a PPO policy driving between the route's waypoints from the LRF.

The classic hospital agent (`pico_gym.agents.classic.hospital`) localises on the given map, keeps
its evidence grid of what the map does not show, plans the A* route to the next cabinet's dock
point and runs the state machine (localise, navigate, dock, dwell, yield, recover). While it
navigates, the policy drives instead of its potential field: it sees the LRF (pooled, with a
360-degree range memory), the odometry's velocity and the waypoint `lookahead_m` along the route,
as range and bearing from the agent's own pose estimate, with the heading error to facing the
cabinet (`encode_goal`, the layout of the point-goal baseline, but computed from what the agent
knows: no privileged input). Docking, the dwell, yielding and recovery stay classic, and every
command, the policy's too, passes the classic safety filter (a shield: `HybridConfig.shield`),
which also remembers what the LRF saw in the last seconds and is now behind the robot
(`HybridConfig.blind_memory_s`). Where the policy keeps getting stuck on one leg, the classic
part drives the rest of it (`HybridConfig.fallback_after`; `fallback_after_s` after a long leg).

The policy is trained in exactly this loop (`pico_gym.train.hybrid.HybridTraining`): the classic
part acts by itself in every state but NAVIGATE, and the policy's encoder sees only the steps it
drives (`observe` / `policy_input` / `finish` are the seams the training wrapper uses).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pico_gym.agents.base import RobotSpec
from pico_gym.agents.classic.hospital import HospitalAgent, HospitalAgentConfig, State
from pico_gym.agents.classic.potential_field import safety_filter
from pico_gym.agents.shield import ScanMemory, behind_seen_free, blind_translation
from pico_gym.overlay import Overlay
from pico_gym.types import FloatArray
from pico_gym.wrappers import LearningConfig, LearningEncoder, encode_goal, rescale_action, unit_action

# The shipped hybrid policy (see agents/models/HOSPITAL_HYBRID_CARD.md once shipped).
SHIPPED_HYBRID_POLICY = Path(__file__).parent / "models" / "ppo_hospital_hybrid.npz"


@dataclass(frozen=True)
class HybridConfig:
    """The hybrid agent's own settings (how each default was measured: docs/agents/hybrid.md).

    Attributes:
        lookahead_m: the policy drives to the point this far along the planned route (or its
            end, the dock point, when nearer) [m].
        shield: pass the policy's commands through the classic safety filter (kept in the LRF's
            view, turns cut near corners, scaled down before the footprint meets its margin).
        blind_memory_s: the shield also keeps the footprint off what the LRF saw within 1.2 m in
            the last this many seconds, now behind the robot [s]: the classic part's memory (map
            and evidence) misses a box face seen only in passing (0: off).
        fallback_after: after this many recoveries of the policy's driving on one leg, the
            classic part drives the rest of the leg: it plans around the spot the policy got stuck
            at (0: never).
        fallback_after_s: the classic part also drives the rest of a leg that has lasted this
            long [s]: a person walking to and fro kept the policy yielding for minutes (0: never).
        blind_turn: with the shield, a turn that would swing the rear out of its turning circle
            into the blind sector while translating is cut (`pico_gym.agents.shield.blind_turn`):
            the rear corner meets what comes from behind.
        blind_translation: with `blind_turn`, a translation that would move the rear into space
            no recent scan saw free is cut (`pico_gym.agents.shield.blind_translation`).
        blind_near_m: if > 0, the two cuts apply only with evidence of something the map does
            not show this near [m]; 0 (default): always (a person who walks up behind is in no
            evidence).
        dock_still_s: docking that has stood still this long recovers instead of waiting for the
            classic part's 20 s rule [s]: the policy can hand over at a heading the filter will
            not turn from (0: off).
        recover_turn: recovering with every command cut to nothing, turn in place where the
            safety filter alone allows it, so a rear corner against a wall does not end the run.
        walk_in_mps: if > 0, the policy backs into the strip behind the footprint only where the
            shield's memory saw it free, what it saw taken back at this speed [m/s] (a walking
            person's), or within `back_budget_m` of backing since; the shipped policy was tuned
            with 0.5 and its metadata turns it on.
        back_budget_m: see `walk_in_mps` [m].
        escape_people: what the classic part backs away from and watches also holds where the
            tracker last saw each person walking (one paused just behind the robot is in no
            scan); the hybrid's own switch, not `HospitalAgentConfig.escape_people`.
        classic_near_people_m: while a person tracked walking is within this of the pose estimate,
            the classic part drives (its yielding), not the policy [m] (0: off).
    """

    lookahead_m: float = 1.0
    shield: bool = True
    blind_memory_s: float = 4.0
    fallback_after: int = 2
    fallback_after_s: float = 120.0
    blind_turn: bool = True
    blind_translation: bool = True
    blind_near_m: float = 0.0
    dock_still_s: float = 3.0
    recover_turn: bool = True
    walk_in_mps: float = 0.0
    back_budget_m: float = 0.1
    escape_people: bool = True
    classic_near_people_m: float = 0.0

    def __post_init__(self) -> None:
        for name in ("shield", "blind_turn", "recover_turn", "escape_people", "blind_translation"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"HybridConfig.{name} must be true or false, got {getattr(self, name)!r}")
        for name, lo, hi, unit in (
            ("lookahead_m", 0.1, 5.0, " m"),
            ("blind_near_m", 0.0, 10.0, " m"),
            ("dock_still_s", 0.0, 60.0, " s"),
            ("walk_in_mps", 0.0, 5.0, " m/s"),
            ("back_budget_m", 0.0, 10.0, " m"),
            ("blind_memory_s", 0.0, 10.0, " s"),
            ("classic_near_people_m", 0.0, 10.0, " m"),
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not lo <= value <= hi:
                raise ValueError(f"HybridConfig.{name} must be in [{lo:g}, {hi:g}]{unit}, got {value!r}")
        if not (isinstance(self.fallback_after, int) and not isinstance(self.fallback_after, bool)) or not (
            0 <= self.fallback_after <= 100
        ):
            raise ValueError(f"HybridConfig.fallback_after must be an integer in [0, 100], got {self.fallback_after!r}")
        s = self.fallback_after_s
        if isinstance(s, bool) or not isinstance(s, (int, float)) or not 0.0 <= s <= 3600.0:
            raise ValueError(f"HybridConfig.fallback_after_s must be a number in [0, 3600] s, got {s!r}")


def waypoint_along(here: FloatArray, path: list[FloatArray], lookahead_m: float) -> FloatArray:
    """The point `lookahead_m` along the polyline here -> path[0] -> ... (its end if shorter).

    >>> waypoint_along(np.zeros(2), [np.array([0.5, 0.0]), np.array([0.5, 2.0])], 1.0).tolist()
    [0.5, 0.5]
    """
    left = lookahead_m
    a = np.asarray(here, dtype=np.float64)
    for p in path:
        b = np.asarray(p, dtype=np.float64)
        d = float(np.hypot(*(b - a)))
        if d >= left:
            return a + (b - a) * (left / d)
        left -= d
        a = b
    return a


class HybridAgent(HospitalAgent):
    """The classic hospital agent with a PPO policy driving NAVIGATE (see the module docstring).

    Args:
        spec: the robot's public spec.
        path: the policy (`.npz`, or an SB3 `.zip`); default: the shipped one.
        model: an SB3 model in memory instead (training's evaluations), with its `learning`.
        learning: the observation encoding `model` was trained with.
        hybrid: the hybrid's own settings; default: those the policy's metadata names (its
            training loop's backing cut, `walk_in_mps` and `back_budget_m`), else `HybridConfig()`.
        config: the classic part's settings, but for its blind sector: the hybrid's own
            `HybridConfig.blind_memory_s` is used instead of `config.blind_memory_s`, its blind
            cuts instead of `config.people_cuts_m`, its `escape_people` instead of the config's.
        driver: no policy at all (the training wrapper drives NAVIGATE itself through `observe`,
            `policy_input` and `finish`; `act` then falls back to the classic command).
    """

    name = "hybrid"

    def __init__(
        self,
        spec: RobotSpec,
        path: str | Path | None = None,
        model: Any = None,
        learning: LearningConfig | None = None,
        hybrid: HybridConfig | None = None,
        config: HospitalAgentConfig | None = None,
        driver: bool = False,
    ) -> None:
        super().__init__(spec, config)
        self.hybrid = hybrid or HybridConfig()
        self.actor = None
        if not driver:
            from pico_gym.agents.mlp import export_actor
            from pico_gym.agents.ppo import load_actor, observation_normalizer, policy_metadata_path

            if model is not None:
                if learning is None:
                    raise ValueError("HybridAgent(model=...) needs the LearningConfig it was trained with")
                self.actor = export_actor(model, observation_normalizer(model))
            else:
                if path is None and not SHIPPED_HYBRID_POLICY.exists():
                    raise FileNotFoundError(
                        "no hybrid policy is shipped yet; train one with train/configs/ppo_hospital_hybrid.yaml "
                        "and pass path=... (--policy)"
                    )
                source = path or SHIPPED_HYBRID_POLICY
                self.actor, learning, meta = load_actor(source)
                if hybrid is None and meta.get("hybrid"):  # the cuts the policy was trained with
                    try:
                        self.hybrid = HybridConfig(**meta["hybrid"])
                    except (TypeError, ValueError) as exc:
                        where = policy_metadata_path(source)
                        raise ValueError(f"{where}: the metadata's 'hybrid' settings: {exc}") from None
        self.learning = learning or LearningConfig(n_sectors=64, frame_stack=2, memory_sectors=36, range_scale="log")
        if not self.learning.point_goal:
            self.learning = LearningConfig(**{**self.learning.to_dict(), "point_goal": True})
        self.encoder = LearningEncoder(spec.lrf, spec.robot, spec.dt_s, self.learning)
        if self.actor is not None and self.actor.obs_size != self.encoder.space.shape[0]:
            raise ValueError(
                f"the policy expects observations of length {self.actor.obs_size}, but {self.learning} on this "
                f"robot's LRF ({spec.lrf.n_beams} beams) gives {self.encoder.space.shape}"
            )
        self._low, self._high = spec.robot.action_low, spec.robot.action_high

    def reset(self, obs: dict[str, np.ndarray], info: dict[str, Any] | None = None) -> None:
        super().reset(obs, info)
        self._encoding = False  # the encoder starts at the policy's first step of the episode
        self._near = np.zeros((0, 2))
        self.command = (0.0, 0.0, 0.0)
        self.waypoint: FloatArray | None = None
        # The classic part's blind-sector memory and cuts, with the hybrid's settings (its own cuts
        # below replace the classic part's `people_cuts_m`).
        self._memory = ScanMemory(self.hybrid.blind_memory_s, self.spec.dt_s)
        self._people_free = None
        self._seen_free = self.seen_free(self.hybrid.blind_memory_s, walk_in_mps=float(self.hybrid.walk_in_mps))
        self._back_left = self.hybrid.back_budget_m  # backing left into unvouched space [m]
        self._leg = 0  # the cabinet the recoveries below were counted for
        self._leg_start = 0  # the step its leg began at
        self._recoveries = 0  # recoveries the policy's driving ended in on this leg
        self._drove = False  # the policy drove the last step

    def _go(self, state: State) -> None:
        if state is State.RECOVER and self.state is State.NAVIGATE and getattr(self, "_drove", False):
            self._recoveries += 1
        super()._go(state)

    @property
    def classic_leg(self) -> bool:
        """Whether the classic part drives the rest of this leg (`HybridConfig.fallback_after`,
        `fallback_after_s`)."""
        n, limit_s = self.hybrid.fallback_after, self.hybrid.fallback_after_s
        if n > 0 and self._recoveries >= n:
            return True
        return limit_s > 0.0 and (self.steps - self._leg_start) * self.spec.dt_s > limit_s

    # --- the shield's short memory of the blind sector ---------------------------------------------
    def _sense(self, obs: dict[str, np.ndarray]) -> FloatArray:
        near = super()._sense(obs)
        if self.hybrid.blind_turn:  # only the blind cuts ask it
            self._seen_free.add(np.asarray(obs["lrf"], dtype=np.float64), self._odom)
        return near

    def _escapes_people(self) -> bool:
        """The hybrid's own switch (`HybridConfig.escape_people`) decides, not its classic part's."""
        return self.hybrid.escape_people

    def _person_close(self) -> bool:
        """A person tracked walking within `classic_near_people_m` of the pose estimate."""
        reach = self.hybrid.classic_near_people_m
        if reach <= 0.0 or not self.localised or not self.config.track_people:
            return False
        here = np.array([self.pose.x, self.pose.y])
        return any(float(np.hypot(*(t.position - here))) < reach for t in self.world.tracker.moving())

    # --- the seams the training wrapper drives ----------------------------------------------------
    def observe(self, obs: dict[str, np.ndarray]) -> bool:
        """Take in an observation and run the classic part (its command is `self.command`);
        True when the policy is to drive this step (the classic part is navigating a route)."""
        self._near = self._sense(obs)
        if self.done != self._leg:
            self._leg, self._recoveries, self._leg_start = self.done, 0, self.steps
        self.command = self._decide(self._near)
        driving = self.state is State.NAVIGATE and bool(self.route.path) and not self.classic_leg
        driving = driving and not self._person_close()
        self._drove = driving
        if driving:
            here = np.array([self.pose.x, self.pose.y])
            self.waypoint = waypoint_along(here, self.route.path, self.hybrid.lookahead_m)
        return driving

    def goal(self) -> np.ndarray:
        """The waypoint as the policy sees it (`encode_goal` from the pose estimate); once every
        cabinet is done, the robot is at its goal: [0, 0, 1, 0, 1]."""
        if self.done >= len(self.order):
            return np.array([0.0, 0.0, 1.0, 0.0, 1.0], np.float32)
        wp = self.waypoint if self.waypoint is not None else self.dock_point()
        p = self.pose
        return encode_goal(p.x, p.y, p.theta, float(wp[0]), float(wp[1]), self.cabinet().facing_rad)

    def policy_input(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        """The policy's input for this step (call after `observe` returned True)."""
        full = {**obs, "point_goal": self.goal()}
        if not self._encoding:
            self._encoding = True
            return self.encoder.reset(full)
        return self.encoder.encode(full)

    def finish(self, command: tuple[float, float, float]) -> np.ndarray:
        """A command (the policy's or the classic part's) as the action: shielded or not."""
        if self.hybrid.shield or self.state is not State.NAVIGATE:
            if self.hybrid.blind_turn and self._cluttered():
                seen_free = lambda pts: self._seen_free.free(pts, self._odom, aged=False)  # noqa: E731
                command = self._blind_cuts(command, seen_free, translate=self.hybrid.blind_translation)
            return self._finish(self._near, command)
        return np.array([*command, -1.0] if self.announce else command, dtype=np.float32)

    def _translate(self, twist: tuple[float, float, float], seen_free: Any) -> tuple[float, float]:
        """`blind_translation`; with `walk_in_mps`, backing only into the strip behind that was
        seen free lately, or within `back_budget_m` of backing since it last was."""
        if self.hybrid.walk_in_mps <= 0.0 or self.classic_leg:
            return super()._translate(twist, seen_free)
        behind = behind_seen_free(self.motion, lambda pts: self._seen_free.free(pts, self._odom, aged=True))
        if behind:
            self._back_left = self.hybrid.back_budget_m
        may_back = behind or self._back_left > 0.0
        vx, vy = blind_translation(twist, self.motion, *self._view, seen_free=seen_free, may_back=may_back)
        if vx < 0.0 and not behind:
            self._back_left += vx * self.spec.dt_s
        return vx, vy

    def _finish(self, near: FloatArray, command: tuple[float, float, float]) -> np.ndarray:
        """The classic part's filters and never-stand-still rule; then, recovering with the command
        cut to nothing, a turn in place the safety filter lets through (`recover_turn`)."""
        out = super()._finish(near, command)
        if not (self.hybrid.recover_turn and self.state is State.RECOVER) or len(near) == 0:
            return out
        if math.hypot(float(out[0]), float(out[1])) > 0.03 or abs(float(out[2])) > 0.08:
            return out  # it moves
        motion = self.motion
        sense = self._way_out_sense(near)
        for w in (0.5 * sense, 0.25 * sense, -0.5 * sense, -0.25 * sense):
            _, _, fw = safety_filter(near, (0.0, 0.0, w * motion.max_turn), motion)
            if abs(fw) > 0.08:
                out[:3] = (0.0, 0.0, fw)
                self.still_steps = 0
                break
        return out

    def _way_out_sense(self, near: FloatArray) -> float:
        """+1 (left) or -1: the sense of turn that brings the nearest direction behind the view
        that the safety filter lets the robot translate along into view (+1 if none)."""
        lo, hi = self._view
        best, best_off = 1.0, math.inf
        for a in np.linspace(-math.pi, math.pi, 24, endpoint=False):
            a = float(a)
            off = a - hi if a > hi else lo - a  # how far behind the view's edge
            if off < 0.0 or off >= best_off:
                continue
            tx, ty, _ = safety_filter(near, (0.2 * math.cos(a), 0.2 * math.sin(a), 0.0), self.motion)
            if math.hypot(tx, ty) > 0.03:
                best, best_off = math.copysign(1.0, a), off
        return best

    def _max_still_s(self) -> float:
        """The classic part's never-stand-still limit, shorter while docking (`dock_still_s`)."""
        if self.state is State.DOCK and self.hybrid.dock_still_s > 0.0:
            return min(self.hybrid.dock_still_s, self.config.max_still_s)
        return super()._max_still_s()

    def _cluttered(self) -> bool:
        """Whether the evidence holds anything the map does not show (a box, a person) within
        `blind_near_m` of the robot; before localisation, always. A blind sweep can only meet
        what the map does not show, and where nothing of that kind is near, it is not cut."""
        radius = self.hybrid.blind_near_m
        if not self.localised or radius <= 0.0:
            return True
        g = self.given.grid
        rows, cols = g.shape
        c0 = int((self.pose.x - radius - g.x0) / g.resolution)
        c1 = int((self.pose.x + radius - g.x0) / g.resolution) + 1
        r0 = int((self.pose.y - radius - g.y0) / g.resolution)
        r1 = int((self.pose.y + radius - g.y0) / g.resolution) + 1
        return bool(self.world.seen()[max(r0, 0) : min(r1, rows), max(c0, 0) : min(c1, cols)].any())

    def teacher(self) -> np.ndarray:
        """The classic part's own command this step, in the policy's [-1, 1] action units."""
        return unit_action(np.array(self.command, dtype=np.float64), self._low, self._high)

    # --- the agent ----------------------------------------------------------------------------------
    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        if self.observe(obs) and self.actor is not None:
            unit = self.actor.act(self.policy_input(obs))
            vx, vy, w = (float(v) for v in rescale_action(unit, self._low, self._high))
            return self.finish((vx, vy, w))
        return self.finish(self.command)

    def overlay(self) -> Overlay:
        base = super().overlay()
        policy = self.state is State.NAVIGATE and self.actor is not None and not self.classic_leg
        driving = "policy" if policy else "classic"
        target = self.waypoint if self.state is State.NAVIGATE and self.waypoint is not None else base.target
        return Overlay(
            frame=base.frame,
            segments=base.segments,
            points=base.points,
            path=base.path,
            target=target,
            text=base.text.replace("classic:", f"hybrid ({driving}):", 1),
        )


def build(env: Any, **kwargs: Any) -> HybridAgent:
    """The hybrid hospital agent for an env's robot (`make_agent("hybrid", env)`)."""
    return HybridAgent(RobotSpec.of(env), **kwargs)
