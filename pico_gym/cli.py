"""The `pico-gym` command line.

Sub-commands:
    maps        list the shipped maps, or draw one to a PNG
    bench-env   measure env steps/s, LRF scans/s and vector-env throughput on this machine
and, registered by pico_gym.agents and pico_gym.train through the `pico_gym.commands` entry points:
    run, bench, compare, train
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from importlib.metadata import entry_points
from typing import Any

from gymnasium.error import DependencyNotInstalled

from pico_gym.registry import DEFAULT_ENV_ID, TASKS, task_info
from pico_gym.timing import machine, versions
from pico_gym.world.map import MapError

# --- maps -----------------------------------------------------------------------------------


def cmd_maps(args: argparse.Namespace) -> int:
    from pico_gym.world.catalog import load_shipped, shipped_maps

    if args.name is not None and args.map_path is not None:
        raise ValueError("give a shipped map's name or --map-path FILE, not both")
    if args.name is None and args.map_path is None:
        print(f"{'name':<30} {'env':<16} {'size (m)':<13} {'segments':>8} {'cabinets':>8} {'doors':>5}  file")
        for name, path in shipped_maps().items():
            world = load_shipped(name)
            x0, y0, x1, y1 = world.bounds
            env = next((i.env_id for i in TASKS.values() if i.map_prefix and name.startswith(i.map_prefix)), "-")
            print(
                f"{name:<30} {env:<16} {x1 - x0:5.1f} x {y1 - y0:<5.1f} {len(world.seen_segments(False)):>8}"
                f" {len(world.cabinets):>8} {len(world.door_segments):>5}  {path.name}"
            )
        return 0
    if args.map_path is not None:
        from pico_gym.world.map import load_map

        world = load_map(args.map_path)
    else:
        world = load_shipped(args.name)
    out = args.png or f"{world.name or 'map'}.png"
    from pico_gym.render import render_map_png

    render_map_png(world, out)
    print(f"wrote {out}")
    return 0


# --- benchmarks ---------------------------------------------------------------------------


def cmd_bench_env(args: argparse.Namespace) -> int:
    from pico_gym import bench

    if args.lrf:
        print(f"machine : {machine()}\nversions: {versions()}\n")
        bench.bench_lrf(args.repeats, args.seed)
    elif task_info(args.env).bench_rows:
        bench.bench_task(args.env, args.steps, args.seed, args.repeats)
    else:
        bench.bench_escape(args.steps, args.seed, args.repeats)
    return 0


def cmd_bench_walls(args: argparse.Namespace) -> int:
    from pico_gym import bench

    return bench.bench_walls(args.steps, args.seed, args.env)


# --- entry point ----------------------------------------------------------------------------


class _ParserWithDefaults(argparse.ArgumentParser):
    """A sub-command's parser: its help shows every option's default (`HelpFormatter`)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows every option's default (options without one, or with None, show none)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        if action.default in (None, False) or action.default is argparse.SUPPRESS:
            return action.help or ""
        return super()._get_help_string(action) or ""


def build_parser() -> argparse.ArgumentParser:
    import pico_gym

    parser = argparse.ArgumentParser(
        prog="pico-gym", description="PICO challenges as Gymnasium environments.", formatter_class=HelpFormatter
    )
    parser.add_argument("--version", action="version", version=f"pico-gym {pico_gym.__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_ParserWithDefaults)

    p = sub.add_parser("maps", help="list the shipped maps, or draw one (or any map file) to a PNG")
    p.add_argument("name", nargs="?", help="a shipped map to draw")
    p.add_argument(
        "--map-path", help="a map file to draw as pico-gym reads it (JSON, heightmap image, map_server YAML)"
    )
    p.add_argument("--png", help="output file (default: NAME.png)")
    p.set_defaults(func=cmd_maps)

    p = sub.add_parser("bench-env", help="measure env and LRF throughput on this machine")
    p.add_argument("--env", default=DEFAULT_ENV_ID, choices=tuple(TASKS), help="which env's rows")
    p.add_argument("--steps", type=int, default=20000, help="env steps per run")
    p.add_argument("--repeats", type=int, default=5, help="runs per figure (the median is printed)")
    p.add_argument("--seed", type=int, default=0, help="seed of the envs and the random actions")
    p.add_argument("--lrf", action="store_true", help="only the LRF rows (pico-gym against f1tenth-style ray marching)")
    p.set_defaults(func=cmd_bench_env)

    p = sub.add_parser(
        "bench-walls", help="adversarial driving: count overlaps of the true footprint with walls, boxes and people"
    )
    p.add_argument("--env", default=DEFAULT_ENV_ID, choices=tuple(TASKS), help="whose worlds (its walls_rows)")
    p.add_argument("--steps", type=int, default=1_000_000, help="env steps in total")
    p.add_argument("--seed", type=int, default=0, help="seed of the rooms and the commands")
    p.set_defaults(func=cmd_bench_walls)

    # Sub-commands of packages built on pico_gym (agents, training) register themselves here.
    for entry in entry_points(group="pico_gym.commands"):
        entry.load()(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (MapError, ValueError, FileNotFoundError, DependencyNotInstalled) as error:
        print(f"pico-gym {args.command}: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
