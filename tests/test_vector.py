"""The vector env (`make_vec(..., vectorization_mode="vector_entry_point")`): the same episodes as
gymnasium's SyncVectorEnv over single envs, bit for bit, in both autoreset modes."""

from __future__ import annotations

import sys
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import pico_gym  # noqa: F401


def assert_same(a: Any, b: Any, where: str = "") -> None:
    """Equal batches: arrays bit for bit (dtype and shape too), dicts key by key, objects by repr."""
    if isinstance(a, tuple):
        assert isinstance(b, tuple) and len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same(x, y, f"{where}[{k}]")
    elif isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), (where, sorted(set(a) ^ set(b)))
        for key in a:
            assert_same(a[key], b[key], f"{where}/{key}")
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and (a.shape, a.dtype) == (b.shape, b.dtype), (where, a.dtype, b.dtype)
        if a.dtype == object:
            for x, y in zip(a, b, strict=True):
                assert_same(x, y, f"{where}[]")
        else:
            assert np.array_equal(a, b, equal_nan=True), where
    elif isinstance(a, (int, float, bool, str, type(None), np.number)):
        assert a == b, (where, a, b)
    else:
        with np.printoptions(threshold=sys.maxsize):
            assert repr(a) == repr(b), where


CASES = [
    # (env id, options, autoreset mode): short time limits and bumps end many episodes.
    ("PicoEscape-v0", {"time_limit_s": 4.0}, AutoresetMode.NEXT_STEP),
    ("PicoEscape-v0", {"n_obstacles": 2, "slip_std": 0.05, "noise_m": 0.0, "time_limit_s": 6.0},
     AutoresetMode.SAME_STEP),
    # The escape robots' compiled batch (`pico_gym.batched`): contacts the physics steps, bumps
    # that go on, idle ends, random odometry starts, noisier scans.
    ("PicoEscape-v0", {"n_obstacles": 2, "noise_m": 0.03, "collision": "continue", "time_limit_s": 8.0},
     AutoresetMode.NEXT_STEP),
    ("PicoEscape-v0", {"random_start": True, "idle_time_s": 1.0, "time_limit_s": 5.0}, AutoresetMode.SAME_STEP),
    ("PicoHospital-v0", {"map": "hospital_2019", "n_movers": (1, 1), "n_boxes": (2, 2), "n_closed_doors": (1, 1),
                         "time_limit_s": 5.0}, AutoresetMode.SAME_STEP),
    ("PicoHospital-v0", {"map": "hospital_2021", "time_limit_s": 3.0}, AutoresetMode.NEXT_STEP),
    ("PicoExplore-v0", {"time_limit_s": 4.0}, AutoresetMode.NEXT_STEP),
]  # fmt: skip


@pytest.mark.parametrize(("env_id", "options", "mode"), CASES)
def test_vector_env_gives_the_episodes_of_single_envs(env_id: str, options: dict, mode: AutoresetMode) -> None:
    n = 3
    reference = gym.make_vec(
        env_id, num_envs=n, vectorization_mode="sync", vector_kwargs={"autoreset_mode": mode}, **options
    )
    vector = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", autoreset_mode=mode, **options)
    assert type(vector.unwrapped).__name__ == "PicoVectorEnv"
    assert vector.metadata["autoreset_mode"] == mode
    assert_same(reference.reset(seed=11), vector.reset(seed=11))
    rng = np.random.default_rng(0)
    ends = 0
    for t in range(120):
        actions = rng.uniform(reference.action_space.low, reference.action_space.high).astype(np.float32)
        expected, got = reference.step(actions), vector.step(actions)
        assert_same(expected, got, f"step {t}")
        ends += int(np.sum(expected[2] | expected[3]))
    assert ends >= n  # every robot went through an autoreset at least once (in sum)
    # The escape robots took most steps in the compiled batch (the rest, contacts and episode
    # ends, in their own envs): the same episodes must come from that path, not around it.
    if env_id == "PicoEscape-v0":
        assert vector.unwrapped.batch_steps >= 0.6 * n * 120
    else:
        assert vector.unwrapped.batch_steps == 0
    # A partial reset, as SyncVectorEnv takes it.
    mask = np.array([False, True, False])
    assert_same(
        reference.reset(seed=[None, 5, None], options={"reset_mask": mask.copy()}),
        vector.reset(seed=[None, 5, None], options={"reset_mask": mask.copy()}),
    )
    reference.close()
    vector.close()


