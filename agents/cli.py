"""`pico-gym run` and `pico-gym bench`: play one episode with an agent, or benchmark it.

Registered with the `pico-gym` command through the `pico_gym.commands` entry points, so that
pico_gym itself does not depend on the agents.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import difflib
import json
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from pico_gym.agents.registry import AGENT_ENTRIES
from pico_gym.envs.base import pico_env
from pico_gym.extras import require
from pico_gym.registry import DEFAULT_ENV_ID, TASKS, task_info


def _set_option(key: str, text: str, env_id: str) -> Any:
    """The value of `--set KEY=TEXT`, checked against the env config's field of that name."""
    if key == "family":  # a named family of generated worlds: the env checks the name now
        import gymnasium as gym

        gym.make(env_id, family=text).close()
        return text
    fields = _config_fields(env_id)
    if key not in fields:
        close = difflib.get_close_matches(key, fields, n=3)
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        raise ValueError(f"--set {key}: no such env option{hint}; options: {', '.join(sorted(fields))}")
    try:
        value = ast.literal_eval(text)
    except (ValueError, SyntaxError):
        value = text
    current = fields[key]
    if isinstance(current, bool):
        ok = isinstance(value, bool)
    elif isinstance(current, (int, float)):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    elif isinstance(current, str):
        ok = isinstance(value, str)
    else:
        ok = True  # tuples, nested configs (as dicts), None-able fields: the config checks them
    if not ok:
        raise ValueError(f"--set {key}={text}: expected a {type(current).__name__} like {current!r}")
    return value


def _config_fields(env_id: str = DEFAULT_ENV_ID) -> dict[str, Any]:
    """Every field name of an env's config (at any depth) -> its default value."""
    import gymnasium as gym

    import pico_gym  # noqa: F401
    from pico_gym.envs import env_class

    out: dict[str, Any] = {}

    def walk(config: Any) -> None:
        for f in dataclasses.fields(config):
            value = getattr(config, f.name)
            out.setdefault(f.name, value)
            if dataclasses.is_dataclass(value):
                walk(value)

    walk(env_class(gym.spec(env_id)).default_config())
    return out


def _env_options(args: argparse.Namespace) -> dict[str, Any]:
    options: dict[str, Any] = {}
    if args.map:
        options["map"] = args.map
    if args.map_path:
        options["map_path"] = args.map_path
    if getattr(args, "sim_config", None):
        options["sim_config"] = args.sim_config
    for item in args.set or []:
        key, _, value = item.partition("=")
        if not key or not value:
            raise ValueError(f"--set takes KEY=VALUE, got {item!r}")
        options[key] = _set_option(key, value, args.env)
    return options


def _has_display() -> bool:
    """Whether a window can be opened (an X or Wayland display, or not Linux)."""
    if os.environ.get("SDL_VIDEODRIVER") in ("dummy", "offscreen"):
        return False
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def _add_env(p: argparse.ArgumentParser) -> None:
    p.add_argument("--env", default=DEFAULT_ENV_ID, choices=tuple(TASKS), help="the environment id")


def _add_workers(p: argparse.ArgumentParser) -> None:
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=None, help="local processes (default: one per core)")
    where.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="run the episodes as Ray tasks on a cluster: 'auto' (the one this machine is in), "
        "'ray://HEAD:10001', or 'local' (start Ray here); needs the ray extra",
    )


def _common(p: argparse.ArgumentParser, seed_default: int | None = 0) -> None:
    _add_env(p)
    p.add_argument("--agent", choices=tuple(AGENT_ENTRIES), help="the agent (default: the task's own)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--map", help="a shipped map (default: generated rooms)")
    where.add_argument("--map-path", help="a map file")
    p.add_argument(
        "--sim-config", help="a course simulator config file (its objects, odometry, start poses, ...; with --map)"
    )
    p.add_argument("--seed", type=int, default=seed_default, help="the (first) episode's seed (default: 0)")
    p.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="an env option, e.g. --set noise_m=0.02 --set slip_std=0.05 (repeatable)",
    )
    p.add_argument("--policy", help=POLICY_HELP)
    p.add_argument(
        "--option",
        action="append",
        metavar="KEY=VALUE",
        help="a reset option for every episode, a Python literal, e.g. --option 'cabinet_order=[0, 1, 3]' (repeatable)",
    )


