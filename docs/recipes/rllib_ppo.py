"""RLlib PPO on PicoEscape-v0: on this machine, or on a Ray cluster (`--address auto` on a node of
it, or `--address ray://HEAD:10001`), where env runners spread over the cluster's CPUs.

    pip install torch --index-url https://download.pytorch.org/whl/cpu   # CPU-only machines
    pip install "pico-gym[rllib]"
    python docs/recipes/rllib_ppo.py --iterations 50 --env-runners 8 --address auto
"""

import argparse

import gymnasium as gym
import ray
from ray.rllib.algorithms.ppo import PPOConfig
from ray.tune.registry import register_env


def make_env(env_config: dict):
    import pico_gym  # noqa: F401  (registers the ids in each env-runner process)
    from pico_gym.wrappers import PicoLearningWrapper

    return PicoLearningWrapper(gym.make("PicoEscape-v0", **env_config), memory_sectors=36, range_scale="log")


parser = argparse.ArgumentParser()
parser.add_argument("--iterations", type=int, default=50)
parser.add_argument("--env-runners", type=int, default=0, help="0: sample in the driver process")
parser.add_argument("--batch", type=int, default=4000, help="env steps per training iteration")
parser.add_argument("--address", default=None, help="a Ray cluster's address ('auto', 'ray://...'); default: local")
args = parser.parse_args()

ray.init(address=args.address)
register_env("PicoEscape", make_env)
config = (
    PPOConfig()
    .environment("PicoEscape", env_config={"time_limit_s": 60.0})
    .env_runners(num_env_runners=args.env_runners, num_envs_per_env_runner=2)
    .training(
        train_batch_size_per_learner=args.batch,
        minibatch_size=min(512, args.batch),
        num_epochs=5,
        lr=3e-4,
        gamma=0.99,
    )
    .rl_module(model_config={"fcnet_hiddens": [256, 256]})
)
algo = config.build_algo()
for i in range(args.iterations):
    result = algo.train()
    runners = result.get("env_runners", {})
    print(
        f"iteration {i + 1}: {runners.get('num_env_steps_sampled_lifetime', '?')} env steps, "
        f"episode return mean {runners.get('episode_return_mean', float('nan')):.2f}"
    )
algo.stop()
ray.shutdown()
