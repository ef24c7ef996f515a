"""The escape room's exit as a point goal from the robot's own perception (`agents/exit_goal.py`)."""

from __future__ import annotations

import json
import math

import gymnasium as gym
import numpy as np
import pytest

from pico_gym.agents import make_agent
from pico_gym.agents.base import RobotSpec
from pico_gym.agents.exit_goal import INTO_CORRIDOR_M, LEAD_M, NO_GOAL, ExitGoal, ExitGoalObservation
from pico_gym.agents.mlp import MlpActor
from pico_gym.agents.ppo import PpoAgent
from pico_gym.wrappers import POINT_GOAL_RANGE_M, LearningConfig, LearningEncoder, PicoLearningWrapper


def _goal_in_map(env: gym.Env, obs: dict[str, np.ndarray], goal: np.ndarray) -> tuple[np.ndarray, float]:
    """The encoded goal point and facing, back in the map frame (through the env's odometry frame)."""
    r, sb, cb, se, ce = (float(v) for v in goal)
    d = 0.1 * math.expm1(r * math.log1p(POINT_GOAL_RANGE_M / 0.1))
    x, y, th = (float(v) for v in obs["odom"])
    px, py = x + d * math.cos(th + math.atan2(sb, cb)), y + d * math.sin(th + math.atan2(sb, cb))
    m = env.unwrapped.map_from_odom
    c, s = math.cos(m.theta), math.sin(m.theta)
    return np.array([m.x + c * px - s * py, m.y + s * px + c * py]), th + m.theta + math.atan2(se, ce)


def _corridor(env: gym.Env) -> tuple[np.ndarray, np.ndarray]:
    """The generated room's mouth centre and the unit direction down its corridor."""
    room = env.unwrapped.episode.extra["room"]
    mouth = room.mouth.mean(axis=0)
    finish = np.asarray(room.map.finish).mean(axis=0)
    return mouth, (finish - mouth) / np.linalg.norm(finish - mouth)


def test_the_exit_goal_is_the_mouth_seen_twice_where_it_is():
    """Nothing on the first scan (a mouth counts once seen twice); from the second, the goal lies
    INTO_CORRIDOR_M inside the true mouth facing down the corridor (from LRF and odometry only)."""
    env = gym.make("PicoEscape-v0")
    spec = RobotSpec.of(env)
    errors, facing = [], []
    for seed in range(40):
        obs, _ = env.reset(seed=seed)
        goal = ExitGoal(spec, every=1)
        assert np.array_equal(goal.reset(obs), NO_GOAL)
        obs, *_ = env.step(np.zeros(3, np.float32))
        encoded = goal.update(obs)
        if np.array_equal(encoded, NO_GOAL):
            continue  # the mouth is not in view from this start
        point, heading = _goal_in_map(env, obs, encoded)
        mouth, along = _corridor(env)
        errors.append(float(np.linalg.norm(point - (mouth + INTO_CORRIDOR_M * along))))
        facing.append(abs(math.remainder(heading - math.atan2(along[1], along[0]), 2 * math.pi)))
    assert len(errors) >= 20
    assert max(errors) < 0.2 and max(facing) < 0.1


def test_the_exit_goal_leads_down_the_corridor_not_back_to_the_mouth():
    """Inside the corridor the goal is LEAD_M ahead of the robot along the corridor's axis."""
    env = ExitGoalObservation(gym.make("PicoEscape-v0"), every=1)
    agent = make_agent("classic", env.unwrapped)
    obs, info = env.reset(seed=1)
    agent.reset(obs, info)
    leads = []
    for _ in range(600):
        obs, _, terminated, truncated, info = env.step(agent.act(obs))
        if terminated or truncated:
            break
        if np.array_equal(obs["point_goal"], NO_GOAL):
            continue
        mouth, along = _corridor(env)
        pose = env.unwrapped.pose
        here = float((np.array([pose.x, pose.y]) - mouth) @ along)
        if here > 0.2:  # well inside the corridor
            point, _ = _goal_in_map(env, obs, obs["point_goal"])
            leads.append(float((point - mouth) @ along) - here)
    assert info["is_success"] and len(leads) >= 5
    assert np.allclose(leads, LEAD_M, atol=0.15)


def test_exit_goal_arguments_and_placement_are_checked():
    with pytest.raises(ValueError, match="every"):
        ExitGoal(RobotSpec.of(gym.make("PicoEscape-v0")), every=0)
    with pytest.raises(ValueError, match="before PicoLearningWrapper"):
        ExitGoalObservation(PicoLearningWrapper(gym.make("PicoEscape-v0")))


def test_a_policy_with_the_exit_goal_plays_as_it_was_trained(tmp_path):
    """A PpoAgent whose metadata says point_goal_source 'exit' tracks the exit itself on a plain
    env, and acts exactly as the policy does on its training wrapper's encoding."""
    env = gym.make("PicoEscape-v0")
    spec = RobotSpec.of(env)
    learning = LearningConfig(n_sectors=16, frame_stack=2, memory_sectors=8, range_scale="log", point_goal=True)
    size = LearningEncoder(spec.lrf, spec.robot, spec.dt_s, learning).space.shape[0]
    rng = np.random.default_rng(0)
    actor = MlpActor(
        weights=(rng.normal(0, 0.3, (32, size)).astype(np.float32), rng.normal(0, 0.3, (3, 32)).astype(np.float32)),
        biases=(np.zeros(32, np.float32), np.zeros(3, np.float32)),
        activation="tanh",
        log_std=np.zeros(3, np.float32),
        action_low=-np.ones(3, np.float32),
        action_high=np.ones(3, np.float32),
    )
    path = actor.save(tmp_path / "exit.npz")
    meta = {"algo": "ppo", "learning": learning.to_dict(), "point_goal_source": "exit", "exit_goal": {"every": 2}}
    path.with_suffix(".json").write_text(json.dumps(meta))
    agent = PpoAgent(spec, path=path)

    wrapped = ExitGoalObservation(gym.make("PicoEscape-v0"), every=2)
    encoder = LearningEncoder(spec.lrf, spec.robot, spec.dt_s, learning)
    obs, info = env.reset(seed=7)
    seen, _ = wrapped.reset(seed=7)
    agent.reset(obs, info)
    x = encoder.reset(seen)
    goals = 0
    for _ in range(120):
        action = agent.act(obs)
        expected = spec.robot.action_low + (actor.act(x) + 1.0) * 0.5 * (spec.robot.action_high - spec.robot.action_low)
        np.testing.assert_allclose(action, expected.astype(np.float32), rtol=0, atol=1e-6)
        obs, _, terminated, truncated, _ = env.step(action)
        seen, *_ = wrapped.step(action)
        goals += not np.array_equal(seen["point_goal"], NO_GOAL)
        if terminated or truncated:
            break
        x = encoder.encode(seen)
    assert goals > 0  # the goal was in the input, not only NO_GOAL

    meta["exit_goal"] = {"every": 0}
    path.with_suffix(".json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match="exit_goal"):
        PpoAgent(spec, path=path)
