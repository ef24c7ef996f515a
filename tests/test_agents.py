"""The agent interface, the classic agent on the env (CI rollout), and the run/bench commands."""

from __future__ import annotations

import json
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from helpers import EPISODE_FIELDS, SUMMARY_FIELDS

import pico_gym  # noqa: F401
from pico_gym.agents import AGENTS, PRIVILEGED_AGENTS, make_agent
from pico_gym.agents.base import RobotSpec
from pico_gym.agents.classic.features import extract_features
from pico_gym.agents.classic.split_merge import preprocess, split_and_merge
from pico_gym.agents.evaluation import run_episode
from pico_gym.cli import main
from pico_gym.overlay import Overlay
from pico_gym.world.geometry import inverse, transform_points


@pytest.mark.parametrize("name", [a for a in AGENTS if a not in PRIVILEGED_AGENTS])
def test_every_agent_acts_within_the_action_space(name: str) -> None:
    env = gym.make("PicoHospital-v0" if name == "hybrid" else "PicoEscape-v0")
    if name == "hybrid":
        from pico_gym.agents.hybrid import SHIPPED_HYBRID_POLICY

        if not SHIPPED_HYBRID_POLICY.exists():
            pytest.skip("no hybrid policy shipped")
    agent = make_agent(name, env)
    obs, info = env.reset(seed=0)
    agent.reset(obs, info)
    for _ in range(20):
        action = agent.act(obs)
        assert env.action_space.contains(action)
        obs, *_ = env.step(action)


def test_unknown_agent_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="unknown agent 'magic'; agents: classic"):
        make_agent("magic", gym.make("PicoEscape-v0"))


def test_agents_get_only_the_robot_spec() -> None:
    env = gym.make("PicoEscape-v0")
    agent = make_agent("classic", env)
    assert isinstance(agent.spec, RobotSpec)
    assert not any(isinstance(v, gym.Env) for v in vars(agent).values())


@pytest.mark.slow
def test_classic_escapes_20_fixed_seeds_without_bumping() -> None:
    env = gym.make("PicoEscape-v0")
    agent = make_agent("classic", env)
    records = [run_episode(env, agent, seed, "classic") for seed in range(500, 520)]
    failed = [(r.seed, r.termination_reason, r.bumps) for r in records if not r.success or r.bumps]
    assert failed == []
    assert all(r.time_s < 120 for r in records)


@pytest.mark.parametrize(
    "name", ["escape_2018", "escape_2019", "escape_2020_corner", "escape_small", "escape_student_2019"]
)
def test_classic_escapes_the_shipped_maps(name: str) -> None:
    env = gym.make("PicoEscape-v0", map=name)
    agent = make_agent("classic", env)
    records = [run_episode(env, agent, seed, "classic") for seed in range(3)]
    assert [(r.success, r.bumps) for r in records] == [(True, 0)] * 3


def features_at(map_name: str, pose: tuple[float, float, float]):
    env = gym.make("PicoEscape-v0", map=map_name)
    obs, _ = env.reset(seed=0, options={"start_pose": pose})
    angles = env.unwrapped.lrf.beam_angles
    scan = preprocess(obs["lrf"], angles, 0.01, 10.0)
    lines = split_and_merge(scan)
    return extract_features(scan, lines, obs["lrf"], angles, 10.0), env.unwrapped


@pytest.mark.parametrize(
    "map_name,pose,mouth",
    [
        ("escape_2018", (2.0, 2.0, 1.4), [[1.5, 5.0], [2.5, 5.0]]),  # mid-wall exit
        ("escape_2020_corner", (1.5, 2.0, 2.0), [[0.0, 4.2], [0.6, 4.2]]),  # flush with a corner
        ("escape_2019", (3.5, 1.5, 0.3), [[5.6, 2.55], [5.58, 3.1]]),  # narrow, crooked
    ],
)
def test_exit_detection_on_env_scans(map_name: str, pose: tuple, mouth: list) -> None:
    features, env = features_at(map_name, pose)
    mouth_robot = transform_points(inverse(env.pose), np.array(mouth, dtype=float))
    found = [e for e in features.exits if np.linalg.norm(e.centre - mouth_robot.mean(axis=0)) < 0.1]
    assert len(found) == 1 and len(features.exits) == 1
    assert found[0].width == pytest.approx(np.linalg.norm(mouth_robot[1] - mouth_robot[0]), abs=0.06)


def test_classic_overlay_draws_its_view() -> None:
    env = gym.make("PicoEscape-v0", render_mode="rgb_array")
    agent = make_agent("classic", env)
    obs, info = env.reset(seed=1)
    agent.reset(obs, info)
    for _ in range(15):
        obs, *_ = env.step(agent.act(obs))
    overlay = agent.overlay()
    assert isinstance(overlay, Overlay) and len(overlay.segments) > 0 and overlay.text.startswith("classic")
    env.unwrapped.set_overlay(agent.overlay)
    assert env.render().shape == (640, 640, 3)