def _reset_options(args: argparse.Namespace) -> dict[str, Any]:
    """`--option KEY=VALUE` as reset options, checked by one reset of the env (bad keys and values
    are refused here, not in a worker)."""
    import gymnasium as gym

    options: dict[str, Any] = {}
    for item in getattr(args, "option", None) or []:
        key, _, text = item.partition("=")
        if not key or not text:
            raise ValueError(f"--option takes KEY=VALUE, got {item!r}")
        try:
            options[key] = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            raise ValueError(f"--option {key}={text}: not a Python literal (a number, list, string ...)") from None
    if options:
        env = gym.make(args.env, **_env_options(args))
        try:
            env.reset(seed=args.seed or 0, options=options)
        except ValueError as error:
            raise ValueError(f"--option: {error}") from None
        finally:
            env.close()
    return options


POLICY_HELP = (
    "the PPO agent's policy: a .npz (numpy, no torch) or an SB3 .zip (needs torch); default: the shipped "
    "one. An SB3 zip runs code when loaded: use only files from a source you trust"
)


def _agent_kwargs(args: argparse.Namespace, agent: str) -> dict[str, Any]:
    return {"path": args.policy} if AGENT_ENTRIES[agent].policy and args.policy else {}


def _agent(args: argparse.Namespace) -> str:
    """The agent asked for, else the task's default (`TaskInfo.default_agent`)."""
    return args.agent or task_info(args.env).default_agent


def cmd_run(args: argparse.Namespace) -> int:
    import gymnasium as gym

    import pico_gym  # noqa: F401
    from pico_gym.agents import make_agent
    from pico_gym.agents.evaluation import run_episode
    from pico_gym.render import save_gif

    if args.render == "human" and not _has_display():
        raise ValueError("--render human needs a display (none found: DISPLAY is not set); use --gif or --video")
    if args.video:
        require("moviepy", "video", "--video")
    if args.gif_every < 1 or not 0.05 <= args.gif_scale <= 1.0:
        raise ValueError(
            f"--gif-every must be >= 1 and --gif-scale in [0.05, 1], got {args.gif_every} and {args.gif_scale}"
        )
    for flag, path in (("--gif", args.gif), ("--video", args.video), ("--png", args.png)):
        if path and not Path(path).resolve().parent.is_dir():
            raise ValueError(f"{flag} {path}: folder {Path(path).resolve().parent} does not exist")
    want_frames = bool(args.gif or args.video or args.png)
    mode = "human" if args.render == "human" else ("rgb_array" if want_frames else None)
    env = gym.make(args.env, render_mode=mode, **_env_options(args))
    args.agent = _agent(args)
    agent = make_agent(args.agent, env, **_agent_kwargs(args, args.agent))
    pico_env(env).set_overlay(agent.overlay)
    frames: list[Any] = []
    stride = args.gif_every if args.gif and not args.video else 1
    steps = [0]

    def record_frame() -> None:
        if len(frames) < args.max_frames and steps[0] % stride == 0:
            frames.append(env.render())
        steps[0] += 1

    record = run_episode(
        env,
        agent,
        args.seed,
        args.agent,
        on_step=record_frame if args.gif or args.video else None,
        options=_reset_options(args) or None,
    )
    if args.gif:
        save_gif(frames, args.gif, env.metadata["render_fps"] * stride, scale=args.gif_scale)
        print(f"wrote {args.gif} ({len(frames)} frames)")
    if args.video:
        from moviepy import ImageSequenceClip

        ImageSequenceClip(frames, fps=env.metadata["render_fps"]).write_videofile(args.video, logger=None)
        print(f"wrote {args.video}")
    if args.png:
        from PIL import Image

        Image.fromarray(np.asarray(env.render())).save(args.png)
        print(f"wrote {args.png}")
    env.close()
    outcome = f"{record.termination_reason}" + (" (success)" if record.success else " (no success)")
    print(f"agent: {args.agent}   map: {record.map}   seed: {record.seed}")
    print(f"outcome: {outcome}")
    print(
        f"time: {record.time_s:.1f} s   bumps: {record.bumps}   path: {record.path_length:.2f} m   "
        f"shortest path: {record.shortest_path_length:.2f} m   SPL: {record.spl:.2f}   SCT: {record.sct:.2f}"
    )
    print(f"min clearance: {record.min_clearance:.3f} m   act(): {record.act_ms:.2f} ms/step (median)")
    return 0


