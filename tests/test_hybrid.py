"""The hybrid hospital agent: the classic route and states, a policy driving between waypoints."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from helpers import person_paused_behind

import pico_gym  # noqa: F401
from pico_gym.agents import make_agent
from pico_gym.agents.base import RobotSpec
from pico_gym.agents.classic.hospital import State, states
from pico_gym.agents.classic.potential_field import MotionConfig
from pico_gym.agents.hybrid import HybridAgent, HybridConfig, waypoint_along
from pico_gym.agents.mlp import MlpActor
from pico_gym.agents.shield import ScanMemory, SeenFree, behind_seen_free, blind_translation, blind_turn
from pico_gym.train.hybrid import HybridTraining
from pico_gym.types import Pose
from pico_gym.wrappers import LearningConfig, LearningEncoder

LEARNING = LearningConfig(n_sectors=64, frame_stack=2, memory_sectors=36, range_scale="log", point_goal=True)
QUIET = {"map": "hospital_2019", "n_closed_doors": (0, 0), "n_boxes": (0, 0), "n_movers": (0, 0)}


def _policy_file(tmp_path, env: gym.Env, scale: float = 0.0, bias=(0.0, 0.0, 0.0)):  # type: ignore[no-untyped-def]
    """A policy file of the hybrid's input size: zero weights (it always gives `bias`, in [-1, 1]
    action units: by default the middle of the action range, i.e. it stands still) unless `scale`."""
    spec = RobotSpec.of(env)
    n = LearningEncoder(spec.lrf, spec.robot, spec.dt_s, LEARNING).space.shape[0]
    rng = np.random.default_rng(0)
    w1, w2 = scale * rng.standard_normal((16, n)), scale * rng.standard_normal((3, 16))
    actor = MlpActor(
        (w1.astype(np.float32), w2.astype(np.float32)),
        (np.zeros(16, np.float32), np.asarray(bias, np.float32)),
        "tanh",
        np.zeros(3, np.float32),
        -np.ones(3, np.float32),
        np.ones(3, np.float32),
    )
    path = actor.save(tmp_path / "hybrid.npz")
    path.with_suffix(".json").write_text(json.dumps({"algo": "ppo", "learning": LEARNING.to_dict()}))
    return path


def test_the_waypoint_lies_along_the_route() -> None:
    path = [np.array([1.0, 0.0]), np.array([1.0, 3.0])]
    assert waypoint_along(np.zeros(2), path, 0.5).tolist() == [0.5, 0.0]
    assert waypoint_along(np.zeros(2), path, 2.0).tolist() == [1.0, 1.0]
    assert waypoint_along(np.zeros(2), path, 10.0).tolist() == [1.0, 3.0]  # the route's end


def test_the_training_wrapper_hands_the_policy_only_navigation_steps() -> None:
    env = HybridTraining(gym.make("PicoHospital-v0", **QUIET))
    obs, info = env.reset(seed=1)
    assert set(obs) == {"lrf", "odom", "point_goal"} and env.observation_space.contains(obs)
    assert env.driver.state is State.NAVIGATE  # LOCALISE went by inside reset
    for _ in range(50):
        teacher = env.teacher_action()
        assert teacher.shape == (3,) and np.all(np.abs(teacher) <= 1.0)
        obs, reward, terminated, truncated, info = env.step(np.array(env.driver.command))
        assert env.driver.state is State.NAVIGATE or terminated or truncated
        if terminated or truncated:
            break
    assert env.classic_steps > 0  # the localising turn, at least


def test_the_hybrid_agent_plays_from_public_information_only(tmp_path) -> None:  # type: ignore[no-untyped-def]
    env = gym.make("PicoHospital-v0", **QUIET)
    agent = make_agent("hybrid", env, path=_policy_file(tmp_path, env, scale=0.1))
    obs, info = env.reset(seed=2)
    agent.reset(obs, {"task": info["task"]})  # the privileged info keys removed
    drove = 0
    for _ in range(300):
        action = agent.act(obs)
        assert env.action_space.contains(action)
        drove += agent.state is State.NAVIGATE
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    assert drove > 0 and agent.belief() is not None
    assert "hybrid" in agent.overlay().text


def test_a_policy_of_the_wrong_size_is_refused(tmp_path) -> None:  # type: ignore[no-untyped-def]
    env = gym.make("PicoHospital-v0", **QUIET)
    path = _policy_file(tmp_path, env)
    meta = json.loads(path.with_suffix(".json").read_text())
    meta["learning"]["n_sectors"] = 32
    path.with_suffix(".json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match="expects observations of length"):
        HybridAgent(RobotSpec.of(env), path=path)


def test_hybrid_config_is_validated() -> None:
    with pytest.raises(ValueError, match="lookahead_m"):
        HybridConfig(lookahead_m=0.0)
    with pytest.raises(ValueError, match="blind_near_m"):
        HybridConfig(blind_near_m=-1.0)
    with pytest.raises(ValueError, match="blind_translation"):
        HybridConfig(blind_translation=1)  # type: ignore[arg-type]


def test_the_hybrid_plays_the_hospital_only() -> None:
    with pytest.raises(ValueError, match="PicoHospital-v0 only"):
        make_agent("hybrid", gym.make("PicoEscape-v0"))


def test_the_goal_is_reached_once_every_cabinet_is_done() -> None:
    """The training run crashed here: a wrapper step after the agent believed the order done."""
    env = gym.make("PicoHospital-v0", **QUIET)
    agent = HybridAgent(RobotSpec.of(env), driver=True)
    obs, info = env.reset(seed=1)
    agent.reset(obs, {"task": info["task"]})
    agent.done = len(agent.order)
    assert agent.goal().tolist() == [0.0, 0.0, 1.0, 0.0, 1.0]


def test_hybrid_config_refuses_a_bad_blind_memory() -> None:
    with pytest.raises(ValueError, match="blind_memory_s"):
        HybridConfig(blind_memory_s=-1.0)


def test_the_shield_remembers_what_the_lrf_saw_before_it_turned_into_the_blind_sector() -> None:
    """A point seen at +100 deg is behind the robot (+160 deg) after a 60 deg turn on the spot:
    the shield keeps it (in the odometry frame) for `blind_memory_s`, then forgets it."""
    env = gym.make("PicoHospital-v0", **QUIET)
    spec = RobotSpec.of(env)
    obs, info = env.reset(seed=1)
    angles = spec.beam_angles
    empty = np.full(len(angles), spec.lrf.range_max_m, np.float32)
    one = empty.copy()
    one[int(np.argmin(np.abs(angles - np.radians(100.0))))] = 0.5
    odom = np.asarray(obs["odom"], np.float64)
    turned = {"lrf": empty, "odom": (odom - [0.0, 0.0, np.radians(60.0)]).astype(np.float32)}
    behind = 0.5 * np.array([np.cos(np.radians(160.0)), np.sin(np.radians(160.0))])

    def remembers(agent: HybridAgent) -> bool:
        return bool(
            (np.hypot(*(agent.world.remembered(agent.pose, agent._memory, agent._odom) - behind).T) < 0.01).any()
        )

    seen = {}
    for memory in (0.0, 4.0):
        agent = HybridAgent(spec, driver=True, hybrid=HybridConfig(blind_memory_s=memory))
        agent.reset(obs, {"task": info["task"]})
        agent._sense({"lrf": one, "odom": odom.astype(np.float32)})
        agent._sense(turned)
        seen[memory] = remembers(agent)
        if memory:
            for _ in range(40):  # 4 s more
                agent._sense(turned)
            assert not remembers(agent)
    assert seen == {0.0: False, 4.0: True}


@pytest.mark.slow
def test_the_classic_part_drives_the_rest_of_a_leg_the_policy_got_stuck_on(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A policy that only ever drives sideways at full speed ends against a wall, the shield stops
    it, and the never-stand-still rule recovers; after `fallback_after` such recoveries on a leg
    the classic part drives (and gets the robot somewhere)."""
    env = gym.make("PicoHospital-v0", **QUIET)
    path = _policy_file(tmp_path, env, bias=(0.0, 1.0, 0.0))
    for fallback_after, classic_drives in ((2, True), (0, False)):
        agent = make_agent("hybrid", env, path=path, hybrid=HybridConfig(fallback_after=fallback_after))
        obs, info = env.reset(seed=2)
        agent.reset(obs, info)
        recoveries, classic_navigating = 0, 0
        for _ in range(1500):
            state = agent.state
            obs, _, terminated, truncated, info = env.step(agent.act(obs))
            recoveries += state is not State.RECOVER and agent.state is State.RECOVER
            classic_navigating += agent.state is State.NAVIGATE and agent.classic_leg
            if terminated or truncated or classic_navigating >= 20:
                break
        assert recoveries >= 2
        assert (classic_navigating >= 20) is classic_drives


