"""The Gymnasium contract of every registered pico-gym id (driven by the registry, as Minigrid's
tests are): checkers, spaces, determinism across processes, pickling, rendering, bad actions."""

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

import pico_gym

IDS = [env_id for env_id, spec in gym.registry.items() if str(spec.entry_point).startswith("pico_gym.")]
# Settings that exercise each id's moving parts (movers, boxes, closed doors on the hospital).
BUSY = {
    "PicoEscape-v0": {"n_obstacles": 2, "slip_std": 0.05},
    "PicoHospital-v0": {"map": "hospital_2019", "n_movers": (2, 2), "n_boxes": (2, 2), "n_closed_doors": (1, 1)},
    "PicoExplore-v0": {"n_rooms": (6, 6), "phase_observation": True, "arrival": "announce"},
}


def test_every_id_is_registered_and_covered() -> None:
    assert set(IDS) == set(pico_gym.ENV_IDS)
    assert set(BUSY) == set(IDS)


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("busy", [False, True])
def test_gymnasium_check_env(env_id: str, busy: bool) -> None:
    env = gym.make(env_id, **(BUSY[env_id] if busy else {}))
    check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("env_id", IDS)
def test_sb3_check_env(env_id: str) -> None:
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    sb3_check_env(gym.make(env_id, **BUSY[env_id]).unwrapped, warn=True)


def rollout_digest(env_id: str, seed: int, steps: int = 200) -> str:
    env = gym.make(env_id, collision="continue", **BUSY[env_id])
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    high = env.action_space.high
    h = hashlib.sha256()
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, high.shape) * high)
        h.update(obs["lrf"].tobytes() + obs["odom"].tobytes() + np.float64(reward).tobytes())
        h.update(repr(sorted((k, repr(v)) for k, v in info.items() if k != "task")).encode())
        if terminated or truncated:
            obs, info = env.reset()
    return h.hexdigest()


@pytest.mark.slow
@pytest.mark.parametrize("env_id", IDS)
def test_same_seed_same_episode_across_processes(env_id: str) -> None:
    code = textwrap.dedent(f"""
        import sys; sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_contract import rollout_digest
        print(rollout_digest({env_id!r}, 11))
    """)
    out = [
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
        for _ in range(2)
    ]
    here = rollout_digest(env_id, 11)
    assert out[0] == out[1] == here
    assert rollout_digest(env_id, 12) != here


@pytest.mark.parametrize("env_id", IDS)
def test_pickling_mid_episode_and_rgb_array(env_id: str) -> None:
    env = gym.make(env_id, render_mode="rgb_array", **BUSY[env_id])
    env.reset(seed=1)
    zero = np.zeros(env.action_space.shape, dtype=np.float32)
    for _ in range(5):
        env.step(zero + np.r_[0.1, 0.0, 0.2, np.zeros(env.action_space.shape[0] - 3)].astype(np.float32))
    frame = env.render()
    assert frame.shape == (640, 640, 3) and frame.dtype == np.uint8
    clone = pickle.loads(pickle.dumps(env))
    action = np.r_[0.2, 0.1, -0.3, np.zeros(env.action_space.shape[0] - 3)].astype(np.float32)
    a, b = env.step(action), clone.step(action)
    assert np.array_equal(a[0]["lrf"], b[0]["lrf"]) and a[1] == b[1]
    assert np.array_equal(clone.render(), env.render())


@pytest.mark.parametrize("env_id", IDS)
def test_bad_actions_options_and_ended_episodes_are_refused(env_id: str) -> None:
    env = gym.make(env_id, **BUSY[env_id])
    env.reset(seed=0)
    n = env.action_space.shape[0]
    for i, name in enumerate(("vx", "vy", "w")):
        bad = np.zeros(n)
        bad[i] = np.nan
        with pytest.raises(ValueError, match=f"component {name}"):
            env.step(bad)
    with pytest.raises(ValueError, match=f"must have {n} components"):
        env.step(np.zeros(n + 1))
    with pytest.raises(ValueError, match="unknown reset option.*'start_poze'"):
        env.reset(seed=0, options={"start_poze": (0, 0, 0)})
    # An ended episode never pays again: stepping it raises until reset.
    env = gym.make(env_id, **BUSY[env_id], time_limit_s=0.3)
    env.reset(seed=0)
    for _ in range(3):
        *_, truncated, info = env.step(np.zeros(n))
    assert truncated and info["termination_reason"] == "timeout"
    with pytest.raises(RuntimeError, match="call reset"):
        env.step(np.zeros(n))
    env.reset(seed=1)
    env.step(np.zeros(n))


@pytest.mark.parametrize("env_id", IDS)
def test_task_neutral_info(env_id: str) -> None:
    env = gym.make(env_id)
    _, info = env.reset(seed=0)
    assert {
        "pose",
        "odom_error",
        "bumps",
        "bumps_by_kind",
        "clearance",
        "min_clearance",
        "sim_time",
        "path_length",
        "shortest_path_length",
        "is_success",
        "termination_reason",
        "reward_terms",
        "cost",
    } <= set(info)
    assert np.isfinite(info["shortest_path_length"]) and info["shortest_path_length"] > 0
