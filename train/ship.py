"""Ship a trained policy as an agent's default, with a model card of measured numbers.

    python -m pico_gym.train.ship runs/ppo_escape_seed0/best.zip [--episodes 500] [--seed 1000]
    python -m pico_gym.train.ship runs/hosp/best.zip --target hospital-pointgoal --episodes 100
    python -m pico_gym.train.ship runs/hybrid/best.zip --target hospital-hybrid --episodes 100

copies the policy to agents/models/<name>.{zip,json,npz} (`ppo_escape` for the PPO agent,
`ppo_hospital_pointgoal` for the privileged end-to-end hospital baseline `ppo-pointgoal`),
evaluates it with `pico-gym bench`'s machinery on episodes it never trained on (for the escape, a
realism row too: LRF noise doubled and odometry slip), and writes its model card. The JSON keeps
the card's numbers and a short check (`check`: the first seeds' results) that the tests reproduce.
"""

from __future__ import annotations

import argparse
import csv
import json
import re
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from pico_gym.agents.evaluation import Summary, run_episodes, summarize
from pico_gym.agents.hybrid import SHIPPED_HYBRID_POLICY
from pico_gym.agents.mlp import export_actor
from pico_gym.agents.ppo import SHIPPED_POINTGOAL_POLICY, SHIPPED_POLICY, load_policy, policy_metadata_path
from pico_gym.registry import task_info
from pico_gym.train.config import MIRROR_POLICY

CHECK_EPISODES = 20
REALISM = {"noise_m": 0.02, "slip_std": 0.05}


@dataclass(frozen=True)
class Target:
    """Where a shipped policy goes and how its card reads."""

    agent: str  # the make_agent name that loads it
    policy: Path  # its .npz (the .zip and .json beside it)
    card: Path
    env_id: str
    trained_on: str
    success_target: float
    bump_target: float | None
    realism: bool
    privileged: str = ""
    # Further rows on the same seeds: (name, env kwargs); e.g. rooms with boxes for the escape policy.
    variants: tuple[tuple[str, dict[str, Any]], ...] = ()
    variants_target: float | None = None  # success over all the variants' episodes

    @property
    def model(self) -> Path:
        return self.policy.with_suffix(".zip")


TARGETS = {
    "escape": Target(
        "ppo", SHIPPED_POLICY, SHIPPED_POLICY.parent / "MODEL_CARD.md", "PicoEscape-v0",
        "PicoEscape-v0's generated rooms", 0.95, 0.02, True,
        variants=(("1 box", {"n_obstacles": 1}), ("2 boxes", {"n_obstacles": 2}), ("3 boxes", {"n_obstacles": 3})),
        variants_target=0.95,
    ),
    "hospital-pointgoal": Target(
        "ppo-pointgoal", SHIPPED_POINTGOAL_POLICY, SHIPPED_POINTGOAL_POLICY.parent / "HOSPITAL_POINTGOAL_CARD.md",
        "PicoHospital-v0", "PicoHospital-v0's generated hospitals", 0.80, None, False,
        privileged="PRIVILEGED: it sees the range and bearing to the next arrival square and the heading error to "
        "facing its cabinet, from the true pose (`pico_gym.wrappers.PrivilegedPointGoal`, Habitat PointNav's "
        "convention). A baseline for RL research, never a course agent (`PRIVILEGED_AGENTS`).",
    ),
    "hospital-hybrid": Target(
        "hybrid", SHIPPED_HYBRID_POLICY, SHIPPED_HYBRID_POLICY.parent / "HOSPITAL_HYBRID_CARD.md",
        "PicoHospital-v0", "PicoHospital-v0's hospitals, driving NAVIGATE inside the hybrid agent's loop "
        "(`pico_gym.train.hybrid.HybridTraining`)", 0.95, 0.01, False,
        variants=(("narrow family", {"family": "narrow"}), ("crowded family", {"family": "crowded"})),
    ),
}  # fmt: skip


