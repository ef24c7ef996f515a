"""A trained policy's actor as plain arrays, evaluated with numpy: running a policy needs no torch.

stable-baselines3's zip (with torch inside) stays the training artefact. `export_actor` writes
what acting needs, the actor MLP's weights, the Gaussian's log-std and the observation
normalisation, to an `.npz` file, which `MlpActor.load` reads with pickling off (so, unlike a zip
or a pickle, loading it cannot run code). `MlpActor.act` computes the same action as SB3's
`predict(deterministic=True)` (to float32 rounding: tested to 1e-5).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

FORMAT = "pico-gym-mlp-actor-1"
_ACTIVATIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "tanh": np.tanh,
    "relu": lambda x: np.maximum(x, 0.0),
    "elu": lambda x: np.where(x > 0.0, x, np.expm1(np.minimum(x, 0.0))),
    "leaky_relu": lambda x: np.where(x > 0.0, x, 0.01 * x),
}


@dataclass(frozen=True)
class MlpActor:
    """The deterministic actor of an MLP policy: normalise, hidden layers, linear head, clip.

    Attributes:
        weights: per layer an (out, in) float32 matrix (the last is the action head).
        biases: per layer an (out,) float32 vector.
        activation: the hidden layers' activation ("tanh", "relu", "elu", "leaky_relu").
        log_std: the Gaussian's log standard deviation per action component.
        action_low, action_high: the policy's action space bounds (actions are clipped to them).
        obs_mean, obs_std, obs_clip: VecNormalize's observation transform, if any:
            clip((x - mean) / std, -clip, clip).
        mirror_index, mirror_sign, mirror_action_sign: a mirror-symmetric actor
            (`pico_gym.train.mirror`): the mean is the average of the network's mean for x and
            the reflection (times `mirror_action_sign`) of its mean for the reflected x,
            x[mirror_index] * mirror_sign (`pico_gym.wrappers.mirror_maps`); None: plain.
    """

    weights: tuple[np.ndarray, ...]
    biases: tuple[np.ndarray, ...]
    activation: str
    log_std: np.ndarray
    action_low: np.ndarray
    action_high: np.ndarray
    obs_mean: np.ndarray | None = None
    obs_std: np.ndarray | None = None
    obs_clip: float = np.inf
    mirror_index: np.ndarray | None = None
    mirror_sign: np.ndarray | None = None
    mirror_action_sign: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.activation not in _ACTIVATIONS:
            raise ValueError(f"activation must be one of {sorted(_ACTIVATIONS)}, got {self.activation!r}")
        if not self.weights or len(self.weights) != len(self.biases):
            raise ValueError("an MLP needs as many bias vectors as weight matrices, and at least one layer")
        mirror = (self.mirror_index, self.mirror_sign, self.mirror_action_sign)
        if any(m is not None for m in mirror):
            n, n_act = self.obs_size, int(self.weights[-1].shape[0])
            if any(m is None for m in mirror):
                raise ValueError("a mirrored actor needs mirror_index, mirror_sign and mirror_action_sign")
            index = np.asarray(self.mirror_index)
            if index.shape != (n,) or np.asarray(self.mirror_sign).shape != (n,):
                raise ValueError(f"mirror_index and mirror_sign must have the observation's length {n}")
            if not np.array_equal(np.sort(index), np.arange(n)):
                raise ValueError("mirror_index must be a permutation of the observation's indices")
            if np.asarray(self.mirror_action_sign).shape != (n_act,):
                raise ValueError(f"mirror_action_sign must have the action's length {n_act}")

    @property
    def obs_size(self) -> int:
        """The length of the observation vector the actor takes."""
        return int(self.weights[0].shape[1])

    def mean_action(self, x: np.ndarray) -> np.ndarray:
        """The Gaussian's mean for one observation vector (before clipping)."""
        h = np.asarray(x, dtype=np.float32).reshape(-1)
        if h.shape[0] != self.obs_size:
            raise ValueError(f"the actor takes observations of length {self.obs_size}, got {h.shape[0]}")
        if self.mirror_index is None:
            return self._network(h)
        reflected = self._network(h[self.mirror_index] * self.mirror_sign) * self.mirror_action_sign
        return np.float32(0.5) * (self._network(h) + reflected)

    def _network(self, h: np.ndarray) -> np.ndarray:
        if self.obs_mean is not None:  # in float64, as VecNormalize does
            h = np.clip((h - self.obs_mean) / self.obs_std, -self.obs_clip, self.obs_clip).astype(np.float32)
        act = _ACTIVATIONS[self.activation]
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            h = w @ h + b
            if i < last:
                h = act(h)
        return h

    def act(self, x: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """The action for one observation: the mean (rng None), or a sample of the Gaussian, clipped."""
        mean = self.mean_action(x)
        if rng is not None:
            mean = mean + np.exp(self.log_std) * rng.standard_normal(mean.shape)
        return np.clip(mean, self.action_low, self.action_high)

    # --- files -----------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the actor to an .npz file (plain arrays, no pickles)."""
        path = Path(path).with_suffix(".npz")
        arrays: dict[str, Any] = {
            "format": np.array(FORMAT),
            "activation": np.array(self.activation),
            "n_layers": np.array(len(self.weights)),
            "log_std": self.log_std,
            "action_low": self.action_low,
            "action_high": self.action_high,
            "obs_clip": np.array(self.obs_clip),
        }
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            arrays[f"w{i}"], arrays[f"b{i}"] = w, b
        if self.obs_mean is not None:
            arrays["obs_mean"], arrays["obs_std"] = self.obs_mean, self.obs_std
        if self.mirror_index is not None:
            arrays["mirror_index"], arrays["mirror_sign"] = self.mirror_index, self.mirror_sign
            arrays["mirror_action_sign"] = self.mirror_action_sign
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        with tmp.open("wb") as f:
            np.savez(f, **arrays)
        tmp.replace(path)  # atomic: a kill while writing leaves the old file or none
        return path

    @classmethod
    def load(cls, path: str | Path) -> MlpActor:
        """Read an actor written by `save` (pickling off).

        Raises:
            ValueError: naming the file, when it is not such an actor file.
        """
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                if str(data["format"]) != FORMAT:
                    raise ValueError(f"format {str(data['format'])!r}, expected {FORMAT!r}")
                n = int(data["n_layers"])
                weights = tuple(np.asarray(data[f"w{i}"], np.float32) for i in range(n))
                biases = tuple(np.asarray(data[f"b{i}"], np.float32) for i in range(n))
                has_norm = "obs_mean" in data.files
                mirrored = "mirror_index" in data.files
                return cls(
                    weights=weights,
                    biases=biases,
                    activation=str(data["activation"]),
                    log_std=np.asarray(data["log_std"], np.float32),
                    action_low=np.asarray(data["action_low"], np.float32),
                    action_high=np.asarray(data["action_high"], np.float32),
                    obs_mean=np.asarray(data["obs_mean"], np.float64) if has_norm else None,
                    obs_std=np.asarray(data["obs_std"], np.float64) if has_norm else None,
                    obs_clip=float(data["obs_clip"]),
                    mirror_index=np.asarray(data["mirror_index"], np.int64) if mirrored else None,
                    mirror_sign=np.asarray(data["mirror_sign"], np.float32) if mirrored else None,
                    mirror_action_sign=np.asarray(data["mirror_action_sign"], np.float32) if mirrored else None,
                )
        except FileNotFoundError:
            raise
        except (OSError, KeyError, ValueError, TypeError) as exc:
            raise ValueError(f"{path}: not a pico-gym policy array file ({exc})") from None


def export_actor(model: Any, norm: dict[str, Any] | None = None) -> MlpActor:
    """The actor of an SB3 PPO `MlpPolicy` (Box observations and actions) as an `MlpActor`.

    Args:
        model: a stable-baselines3 PPO model.
        norm: VecNormalize's observation statistics ({"mean", "var", "epsilon", "clip"}), if any.

    Raises:
        ValueError: for a policy this cannot represent (gSDE, squashed actions, a feature
            extractor other than flattening, an activation it does not know).
    """
    import torch

    policy = model.policy
    if getattr(policy, "use_sde", False) or getattr(policy, "squash_output", False):
        raise ValueError("export_actor handles Gaussian MLP policies without gSDE or squashing")
    if type(policy.pi_features_extractor).__name__ != "FlattenExtractor":
        raise ValueError(f"export_actor needs a FlattenExtractor, got {type(policy.pi_features_extractor).__name__}")
    names = {torch.nn.Tanh: "tanh", torch.nn.ReLU: "relu", torch.nn.ELU: "elu", torch.nn.LeakyReLU: "leaky_relu"}
    linears, activation = [], None
    for layer in policy.mlp_extractor.policy_net:
        if isinstance(layer, torch.nn.Linear):
            linears.append(layer)
        elif type(layer) in names:
            activation = names[type(layer)]
        else:
            raise ValueError(f"export_actor: unsupported layer {layer!r}")
    linears.append(policy.action_net)

    def arr(t: Any) -> np.ndarray:
        return t.detach().cpu().numpy().astype(np.float32)

    mean = std = None
    clip = np.inf
    if norm is not None:
        mean = np.asarray(norm["mean"], np.float64)
        std = np.sqrt(np.asarray(norm["var"], np.float64) + float(norm["epsilon"]))
        clip = float(norm["clip"])
    return MlpActor(
        weights=tuple(arr(layer.weight) for layer in linears),
        biases=tuple(arr(layer.bias) for layer in linears),
        activation=activation or "tanh",
        log_std=arr(policy.log_std),
        action_low=np.asarray(model.action_space.low, np.float32),
        action_high=np.asarray(model.action_space.high, np.float32),
        obs_mean=mean,
        obs_std=std,
        obs_clip=clip,
        **_mirror_of(policy),
    )


def _mirror_of(policy: Any) -> dict[str, Any]:
    """A mirror-symmetric policy's reflection (`pico_gym.train.mirror.MirrorPolicy`), as
    `MlpActor` fields; none for a plain one."""
    index = getattr(policy, "mirror_index", None)
    if index is None:
        return {}
    n_act = int(policy.action_net.out_features)
    return {
        "mirror_index": np.asarray(index, np.int64),
        "mirror_sign": np.asarray(policy.mirror_sign, np.float32),
        "mirror_action_sign": np.asarray(policy.mirror_action_sign, np.float32)[:n_act],
    }
