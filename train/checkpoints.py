"""A run's checkpoints: written whole or not at all, found again on a resume, and checked against
the config the run was trained with."""

from __future__ import annotations

import json
import re
import zipfile
from pathlib import Path

import yaml

from pico_gym.train.config import PICO_KEY, ConfigError, TrainConfig


def _readable_zip(path: Path) -> bool:
    """Whether a checkpoint zip is whole (a kill while writing leaves a partial or empty file)."""
    try:
        with zipfile.ZipFile(path) as z:
            return z.testzip() is None and "data" in z.namelist()
    except (OSError, zipfile.BadZipFile, EOFError):
        return False


def zip_timesteps(path: Path) -> int:
    """The env steps a stable-baselines3 policy zip was trained for (its `data` record)."""
    try:
        with zipfile.ZipFile(path) as z:
            return int(json.loads(z.read("data"))["num_timesteps"])
    except (OSError, zipfile.BadZipFile, EOFError, KeyError, ValueError, TypeError) as err:
        raise ConfigError(f"--init-from {path}: not a stable-baselines3 policy zip ({err})") from None


def _readable_pickle(path: Path) -> bool:
    import pickle

    try:
        with path.open("rb") as f:
            pickle.load(f)  # our own run's statistics file (trusted: written by this trainer)
        return True
    except Exception:  # noqa: BLE001  (truncated or corrupt: any unpickling error)
        return False


def latest_checkpoint(run_dir: Path, needs_stats: bool = False) -> tuple[Path, int] | None:
    """The newest readable checkpoint in `run_dir/checkpoints` (and, with `needs_stats`, with a
    readable VecNormalize file beside it), if any; an unreadable newer one is reported and skipped."""
    found = []
    for p in (run_dir / "checkpoints").glob("ppo_*_steps.zip"):
        m = re.fullmatch(r"ppo_(\d+)_steps\.zip", p.name)
        if m:
            found.append((int(m.group(1)), p))
    for steps, path in sorted(found, reverse=True):
        stats = path.with_name(f"ppo_vecnormalize_{steps}_steps.pkl")
        if not _readable_zip(path):
            print(f"skipping {path.name}: not a whole checkpoint (a run killed while saving?)")
        elif needs_stats and not (stats.exists() and _readable_pickle(stats)):
            print(f"skipping {path.name}: its VecNormalize statistics {stats.name} are missing or unreadable")
        else:
            return path, steps
    return None


# Settings that change the model or what it observes: a resume must not change them silently.
MODEL_KEYS = ("policy", "policy_kwargs", "env_wrapper", "normalize", "frame_stack", "n_envs")
PICO_MODEL_KEYS = ("env_kwargs", "learning")


def config_changes(run_dir: Path, config: TrainConfig) -> list[str]:
    """Keys that change the model or the observation and differ from the run's stored config."""
    stored_path = run_dir / "config.yaml"
    if not stored_path.exists():
        return []
    stored = yaml.safe_load(stored_path.read_text()) or {}
    zoo, pico = stored.get(config.env_id, {}), stored.get(PICO_KEY, {})
    changed = [k for k in MODEL_KEYS if zoo.get(k) != config.zoo.get(k)]
    changed += [f"{PICO_KEY}.{k}" for k in PICO_MODEL_KEYS if pico.get(k) != config.pico.get(k)]
    return changed