def test_escape_robots_envs_are_up_to_date_whenever_read() -> None:
    """The batch keeps the escape robots' state in its rows; the robots' envs, read through
    `envs`, are what single envs are at the same step, and stepping on (by `step` or by the
    per-robot `step_each` that the SB3 adapter uses) gives the same episodes."""
    n, options = 3, {"n_obstacles": 1, "time_limit_s": 6.0}
    reference = gym.make_vec("PicoEscape-v0", num_envs=n, vectorization_mode="sync", **options)
    vector = gym.make_vec("PicoEscape-v0", num_envs=n, vectorization_mode="vector_entry_point", **options)
    reference.reset(seed=3)
    vector.reset(seed=3)
    rng = np.random.default_rng(1)
    for t in range(90):
        actions = rng.uniform(-0.5, 0.5, size=(n, 3)).astype(np.float32)
        if t % 30 == 29:
            for ours, theirs in zip(vector.unwrapped.envs, reference.envs, strict=True):
                theirs = theirs.unwrapped
                assert (ours.pose, ours.odometry.pose, ours.steps) == (theirs.pose, theirs.odometry.pose, theirs.steps)
                assert ours.trajectory == theirs.trajectory
                assert np.array_equal(ours.last_scan, theirs.last_scan)
                assert ours.np_random.bit_generator.state == theirs.np_random.bit_generator.state
        if 40 <= t < 50:
            obs, rewards, terminated, truncated, infos, _ = vector.unwrapped.step_each(actions)
            expected = reference.step(actions)
            assert np.array_equal(obs["lrf"], expected[0]["lrf"]) and np.array_equal(rewards, expected[1])
        else:
            assert_same(reference.step(actions), vector.step(actions), f"step {t}")
    reference.close()
    vector.close()


def test_vector_env_batches_infos_whose_arrays_differ_in_shape() -> None:
    """Generated hospitals draw how many people walk: info["movers"] has a row per person, so its
    shape differs between robots (SyncVectorEnv cannot batch that): an object array, robot by robot."""
    vector = gym.make_vec("PicoHospital-v0", num_envs=3, vectorization_mode="vector_entry_point", n_movers=(0, 2))
    for seed in range(20):
        _, info = vector.reset(seed=seed)
        counts = {len(m) for m in info["movers"]} if info["movers"].dtype == object else set()
        if len(counts) > 1:
            break
    assert len(counts) > 1, "no seed in 0-19 gave robots different numbers of people"
    for _ in range(3):
        _, _, _, _, info = vector.step(np.zeros((3, 3), dtype=np.float32))
        assert info["movers"].dtype == object and info["_movers"].all()
        for env, movers in zip(vector.unwrapped.envs, info["movers"], strict=True):
            assert np.array_equal(movers, env.scene.mover_poses())
    vector.close()


def test_vector_env_refuses_bad_input() -> None:
    with pytest.raises(ValueError, match="num_envs"):
        gym.make_vec("PicoEscape-v0", num_envs=0, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match="autoreset_mode"):
        gym.make_vec("PicoEscape-v0", num_envs=2, vectorization_mode="vector_entry_point", autoreset_mode="Disabled")
    with pytest.raises(TypeError, match="unknown option"):
        gym.make_vec("PicoEscape-v0", num_envs=2, vectorization_mode="vector_entry_point", no_such_option=1)
    vector = gym.make_vec("PicoEscape-v0", num_envs=2, vectorization_mode="vector_entry_point")
    vector.reset(seed=0)
    with pytest.raises(ValueError, match="one row per env"):
        vector.step(np.zeros((3, 3), dtype=np.float32))
    with pytest.raises(ValueError, match="action component vy"):
        vector.step(np.array([[0.0, 0.0, 0.0], [0.0, np.nan, 0.0]], dtype=np.float32))
    with pytest.raises(ValueError, match="2 seeds"):
        vector.reset(seed=[1, 2, 3])
    with pytest.raises(ValueError, match="reset_mask"):
        vector.reset(options={"reset_mask": np.array([1, 0])})
    vector.close()


