"""PicoEscape-v0 in CleanRL's ppo_continuous_action.py: its env stack and episode logging, written
for gymnasium 1.x (the script's gymnasium-0.29 version needs exactly these two changes).

Paste `make_env` over the script's own, and the `final_info` block over its logging loop. Run this
file to check the stack on its own (random actions, no training):

    python docs/recipes/cleanrl_env.py --steps 3000
"""

import argparse

import gymnasium as gym
import numpy as np

import pico_gym  # noqa: F401  (registers the ids)
from pico_gym.wrappers import PicoLearningWrapper


def make_env(env_id, idx, capture_video, run_name, gamma):
    def thunk():
        if capture_video and idx == 0:
            env = gym.make(env_id, render_mode="rgb_array")
            env = gym.wrappers.RecordVideo(env, f"videos/{run_name}")
        else:
            env = gym.make(env_id)
        env = PicoLearningWrapper(env)  # the Dict observation as one vector (CleanRL's MLP needs a Box)
        env = gym.wrappers.RecordEpisodeStatistics(env)
        env = gym.wrappers.ClipAction(env)
        env = gym.wrappers.NormalizeObservation(env)
        # Change 1: gymnasium 1.x's TransformObservation takes the new observation space.
        env = gym.wrappers.TransformObservation(env, lambda obs: np.clip(obs, -10, 10), env.observation_space)
        env = gym.wrappers.NormalizeReward(env, gamma=gamma)
        env = gym.wrappers.TransformReward(env, lambda reward: np.clip(reward, -10, 10))
        return env

    return thunk


def log_finished_episodes(infos, global_step):
    """Change 2: with gymnasium 1.x (and SAME_STEP autoreset) `final_info` is one dict of arrays
    with `_episode` marking the envs whose episode ended, not a list of per-env dicts."""
    if "final_info" not in infos:
        return []
    over = np.nonzero(infos["final_info"]["_episode"])[0]
    returns = infos["final_info"]["episode"]["r"][over]
    lengths = infos["final_info"]["episode"]["l"][over]
    for r, length in zip(returns, lengths, strict=True):
        print(f"global_step={global_step}, episodic_return={r:.2f}, episodic_length={length}")
    return list(returns)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--steps", type=int, default=3000)
    args = parser.parse_args()
    envs = gym.vector.SyncVectorEnv(
        [make_env("PicoEscape-v0", i, False, "check", 0.99) for i in range(2)],
        autoreset_mode=gym.vector.AutoresetMode.SAME_STEP,
    )
    envs.action_space.seed(0)
    next_obs, _ = envs.reset(seed=1)
    episodes = []
    for step in range(0, args.steps, envs.num_envs):
        next_obs, reward, terminations, truncations, infos = envs.step(envs.action_space.sample())
        episodes += log_finished_episodes(infos, step)
    print(f"ran {args.steps} steps, {len(episodes)} episodes, observation {next_obs.shape}")