MOTION = MotionConfig()  # PICO: 0.2 m deep, 0.4 m wide, 0.35 s horizon


def test_the_turn_is_cut_when_the_rear_would_swing_into_unseen_space() -> None:
    """Backing sideways at the edge of the view while turning towards that side swings the rear
    corner through the blind sector (the dev bumps); turning the other way, driving forward or
    turning in place do not, and the turn is kept."""
    lo, hi = -2.0, 2.0
    assert blind_turn((-0.15, -0.5, -1.2), MOTION, lo, hi) == 0.0
    assert blind_turn((-0.15, 0.5, 1.2), MOTION, lo, hi) == 0.0  # the mirror image
    assert blind_turn((0.0, -0.5, -1.2), MOTION, lo, hi) == -0.6  # half the turn keeps the rear in view
    for command in [(0.5, 0.0, 1.2), (0.5, 0.0, -1.2), (0.0, 0.0, 1.2), (0.3, -0.4, -1.2), (-0.15, -0.5, 0.0)]:
        assert blind_turn(command, MOTION, lo, hi) == command[2]
    # Where the rear goes was seen free: the turn is kept.
    assert blind_turn((-0.15, -0.5, -1.2), MOTION, lo, hi, seen_free=lambda p: np.ones(len(p), bool)) == -1.2
    assert blind_turn((-0.15, -0.5, -1.2), MOTION, lo, hi, seen_free=lambda p: np.zeros(len(p), bool)) == 0.0