def test_bench_json_has_the_documented_fields(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "bench.json"
    assert (
        main(
            [
                "bench",
                "--agent",
                "classic",
                "--episodes",
                "3",
                "--seed",
                "7",
                "--workers",
                "1",
                "--quiet",
                "--json",
                str(out),
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    for key in (
        "success rate",
        "bump rate",
        "idle / timeout",
        "time median / p90 (successes)",
        "SPL",
        "SCT",
        "mean min clearance",
        "act() compute",
    ):
        assert key in text
    data = json.loads(out.read_text())
    assert [e["seed"] for e in data["episodes"]] == [7, 8, 9]
    for e in data["episodes"]:
        assert EPISODE_FIELDS <= set(e)
    summary = data["summary"]["classic"]  # compare's layout: a summary per agent
    assert SUMMARY_FIELDS <= set(summary)
    assert 0.0 <= summary["success_rate"] <= 1.0 and not math.isnan(summary["spl"])
    assert data["settings"]["env_id"] == "PicoEscape-v0"
    assert data["settings"]["episodes"] == [{"group": "generated", "env_kwargs": {}, "seeds": [7, 8, 9]}]


@pytest.mark.slow
def test_run_prints_the_outcome_and_writes_a_gif(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gif = tmp_path / "run.gif"
    assert main(["run", "--agent", "classic", "--map", "escape_small", "--gif", str(gif)]) == 0
    out = capsys.readouterr().out
    assert "outcome: escaped" in out and "shortest path" in out and gif.is_file()


def test_classic_thresholds_are_times_not_steps() -> None:
    from pico_gym.agents.classic.agent import ClassicAgent, EscapeState

    coarse = make_agent("classic", gym.make("PicoEscape-v0"))
    fine = make_agent("classic", gym.make("PicoEscape-v0", dt_s=0.05))
    assert isinstance(coarse, ClassicAgent) and coarse.state is EscapeState.START
    ratio = coarse.spec.dt_s / fine.spec.dt_s
    for name in ("_replan", "_memory", "_start_look", "_start_timeout", "_explore_timeout", "_backoff_steps"):
        assert getattr(fine, name) == round(ratio * getattr(coarse, name)), name  # the same seconds


def test_backoff_moves_away_then_looks_again() -> None:
    """BACKOFF (stuck or boxed in) steps, moves away from what is near and hands over to LOOK after
    `backoff_s` (its step count once shadowed the state's handler: every BACKOFF crashed)."""
    from pico_gym.agents.classic.agent import EscapeState

    env = gym.make("PicoEscape-v0")
    agent = make_agent("classic", env)
    obs, info = env.reset(seed=0)
    agent.reset(obs, info)
    agent._go(EscapeState.BACKOFF)
    states = []
    for _ in range(round(agent.config.backoff_s / agent.spec.dt_s) + 2):
        action = agent.act(obs)
        assert env.action_space.contains(action)
        states.append(agent.state)
        obs, *_ = env.step(action)
    assert states[0] is EscapeState.BACKOFF and states[-1] is EscapeState.LOOK


def test_perception_is_one_value_both_agents_read() -> None:
    from pico_gym.agents.classic.perception import perceive

    env = gym.make("PicoEscape-v0", map="escape_2019")
    obs, _ = env.reset(seed=0)
    spec = RobotSpec.of(env)
    percept = perceive(obs["lrf"], spec.beam_angles, spec.lrf)
    scan = preprocess(np.asarray(obs["lrf"], float), spec.beam_angles, spec.lrf.range_min_m, spec.lrf.range_max_m)
    assert np.array_equal(percept.scan.points, scan.points)
    assert np.array_equal(percept.lines.segments, split_and_merge(scan).segments)
    directions = percept.long_line_directions()
    assert np.allclose(np.hypot(directions[:, 0], directions[:, 1]), 1.0)


def test_run_takes_the_reset_options(capsys: pytest.CaptureFixture[str]) -> None:
    # `run --option` used to be accepted and ignored: it must reach the reset (a bad one is refused).
    assert main(["run", "--env", "PicoHospital-v0", "--map", "hospital_2019", "--option", "cabinet_order=[99]"]) == 2
    assert "--option" in capsys.readouterr().err
    args = ["run", "--env", "PicoHospital-v0", "--map", "hospital_2019", "--seed", "3", "--option", "cabinet_order=[0]"]
    assert main([*args, "--set", "n_movers=(0, 0)", "--set", "n_boxes=(0, 0)", "--set", "n_closed_doors=(0, 0)"]) == 0
    out = capsys.readouterr().out
    assert "outcome: done" in out


def test_the_ppo_agents_shield_keeps_the_footprint_off_what_the_scan_shows() -> None:
    """`PpoAgent(shield=True)`: the twist passes the classic safety filter on the current scan."""
    from pico_gym.agents.ppo import PpoAgent

    env = gym.make("PicoEscape-v0")
    spec = RobotSpec.of(env)
    agent = PpoAgent(spec, shield=True)
    ranges = np.full(spec.lrf.n_beams, spec.lrf.range_max_m, np.float32)
    ranges[np.abs(spec.beam_angles) < math.radians(30.0)] = 0.15  # a wall 5 cm ahead of the front
    obs = {"lrf": ranges, "odom": np.zeros(3, np.float32)}
    vx, vy, w = agent._shielded(obs, np.array([spec.robot.max_speed_mps, 0.0, 0.0]))
    assert vx < 0.05 * spec.robot.max_speed_mps  # not into the wall
    free = {"lrf": np.full(spec.lrf.n_beams, spec.lrf.range_max_m, np.float32), "odom": np.zeros(3, np.float32)}
    assert agent._shielded(free, np.array([0.3, 0.1, 0.5])).tolist() == pytest.approx([0.3, 0.1, 0.5])
    with pytest.raises(ValueError, match="shield"):
        PpoAgent(spec, shield=1)  # type: ignore[arg-type]
