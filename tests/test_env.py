"""PicoEscape-v0's contract: checkers, spaces, determinism, episode ends, rewards, rendering."""

from __future__ import annotations

import hashlib
import pickle
import subprocess
import sys
import textwrap
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import pico_gym  # noqa: F401
from pico_gym.envs.base import EnvConfig
from pico_gym.overlay import Overlay
from pico_gym.tasks.escape import EscapeTaskConfig

FIXED = {"map": "escape_2018"}


@pytest.mark.parametrize("kwargs", [{}, FIXED, {"n_beams": 64, "n_obstacles": 3}])
def test_gymnasium_check_env(kwargs: dict) -> None:
    env = gym.make("PicoEscape-v0", **kwargs)
    check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("kwargs", [{}, FIXED])
def test_sb3_check_env(kwargs: dict) -> None:
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    sb3_check_env(gym.make("PicoEscape-v0", **kwargs).unwrapped, warn=True)


def test_spaces_match_the_spec() -> None:
    env = gym.make("PicoEscape-v0")
    assert set(env.observation_space.spaces) == {"lrf", "odom"}
    assert env.observation_space["lrf"].shape == (1000,)
    assert env.observation_space["lrf"].high.max() == pytest.approx(10.0)
    assert env.action_space.low == pytest.approx([-0.5, -0.5, -1.2])
    assert env.action_space.high == pytest.approx([0.5, 0.5, 1.2])
    obs, info = env.reset(seed=0)
    assert obs["odom"] == pytest.approx([0.0, 0.0, 0.0])  # odometry starts at zero
    assert {
        "pose",
        "odom_error",
        "bumps",
        "min_clearance",
        "sim_time",
        "path_length",
        "geodesic_to_finish",
        "shortest_path_length",
        "is_success",
        "termination_reason",
        "reward_terms",
    } <= set(info)


def test_pickling_an_env_mid_episode() -> None:
    env = gym.make("PicoEscape-v0", render_mode="rgb_array")
    env.reset(seed=1)
    env.step(np.array([0.1, 0.0, 0.2]))
    env.render()
    clone = pickle.loads(pickle.dumps(env))
    a = env.step(np.array([0.2, 0.1, -0.3]))
    b = clone.step(np.array([0.2, 0.1, -0.3]))
    assert np.array_equal(a[0]["lrf"], b[0]["lrf"]) and a[1] == b[1]
    assert clone.render().shape == (640, 640, 3)


def test_rgb_array_frames_and_overlay() -> None:
    env = gym.make("PicoEscape-v0", render_mode="rgb_array")
    env.reset(seed=2)
    plain = env.render()
    assert plain.shape == (640, 640, 3) and plain.dtype == np.uint8
    env.unwrapped.set_overlay(
        lambda: Overlay(frame="robot", segments=np.array([[0.4, -0.3, 0.4, 0.3]]), target=np.array([0.6, 0.0]))
    )
    drawn = env.render()
    assert (drawn != plain).any()


def test_human_mode_runs_headless() -> None:
    env = gym.make("PicoEscape-v0", render_mode="human")
    env.reset(seed=0)
    assert env.render() is None
    env.step(env.action_space.sample())
    env.close()


def test_record_video(tmp_path: Path) -> None:
    pytest.importorskip("moviepy")
    env = gym.wrappers.RecordVideo(
        gym.make("PicoEscape-v0", render_mode="rgb_array"), str(tmp_path), disable_logger=True
    )
    env.reset(seed=0)
    for _ in range(15):
        env.step(np.array([0.0, 0.0, 0.5]))
    env.close()
    assert list(tmp_path.glob("*.mp4"))


def rollout_digest(seed: int, steps: int = 150, **kwargs: object) -> str:
    env = gym.make("PicoEscape-v0", collision="continue", **kwargs)
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    h = hashlib.sha256()
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, 3) * [0.5, 0.5, 1.2])
        h.update(obs["lrf"].tobytes() + obs["odom"].tobytes() + np.float64(reward).tobytes())
        h.update(repr(sorted((k, repr(v)) for k, v in info.items())).encode())
        if terminated or truncated:
            obs, info = env.reset()
    return h.hexdigest()