def _evaluate(target: Target, seeds: range, env_kwargs: dict[str, Any]) -> tuple[Summary, list[Any]]:
    from tqdm import tqdm

    with tqdm(total=len(seeds), desc=target.agent, unit="ep", file=sys.stderr) as bar:
        records = run_episodes(
            target.agent, seeds, env_kwargs, {"path": str(target.policy)}, progress=bar.update, env_id=target.env_id
        )
    return summarize(records, target.env_id), records


def _row(name: str, s: Summary) -> str:
    return (
        f"| {name} | {s.episodes} | {100 * s.success_rate:.1f} % | {100 * s.bump_rate:.1f} % | {s.idle} / "
        f"{s.timeout} | {s.time_median_s:.1f} s / {s.time_p90_s:.1f} s | {s.spl:.3f} | "
        f"{s.sct_median:.3f} | {s.act_ms_median:.2f} ms |"
    )


def wall_clock(run_dir: Path, timesteps: int) -> float | None:
    """Seconds of training to reach `timesteps` (an evaluation point): behaviour cloning, the
    run's own learning time, and that of the run it started from (--init-from), if any. Between
    two evaluations, or between the last one and the run's end (done.json), interpolated."""
    bc = run_dir / "behaviour_cloning.json"
    seconds = json.loads(bc.read_text())["seconds"] if bc.exists() else 0.0
    rows = list(csv.DictReader((run_dir / "eval.csv").open())) if (run_dir / "eval.csv").exists() else []
    points = sorted((int(r["timesteps"]), float(r["wall_clock_s"])) for r in rows)
    done = run_dir / "done.json"
    if done.exists():
        end = json.loads(done.read_text())
        if not points or int(end["timesteps"]) > points[-1][0]:
            points.append((int(end["timesteps"]), float(end["wall_clock_s"])))
    at = [w for t, w in points if t == timesteps]
    if not at:
        # A checkpoint between two evaluations: interpolated.
        before_t = [(t, w) for t, w in points if t < timesteps]
        after_t = [(t, w) for t, w in points if t > timesteps]
        if not before_t or not after_t:
            return None
        (t0, w0), (t1, w1) = before_t[-1], after_t[0]
        at = [w0 + (w1 - w0) * (timesteps - t0) / (t1 - t0)]
    parent, parent_run = _started_from(run_dir)
    if parent is not None and parent_run is not None:  # (a start from a shipped policy is not counted here)
        before = wall_clock(parent_run, int(parent["timesteps"]))
        if before is None:
            return None
        seconds += before
    return round(seconds + at[0], 1)


def _started_from(run_dir: Path) -> tuple[dict[str, Any] | None, Path | None]:
    """The run's --init-from record, and the run directory it names (None for a policy that is
    not a run's checkpoint, e.g. a shipped one)."""
    init = run_dir / "init_from.json"
    if not init.exists():
        return None, None
    parent = json.loads(init.read_text())
    parent_run = Path(parent["checkpoint"]).parent.parent
    return parent, parent_run if (parent_run / "config.yaml").exists() else None


def history(run_dir: Path) -> list[str]:
    """What was run, oldest first: the commands of this run and of the runs it started from."""
    config = yaml.safe_load((run_dir / "config.yaml").read_text())
    lines = []
    parent, parent_run = _started_from(run_dir)
    if parent is not None and parent_run is not None:
        lines += history(parent_run)
        lines.append(f"then from its checkpoint at {parent['timesteps']:,} steps:")
    elif parent is not None:
        lines.append(f"started from the policy `{parent['checkpoint']}` (not a run directory here), then:")
    bc = run_dir / "behaviour_cloning.json"
    if bc.exists():
        report = json.loads(bc.read_text())
        lines.append(
            f"behaviour cloning of the classic agent: {report['episodes']} rooms, {report['samples']:,} samples, "
            f"{report['epochs']} epochs, MSE {report['mse_per_epoch'][0]:.4f} -> {report['mse_per_epoch'][-1]:.4f}, "
            f"{report['seconds']:.0f} s"
        )
    lines.append(f"`{config.get('run', {}).get('command', '?')}`")
    return lines