def test_sb3_vec_env_gives_what_dummy_vec_env_gives() -> None:
    """The SB3 adapter over the vector env hands SB3 the observations, rewards, dones and infos
    (terminal observations included) of SB3's own DummyVecEnv over single envs."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.vec_env import DummyVecEnv

    from pico_gym.train.sb3_vec import PicoSB3VecEnv

    options = {"time_limit_s": 4.0, "n_obstacles": 1}
    dummy = DummyVecEnv([lambda: gym.make("PicoEscape-v0", **options) for _ in range(3)])
    ours = PicoSB3VecEnv("PicoEscape-v0", 3, **options)
    dummy.seed(21)
    ours.seed(21)
    assert_same(dummy.reset(), ours.reset())
    rng = np.random.default_rng(1)
    done_seen = 0
    for t in range(90):
        actions = rng.uniform(-0.5, 0.5, size=(3, 3)).astype(np.float32)
        expected, got = dummy.step(actions), ours.step(actions)
        assert_same(expected[:3], got[:3], f"step {t}")
        for a, b in zip(expected[3], got[3], strict=True):
            assert_same(a, b, f"step {t} info")
        done_seen += int(expected[2].sum())
    assert done_seen >= 3
    assert ours.get_attr("steps") == [env.unwrapped.steps for env in dummy.envs]
    assert ours.env_is_wrapped(gym.Wrapper) == [False] * 3
    ours.close()


def test_step_finals_and_the_autoreset_seed_hook() -> None:
    """`step_finals` (SAME_STEP only) returns what `step` does without the step's infos; a
    subclass's `autoreset_seed` seeds every autoreset (here: always the same episode)."""
    from pico_gym.vector import PicoVectorEnv

    class Replay(PicoVectorEnv):
        def autoreset_seed(self, i: int) -> int:
            return 7

    options = {"time_limit_s": 2.0, "n_obstacles": 1}
    ours = Replay("PicoEscape-v0", 2, autoreset_mode=AutoresetMode.SAME_STEP, **options)
    theirs = Replay("PicoEscape-v0", 2, autoreset_mode=AutoresetMode.SAME_STEP, **options)
    first, _ = gym.make("PicoEscape-v0", **options).reset(seed=7)
    ours.reset(seed=[7, 7])
    theirs.reset(seed=[7, 7])
    rng = np.random.default_rng(3)
    ended = 0
    for _ in range(60):
        actions = rng.uniform(-0.3, 0.5, size=(2, 3)).astype(np.float32)
        obs, rewards, terminated, truncated, final = ours.step_finals(actions)
        obs2, rewards2, terminated2, truncated2, infos = theirs.step(actions)
        assert_same((obs, rewards, terminated, truncated), (obs2, rewards2, terminated2, truncated2))
        for i, (final_obs, final_info) in final.items():
            assert_same(final_obs, infos["final_obs"][i])
            assert final_info["sim_time"] == infos["final_info"]["sim_time"][i]
            assert np.array_equal(obs["lrf"][i], first["lrf"])  # the next episode: seed 7 again
            ended += 1
    assert ended >= 2
    with pytest.raises(ValueError, match="SAME_STEP"):
        PicoVectorEnv("PicoEscape-v0", 2).step_finals(np.zeros((2, 3), np.float32))


def test_the_escape_robots_info_masks_are_read_only_when_every_robot_has_every_key() -> None:
    """The common step's masks are shared between steps: a write is refused, not carried on."""
    venv = gym.make_vec("PicoEscape-v0", num_envs=3, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    _, _, _, _, infos = venv.step(np.zeros((3, 3), np.float32))
    assert infos["_pose"].all() and not infos["_pose"].flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        infos["_clearance"][0] = False
    _, _, _, _, again = venv.step(np.zeros((3, 3), np.float32))
    assert again["_clearance"].all()
