"""The shipped policy runs from plain arrays with numpy: same actions as SB3, and no torch needed."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest

import pico_gym  # noqa: F401
from pico_gym.agents import make_agent
from pico_gym.agents.mlp import MlpActor
from pico_gym.agents.ppo import SHIPPED_MODEL, SHIPPED_POLICY


def _recorded_observations(n_episodes: int = 3, steps: int = 80) -> list[np.ndarray]:
    """Encoded observations of the shipped PPO agent's own episodes."""
    env = gym.make("PicoEscape-v0")
    agent = make_agent("ppo", env)
    xs = []
    for seed in range(n_episodes):
        obs, info = env.reset(seed=seed)
        agent.reset(obs, info)
        xs.append(agent._first.copy())
        for _ in range(steps):
            obs, _, terminated, truncated, _ = env.step(agent.act(obs))
            if terminated or truncated:
                break
            xs.append(agent.encoder.encode(agent._with_goal(obs)).copy())  # the goal too, when it has one
            agent._first = xs[-1]
    return xs


@pytest.mark.slow
def test_numpy_actor_gives_sb3s_actions_to_1e_5():
    sb3 = pytest.importorskip("stable_baselines3")
    model = sb3.PPO.load(SHIPPED_MODEL, device="cpu")
    actor = MlpActor.load(SHIPPED_POLICY)
    xs = _recorded_observations()
    assert len(xs) > 100
    for x in xs:
        expected, _ = model.predict(x, deterministic=True)
        np.testing.assert_allclose(actor.act(x), expected, atol=1e-5, rtol=0)


def test_actor_file_round_trips_and_refuses_other_files(tmp_path):
    actor = MlpActor.load(SHIPPED_POLICY)
    copy = MlpActor.load(actor.save(tmp_path / "copy.npz"))
    x = np.linspace(0, 1, actor.obs_size, dtype=np.float32)
    np.testing.assert_array_equal(copy.act(x), actor.act(x))
    bad = tmp_path / "bad.npz"
    np.savez(bad, w0=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="bad.npz: not a pico-gym policy array file"):
        MlpActor.load(bad)
    with pytest.raises(ValueError, match="takes observations of length"):
        actor.act(np.zeros(3))


def test_shipped_ppo_agent_runs_without_torch(tmp_path):
    """With torch and stable-baselines3 made unimportable, the shipped PPO agent still plays."""
    code = textwrap.dedent(
        """
        import sys
        class Block:
            def find_spec(self, name, path=None, target=None):
                if name.split(".")[0] in ("torch", "stable_baselines3"):
                    raise ImportError(f"{name} is blocked in this test")
        sys.meta_path.insert(0, Block())
        import gymnasium as gym, pico_gym
        from pico_gym.agents import make_agent
        from pico_gym.agents.evaluation import run_episode
        env = gym.make("PicoEscape-v0")
        record = run_episode(env, make_agent("ppo", env), 0, "ppo")
        assert "torch" not in sys.modules and "stable_baselines3" not in sys.modules
        print(record.success, record.time_s)
        """
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split()[0] == "True"
