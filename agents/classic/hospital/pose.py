"""Localisation on the given map: where the classic hospital agent believes it is.

At the start, the robot turns in place, joining scans at their odometry offsets, until one pose of
the start area (any heading) explains them clearly better than any other (`search`). Then every
step: the odometry's prediction, registered against the map's walls (point-to-line ICP on a
likelihood field, `Localiser.refine`) when enough beams agree (`track`). A pose that explains few
beams for a while is checked against the whole map (`check_elsewhere`: a hospital's rooms look
alike, a wrong pose can still explain most beams) and searched for locally; one found elsewhere
twice, or not restored, is lost: the whole map's free space is searched (`search` again, with
`relocalising`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from pico_gym.agents.classic.hospital.config import HospitalAgentConfig
from pico_gym.agents.classic.hospital.given import GivenMap
from pico_gym.types import FloatArray, Pose
from pico_gym.world.geometry import compose, inverse, wrap_angle


class Found(NamedTuple):
    """A search's result: the pose was found (again); `moved_far` when a relocalisation moved it
    more than 0.3 m (what was mapped on the lost pose should fade)."""

    moved_far: bool


def joined_at_offsets(odom: Pose, scans: list[tuple[Pose, FloatArray]], points: FloatArray) -> FloatArray:
    """`points` and earlier scans' points (each with its odometry), all in this scan's frame."""
    joined = [points]
    for then, pts in scans:
        off = compose(inverse(odom), then)  # that scan's pose in this one's frame
        c, s = math.cos(off.theta), math.sin(off.theta)
        joined.append(np.column_stack([off.x + c * pts[:, 0] - s * pts[:, 1], off.y + s * pts[:, 0] + c * pts[:, 1]]))
    return np.vstack(joined)


class MapPose:
    """The pose estimate on the given map and its health.

    Args:
        given: the given map (its localiser).
        config: the agent's settings.
        dt_s: the control period [s].
        turn_radps: how fast the robot turns while it searches [rad/s].
    """

    def __init__(self, given: GivenMap, config: HospitalAgentConfig, dt_s: float, turn_radps: float) -> None:
        self.given, self.config, self.dt_s, self.turn_radps = given, config, dt_s, turn_radps
        self.localiser = given.localiser
        self.pose = Pose(0.0, 0.0, 0.0)
        self.localised = False
        self.localise_s: float | None = None  # when it first localised [s]
        self.health = 0.0  # the fraction of the last scan's beams the pose explains
        self.odom0: Pose | None = None  # the odometry of the search's first scan
        self.odom_prev: Pose | None = None
        self.loc_points: list[FloatArray] = []  # the search's scans, in its first scan's frame
        self.turned_since_search = math.inf
        self.turned_total = 0.0
        self.unhealthy_steps = 0
        self.doubt_steps = 0  # steps in a row with the health under doubt_health
        self.lost_attempts = 0  # local relocalisations that did not restore the health
        self.relocalised = 0  # whole-map relocalisations done
        self._elsewhere: tuple[Pose, Pose] | None = None  # (odometry, pose) a check found elsewhere
        self._recent: list[tuple[Pose, FloatArray]] = []  # (odometry, points) of recent scans
        self._lost_from = self.pose

    def _steps(self, seconds: float) -> int:
        return max(1, round(seconds / self.dt_s))

    def predict(self, odom: Pose) -> Pose:
        """The pose odometry predicts from the last one."""
        assert self.odom_prev is not None  # (set by the step before)
        return compose(self.pose, compose(inverse(self.odom_prev), odom))

    def track(
        self, odom: Pose, predicted: Pose, points: FloatArray, fixed: FloatArray, steps: int, relocalising: bool
    ) -> bool:
        """Register the scan's `fixed` points (people left out) at the prediction; keep the health
        checks. Returns whether the pose is lost (the caller searches the whole map)."""
        cfg = self.config
        if steps % self._steps(1.0) == 0:  # one scan a second for `check_elsewhere`
            self._recent = [*self._recent[-(cfg.doubt_scans - 1) :], (odom, fixed)]
        pose = self.localiser.refine(predicted, fixed, prior=cfg.registration_prior)
        health = self.localiser.explained(pose, fixed)
        self.health = health
        if health >= cfg.health_min and math.hypot(pose.x - predicted.x, pose.y - predicted.y) < 0.2:
            self.pose = pose
            self.unhealthy_steps = 0
            self.lost_attempts = 0
        else:
            self.pose = predicted
            self.unhealthy_steps += 1
        lost = False
        if health < cfg.doubt_health and not relocalising:
            self.doubt_steps += 1
            if self.doubt_steps >= self._steps(cfg.doubt_s):
                self.doubt_steps = 0
                lost = self.check_elsewhere(odom, fixed)
        else:
            self.doubt_steps = 0
        if self.unhealthy_steps >= self._steps(3.0) and not (relocalising or lost):
            self._relocalise_near(points)
            self.lost_attempts += 1
            lost = self.lost_attempts >= cfg.lost_after
        if lost:
            self.lose()
        return lost

    def _relocalise_near(self, points: FloatArray) -> None:
        """A local global search (1 x 1 m around the estimate, any heading)."""
        x, y = self.pose.x, self.pose.y
        region = np.array([[x - 0.5, y - 0.5], [x + 0.5, y - 0.5], [x + 0.5, y + 0.5], [x - 0.5, y + 0.5]])
        result = self.localiser.global_search(region, points)
        if result.margin > self.localiser.config.unique_margin:
            self.pose = result.pose
        self.unhealthy_steps = 0

    def search(self, odom: Pose, points: FloatArray, relocalising: bool, steps: int) -> Found | None:
        """One step of the search while turning in place: after every `localise_turn_rad`, the
        scans so far (joined at their odometry offsets) against the start area, or with
        `relocalising` the whole map; found when one pose explains them clearly better than any
        other, or after a full turn, the best. None: turn on (at `turn_radps`)."""
        cfg = self.config
        if self.odom0 is None:
            self.odom0 = odom
        offset = compose(inverse(self.odom0), odom)  # this scan's pose in the first scan's frame
        if self.turned_since_search >= cfg.localise_turn_rad:
            self.loc_points.append(self._moved(offset, points))
            joined = np.vstack(self.loc_points)
            if relocalising:
                result = self.localiser.search_everywhere(self.given.free_positions(), joined)
                # The pose it had when it was judged lost, unless a pose elsewhere clearly beats
                # it: a hospital's rooms look alike, and a false alarm must not move it.
                kept = self.localiser.refine(self._lost_from, joined)
                kept_score = float(self.localiser.scores(np.array([tuple(kept)]), joined)[0])
                if (result.score - kept_score) * len(joined) < self.localiser.config.unique_margin:
                    result = dataclasses.replace(result, pose=kept, rival_score=-math.inf)
            else:
                result = self.localiser.global_search(self.given.region(), joined)
            self.turned_since_search = 0.0
            needed = self.localiser.config.unique_margin
            if relocalising:  # the whole map holds far more look-alikes than a start area
                needed *= 1.0 if len(self.loc_points) >= 3 else math.inf
            if result.margin > needed or self.turned_total > 2.0 * math.pi:
                before, self.pose = self.pose, compose(result.pose, offset)
                moved_far = False
                if not self.localised:
                    self.localised = True
                    self.localise_s = steps * self.dt_s
                else:
                    self.relocalised += 1
                    moved_far = math.hypot(self.pose.x - before.x, self.pose.y - before.y) > 0.3
                self.unhealthy_steps = 0
                self.lost_attempts = 0
                return Found(moved_far)
        self.turned_since_search += self.turn_radps * self.dt_s
        self.turned_total += self.turn_radps * self.dt_s
        return None

    @staticmethod
    def _moved(offset: Pose, points: FloatArray) -> FloatArray:
        c, sn = math.cos(offset.theta), math.sin(offset.theta)
        return np.column_stack(
            [offset.x + c * points[:, 0] - sn * points[:, 1], offset.y + sn * points[:, 0] + c * points[:, 1]]
        )

    def check_elsewhere(self, odom: Pose, points: FloatArray) -> bool:
        """A doubtful pose against the whole map: True (lost) when a pose elsewhere explains the
        last few scans (joined at their odometry offsets) far better, twice in a row at the same
        place (moved by odometry): clutter that happens to line up with walls elsewhere seldom
        does so twice."""
        joined = joined_at_offsets(odom, self._recent[:-1], points)
        result = self.localiser.search_everywhere(self.given.free_positions(), joined)
        here = float(self.localiser.scores(np.array([tuple(self.pose)]), joined)[0])
        far = math.hypot(result.pose.x - self.pose.x, result.pose.y - self.pose.y) > 0.5
        if not (far and result.score - here > self.config.doubt_gain):
            self._elsewhere = None
            return False
        before = self._elsewhere
        self._elsewhere = (odom, result.pose)
        if before is not None:
            then, there = before
            expected = compose(there, compose(inverse(then), odom))
            if (
                math.hypot(expected.x - result.pose.x, expected.y - result.pose.y) < 0.3
                and abs(wrap_angle(expected.theta - result.pose.theta)) < 0.3
            ):
                self._elsewhere = None
                return True
        return False

    def lose(self) -> None:
        """The pose is lost (kidnapped, or the registration slid off): the next search covers
        the whole map."""
        self._lost_from = self.pose
        self.odom0 = None
        self.loc_points = []
        self.turned_since_search = math.inf
        self.turned_total = 0.0
