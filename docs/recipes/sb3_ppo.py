"""Plain stable-baselines3 PPO on PicoEscape-v0 (no pico-gym training code involved).

python docs/recipes/sb3_ppo.py --timesteps 200000
"""

import argparse

import gymnasium as gym
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env

import pico_gym  # noqa: F401  (registers the ids)
from pico_gym.wrappers import PicoLearningWrapper

parser = argparse.ArgumentParser()
parser.add_argument("--timesteps", type=int, default=200_000)
parser.add_argument("--out", default="ppo_pico_escape")
args = parser.parse_args()

# The Dict observation (1000 ranges + odometry) becomes one vector of 64 min-pooled sectors, a
# range memory and the odometry velocity, with actions in [-1, 1]: what an MLP policy wants.
envs = make_vec_env(
    "PicoEscape-v0",
    n_envs=4,
    seed=0,
    env_kwargs={"time_limit_s": 60.0},  # shorter training episodes
    wrapper_class=PicoLearningWrapper,
)
model = PPO("MlpPolicy", envs, n_steps=256, batch_size=256, seed=0, device="cpu", verbose=0)
model.learn(total_timesteps=args.timesteps)
model.save(args.out)

env = PicoLearningWrapper(gym.make("PicoEscape-v0"))
obs, info = env.reset(seed=1_000_000)
done = False
while not done:
    action, _ = model.predict(obs, deterministic=True)
    obs, reward, terminated, truncated, info = env.step(action)
    done = terminated or truncated
outcome = f"{info['termination_reason']} after {info['sim_time']:.1f} s"
print(f"trained {args.timesteps} steps; evaluation episode: {outcome}")