def test_a_translation_is_cut_when_the_leading_rear_corner_would_enter_unseen_space() -> None:
    """Backing sideways at the view's edge leads with the rear corner through the blind sector
    (a person who walked up behind was backed into so): cut unless that space was seen free.
    Forward, sideways within view and a creep within the slack are kept; the turn is not
    this function's."""
    lo, hi = -2.0, 2.0
    assert blind_translation((-0.12, -0.43, 0.0), MOTION, lo, hi) == (0.0, 0.0)
    assert blind_translation((-0.12, 0.43, 0.0), MOTION, lo, hi) == (0.0, 0.0)  # the mirror image
    assert blind_translation((-0.5, 0.0, 0.0), MOTION, lo, hi) == (0.0, 0.0)  # straight back
    for command in [(0.5, 0.0, 0.0), (0.3, -0.4, 0.0), (0.0, 0.25, 0.0), (-0.05, 0.0, 0.0), (0.0, -0.5, 1.2)]:
        assert blind_translation(command, MOTION, lo, hi) == command[:2]
    free = lambda p: np.ones(len(p), bool)  # noqa: E731
    assert blind_translation((-0.12, -0.43, 0.0), MOTION, lo, hi, seen_free=free) == (-0.12, -0.43)


def test_without_may_back_a_backward_creep_is_dropped_and_the_rest_kept() -> None:
    """A creep backwards stays within one step's prediction slack but, kept up for seconds, backs
    the robot into a person standing (paused) just behind it (dev busy 2019 9022, 9135, 9165):
    with `may_back` false its backward part is dropped and the sideways part kept."""
    lo, hi = -2.0, 2.0
    assert blind_translation((-0.05, 0.0, 0.0), MOTION, lo, hi, may_back=False) == (0.0, 0.0)
    assert blind_translation((-0.03, 0.01, 0.0), MOTION, lo, hi, may_back=False) == (0.0, 0.01)
    assert blind_translation((0.3, 0.1, 0.0), MOTION, lo, hi, may_back=False) == (0.3, 0.1)
    free = lambda p: np.ones(len(p), bool)  # noqa: E731
    assert behind_seen_free(MOTION, free)
    assert not behind_seen_free(MOTION, lambda p: p[:, 1] > 0.0)  # half the strip unseen
    assert not behind_seen_free(MOTION, None)