def test_determinism_in_one_process() -> None:
    assert rollout_digest(5) == rollout_digest(5)
    assert rollout_digest(5) != rollout_digest(6)


@pytest.mark.slow
def test_determinism_across_processes() -> None:
    code = textwrap.dedent(f"""
        import sys; sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_env import rollout_digest
        print(rollout_digest(11, slip_std=0.05, n_obstacles=2))
    """)
    out = [
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
        for _ in range(2)
    ]
    assert out[0] == out[1] == rollout_digest(11, slip_std=0.05, n_obstacles=2)


@pytest.mark.parametrize("bad", [[np.nan, 0, 0], [0, np.inf, 0], [0, 0, -np.inf]])
def test_non_finite_action_raises_naming_the_component(bad: list) -> None:
    env = gym.make("PicoEscape-v0")
    env.reset(seed=0)
    name = ("vx", "vy", "w")[int(np.argmax(~np.isfinite(bad)))]
    with pytest.raises(ValueError, match=f"action component {name}"):
        env.step(np.array(bad, dtype=np.float32))


def test_actions_are_clipped_and_speed_capped() -> None:
    env = gym.make("PicoEscape-v0", map="escape_2018", wheel_noise=0.0)
    env.reset(seed=0, options={"start_pose": (2.0, 1.0, 0.0)})
    _, _, _, _, info = env.step(np.array([5.0, 5.0, 0.0]))
    moved = np.hypot(info["pose"][0] - 2.0, info["pose"][1] - 1.0)
    assert moved == pytest.approx(0.05, abs=1e-9)  # 0.5 m/s for 0.1 s, on the diagonal


def test_escape_on_a_fixed_map() -> None:
    env = gym.make("PicoEscape-v0", map="escape_small", wheel_noise=0.0)
    env.reset(seed=0, options={"start_pose": (2.2, 1.5, np.pi / 2)})
    total, terms_sum = 0.0, 0.0
    for _ in range(200):
        _, reward, terminated, truncated, info = env.step(np.array([0.5, 0.0, 0.0]))
        total += reward
        terms_sum += sum(info["reward_terms"].values())
        if terminated or truncated:
            break
    assert terminated and info["termination_reason"] == "escaped" and info["is_success"]
    assert info["bumps"] == 0
    assert total == pytest.approx(terms_sum)
    # Straight up the corridor: the path is about the oracle's.
    assert info["path_length"] == pytest.approx(info["shortest_path_length"], rel=0.05)


def test_bump_terminates_by_default_and_continue_keeps_going() -> None:
    env = gym.make("PicoEscape-v0", map="escape_2018")
    env.reset(seed=0, options={"start_pose": (1.0, 1.0, np.pi)})
    for _ in range(40):
        _, reward, terminated, truncated, info = env.step(np.array([0.5, 0.0, 0.0]))
        if terminated:
            break
    assert info["termination_reason"] == "bump" and info["bumps"] == 1
    assert info["reward_terms"]["bump"] == pytest.approx(-10.0)
    env = gym.make("PicoEscape-v0", map="escape_2018", collision="continue")
    env.reset(seed=0, options={"start_pose": (1.0, 1.0, np.pi)})
    for _ in range(40):
        _, _, terminated, _, info = env.step(np.array([0.5, 0.0, 0.0]))
        assert not terminated
    assert info["bumps"] == 1 and info["min_clearance"] >= 0.0


