"""`pico-gym run` and `pico-gym bench`: play one episode with an agent, or benchmark it.

Registered with the `pico-gym` command through the `pico_gym.commands` entry points, so that
pico_gym itself does not depend on the agents.
"""

from __future__ import annotations

import argparse
import ast
import json
import sys
from pathlib import Path
from typing import Any

from pico_gym.agents import AGENTS


def _env_options(args: argparse.Namespace) -> dict[str, Any]:
    options: dict[str, Any] = {}
    if args.map:
        options["map"] = args.map
    if args.map_path:
        options["map_path"] = args.map_path
    for item in args.set or []:
        key, _, value = item.partition("=")
        if not key or not value:
            raise ValueError(f"--set takes KEY=VALUE, got {item!r}")
        try:
            options[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            options[key] = value
    return options


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--agent", choices=AGENTS, default="classic")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--map", help="a shipped map (default: generated rooms)")
    where.add_argument("--map-path", help="a map file")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="an env option, e.g. --set noise_m=0.02 --set slip_std=0.05 (repeatable)",
    )
    p.add_argument("--policy", help="the PPO agent's policy zip (default: the shipped one)")


def _agent_kwargs(args: argparse.Namespace, agent: str) -> dict[str, Any]:
    return {"path": args.policy} if agent == "ppo" and args.policy else {}


def cmd_run(args: argparse.Namespace) -> int:
    import gymnasium as gym
    from pico_gym.agents import make_agent
    from pico_gym.agents.evaluation import run_episode

    import pico_gym  # noqa: F401
    from pico_gym.render import save_gif

    mode = "human" if args.render == "human" else ("rgb_array" if args.gif or args.video else None)
    env = gym.make("PicoEscape-v0", render_mode=mode, **_env_options(args))
    agent = make_agent(args.agent, env, **_agent_kwargs(args, args.agent))
    env.unwrapped.set_overlay(agent.overlay)
    frames = []
    record_frame = (lambda: frames.append(env.render())) if mode == "rgb_array" else None
    record = run_episode(env, agent, args.seed, args.agent, on_step=record_frame)
    if args.gif:
        save_gif(frames, args.gif, env.metadata["render_fps"])
        print(f"wrote {args.gif} ({len(frames)} frames)")
    if args.video:
        try:
            from moviepy import ImageSequenceClip
        except ImportError:
            print("pico-gym: --video needs moviepy (pip install moviepy)", file=sys.stderr)
            return 2
        ImageSequenceClip(frames, fps=env.metadata["render_fps"]).write_videofile(args.video, logger=None)
        print(f"wrote {args.video}")
    env.close()
    outcome = "escaped" if record.success else f"did not escape ({record.termination_reason})"
    print(f"agent: {args.agent}   map: {record.map}   seed: {record.seed}")
    print(f"outcome: {outcome}")
    print(
        f"time: {record.time_s:.1f} s   bumps: {record.bumps}   path: {record.path_length:.2f} m   "
        f"shortest path: {record.shortest_path_length:.2f} m   SPL: {record.spl:.2f}   SCT: {record.sct:.2f}"
    )
    print(f"min clearance: {record.min_clearance:.3f} m   act(): {record.act_ms:.2f} ms/step (median)")
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from pico_gym.agents.evaluation import format_summary, run_episodes, summarize
    from tqdm import tqdm

    options = _env_options(args)
    seeds = range(args.seed, args.seed + args.episodes)
    with tqdm(total=args.episodes, desc=f"{args.agent}", unit="ep", file=sys.stderr, disable=args.quiet) as bar:
        records = run_episodes(
            args.agent, seeds, options, _agent_kwargs(args, args.agent), args.workers, progress=bar.update
        )
    summary = summarize(records)
    print(format_summary(args.agent, summary))
    last = args.seed + args.episodes - 1
    print(f"  env options              {options or '(defaults: generated rooms)'}; seeds {args.seed}..{last}")
    failures = [r for r in records if not r.success]
    if failures:
        shown = ", ".join(f"{r.seed}:{r.termination_reason}" for r in failures[:20])
        print(f"  failures (seed:reason)   {shown}{' ...' if len(failures) > 20 else ''}")
    if args.json:
        payload = {
            "agent": args.agent,
            "env_options": options,
            "seeds": [args.seed, args.seed + args.episodes - 1],
            "summary": summary.to_dict(),
            "episodes": [r.to_dict() for r in records],
        }
        Path(args.json).write_text(json.dumps(payload, indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0


def add_run(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="play one episode with an agent and print the outcome")
    _common(p)
    p.add_argument("--render", choices=("human",), help="show the episode in a window")
    p.add_argument("--gif", help="write the episode (with the agent's overlay) as a GIF")
    p.add_argument("--video", help="write the episode as an MP4 (needs moviepy)")
    p.set_defaults(func=cmd_run)


def add_bench(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="run seeded episodes with an agent and print the figures")
    _common(p)
    p.add_argument("--episodes", type=int, default=100)
    p.add_argument("--workers", type=int, default=None, help="processes (default: one per core)")
    p.add_argument("--json", help="write per-episode records and the summary as JSON")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_bench)


def cmd_compare(args: argparse.Namespace) -> int:
    from pico_gym.agents.compare import Episodes, compare, markdown_table
    from tqdm import tqdm

    agents = [a.strip() for a in args.agents.split(",") if a.strip()]
    unknown = [a for a in agents if a not in AGENTS]
    if unknown or not agents:
        print(f"pico-gym compare: unknown agent(s) {unknown}; agents: {', '.join(AGENTS)}", file=sys.stderr)
        return 2
    episodes = Episodes.suite(args.suite, args.episodes, args.seed, _env_options(args))
    total = len(agents) * sum(len(seeds) for _, seeds in episodes.groups)
    kwargs = {a: _agent_kwargs(args, a) for a in agents}
    with tqdm(total=total, desc="compare", unit="ep", file=sys.stderr, disable=args.quiet) as bar:
        summaries = compare(agents, episodes, args.out, kwargs, args.workers, args.trajectories, bar.update)
    print(markdown_table(summaries))
    print(
        f"wrote {args.out}/results.md, results.json, results.csv, escape_times.png, success_bumps.png"
        + (", trajectories.png" if args.trajectories else "")
    )
    return 0


def add_compare(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compare", help="run several agents on the same episodes; table, JSON, CSV and plots")
    p.add_argument("--agents", default="classic,ppo,wall-follow,random", help="comma-separated agent names")
    p.add_argument("--episodes", type=int, default=50, help="episodes per suite part (rooms, or starts per map)")
    p.add_argument("--seed", type=int, default=1000, help="first seed (PPO trains on seeds >= 1,000,000)")
    p.add_argument("--suite", choices=("generated", "maps", "all"), default="generated")
    p.add_argument("--out", default="compare", help="output directory")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="an env option (repeatable)")
    p.add_argument("--policy", help="the PPO agent's policy zip (default: the shipped one)")
    p.add_argument("--trajectories", type=int, default=3, help="rooms in trajectories.png (0: no figure)")
    p.add_argument("--workers", type=int, default=None, help="processes (default: one per core)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_compare, map=None, map_path=None)