def ship(
    source: Path,
    episodes: int,
    seed: int,
    realism: bool = True,
    reproduce: list[str] | None = None,
    picked: str = "",
    note: str = "",
    target: Target = TARGETS["escape"],
    shield: bool = False,
) -> Path:
    """Ship `source` as `target`'s policy: copy it, export its arrays, evaluate it on `episodes`
    seeds from `seed`, write its card. `shield`: the policy ships shielded (its agent passes the
    twist through the classic safety filter unless told otherwise; `PpoAgent(shield=...)`), and
    is evaluated so."""
    SHIPPED_MODEL, SHIPPED_POLICY = target.model, target.policy  # noqa: N806
    realism = realism and target.realism
    run_dir = source.parent.parent if source.parent.name == "checkpoints" else source.parent
    config = yaml.safe_load((run_dir / "config.yaml").read_text())
    done = json.loads((run_dir / "done.json").read_text()) if (run_dir / "done.json").exists() else {}
    meta_path = policy_metadata_path(source)
    if meta_path.exists():
        meta = json.loads(meta_path.read_text())
    else:  # a checkpoint: its metadata comes from the run's resolved config
        from pico_gym.train.config import TrainConfig

        m = re.fullmatch(r"ppo_(\d+)_steps\.zip", source.name)
        if m is None:
            raise SystemExit(f"{source}: neither a saved policy (no {meta_path.name}) nor a checkpoint")
        env_id = next(k for k in config if k not in ("pico-gym", "run"))
        if config[env_id].get("normalize"):
            raise SystemExit(f"{source}: ship best.zip or model.zip, which carry the VecNormalize statistics")
        from pico_gym.train.config import goal_metadata

        resolved = TrainConfig(env_id, config[env_id], config["pico-gym"], str(run_dir))
        meta = {
            "algo": "ppo",
            "learning": resolved.learning.to_dict(),
            "env_id": env_id,
            "env_kwargs": config["pico-gym"].get("env_kwargs") or {},
            "timesteps": int(m.group(1)),
            **goal_metadata(resolved),
        }
    evals = list(csv.DictReader((run_dir / "eval.csv").open())) if (run_dir / "eval.csv").exists() else []
    meta["wall_clock_s"] = wall_clock(run_dir, int(meta.get("timesteps", -1))) or done.get("wall_clock_s")
    meta["shield"] = shield
    SHIPPED_MODEL.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(source, SHIPPED_MODEL)
    policy_metadata_path(SHIPPED_MODEL).write_text(json.dumps(meta, indent=1, default=str) + "\n")
    # The actor as plain arrays: what the PPO agent runs on (no torch needed to act).
    SHIPPED_POLICY.unlink(missing_ok=True)
    model, _, _ = load_policy(SHIPPED_MODEL)
    export_actor(model, meta.get("obs_norm")).save(SHIPPED_POLICY)

    seeds = range(seed, seed + episodes)
    # The card's rows: the task's generated worlds as the run evaluated on them while training
    # (its env kwargs, e.g. the arrival mode the policy acts in), but never a family's worlds: a
    # run that evaluated on a family still reports the default worlds first, then the target's
    # variants of them.
    card_kwargs = {k: v for k, v in (meta.get("env_kwargs") or {}).items() if k != "family"}
    summary, records = _evaluate(target, seeds, card_kwargs)
    rows = [_row(f"generated {task_info(target.env_id).worlds}", summary)]
    evaluation = {"generated": {"seeds": [seeds[0], seeds[-1]], **summary.to_dict()}}
    if realism:
        hard, _ = _evaluate(target, seeds, {**card_kwargs, **REALISM})
        rows.append(_row("noise x2 + slip", hard))
        evaluation["realism"] = {"seeds": [seeds[0], seeds[-1]], "env_kwargs": REALISM, **hard.to_dict()}
    pooled = []
    for name, kwargs in target.variants:
        summary_v, records_v = _evaluate(target, seeds, {**card_kwargs, **kwargs})
        rows.append(_row(name, summary_v))
        evaluation[name] = {"seeds": [seeds[0], seeds[-1]], "env_kwargs": kwargs, **summary_v.to_dict()}
        pooled += records_v
    if pooled:
        evaluation["variants_pooled"] = summarize(pooled, target.env_id).to_dict()
    check = records[:CHECK_EPISODES]
    meta.update(
        source=str(source),
        command=config.get("run", {}).get("command", ""),
        train_seed=config.get("run", {}).get("seed"),
        run_timesteps=done.get("timesteps") or max((int(r["timesteps"]) for r in evals), default=None),
        evaluation=evaluation,
        history=history(run_dir),
        reproduce=reproduce or [],
        picked=picked,
        wall_clock_note=note,
        check={
            "env_kwargs": card_kwargs,
            "seeds": [r.seed for r in check],
            "success": [r.success for r in check],
            "bumps": [r.bumps for r in check],
        },
    )
    policy_metadata_path(SHIPPED_MODEL).write_text(json.dumps(meta, indent=1, default=str) + "\n")
    _write_card(meta, config, rows, target)
    return SHIPPED_MODEL


