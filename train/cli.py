"""`pico-gym train`: PPO from a YAML config (registered through the `pico_gym.commands` entry points)."""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

DEFAULT_CONFIG = Path(__file__).parent / "configs" / "ppo_escape.yaml"


def cmd_train(args: argparse.Namespace) -> int:
    try:
        from pico_gym.train.config import ConfigError, load_config
        from pico_gym.train.ppo import train
    except ImportError as exc:
        print(
            f"pico-gym train needs the train extra ({exc.name} is missing): "
            "pip install torch==2.13.0 'pico-gym[train]'",
            file=sys.stderr,
        )
        return 2
    try:
        config = load_config(args.config)
    except ConfigError as exc:
        print(f"pico-gym train: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out or f"runs/{Path(args.config).stem}_seed{args.seed}")
    start = time.perf_counter()
    command = shlex.join(["pico-gym", *sys.argv[1:]])
    path = train(
        config,
        out,
        args.timesteps,
        args.seed,
        progress_bar=not args.no_progress,
        command=command,
        init_from=args.init_from,
    )
    print(f"wrote {path} ({(time.perf_counter() - start) / 60:.1f} min); run directory {out}")
    return 0


def add_train(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("train", help="train a PPO agent (resumes if --out has checkpoints)")
    p.add_argument("--config", default=str(DEFAULT_CONFIG), help="YAML config (rl-zoo3 layout)")
    p.add_argument("--timesteps", type=int, help="total env steps (default: the config's n_timesteps)")
    p.add_argument("--seed", type=int, default=0, help="the run's seed (SB3, envs)")
    p.add_argument("--out", help="run directory (default: runs/<config>_seed<S>)")
    p.add_argument(
        "--init-from",
        help="start from this checkpoint of another run (e.g. to fine-tune). Checkpoints, policy zips and "
        "VecNormalize pickles run code when loaded (as does resuming a run directory): trusted sources only",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_train)