def _bench_episodes(args: argparse.Namespace) -> tuple[Any, str]:
    """The episodes `pico-gym bench` runs (`Episodes`), and how to describe their seeds: a suite's
    split (`--suite NAME --split dev|test`: the suite's own seeds; `--episodes` may take fewer),
    or `--episodes` from `--seed` in the worlds the options ask for."""
    from pico_gym.agents.compare import Episodes
    from pico_gym.registry import Suite, SuiteGroup

    options = _env_options(args)
    if args.suite is None:
        if args.split is not None:
            raise ValueError("--split needs --suite (the suite whose seed split to run)")
        seed, n = args.seed if args.seed is not None else 0, args.episodes or 100
        label = args.map or (Path(args.map_path).stem if args.map_path else "generated")
        suite = Suite(label, label, (SuiteGroup(label),))
        return Episodes.of(suite, range(seed, seed + n), options, args.env), f"seeds {seed}..{seed + n - 1}"
    suite = task_info(args.env).suite(args.suite)
    if args.split is not None:
        if args.seed is not None:
            raise ValueError(f"--split {args.split} runs the suite's own seeds: leave out --seed")
        seeds = suite.seeds(args.split)
        if args.episodes is not None:
            seeds = seeds[: args.episodes]
        where = f"suite {suite.name}, {args.split} split, seeds {seeds[0]}..{seeds[-1]}"
    else:
        seed, n = args.seed if args.seed is not None else 0, args.episodes or 100
        seeds = range(seed, seed + n)
        where = f"suite {suite.name}, seeds {seed}..{seed + n - 1}"
    return Episodes.of(suite, seeds, options, args.env), where


