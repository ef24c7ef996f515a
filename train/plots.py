"""The learning curve of a training run (matplotlib, headless)."""

from __future__ import annotations

import csv
import json
from pathlib import Path


def _read(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(path.open())) if path.exists() else []


def _lineage(run_dir: Path, name: str, key: str) -> list[dict[str, str]]:
    """A run's rows of `name`, preceded by those of the run it started from (--init-from)."""
    rows = _read(run_dir / name)
    init = run_dir / "init_from.json"
    if init.exists():
        parent = json.loads(init.read_text())
        parent_dir = Path(parent["checkpoint"]).parent.parent  # RUN/checkpoints/ppo_N_steps.zip
        earlier = [r for r in _lineage(parent_dir, name, key) if int(r[key]) <= int(parent["timesteps"])]
        rows = earlier + rows
    return rows


def _env_id(run_dir: Path) -> str:
    """The env a run trained on (its resolved config's env block), PicoEscape-v0 if unknown."""
    import yaml

    config = run_dir / "config.yaml"
    blocks = (
        [k for k in (yaml.safe_load(config.read_text()) or {}) if k not in ("pico-gym", "run")]
        if config.exists()
        else []
    )
    return blocks[0] if blocks else "PicoEscape-v0"


def plot_learning_curve(
    run_dir: str | Path, out: str | Path, mark: int | None = None, title: str | None = None
) -> Path:
    """Success rate vs env steps: training episodes (last 100) and periodic evaluations (including
    those of the run this one started from, if it was started with --init-from)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run_dir = Path(run_dir)
    fig, ax = plt.subplots(figsize=(7, 4), dpi=110)
    progress = [r for r in _lineage(run_dir, "progress.csv", "time/total_timesteps") if r.get("escape/success_rate")]
    if progress:
        ax.plot(
            [int(r["time/total_timesteps"]) for r in progress],
            [100 * float(r["escape/success_rate"]) for r in progress],
            color="0.6",
            lw=1,
            label="training episodes (last 100)",
        )
    evals = _lineage(run_dir, "eval.csv", "timesteps")
    init = run_dir / "init_from.json"
    if init.exists():
        start = json.loads(init.read_text())["timesteps"]
        ax.axvline(start, color="0.3", ls=":", lw=1)
        ax.text(start, 2, " fine-tuning starts", fontsize=8, color="0.3")
    if evals:
        steps = [int(r["timesteps"]) for r in evals]
        ax.plot(steps, [100 * float(r["success_rate"]) for r in evals], "o-", color="C0", label="evaluation: success")
        ax.plot(steps, [100 * float(r["bump_rate"]) for r in evals], "s--", color="C3", label="evaluation: bumps")
    if mark is not None:
        ax.axvline(mark, color="C1", ls="--", lw=1)
        ax.text(mark, 30, " shipped", fontsize=8, color="C1", va="top")
    ax.set_xlabel("env steps")
    ax.set_ylabel("% of episodes")
    ax.set_ylim(0, 100)
    ax.grid(alpha=0.3)
    ax.legend(loc="center right")
    ax.set_title(title or f"PPO on {_env_id(run_dir)}: {run_dir.name}")
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return Path(out)


if __name__ == "__main__":
    import sys

    from pico_gym.train.records import join_progress

    run = Path(sys.argv[1])
    if (run / "tb" / "progress.csv").exists():  # a run still going (or stopped) has its progress only in tb/
        join_progress(run)  # every session's rows (a resumed run has one file per session)
    out = sys.argv[2] if len(sys.argv) > 2 else run / "learning_curve.png"
    mark = int(sys.argv[3]) if len(sys.argv) > 3 else None
    title = sys.argv[4] if len(sys.argv) > 4 else None  # default: the run's env and directory
    print(plot_learning_curve(run, out, mark, title))
