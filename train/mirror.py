"""A mirror-symmetric PPO actor: the robot's left and right are the same to it by construction.

The escape policy trained with a plain MLP learnt one way out of every room: turn left and follow
the walls round until the exit comes by (median SPL 0.53 with the exit to its right at the start,
0.92 to its left; docs/training.md). A policy whose mean action for the reflected
observation is the reflected action cannot prefer a hand; it must take the side the exit is on.

`MirrorPolicy` is SB3's `ActorCriticPolicy` with the Gaussian's mean replaced by
(mu(x) + R_a mu(R_o x)) / 2, where R_o reflects the learning input (`pico_gym.wrappers.mirror_maps`)
and R_a the action (vx, vy, w) -> (vx, -vy, -w): equivariant for any weights, so PPO trains it as
it is (the critic is left as it is). Configs name it `policy: MirrorMlpPolicy`; `export_actor`
writes the reflection into the `.npz`, and `MlpActor` plays it the same way without torch.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from stable_baselines3.common.policies import ActorCriticPolicy

from pico_gym.wrappers import MIRROR_ACTION_SIGN, LearningConfig, mirror_maps


class MirrorPolicy(ActorCriticPolicy):
    """`ActorCriticPolicy` (MLP) with a mirror-symmetric actor (module docstring).

    Args (besides ActorCriticPolicy's):
        mirror_index, mirror_sign: the observation's reflection, x[index] * sign.
        mirror_action_sign: the action's reflection, a * sign (its first n components).
    """

    def __init__(
        self,
        *args: Any,
        mirror_index: Any = None,
        mirror_sign: Any = None,
        mirror_action_sign: Any = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(*args, **kwargs)
        if mirror_index is None or mirror_sign is None or mirror_action_sign is None:
            raise ValueError("MirrorPolicy needs mirror_index, mirror_sign and mirror_action_sign")
        obs_shape, act_shape = self.observation_space.shape, self.action_space.shape
        assert obs_shape is not None and act_shape is not None  # (Box spaces)
        n = int(obs_shape[0])
        n_act = int(act_shape[0])
        self.mirror_index = np.asarray(mirror_index, np.int64)
        self.mirror_sign = np.asarray(mirror_sign, np.float32)
        self.mirror_action_sign = np.asarray(mirror_action_sign, np.float32)[:n_act]
        if self.mirror_index.shape != (n,) or not np.array_equal(np.sort(self.mirror_index), np.arange(n)):
            raise ValueError(f"mirror_index must be a permutation of the observation's {n} indices")
        if self.mirror_sign.shape != (n,) or self.mirror_action_sign.shape != (n_act,):
            raise ValueError(f"mirror_sign must have {n} entries and mirror_action_sign at least {n_act}")
        self._index = torch.as_tensor(self.mirror_index)
        self._sign = torch.as_tensor(self.mirror_sign)
        self._action_sign = torch.as_tensor(self.mirror_action_sign)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.update(
            mirror_index=self.mirror_index.tolist(),
            mirror_sign=self.mirror_sign.tolist(),
            mirror_action_sign=self.mirror_action_sign.tolist(),
        )
        return data

    def mean_actions(self, obs: torch.Tensor) -> torch.Tensor:
        """The Gaussian's mean: (mu(x) + R_a mu(R_o x)) / 2."""
        obs = obs.float()
        reflected = obs[:, self._index] * self._sign
        return 0.5 * (self._mu(obs) + self._mu(reflected) * self._action_sign)

    def _mu(self, obs: torch.Tensor) -> torch.Tensor:
        features = self.extract_features(obs, self.pi_features_extractor)
        assert isinstance(features, torch.Tensor)  # (one features extractor for the actor)
        return self.action_net(self.mlp_extractor.forward_actor(features))

    def _distribution(self, obs: torch.Tensor) -> Any:
        return self.action_dist.proba_distribution(self.mean_actions(obs), self.log_std)

    def forward(
        self, obs: torch.Tensor, deterministic: bool = False
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        distribution = self._distribution(obs)
        actions = distribution.get_actions(deterministic=deterministic)
        log_prob = distribution.log_prob(actions)
        return actions.reshape((-1, *(self.action_space.shape or ()))), self.predict_values(obs), log_prob

    def evaluate_actions(  # type: ignore[override]  # (Box observations only, no dict)
        self, obs: torch.Tensor, actions: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, Any]:
        distribution = self._distribution(obs)
        return self.predict_values(obs), distribution.log_prob(actions), distribution.entropy()

    def get_distribution(self, obs: torch.Tensor) -> Any:  # type: ignore[override]  # (Box observations only)
        return self._distribution(obs)


def mirror_policy_kwargs(learning: LearningConfig) -> dict[str, Any]:
    """The `MirrorPolicy` arguments for policies that see `learning`'s encoding."""
    index, sign = mirror_maps(learning)
    return {
        "mirror_index": index.tolist(),
        "mirror_sign": sign.tolist(),
        "mirror_action_sign": MIRROR_ACTION_SIGN.tolist(),
    }


def mirrored_demonstrations(xs: np.ndarray, ys: np.ndarray, learning: LearningConfig) -> tuple[np.ndarray, np.ndarray]:
    """Demonstrations with their reflections added (behaviour cloning of a mirrored policy)."""
    index, sign = mirror_maps(learning)
    action_sign = MIRROR_ACTION_SIGN[: ys.shape[1]]
    return np.concatenate([xs, xs[:, index] * sign]), np.concatenate([ys, ys * action_sign])
