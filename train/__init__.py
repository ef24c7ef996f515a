"""Training pico-gym agents: PPO with stable-baselines3 (`pico-gym train`, see `pico_gym.train.ppo`)."""