def _train_worlds(config: dict[str, Any]) -> str:
    """The card's words for the worlds a run trained in: its env kwargs and variants, if any."""
    settings = config.get("pico-gym", {})
    kwargs, variants = settings.get("train_env_kwargs") or {}, settings.get("train_env_variants") or []
    words = f", train env kwargs {kwargs}" if kwargs else ""
    if variants:
        words += f", its episodes drawn in turn from {len(variants)} variants: " + "; ".join(map(str, variants))
    return words


def _policy_kind(config: dict[str, Any]) -> str:
    """The card's words for the run's policy class."""
    if any(isinstance(block, dict) and block.get("policy") == MIRROR_POLICY for block in config.values()):
        return "MLP policy with a mirror-symmetric actor (`pico_gym.train.mirror`: it cannot prefer a hand)"
    return "MLP policy"


def _write_card(meta: dict[str, Any], config: dict[str, Any], rows: list[str], target: Target) -> None:
    run = config.pop("run", {})
    minutes = (meta.get("wall_clock_s") or 0) / 60
    name = target.policy.stem
    generated = meta["evaluation"]["generated"]
    targets = f"success >= {100 * target.success_target:.0f} % (" + (
        "met" if generated["success_rate"] >= target.success_target else "NOT met"
    )
    if target.bump_target is not None:
        targets += f"), bump rate <= {100 * target.bump_target:.0f} % (" + (
            "met" if generated["bump_rate"] <= target.bump_target else "NOT met"
        )
    if target.variants_target is not None and "variants_pooled" in meta["evaluation"]:
        pooled = meta["evaluation"]["variants_pooled"]
        names = ", ".join(n for n, _ in target.variants)
        targets += (
            f"), success over the {names} rows {100 * pooled['success_rate']:.1f} % >= "
            f"{100 * target.variants_target:.0f} % ("
            + ("met" if pooled["success_rate"] >= target.variants_target else "NOT met")
        )
    lines = [
        f"# Model card: `{name}` (the `{target.agent}` agent's shipped policy)",
        "",
        "Written by `python -m pico_gym.train.ship` from measured runs; do not edit the numbers by hand.",
        "",
        "## What it is",
        f"- PPO (stable-baselines3 {run.get('versions', {}).get('stable-baselines3', '?')}), {_policy_kind(config)}, "
        f"trained on {target.trained_on} (seeds >= 1,000,000){_train_worlds(config)}; the run's own evaluations "
        f"during training on env kwargs {meta.get('env_kwargs') or {}}.",
        *([f"- {target.privileged}"] if target.privileged else []),
        *(
            [
                "- Shielded: its agent passes the policy's twist through the classic agents' safety filter on the "
                "current scan (`PpoAgent(shield=True)`, the default this policy's metadata sets); the table is "
                "measured so."
            ]
            if meta.get("shield")
            else []
        ),
        *(
            [
                "- Drives with the backing cut it was trained with: `HybridConfig("
                + ", ".join(f"{k}={v!r}" for k, v in meta["hybrid"].items())
                + ")`, which this policy's metadata sets (`HybridAgent` reads it unless given a config); the "
                "table is measured so."
            ]
            if meta.get("hybrid")
            else []
        ),
        "- Observation: `PicoLearningWrapper("
        + ", ".join(f"{k}={v!r}" for k, v in meta["learning"].items())
        + ")` (min-pooled LRF sectors, 360-degree range memory, odometry velocity, frame stack); "
        "actions in [-1, 1] rescaled to the robot's limits.",
        *(
            [
                "- Point goal: the exit as the robot's own perception tracks it (`pico_gym.agents.exit_goal.ExitGoal`"
                f"({', '.join(f'{k}={v!r}' for k, v in (meta.get('exit_goal') or {}).items())}): the classic agent's "
                "mouth detection on the LRF, tracked with odometry; not privileged), computed by the agent itself "
                "as it plays."
            ]
            if meta.get("point_goal_source") == "exit"
            else []
        ),
        f'- Loads with `make_agent("{target.agent}", env)` from `{name}.npz` (the actor as plain arrays, numpy '
        f"only, loaded with pickling off); `{name}.zip` is the stable-baselines3 training artefact (needs torch, "
        "the `train` extra). A zip or pickle runs code when loaded: use only files from a source you trust.",
        "",
        "## How it was trained",
        *[f"- {line}" for line in meta.get("history", [])],
        f"- Seed: {run.get('seed')}; env steps: {meta.get('timesteps'):,} (this checkpoint; the run went to "
        f"{meta.get('run_timesteps') or 0:,})",
        f"- Wall-clock to this checkpoint: {minutes:.0f} min (behaviour cloning + training + periodic "
        f"evaluations) on {run.get('versions', {}).get('machine', '?')}"
        + (f"; {meta['wall_clock_note']}" if meta.get("wall_clock_note") else ""),
        f"- Picked: `{Path(meta['source']).name}` of the run: {meta.get('picked') or 'by hand'}.",
        f"- Learning curve: [docs/{name}_learning_curve.png](../../docs/{name}_learning_curve.png)"
        if name != "ppo_escape"
        else "- Learning curve: [docs/ppo_learning_curve.png](../../docs/ppo_learning_curve.png)",
        "",
        "To reproduce (same configs, in this repository):",
        "",
        "```bash",
        *meta.get("reproduce", []),
        "```",
        "",
        "## Evaluation (rooms it never trained on; deterministic policy)",
        "",
        "| episodes | n | success | bump rate | idle / timeout | escape time median / p90 | SPL | SCT median |"
        " compute per step |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        *rows,
        "",
        f"Seeds {generated['seeds'][0]}-{generated['seeds'][1]}; targets: {targets}).",
        "",
        "## Config",
        "```yaml",
        yaml.safe_dump(config, sort_keys=False).rstrip(),
        "```",
        "",
    ]
    target.card.write_text("\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m pico_gym.train.ship", description=__doc__.split("\n\n")[0])
    p.add_argument("policy", type=Path, help="a policy zip of a run directory (e.g. runs/x/best.zip)")
    p.add_argument("--episodes", type=int, default=500)
    p.add_argument("--seed", type=int, default=1000)
    p.add_argument("--no-realism", action="store_true", help="skip the noise x2 + slip evaluation")
    p.add_argument("--reproduce", action="append", help="a command reproducing the run (repeatable)")
    p.add_argument("--picked", default="", help="how this policy was chosen among the run's")
    p.add_argument("--wall-clock-note", default="", help="context for the wall-clock figure")
    p.add_argument("--target", choices=sorted(TARGETS), default="escape", help="which agent's policy this is")
    p.add_argument("--shield", action="store_true", help="ship it shielded (the classic safety filter on its twist)")
    args = p.parse_args(argv)
    path = ship(
        args.policy,
        args.episodes,
        args.seed,
        realism=not args.no_realism,
        reproduce=args.reproduce,
        picked=args.picked,
        note=args.wall_clock_note,
        target=TARGETS[args.target],
        shield=args.shield,
    )
    print(f"shipped {path} ({path.stat().st_size / 1e6:.1f} MB); card: {TARGETS[args.target].card}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