def test_proximity_term_grows_towards_a_wall_and_is_off_by_default() -> None:
    def drive(**options):
        env = gym.make("PicoEscape-v0", map="escape_2018", wheel_noise=0.0, **options)
        env.reset(seed=0, options={"start_pose": (1.0, 1.0, np.pi)})
        terms = []
        for _ in range(40):
            _, _, terminated, _, info = env.step(np.array([0.5, 0.0, 0.0]))
            terms.append((info["clearance"], info["reward_terms"]["proximity"]))
            if terminated:
                return terms, info
        raise AssertionError("never bumped")

    terms, _ = drive()
    assert all(p == 0.0 for _, p in terms)
    terms, info = drive(rewards={"proximity": 5.0, "proximity_m": 0.2})
    assert info["termination_reason"] == "bump"
    for clearance, p in terms:
        assert p == pytest.approx(-5.0 * 0.1 * max(0.0, 1.0 - clearance / 0.2))
    near = [p for c, p in terms if c < 0.2]
    assert len(near) >= 2 and near == sorted(near, reverse=True)  # more negative as the wall nears
    with pytest.raises(ValueError, match="proximity_m"):
        gym.make("PicoEscape-v0", rewards={"proximity_m": 0.0})


def test_approach_term_is_potential_based_shaping_towards_walls() -> None:
    k, approach_m = 4.0, 0.3

    def closeness(clearance: float) -> float:
        return max(0.0, 1.0 - clearance / approach_m)

    def drive(vx: float, x: float = 1.0, **options):
        env = gym.make("PicoEscape-v0", map="escape_2018", wheel_noise=0.0, **options)
        _, info = env.reset(seed=0, options={"start_pose": (x, 1.0, np.pi)})  # facing the wall x = 0
        clearances, terms = [info["clearance"]], []
        for _ in range(40):
            _, _, terminated, _, info = env.step(np.array([vx, 0.0, 0.0]))
            clearances.append(info["clearance"])
            terms.append(info["reward_terms"]["approach"])
            if terminated:
                break
        return clearances, terms, info

    _, terms, _ = drive(0.5)
    assert all(t == 0.0 for t in terms)  # off by default
    rewards = {"approach": k, "approach_m": approach_m}
    clearances, terms, info = drive(0.5, rewards=rewards)
    assert info["termination_reason"] == "bump"
    assert all(t <= 0.0 for t in terms) and sum(t < 0.0 for t in terms) >= 3  # closing in costs
    # It telescopes: the episode's sum is k times the closeness at the start minus at the end.
    assert sum(terms) == pytest.approx(k * (closeness(clearances[0]) - closeness(clearances[-1])))
    # Backing away from the same wall, from 0.1 m, pays it back.
    clearances, away, _ = drive(-0.5, x=0.2, rewards=rewards)
    assert clearances[0] == pytest.approx(0.1) and all(t >= 0.0 for t in away)
    assert sum(away) == pytest.approx(k * (closeness(0.1) - closeness(clearances[-1])))
    assert sum(away) > 0.5 * k * closeness(0.1)
    with pytest.raises(ValueError, match="approach_m"):
        gym.make("PicoEscape-v0", rewards={"approach_m": -1.0})


def test_idle_ends_after_30_seconds() -> None:
    env = gym.make("PicoEscape-v0")
    env.reset(seed=0)
    for step in range(1, 400):  # noqa: B007  (read after the loop)
        _, _, terminated, truncated, info = env.step(np.zeros(3))
        if terminated or truncated:
            break
    assert info["termination_reason"] == "idle" and step == 300


def test_timeout_truncates_at_300_simulated_seconds() -> None:
    env = gym.make("PicoEscape-v0", dt_s=0.2, idle_time_s=1000.0)
    env.reset(seed=0)
    for step in range(1, 2000):  # noqa: B007  (read after the loop)
        _, _, terminated, truncated, info = env.step(np.array([0.0, 0.0, 1.0]))
        if terminated or truncated:
            break
    assert truncated and not terminated
    assert info["termination_reason"] == "timeout" and step == 1500 and info["sim_time"] == pytest.approx(300.0)


