"""The `pico-gym` command line.

Sub-commands:
    maps        list the shipped maps, or draw one to a PNG
    bench-env   measure env steps/s, LRF scans/s and vector-env throughput on this machine
and, registered by pico_gym.agents and pico_gym.train through the `pico_gym.commands` entry points:
    run, bench, compare, train
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium.error import DependencyNotInstalled

from pico_gym.world.map import MapError

# --- maps -----------------------------------------------------------------------------------


def cmd_maps(args: argparse.Namespace) -> int:
    from pico_gym.world.catalog import load_shipped, shipped_maps

    if args.name is None:
        print(f"{'name':<30} {'env':<16} {'size (m)':<13} {'segments':>8} {'cabinets':>8} {'doors':>5}  file")
        for name, path in shipped_maps().items():
            world = load_shipped(name)
            x0, y0, x1, y1 = world.bounds
            env = (
                "PicoEscape-v0"
                if world.finish is not None
                else "PicoHospital-v0"
                if world.cabinets
                else "PicoExplore-v0"
                if "parking_wall" in world.extra
                else "-"
            )
            print(
                f"{name:<30} {env:<16} {x1 - x0:5.1f} x {y1 - y0:<5.1f} {len(world.seen_segments(False)):>8}"
                f" {len(world.cabinets):>8} {len(world.door_segments):>5}  {path.name}"
            )
        return 0
    world = load_shipped(args.name)
    out = args.png or f"{args.name}.png"
    from pico_gym.render import render_map_png

    render_map_png(world, out)
    print(f"wrote {out}")
    return 0


# --- bench-env ------------------------------------------------------------------------------


def _machine() -> str:
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} logical cores, {platform.system()} {platform.release()}"


def _versions() -> str:
    import gymnasium
    import numba
    import pymunk

    import pico_gym

    return (
        f"pico-gym {pico_gym.__version__}, Python {platform.python_version()}, numpy {np.__version__}, "
        f"gymnasium {gymnasium.__version__}, pymunk {pymunk.version}, numba {numba.__version__}"
    )


def _median_rate(fn: Callable[[], int], repeats: int) -> tuple[float, list[float]]:
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        count = fn()
        rates.append(count / (time.perf_counter() - t0))
    return statistics.median(rates), rates


def _env_rate(
    steps: int, seed: int, env_id: str = "PicoEscape-v0", env: Any = None, **kwargs: object
) -> Callable[[], int]:
    import gymnasium as gym

    env = gym.make(env_id, **kwargs) if env is None else env
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(steps)]
    for a in actions[:200]:  # warm-up (JIT caches, allocations)
        if any(env.step(a)[2:4]):
            env.reset()

    def run() -> int:
        resets = 0
        for a in actions:
            _, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:
                env.reset()
                resets += 1
        run.resets = resets  # type: ignore[attr-defined]
        return steps

    return run


def clutter_scene(n_segments: int, seed: int = 0) -> np.ndarray:
    """A 10 x 10 m room holding (n_segments - 4) / 4 random boxes: an LRF benchmark scene."""
    rng = np.random.default_rng(seed)
    segs = [[-5, -5, 5, -5], [5, -5, 5, 5], [5, 5, -5, 5], [-5, 5, -5, -5]]
    while len(segs) + 4 <= n_segments:
        cx, cy = rng.uniform(-4.5, 4.5, size=2)
        if abs(cx) < 0.6 and abs(cy) < 0.6:
            continue  # keep the sensor's own spot free
        h = rng.uniform(0.1, 0.3)
        box = [(cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h)]
        segs += [[*box[i], *box[(i + 1) % 4]] for i in range(4)]
    return np.array(segs[:n_segments], dtype=np.float64)


def free_poses(segments: np.ndarray, n: int, seed: int = 0, clearance_m: float = 0.3) -> list[Any]:
    """n poses uniform in a `clutter_scene` room (random headings), each at least `clearance_m`
    from every segment (so outside every box: a box's half side is at most 0.3 m)."""
    from pico_gym.types import Pose

    rng = np.random.default_rng(seed)
    a, e = segments[:, :2], segments[:, 2:] - segments[:, :2]
    length_sq = np.maximum((e * e).sum(axis=1), 1e-300)
    poses: list[Any] = []
    while len(poses) < n:
        p = rng.uniform(-4.9, 4.9, size=2)
        t = np.clip(((p - a) * e).sum(axis=1) / length_sq, 0.0, 1.0)
        if np.hypot(*(a + t[:, None] * e - p).T).min() >= clearance_m:
            poses.append(Pose(float(p[0]), float(p[1]), float(rng.uniform(-math.pi, math.pi))))
    return poses


def _reset_rate(env_id: str, seed: int, repeats: int, **kwargs: object) -> tuple[float, float]:
    """Median resets/s over `repeats` runs of 20 resets, and the median reset time [ms]."""
    import gymnasium as gym

    env = gym.make(env_id, **kwargs)
    env.reset(seed=seed)
    times: list[float] = []

    def resets() -> int:
        for _ in range(20):
            t0 = time.perf_counter()
            env.reset()
            times.append(time.perf_counter() - t0)
        return 20

    median, _ = _median_rate(resets, repeats)
    return median, 1e3 * statistics.median(times)


HOSPITAL_ROWS = [
    (
        "PicoHospital-v0, hospital_2019, 2 movers, 2 boxes, 0-1 closed doors",
        {"map": "hospital_2019", "n_movers": (2, 2), "n_boxes": (2, 2)},
    ),
    ("PicoHospital-v0, hospital_2019, defaults", {"map": "hospital_2019"}),
    ("PicoHospital-v0, hospital_2021 (its 2 movers, 0-2 boxes)", {"map": "hospital_2021"}),
    ("PicoHospital-v0, generated hospitals, defaults", {}),
]
EXPLORE_ROWS = [
    ("PicoExplore-v0, generated 2018 hospitals, defaults", {}),
    ("PicoExplore-v0, generated 2018 hospitals, collision=continue", {"collision": "continue"}),
]


def bench_hospital(args: argparse.Namespace, env_id: str = "PicoHospital-v0") -> int:
    """A task env's rows (PicoHospital-v0, PicoExplore-v0), with PicoEscape-v0's default row measured
    in the same run as the reference."""
    import gymnasium as gym

    import pico_gym  # noqa: F401
    from pico_gym.sensors.lrf import Lrf, LrfConfig

    print(f"machine : {_machine()}")
    print(f"versions: {_versions()}")
    print(
        f"method  : {args.repeats} rounds, each running every row once (interleaved, so a slow spell of a shared "
        "machine hits all rows alike); random actions, one process; steps/s: median over the rounds; ratio: median "
        "of each round's ratio to escape's row in that round\n"
    )
    rows = HOSPITAL_ROWS if env_id == "PicoHospital-v0" else EXPLORE_ROWS
    runs = [_env_rate(args.steps, args.seed)] + [
        _env_rate(args.steps, args.seed, env_id, **kwargs) for _, kwargs in rows
    ]
    rates: list[list[float]] = [[] for _ in runs]
    for _ in range(args.repeats):
        for k, run in enumerate(runs):
            t0 = time.perf_counter()
            count = run()
            rates[k].append(count / (time.perf_counter() - t0))
    labels = ["PicoEscape-v0, 1000 beams, defaults (reference)"] + [label for label, _ in rows]
    for k, (label, run) in enumerate(zip(labels, runs, strict=True)):
        ratios = [r / e for r, e in zip(rates[k], rates[0], strict=True)]
        ratio = f"   {statistics.median(ratios):5.2f}x escape" if k else " " * 16
        print(
            f"{label:<66} {statistics.median(rates[k]):9,.0f} steps/s{ratio}   (runs: "
            f"{', '.join(f'{r:,.0f}' for r in rates[k])}; {run.resets} episode ends per {args.steps:,} steps)"  # type: ignore[attr-defined]
        )
    print()
    for label, kwargs in rows:
        rate, ms = _reset_rate(env_id, args.seed, args.repeats, **kwargs)
        print(f"{'reset, ' + label.split(', ', 1)[1]:<66} {rate:9,.0f} resets/s   ({ms:.1f} ms median)")
    print()
    if env_id != "PicoHospital-v0":
        return 0
    lrf = Lrf(LrfConfig())
    for name in ("hospital_2019", "hospital_2021"):
        env = gym.make("PicoHospital-v0", map=name)
        env.reset(seed=args.seed)
        scene = env.unwrapped.scene
        pose = env.unwrapped.pose
        lrf.exact(pose, scene.lrf_static, scene.mover_segments, scene.static_one_sided)

        def scans(scene=scene, pose=pose) -> int:  # noqa: ANN001
            for _ in range(1000):  # the env's own path: the grid on large maps, plus the movers
                lrf.exact(pose, scene.lrf_static, scene.mover_segments, scene.static_one_sided)
            return 1000

        median, _ = _median_rate(scans, args.repeats)
        n = len(scene.static_seen) + len(scene.mover_segments)
        print(f"{f'LRF, 1000 beams, {name} at its start ({n} segments)':<66} {median:9,.0f} scans/s")
    return 0


def _interleaved(runs: list[Callable[[], int]], repeats: int) -> list[list[float]]:
    """Rates of each run, measured in `repeats` rounds that take every run in turn (same load)."""
    rates: list[list[float]] = [[] for _ in runs]
    for _ in range(repeats):
        for k, run in enumerate(runs):
            t0 = time.perf_counter()
            count = run()
            rates[k].append(count / (time.perf_counter() - t0))
    return rates


def bench_lrf(repeats: int, seed: int, scans: int = 300) -> None:
    """pico-gym's exact LRF against f1tenth_gym's ray marching on the same scenes, in one run.

    Per scene: pico-gym's env path (`Lrf.exact` on `Scene.lrf_static`'s choice), the public pure
    function `lrf_ranges` on the segment array (its grid and beams found again by content) and on
    what the env scans (a prebuilt `SegmentGrid` on large scenes) with `out=`, and the
    f1tenth-style scanner (`pico_gym.sensors.raymarch`, 1080 beams on a 0.05 m raster), interleaved
    round by round; ratios are medians of per-round ratios. Then each env's whole sensor as it scans
    every step, noise included (`Lrf.scan` against f1tenth_gym's `scan()` as written), and the
    sensor moving through 64 free poses.
    """
    import gymnasium as gym

    from pico_gym.sensors.lrf import Lrf, LrfConfig, lrf_ranges
    from pico_gym.sensors.raymarch import RayMarchScanner
    from pico_gym.types import Pose
    from pico_gym.world.segment_grid import GRID_MIN_SEGMENTS, SegmentGrid

    lrf = Lrf(LrfConfig())
    scenes: list[tuple[str, np.ndarray, np.ndarray | None, Pose]] = []
    for n in (20, 100, 400, 1000, 2000):
        scenes.append(
            (f"{n:>4} segments (10 x 10 m room with boxes)", clutter_scene(n, seed), None, Pose(0.1, 0.05, 0.3))
        )
    env = gym.make("PicoHospital-v0", map="hospital_2021")
    env.reset(seed=seed)
    scene = env.unwrapped.scene
    scenes.append(
        (
            f"hospital_2021 as shipped ({len(scene.static_seen)} segments)",
            scene.static_seen,
            scene.static_one_sided,
            env.unwrapped.pose,
        )
    )
    env.close()
    noise_rng = np.random.default_rng(seed)
    unit = np.empty(lrf.config.n_beams)
    print("LRF scans/s (1000 beams; f1tenth-style: 1080 beams, EDT ray marching on a 0.05 m raster)")
    print(f"{'':<48} {'':>9} {'lrf_ranges':>11} {'lrf_ranges':>11}")
    print(f"{'scene':<48} {'pico-gym':>9} {'(arrays)':>11} {'(as env)':>11} {'f1tenth':>9} {'ratio':>7}")
    buffer = np.empty(lrf.config.n_beams)
    pure_ratios: list[tuple[float, float]] = []
    for label, segs, flags, pose in scenes:
        seen = SegmentGrid(segs, flags) if len(segs) >= GRID_MIN_SEGMENTS else segs
        marcher = RayMarchScanner(segs)
        angles = lrf.beam_angles
        lrf.exact(pose, seen, None, flags)
        lrf_ranges(pose, segs, angles, one_sided=flags)
        lrf_ranges(pose, seen, angles, one_sided=flags, out=buffer)
        marcher.scan(*pose)

        def ours(seen=seen, pose=pose, flags=flags) -> int:  # noqa: ANN001
            for _ in range(scans):
                lrf.exact(pose, seen, None, flags)
            return scans

        def pure(segs=segs, pose=pose, flags=flags, angles=angles) -> int:  # noqa: ANN001
            for _ in range(scans):
                lrf_ranges(pose, segs, angles, one_sided=flags)
            return scans

        def pure_as_env(seen=seen, pose=pose, flags=flags, angles=angles) -> int:  # noqa: ANN001
            for _ in range(scans):
                lrf_ranges(pose, seen, angles, one_sided=flags, out=buffer)
            return scans

        def theirs(marcher=marcher, pose=pose) -> int:  # noqa: ANN001
            for _ in range(scans):
                marcher.scan(*pose)
            return scans

        a, b, b2, c = _interleaved([ours, pure, pure_as_env, theirs], repeats)
        ratio = statistics.median(x / y for x, y in zip(a, c, strict=True))
        pure_ratios.append(
            (
                statistics.median(x / y for x, y in zip(b, a, strict=True)),
                statistics.median(x / y for x, y in zip(b2, a, strict=True)),
            )
        )
        print(
            f"{label:<48} {statistics.median(a):9,.0f} {statistics.median(b):11,.0f} "
            f"{statistics.median(b2):11,.0f} {statistics.median(c):9,.0f} {ratio:6.2f}x"
        )
    print(
        "lrf_ranges / the env path, per scene: arrays "
        + " ".join(f"{r:.2f}x" for r, _ in pure_ratios)
        + "; as the env scans, out= "
        + " ".join(f"{r:.2f}x" for _, r in pure_ratios)
    )

    # The whole sensor as each env takes it on every step, noise included: pico-gym's `Lrf.scan`
    # (the cast, 1000 uniform draws, the noise model, float32 ranges) against f1tenth_gym's
    # `ScanSimulator2D.scan` as written (its lookup rotates into the image frame, a new array per
    # scan, 1080 normal draws). The lean loop above is the stricter reference; both are reported.
    print("\nLRF scans/s as each env scans on every step (noise included; f1tenth: its scan() as written)")
    print(f"{'scene':<48} {'pico-gym':>9} {'':>11} {'':>11} {'f1tenth':>9} {'ratio':>7}")
    for label, segs, flags, pose in scenes:
        seen = SegmentGrid(segs, flags) if len(segs) >= GRID_MIN_SEGMENTS else segs
        marcher = RayMarchScanner(segs)
        our_rng, their_rng = np.random.default_rng(seed), np.random.default_rng(seed)
        pose_array = np.array([pose[0], pose[1], pose[2]])

        def ours_noisy(seen=seen, pose=pose, flags=flags, rng=our_rng) -> int:  # noqa: ANN001
            for _ in range(scans):
                lrf.scan(pose, seen, rng, None, flags)
            return scans

        def theirs_noisy(marcher=marcher, pose=pose_array, rng=their_rng) -> int:  # noqa: ANN001
            for _ in range(scans):
                marcher.scan_as_shipped(pose, rng)
            return scans

        ours_noisy()
        theirs_noisy()
        a, c = _interleaved([ours_noisy, theirs_noisy], repeats)
        ratio = statistics.median(x / y for x, y in zip(a, c, strict=True))
        print(f"{label:<48} {statistics.median(a):9,.0f} {'':>11} {'':>11} {statistics.median(c):9,.0f} {ratio:6.2f}x")

    # A moving robot: every scan from another place. (The rows above scan one pose over and over:
    # the same scan each time, whose branches the CPU's predictors can learn, both scanners'.)
    n_poses = 64
    print(f"\nLRF scans/s, the sensor at {n_poses} free poses in turn (>= 0.3 m from every wall, random headings)")
    print(f"{'scene':<48} {'pico-gym':>9} {'':>11} {'':>11} {'f1tenth':>9} {'ratio':>7}")
    for label, segs, flags, _ in scenes[:-1]:  # (the room scenes: poses drawn inside the room)
        seen = SegmentGrid(segs, flags) if len(segs) >= GRID_MIN_SEGMENTS else segs
        marcher = RayMarchScanner(segs)
        poses = free_poses(segs, n_poses, seed)
        rounds = max(1, scans // n_poses)

        def ours_moving(seen=seen, poses=poses, flags=flags, rounds=rounds) -> int:  # noqa: ANN001
            for _ in range(rounds):
                for pose in poses:
                    lrf.exact(pose, seen, None, flags)
            return rounds * len(poses)

        def theirs_moving(marcher=marcher, poses=poses, rounds=rounds) -> int:  # noqa: ANN001
            for _ in range(rounds):
                for pose in poses:
                    marcher.scan(*pose)
            return rounds * len(poses)

        ours_moving()
        theirs_moving()
        a, c = _interleaved([ours_moving, theirs_moving], repeats)
        ratio = statistics.median(x / y for x, y in zip(a, c, strict=True))
        print(f"{label:<48} {statistics.median(a):9,.0f} {'':>11} {'':>11} {statistics.median(c):9,.0f} {ratio:6.2f}x")

    def draws() -> int:
        for _ in range(scans):
            noise_rng.random(out=unit)
        return scans

    median, _ = _median_rate(draws, repeats)
    print(f"{'noise draw (1000 uniforms)':<48} {median:9,.0f} draws/s")


def cmd_bench_env(args: argparse.Namespace) -> int:
    import gymnasium as gym

    import pico_gym  # noqa: F401

    if args.lrf:
        print(f"machine : {_machine()}\nversions: {_versions()}\n")
        bench_lrf(args.repeats, args.seed)
        return 0
    if args.env in ("PicoHospital-v0", "PicoExplore-v0"):
        return bench_hospital(args, args.env)
    print(f"machine : {_machine()}")
    print(f"versions: {_versions()}")
    print(f"method  : median of {args.repeats} runs; random actions, one process, a generated room per episode\n")

    rows = [
        ("PicoEscape-v0, 1000 beams, defaults (collision=terminate)", {}),
        ("PicoEscape-v0, 1000 beams, collision=continue", {"collision": "continue"}),
        ("PicoEscape-v0, 64 beams, collision=continue", {"collision": "continue", "n_beams": 64}),
        ("PicoEscape-v0, 1000 beams, pymunk sub-steps on every step", {"free_space_shortcut": False}),
    ]
    for label, kwargs in rows:
        run = _env_rate(args.steps, args.seed, **kwargs)
        median, rates = _median_rate(run, args.repeats)
        print(
            f"{label:<60} {median:9,.0f} steps/s   (runs: {', '.join(f'{r:,.0f}' for r in rates)}; "
            f"{run.resets} episode ends per {args.steps:,} steps)"
        )

    # The toy ceiling (a pymunk body + an exact numba scan of all 20 segments per step, nothing
    # else), interleaved with PicoEscape-v0 through gym.make and unwrapped: the same load for all.
    from pico_gym.envs.toy import ToyCeilingEnv

    toy = _env_rate(args.steps, args.seed, env=ToyCeilingEnv())
    made = _env_rate(args.steps, args.seed)
    bare = _env_rate(args.steps, args.seed, env=gym.make("PicoEscape-v0").unwrapped)
    rates = _interleaved([toy, made, bare], args.repeats)
    for label, r in zip(("toy ceiling (pymunk body + exact scan, 20 segments)", "PicoEscape-v0 through gym.make",
                         "PicoEscape-v0 unwrapped"), rates, strict=True):  # fmt: skip
        ratio = statistics.median(x / t for x, t in zip(r, rates[0], strict=True))
        print(f"{label:<60} {statistics.median(r):9,.0f} steps/s   {ratio:5.2f}x the toy (median of per-round ratios)")

    env = gym.make("PicoEscape-v0")
    env.reset(seed=args.seed)

    def resets() -> int:
        for _ in range(50):
            env.reset()
        return 50

    median, _ = _median_rate(resets, args.repeats)
    print(f"{'PicoEscape-v0 reset (new room, geodesic field, space)':<60} {median:9,.0f} resets/s")

    print()
    bench_lrf(args.repeats, args.seed)
    print()

    # Vector envs: N robots per call, aggregate env steps/s, interleaved with the single env.
    def vec_rate(mode: str, n: int) -> Callable[[], int]:
        venv = gym.make_vec("PicoEscape-v0", num_envs=n, vectorization_mode=mode)
        venv.reset(seed=args.seed)
        venv.action_space.seed(args.seed)
        batch = [venv.action_space.sample() for _ in range(max(args.steps // n, 1))]
        for a in batch[:20]:
            venv.step(a)

        def run(venv: gym.vector.VectorEnv = venv, batch: list = batch) -> int:
            for a in batch:
                venv.step(a)
            return n * len(batch)

        return run

    single = _env_rate(args.steps, args.seed)
    vec_rows = [("vector_entry_point", 16), ("sync", 16), ("vector_entry_point", 2), ("async", 2)]
    rates = _interleaved([single] + [vec_rate(mode, n) for mode, n in vec_rows], args.repeats)
    print(f"{'PicoEscape-v0, one env (gym.make)':<60} {statistics.median(rates[0]):9,.0f} steps/s")
    for (mode, n), r in zip(vec_rows, rates[1:], strict=True):
        ratio = statistics.median(x / s for x, s in zip(r, rates[0], strict=True))
        label = f"gymnasium.make_vec, {n} envs, {mode}"
        print(f"{label:<60} {statistics.median(r):9,.0f} env steps/s  {ratio:5.2f}x one env (aggregate)")
    return 0


def cmd_bench_walls(args: argparse.Namespace) -> int:
    """Adversarial driving: full speed, spinning, into walls and corners; counts overlaps of the true
    footprint with anything solid (there must be none: walls are solid at every accepted setting)."""
    import gymnasium as gym

    import pico_gym  # noqa: F401
    from pico_gym.physics import PhysicsConfig
    from pico_gym.robot import RobotConfig
    from pico_gym.world.catalog import shipped_maps
    from pico_gym.world.geometry import footprint_clearance

    rng = np.random.default_rng(args.seed)
    settings = [("generated room", {}), ("generated room, 3 obstacles", {"n_obstacles": 3})]
    settings += [(m, {"map": m, "sample_start": True}) for m in shipped_maps() if m.startswith("escape")]
    robot, physics = RobotConfig(), PhysicsConfig()
    # The highest speed the default physics accepts at the full turn rate (check_solid's limit).
    top = (
        math.floor(
            1000 * (physics.contact_skin_m / physics.substep_s - robot.max_turn_rate_radps * robot.circumradius_m)
        )
        / 1000
    )
    speeds = (0.5, 0.6, 0.7, top)
    steps = overlaps = held = contact_steps = 0
    nearest = math.inf
    t0 = time.perf_counter()
    per_setting = max(1, args.steps // (len(settings) * len(speeds)))
    print(f"machine : {_machine()}")
    for _name, options in settings:
        for speed in speeds:
            kwargs = {"collision": "continue", "max_speed_mps": speed, "time_limit_s": 1e5, "idle_time_s": 1e5}
            kwargs.update(options)
            env = gym.make("PicoEscape-v0", **kwargs)
            env.reset(seed=int(rng.integers(1 << 30)))
            outline = env.unwrapped.config.robot.outline
            high = env.action_space.high
            done = 0
            while done < per_setting:
                # Hold one full-speed command (drive and spin) for 0.5-3 s, into whatever is there.
                action = high * rng.choice([-1.0, 1.0], size=3) * rng.choice([0.0, 1.0], size=3, p=[0.2, 0.8])
                for _ in range(int(rng.integers(5, 30))):
                    _, _, terminated, truncated, info = env.step(action)
                    u = env.unwrapped
                    pose = u.pose
                    clearance = footprint_clearance(pose.x, pose.y, pose.theta, outline, u.scene.static_solid, 0.05)
                    steps += 1
                    done += 1
                    overlaps += clearance <= 0.0
                    contact_steps += u.physics.in_contact
                    nearest = min(nearest, clearance)
                    if terminated or truncated:
                        held += u.physics.held
                        env.reset(seed=int(rng.integers(1 << 30)))
                        break
            held += env.unwrapped.physics.held
            env.close()
    rate = steps / (time.perf_counter() - t0)
    print(
        f"adversarial driving: {steps:,} steps over {len(settings)} worlds x speeds {', '.join(map(str, speeds))} m/s "
        f"at the full turn rate ({rate:,.0f} steps/s)"
    )
    print(f"steps in contact: {contact_steps:,}; sub-steps undone because the footprint would have touched: {held:,}")
    print(f"nearest the true footprint came to anything solid: {nearest * 1000:.2f} mm")
    print(f"true footprint overlapping something solid: {overlaps} steps")
    return 0 if overlaps == 0 else 1


# --- entry point ----------------------------------------------------------------------------


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
    sub = parser.add_subparsers(dest="command", required=True)
    add_parser = sub.add_parser

    def add_parser_with_defaults(*args: object, **kwargs: object) -> argparse.ArgumentParser:
        kwargs.setdefault("formatter_class", HelpFormatter)
        return add_parser(*args, **kwargs)

    sub.add_parser = add_parser_with_defaults  # type: ignore[method-assign]  (every command shows defaults)

    p = sub.add_parser("maps", help="list the shipped maps, or draw one to a PNG")
    p.add_argument("name", nargs="?", help="a map to draw")
    p.add_argument("--png", help="output file (default: NAME.png)")
    p.set_defaults(func=cmd_maps)

    p = sub.add_parser("bench-env", help="measure env and LRF throughput on this machine")
    import pico_gym

    p.add_argument("--env", default="PicoEscape-v0", choices=pico_gym.ENV_IDS, help="which env's rows")
    p.add_argument("--steps", type=int, default=20000, help="env steps per run")
    p.add_argument("--repeats", type=int, default=5, help="runs per figure (the median is printed)")
    p.add_argument("--seed", type=int, default=0, help="seed of the envs and the random actions")
    p.add_argument("--lrf", action="store_true", help="only the LRF rows (pico-gym against f1tenth-style ray marching)")
    p.set_defaults(func=cmd_bench_env)

    p = sub.add_parser("bench-walls", help="adversarial driving: count overlaps of the true footprint with walls")
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