def cmd_bench(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    if args.robots == 2:
        return _bench_two_robots(args)

    from pico_gym.agents.compare import protocol_header, protocol_row, run_comparison, settings_of
    from pico_gym.agents.evaluation import format_summary, summarize

    episodes, where = _bench_episodes(args)
    reset_options = _reset_options(args)
    if args.json and not Path(args.json).resolve().parent.is_dir():
        raise ValueError(f"--json {args.json}: folder {Path(args.json).resolve().parent} does not exist")
    args.agent = _agent(args)
    total = sum(len(seeds) for _, seeds in episodes.groups)
    kwargs = {args.agent: _agent_kwargs(args, args.agent)}
    with tqdm(total=total, desc=f"{args.agent}", unit="ep", file=sys.stderr, disable=args.quiet) as bar:
        results = run_comparison([args.agent], episodes, kwargs, args.workers, bar.update, args.ray, reset_options)
    records = results[args.agent]
    summary = summarize(records, args.env)
    print(format_summary(args.agent, summary))
    options = episodes.env_options
    print(
        f"  env                      {args.env} {options or '(defaults: generated worlds)'}; {where}"
        + (f"; reset options {reset_options}" if reset_options else "")
    )
    failures = [r for r in records if not r.success]
    if failures:
        shown = ", ".join(f"{r.seed}:{r.termination_reason}" for r in failures[:20])
        print(f"  failures (seed:reason)   {shown}{' ...' if len(failures) > 20 else ''}")
    if args.suite is not None:
        print(protocol_header(args.env))
        print(protocol_row(args.suite, args.split or "-", args.agent, summary, args.env))
    if args.json:
        payload = {
            "settings": {**settings_of([args.agent], episodes, kwargs), "reset_options": reset_options},
            "summary": {args.agent: summary.to_dict()},
            "episodes": [r.to_dict() for r in records],
        }
        Path(args.json).write_text(json.dumps(payload, indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0


def _bench_two_robots(args: argparse.Namespace) -> int:
    """`pico-gym bench --robots 2`: both robots' figures (success, time, robot-robot bumps)."""
    from tqdm import tqdm

    from pico_gym.agents.two_robots import failures, run_two_robots, summary_table

    if args.suite is not None or args.option:
        raise ValueError("--robots 2 takes --episodes, --seed and env options (--map, --set), not --suite or --option")
    seed, n = args.seed if args.seed is not None else 0, args.episodes or 20
    args.agent = _agent(args)
    options = _env_options(args)
    with tqdm(total=n, desc=f"{args.agent} x2", unit="ep", file=sys.stderr, disable=args.quiet) as bar:
        records = run_two_robots(
            args.env, args.agent, range(seed, seed + n), options, _agent_kwargs(args, args.agent), bar.update
        )
    print(f"{args.env} {options or '(generated worlds)'}, two robots (pico, taco), seeds {seed}..{seed + n - 1}")
    print(summary_table(args.agent, records))
    print(f"failures (seed: reasons): {failures(records)}")
    if args.json:
        Path(args.json).write_text(json.dumps([r.to_dict() for r in records], indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0


def _add_robots(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--robots",
        type=int,
        choices=(1, 2),
        default=1,
        help="2: pico and taco in one world (pico_gym.parallel_env, the multi extra), each agent driving both robots",
    )


def add_run(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="play one episode with an agent and print the outcome")
    _common(p)
    p.add_argument("--render", choices=("human",), help="show the episode in a window")
    p.add_argument("--gif", help="write the episode (with the agent's overlay) as a GIF")
    p.add_argument("--video", help="write the episode as an MP4 (the video extra: moviepy)")
    p.add_argument("--png", help="write the episode's last frame as a PNG")
    p.add_argument("--max-frames", type=int, default=3000, help="cap on GIF/video frames")
    p.add_argument(
        "--gif-every", type=int, default=1, help="keep every N-th step's frame in the GIF (it plays N times faster)"
    )
    p.add_argument("--gif-scale", type=float, default=0.5, help="the GIF's size against the render's (default: 0.5)")
    p.set_defaults(func=cmd_run)


def add_bench(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="run seeded episodes with an agent and print the figures")
    _common(p, seed_default=None)
    p.add_argument(
        "--episodes", type=int, help="episodes (per group of a suite), on seeds --seed, --seed + 1, ... (default: 100)"
    )
    p.add_argument("--suite", help=_suite_help())
    p.add_argument(
        "--split", choices=("dev", "test"), help="with --suite: its dev or test seeds (the benchmark protocol)"
    )
    _add_workers(p)
    p.add_argument("--json", help="write per-episode records and the summary as JSON")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_robots(p)
    p.set_defaults(func=cmd_bench)


def cmd_compare(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from pico_gym.agents.compare import Episodes, compare, markdown_table, read_results, report

    if args.from_:
        # Records already run (`pico-gym bench --json`, earlier compares): the table and figures.
        results, episodes = read_results(args.from_)
        summaries = report(results, episodes, Path(args.out), n_rooms=0)
        print(markdown_table(summaries, episodes.env_id))
        print(f"wrote {args.out}/results.md, results.json, results.csv and the figures ({len(results)} agents)")
        return 0
    agents = [a.strip() for a in args.agents.split(",") if a.strip()]
    unknown = [a for a in agents if a not in AGENT_ENTRIES]
    if unknown or not agents:
        print(f"pico-gym compare: unknown agent(s) {unknown}; agents: {', '.join(AGENT_ENTRIES)}", file=sys.stderr)
        return 2
    if args.robots == 2:
        return _compare_two_robots(args, agents)
    episodes = Episodes.suite(args.suite, args.episodes, args.seed, _env_options(args), args.env)
    if args.split is not None:
        suite = task_info(args.env).suite(args.suite)
        episodes = Episodes.of(suite, suite.seeds(args.split)[: args.episodes], _env_options(args), args.env)
    total = len(agents) * sum(len(seeds) for _, seeds in episodes.groups)
    kwargs = {a: _agent_kwargs(args, a) for a in agents}
    with tqdm(total=total, desc="compare", unit="ep", file=sys.stderr, disable=args.quiet) as bar:
        summaries = compare(agents, episodes, args.out, kwargs, args.workers, args.trajectories, bar.update, args.ray)
    print(markdown_table(summaries, args.env))
    figures = task_info(args.env).load_metrics().figures
    print(
        f"wrote {args.out}/results.md, results.json, results.csv, success_times.png, success_bumps.png"
        + "".join(f", {name}.png" for name in figures)
        + (", trajectories.png" if args.trajectories else "")
    )
    return 0


def _compare_two_robots(args: argparse.Namespace, agents: list[str]) -> int:
    """`pico-gym compare --robots 2`: every agent driving both robots on the same seeds; the
    table (both done, per-robot success and time, robot-robot bumps) printed and written to --out
    with every episode's record."""
    from tqdm import tqdm

    from pico_gym.agents.two_robots import failures, run_two_robots, summary_table

    if args.from_ or args.split is not None or args.suite != "generated":
        raise ValueError("--robots 2 takes --agents, --episodes, --seed and env options (--map, --set)")
    seeds = range(args.seed, args.seed + args.episodes)
    options = _env_options(args)
    tables, records = [], {}
    with tqdm(total=len(agents) * len(seeds), desc="compare x2", unit="ep", file=sys.stderr, disable=args.quiet) as bar:
        for agent in agents:
            records[agent] = run_two_robots(args.env, agent, seeds, options, _agent_kwargs(args, agent), bar.update)
            tables.append(summary_table(agent, records[agent]).splitlines())
    table = "\n".join(tables[0][:2] + [rows[2] for rows in tables])
    title = f"{args.env} {options or '(generated worlds)'}, two robots (pico, taco), seeds {seeds[0]}..{seeds[-1]}"
    lines = [title, "", table, "", *(f"failures of {a} (seed: reasons): {failures(records[a])}" for a in agents)]
    print("\n".join(lines))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.md").write_text("# pico-gym compare, two robots\n\n" + "\n".join(lines) + "\n")
    dump = {"env_id": args.env, "env_options": options, "seeds": [seeds[0], seeds[-1]]}
    dump["records"] = {a: [r.to_dict() for r in rs] for a, rs in records.items()}
    (out / "results.json").write_text(json.dumps(dump, indent=1, default=str) + "\n")
    print(f"wrote {out}/results.md, results.json")
    return 0


def _suite_help() -> str:
    """What `--suite` takes: every task's suites, from the registry."""
    own = "; ".join(f"{s.name} ({info.env_id}): {s.description}" for info in TASKS.values() for s in info.suites)
    return "generated: generated worlds; maps: the task's shipped maps; all: both" + (f"; {own}" if own else "")


def add_compare(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compare", help="run several agents on the same episodes; table, JSON, CSV and plots")
    _add_env(p)
    p.add_argument("--agents", default="classic,ppo,wall-follow,random", help="comma-separated agent names")
    p.add_argument("--episodes", type=int, default=50, help="episodes per suite part (rooms, or starts per map)")
    p.add_argument("--seed", type=int, default=1000, help="first seed (PPO trains on seeds >= 1,000,000)")
    p.add_argument("--suite", default="generated", help=_suite_help())
    p.add_argument(
        "--split", choices=("dev", "test"), help="the suite's dev or test seeds (--episodes of them) instead of --seed"
    )
    p.add_argument(
        "--from",
        dest="from_",
        nargs="+",
        metavar="JSON",
        help="no episodes: the table and figures of results files (pico-gym bench --json, compare) side by side",
    )
    p.add_argument("--out", default="compare", help="output directory")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="an env option (repeatable)")
    p.add_argument("--policy", help=POLICY_HELP)
    p.add_argument("--trajectories", type=int, default=3, help="rooms in trajectories.png (0: no figure)")
    _add_robots(p)
    _add_workers(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_compare, map=None, map_path=None)