def test_progress_reward_follows_the_geodesic() -> None:
    env = gym.make("PicoEscape-v0", map="escape_2018", wheel_noise=0.0)
    _, info = env.reset(seed=0, options={"start_pose": (2.0, 2.0, np.pi / 2)})
    g0 = info["geodesic_to_finish"]
    progress = 0.0
    for _ in range(20):  # 1 m straight towards the corridor
        _, _, _, _, info = env.step(np.array([0.5, 0.0, 0.0]))
        progress += info["reward_terms"]["progress"]
    assert progress == pytest.approx(g0 - info["geodesic_to_finish"])
    assert progress == pytest.approx(1.0, abs=0.05)
    assert info["reward_terms"]["time"] == pytest.approx(-0.01)


def test_observation_holds_no_privileged_information() -> None:
    env = gym.make("PicoEscape-v0")
    obs, info = env.reset(seed=4)
    pose = info["pose"]
    assert not np.allclose(obs["odom"][:2], pose[:2])  # the map frame is not the odometry frame
    assert set(obs) == {"lrf", "odom"}


def test_options_and_config_errors() -> None:
    with pytest.raises(TypeError, match="unknown option 'n_beam'"):
        gym.make("PicoEscape-v0", n_beam=10)
    with pytest.raises(ValueError, match="whole number of physics sub-steps"):
        gym.make("PicoEscape-v0", dt_s=0.015)
    env = gym.make("PicoEscape-v0", map="escape_2018")
    with pytest.raises(ValueError, match="puts the robot in a wall"):
        env.reset(options={"start_pose": (0.0, 0.0, 0.0)})
    with pytest.raises(ValueError, match="outside the walls: not in the room the finish line closes"):
        env.reset(options={"start_pose": (-3.0, 2.0, 0.0)})  # outside the room
    # EnvConfig is task-neutral: the task's config comes from the env (or is passed in).
    config = EnvConfig.make(task=EscapeTaskConfig(), rewards={"time": 0.5}, n_beams=32)
    assert config.task.rewards.time == 0.5 and config.task.rewards.progress == 1.0 and config.lrf.n_beams == 32


def test_every_shipped_escape_map_runs() -> None:
    from pico_gym.world.catalog import shipped_maps

    for name in shipped_maps():
        if not name.startswith("escape_") or name == "escape_room_student_2019":
            continue
        env = gym.make("PicoEscape-v0", map=name)
        for seed in range(3):
            obs, info = env.reset(seed=seed)
            assert np.isfinite(info["shortest_path_length"]) and info["shortest_path_length"] > 3.0
            assert info["clearance"] >= 0.05


def test_sample_start_overrides_a_fixed_start_pose() -> None:
    fixed = gym.make("PicoEscape-v0", map="escape_small")
    sampled = gym.make("PicoEscape-v0", map="escape_small", sample_start=True)
    assert fixed.reset(seed=1)[1]["pose"] == pytest.approx([1.0, 1.0, 0.3])
    poses = [sampled.reset(seed=s)[1]["pose"] for s in range(5)]
    assert len({tuple(np.round(p, 6)) for p in poses}) == 5


def test_random_starts_on_a_map_without_start_area_stay_inside(write_json) -> None:
    path = write_json(
        {
            "points": [[0, 0], [4, 0], [4, 3], [2.6, 3], [2.6, 6.5], [1.8, 6.5], [1.8, 3], [0, 3]],
            "walls": [[0, 1], [1, 2], [2, 3], [3, 4], [5, 6], [6, 7], [7, 0]],
            "finish": [[1.8, 6.2], [2.6, 6.2]],
        }
    )
    env = gym.make("PicoEscape-v0", map_path=str(path))
    for seed in range(30):
        _, info = env.reset(seed=seed)
        x, y, _ = info["pose"]
        assert (0 < x < 4 and 0 < y < 3) or (1.8 < x < 2.6 and y < 6.2)


def test_module_colon_id_needs_no_import() -> None:
    code = "import gymnasium as gym; env = gym.make('pico_gym:PicoEscape-v0'); print(env.reset(seed=0)[0]['lrf'].shape)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "(1000,)"
