"""A run's checkpoints: written whole or not at all, found again on a resume, and checked against
the config the run was trained with.

A checkpoint is a stable-baselines3 zip (torch state, loaded with pickle) and a VecNormalize
pickle: loading either runs code. The trainer records each file's sha256 in the run's
`checkpoints/manifest.json` as it writes it, and a resume takes only files whose hash is there:
a file replaced or put into the folder by anyone else is refused without being unpickled."""

from __future__ import annotations

import hashlib
import json
import os
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


MANIFEST = "manifest.json"


def file_hash(path: Path) -> str:
    """The sha256 of a file, hex."""
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def record_written(path: Path) -> None:
    """Note a checkpoint file this trainer has just written (its sha256 in the folder's manifest)."""
    manifest_path = path.parent / MANIFEST
    manifest = _manifest(path.parent)
    manifest[path.name] = file_hash(path)
    tmp = manifest_path.with_name(f".{MANIFEST}.tmp")
    tmp.write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    os.replace(tmp, manifest_path)


def _manifest(folder: Path) -> dict[str, str]:
    path = folder / MANIFEST
    if not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return {str(k): str(v) for k, v in data.items()} if isinstance(data, dict) else {}


def written_here(path: Path) -> bool:
    """Whether `path` is a file this trainer wrote and nobody changed since (its hash is in the
    folder's manifest): checked without loading it."""
    expected = _manifest(path.parent).get(path.name)
    return expected is not None and path.is_file() and file_hash(path) == expected


def latest_checkpoint(run_dir: Path, needs_stats: bool = False) -> tuple[Path, int] | None:
    """The newest whole checkpoint in `run_dir/checkpoints` that this trainer wrote (and, with
    `needs_stats`, with its VecNormalize file beside it, also written here), if any; a newer one
    that is partial or not the trainer's own is reported and skipped (never unpickled)."""
    found = []
    for p in (run_dir / "checkpoints").glob("ppo_*_steps.zip"):
        m = re.fullmatch(r"ppo_(\d+)_steps\.zip", p.name)
        if m:
            found.append((int(m.group(1)), p))
    for steps, path in sorted(found, reverse=True):
        stats = path.with_name(f"ppo_vecnormalize_{steps}_steps.pkl")
        if not _readable_zip(path):
            print(f"skipping {path.name}: not a whole checkpoint (a run killed while saving?)")
        elif not written_here(path):
            print(f"skipping {path.name}: not written by this run (not in checkpoints/{MANIFEST}): it could run code")
        elif needs_stats and not (stats.exists() and written_here(stats)):
            print(
                f"skipping {path.name}: its VecNormalize statistics {stats.name} are missing or not written by "
                "this run (never unpickled)"
            )
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