def test_walk_in_lets_the_policy_back_only_within_its_budget(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """With `walk_in_mps`, a policy that backs into a strip nothing saw is let back
    `back_budget_m`, then only sideways; without it (the default), backing is left alone."""
    env = gym.make("PicoHospital-v0", **QUIET)
    dt = env.unwrapped.config.dt_s
    for walk_in, budget, expected_back in ((0.5, 0.1, 0.1), (0.0, 0.1, None)):
        agent = _agent_in(State.NAVIGATE, env, tmp_path, HybridConfig(walk_in_mps=walk_in, back_budget_m=budget))
        unseen = lambda p: np.zeros(len(p), bool)  # noqa: E731
        backed = 0.0
        for _ in range(40):
            vx, vy = agent._translate((-0.05, 0.02, 0.0), unseen)
            backed -= vx * dt
            assert vy == pytest.approx(0.02)
        assert backed == pytest.approx(expected_back if expected_back is not None else 40 * 0.05 * dt)
    for bad in (-0.1, 11.0, True):
        with pytest.raises(ValueError, match="back_budget_m"):
            HybridConfig(back_budget_m=bad)  # type: ignore[arg-type]


def test_seen_free_is_what_a_beam_passed_or_the_robot_stood_on() -> None:
    """A beam that ended at 2 m vouches for the points before it (not near its end, nor past
    it, nor outside the LRF's view); the footprint at a kept pose vouches for what it covered;
    after `seconds` both are forgotten."""
    seen = SeenFree(1.0, 0.1, -2.0, 2.0, 0.01, 10.0, 0.1, 0.2, every=1)
    ranges = np.full(1000, 2.0)
    seen.add(ranges, Pose(0.0, 0.0, 0.0))
    # The robot has since turned round on the spot: what was ahead is now behind it.
    now = Pose(0.0, 0.0, np.pi)
    ahead = np.array([[-1.0, 0.0], [-1.98, 0.0], [-2.5, 0.0], [1.0, 0.0], [0.05, 0.1], [-0.5, -0.5], [0.5, 0.5]])
    assert seen.free(ahead, now).tolist() == [True, False, False, False, True, True, False]
    for _ in range(10):
        seen.add(np.zeros(1000), now)  # nothing returned below the minimum range: shows nothing
    assert seen.free(ahead, now).tolist() == [False, False, False, False, True, False, False]


def test_seen_free_space_is_taken_back_at_a_walking_speed() -> None:
    """With `walk_in_mps`, a beam's free stretch shortens and a kept pose's footprint shrinks by
    that speed times their age: a person may have walked in since."""
    seen = SeenFree(4.0, 0.1, -2.0, 2.0, 0.01, 10.0, 0.1, 0.2, every=1, walk_in_mps=0.5)
    seen.add(np.full(1000, 2.0), Pose(0.0, 0.0, 0.0))
    probe = np.array([[1.0, 0.0], [1.8, 0.0], [-0.05, 0.1]])  # the last behind the view
    assert seen.free(probe, Pose(0.0, 0.0, 0.0)).tolist() == [True, True, True]
    for _ in range(4):  # 0.4 s later, from a pose 1 m to the side (its own scans see nothing)
        seen.add(np.zeros(1000), Pose(0.0, 1.0, 0.0))
    # 0.2 m taken back: 1.8 m is no longer vouched for, nor the old footprint (0.1 m deep).
    assert seen.free(probe, Pose(0.0, 0.0, 0.0)).tolist() == [True, False, False]
    with pytest.raises(ValueError, match="walk_in_mps"):
        SeenFree(4.0, 0.1, -2.0, 2.0, 0.01, 10.0, 0.1, 0.2, walk_in_mps=-1.0)
    for bad in (-0.1, float("nan"), 6.0, True):
        with pytest.raises(ValueError, match="walk_in_mps"):
            HybridConfig(walk_in_mps=bad)  # type: ignore[arg-type]


def _seen_free_scan_by_scan(
    scans: list[tuple[np.ndarray, Pose, int]],
    poses: list[tuple[Pose, int]],
    points: np.ndarray,
    odom: Pose,
    now: int,
    decay: float,
) -> np.ndarray:
    """`SeenFree.free` as a loop over the kept scans and poses (view -2..2 rad, footprint 0.1 x 0.2)."""
    out = np.zeros(len(points), dtype=bool)
    c, s = np.cos(odom.theta), np.sin(odom.theta)
    wx, wy = odom.x + c * points[:, 0] - s * points[:, 1], odom.y + s * points[:, 0] + c * points[:, 1]
    for ranges, at, count in scans:
        dx, dy = wx - at.x, wy - at.y
        bearing = (np.arctan2(dy, dx) - at.theta + np.pi) % (2.0 * np.pi) - np.pi
        k = np.rint((bearing + 2.0) / 4.0 * (len(ranges) - 1)).astype(np.int64)
        inside = (k >= 0) & (k < len(ranges))
        out |= inside & (np.hypot(dx, dy) + 0.05 + decay * (now - count) < ranges[np.clip(k, 0, len(ranges) - 1)])
    for at, count in poses:
        dx, dy = wx - at.x, wy - at.y
        along, across = np.cos(at.theta) * dx + np.sin(at.theta) * dy, -np.sin(at.theta) * dx + np.cos(at.theta) * dy
        taken = decay * (now - count)
        out |= (np.abs(along) < 0.1 - taken) & (np.abs(across) < 0.2 - taken)
    return out


def test_seen_free_keeps_the_last_seconds_of_scans_and_poses() -> None:
    """Random walks with random scans: what `SeenFree` vouches for is what the kept scans (every
    second one, the last 2 s) and poses (the last 4 s) vouch for, aged or not."""
    rng = np.random.default_rng(1)
    for walk in range(4):
        seen = SeenFree(0.4, 0.1, -2.0, 2.0, 0.01, 3.0, 0.1, 0.2, every=2, walk_in_mps=0.3)
        scans, poses, odom = [], [], Pose(0.0, 0.0, 0.0)
        for count in range(1, 30):
            odom = Pose(odom.x + rng.normal(0, 0.05), odom.y + rng.normal(0, 0.05), odom.theta + rng.normal(0, 0.3))
            ranges = rng.uniform(0.0, 4.0, 50)
            ranges[rng.random(50) < 0.1] = np.inf
            seen.add(ranges, odom)
            poses = [*poses, (odom, count)][-4:]
            if (count - 1) % 2 == 0:
                r = np.where(np.isfinite(ranges), ranges, 3.0)
                r = np.where(r < 0.01, 0.0, np.minimum(r, 3.0))
                near = np.minimum(r, np.minimum(np.roll(r, 1), np.roll(r, -1)))
                near[0], near[-1] = min(r[0], r[1]), min(r[-1], r[-2])
                scans = [*scans, (near, odom, count)][-2:]
            points = rng.uniform(-1.0, 1.0, (40, 2))
            for aged in (False, True):
                expected = _seen_free_scan_by_scan(scans, poses, points, odom, count, 0.03 if aged else 0.0)
                assert seen.free(points, odom, aged=aged).tolist() == expected.tolist(), (walk, count, aged)
        seen.reset()
        assert not seen.free(points, odom).any()


def test_the_scan_memory_hands_back_the_last_seconds_of_near_points_oldest_first() -> None:
    memory = ScanMemory(0.3, 0.1, stride=1)  # three scans
    rng = np.random.default_rng(2)
    kept = []
    for _ in range(7):
        points = rng.uniform(-2.0, 2.0, (int(rng.integers(0, 30)), 2))
        memory.add(points, Pose(0.0, 0.0, 0.0))
        kept = [*kept, points[np.hypot(points[:, 0], points[:, 1]) < 1.2]][-3:]
        joined = np.vstack(kept)
        assert np.array_equal(memory.recent(Pose(0.0, 0.0, 0.0)), joined[(np.abs(joined) < 1.2).all(axis=1)])
    memory.reset()
    assert memory.recent(Pose(0.0, 0.0, 0.0)).shape == (0, 2)


def _agent_in(state: State, env: gym.Env, tmp_path, hybrid: HybridConfig) -> HybridAgent:  # type: ignore[no-untyped-def]
    """A hybrid agent (standing-still policy) one step into a quiet episode, put in `state`."""
    agent = make_agent("hybrid", env, path=_policy_file(tmp_path, env))
    agent.hybrid = hybrid
    obs, info = env.reset(seed=3)
    agent.reset(obs, info)
    agent.act(obs)
    agent._go(state)
    agent.still_steps = 0
    return agent


def test_docking_that_stands_still_recovers_after_dock_still_s(tmp_path) -> None:  # type: ignore[no-untyped-def]
    env = gym.make("PicoHospital-v0", **QUIET)
    for seconds, expected in ((3.0, State.RECOVER), (0.0, State.DOCK)):
        agent = _agent_in(State.DOCK, env, tmp_path, HybridConfig(dock_still_s=seconds))
        steps = int(round(3.0 / env.unwrapped.config.dt_s))
        states = []
        for _ in range(steps):
            agent.finish((0.0, 0.0, 0.0))  # the dock servo's command, cut to nothing
            states.append(agent.state)
        assert states[: steps - 1] == [State.DOCK] * (steps - 1)
        assert states[-1] is expected


def test_hybrid_config_refuses_a_bad_dock_still_s() -> None:
    for bad in (-1.0, float("nan"), 61.0, True, "3"):
        with pytest.raises(ValueError, match="dock_still_s"):
            HybridConfig(dock_still_s=bad)  # type: ignore[arg-type]


def test_a_wedged_recovery_turns_where_the_safety_filter_lets_it(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A wall touching the right side's corners: `safe_turn` allows no turn (a corner within
    `turn_keep_m`) and the recovery's translation into the wall is cut to nothing; with
    `recover_turn` the recovering robot turns (a sense the safety filter lets through), without it
    it stands."""
    env = gym.make("PicoHospital-v0", **QUIET)
    turns = {}
    for on in (True, False):
        agent = _agent_in(State.RECOVER, env, tmp_path, HybridConfig(recover_turn=on))
        m = agent.motion
        near = np.array([[m.half_depth + 0.002, -m.half_width - 0.002], [-m.half_depth - 0.002, -m.half_width - 0.002]])
        out = agent._finish(near, (0.0, -0.2, 0.0))  # sideways into the wall
        assert abs(out[0]) < 1e-9 and abs(out[1]) < 1e-9
        turns[on] = float(out[2])
    assert abs(turns[False]) < 1e-9
    assert abs(turns[True]) > 0.08
    # The turn it takes keeps the corner off the point (the safety filter's own verdict).
    from pico_gym.agents.classic.potential_field import safety_filter

    assert safety_filter(near, (0.0, 0.0, turns[True]), m)[2] == pytest.approx(turns[True])


def test_recovering_it_backs_away_from_a_person_it_tracked_out_of_view(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A person tracked walking who paused just behind the robot (out of the LRF's view, in no
    scan) is among what the classic part moves away from (`escape_people`); off, only the scan."""
    env = gym.make("PicoHospital-v0", n_movers=0, n_boxes=0, n_closed_doors=0)
    agent = _agent_in(State.RECOVER, env, tmp_path, HybridConfig())
    assert agent.localised
    behind = person_paused_behind(agent, 0.5)
    person = (-0.5, 0.0)  # robot frame
    assert any(np.allclose(q, person) for q in agent._unexplained_near())
    spot = states.escape_spot(agent, agent._unexplained_near())
    agent.hybrid = HybridConfig(escape_people=False)
    assert not any(np.allclose(q, person) for q in agent._unexplained_near())
    blind_spot = states.escape_spot(agent, agent._unexplained_near())
    # It backs off away from the person (1.25 m from it here; blind to it, 0.97 m).
    assert np.hypot(*(spot - behind)) > np.hypot(*(blind_spot - behind)) + 0.2
    with pytest.raises(ValueError, match="escape_people"):
        HybridConfig(escape_people=1)  # type: ignore[arg-type]


def test_hybrid_config_refuses_a_bad_recover_turn() -> None:
    with pytest.raises(ValueError, match="recover_turn"):
        HybridConfig(recover_turn="yes")  # type: ignore[arg-type]


def test_the_training_loop_and_its_evaluations_drive_with_the_configs_cuts(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    import pico_gym.agents.hybrid as hybrid_module
    from pico_gym.train.callbacks import policy_agent
    from pico_gym.train.config import goal_metadata, load_config

    config = load_config(Path(__file__).parents[1] / "train" / "configs" / "ppo_hospital_hybrid_walkin.yaml")
    assert config.hybrid_kwargs == {"lookahead_m": 1.0, "shield": True, "walk_in_mps": 0.5, "back_budget_m": 0.1}
    env = gym.make("PicoHospital-v0", **QUIET)
    wrapped = HybridTraining(env, **config.hybrid_kwargs)
    assert wrapped.driver.hybrid == HybridConfig(walk_in_mps=0.5, back_budget_m=0.1)
    with pytest.raises(ValueError, match="walk_in_mps"):
        HybridTraining(env, walk_in_mps=-1.0)
    # A policy saved from this config carries the cuts into the agent that plays it.
    assert goal_metadata(config) == {"hybrid": {"walk_in_mps": 0.5, "back_budget_m": 0.1}}
    # The periodic evaluations play the policy with the same cuts.
    monkeypatch.setattr(hybrid_module, "HybridAgent", lambda spec, **kwargs: kwargs)
    assert policy_agent(config, RobotSpec.of(env), model=None)["hybrid"] == wrapped.driver.hybrid


def test_a_policy_file_names_the_cuts_its_agent_drives_with(tmp_path) -> None:  # type: ignore[no-untyped-def]
    env = gym.make("PicoHospital-v0", **QUIET)
    path = _policy_file(tmp_path, env)
    assert HybridAgent(RobotSpec.of(env), path=path).hybrid == HybridConfig()  # none named: the defaults
    meta = {"algo": "ppo", "learning": LEARNING.to_dict(), "hybrid": {"walk_in_mps": 0.5}}
    path.with_suffix(".json").write_text(json.dumps(meta))
    assert HybridAgent(RobotSpec.of(env), path=path).hybrid.walk_in_mps == 0.5
    given = HybridConfig(lookahead_m=2.0)  # an explicit config wins
    assert HybridAgent(RobotSpec.of(env), path=path, hybrid=given).hybrid is given
    path.with_suffix(".json").write_text(json.dumps({**meta, "hybrid": {"walk_in_mps": -1}}))
    with pytest.raises(ValueError, match=r"hybrid\.json: the metadata's 'hybrid' settings: .*walk_in_mps"):
        HybridAgent(RobotSpec.of(env), path=path)


def test_the_hybrid_drives_its_classic_part_with_its_own_blind_sector_settings(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The classic agent's opt-in blind-sector options do not stack on the hybrid's own: its
    memory is `HybridConfig.blind_memory_s` long and its cuts are its own."""
    from pico_gym.agents.classic.hospital import HospitalAgentConfig

    env = gym.make("PicoHospital-v0", **QUIET)
    config = HospitalAgentConfig(blind_memory_s=10.0, people_cuts_m=2.0, escape_people=False)
    agent = make_agent("hybrid", env, path=_policy_file(tmp_path, env), config=config)
    agent.hybrid = HybridConfig(blind_memory_s=2.0)
    obs, info = env.reset(seed=3)
    agent.reset(obs, info)
    assert agent._memory.steps == round(2.0 / env.unwrapped.config.dt_s)
    assert agent._people_free is None
    assert agent._escapes_people()  # the hybrid's escape_people (on), not the config's


def test_after_a_long_leg_the_classic_part_drives_the_rest_of_it(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """`fallback_after_s`: once a leg has lasted that long, the classic part drives (no policy);
    a new leg starts the clock again; 0 never falls back on time."""
    env = gym.make("PicoHospital-v0", **QUIET)
    agent = _agent_in(State.NAVIGATE, env, tmp_path, HybridConfig(fallback_after_s=1.0))
    dt = env.unwrapped.config.dt_s
    assert not agent.classic_leg
    agent._leg_start = agent.steps - round(1.5 / dt)  # the leg began 1.5 s ago
    assert agent.classic_leg
    agent.hybrid = HybridConfig(fallback_after_s=0.0)
    assert not agent.classic_leg
    agent.hybrid = HybridConfig(fallback_after_s=1.0)
    agent.done += 1  # the next leg: its clock starts at this step
    obs, *_ = env.step(np.zeros(3, dtype=np.float32))
    agent.observe(obs)
    assert agent._leg_start == agent.steps and not agent.classic_leg


@pytest.mark.parametrize("bad", [-1.0, True, float("nan"), 1e6])
def test_hybrid_config_refuses_a_bad_fallback_after_s(bad: float) -> None:
    with pytest.raises(ValueError, match="fallback_after_s"):
        HybridConfig(fallback_after_s=bad)
