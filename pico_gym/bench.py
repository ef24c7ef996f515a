"""The env benchmarks of `pico-gym bench-env` and `bench-walls`: throughput of each task's env,
of the LRF against f1tenth_gym's ray marching, of the vector envs, and adversarial driving into
walls. Every figure is a median of interleaved rounds, measured in the run that prints it
(`pico_gym.timing`).
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from pico_gym.envs.base import pico_env
from pico_gym.registry import DEFAULT_ENV_ID
from pico_gym.sensors.lrf import Lrf, LrfConfig, lrf_ranges
from pico_gym.timing import EnvRun, interleaved, machine, median_rate, versions
from pico_gym.types import Pose


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


def free_poses(segments: np.ndarray, n: int, seed: int = 0, clearance_m: float = 0.3) -> list[Pose]:
    """n poses uniform in a `clutter_scene` room (random headings), each at least `clearance_m`
    from every segment (so outside every box: a box's half side is at most 0.3 m)."""
    rng = np.random.default_rng(seed)
    a, e = segments[:, :2], segments[:, 2:] - segments[:, :2]
    length_sq = np.maximum((e * e).sum(axis=1), 1e-300)
    poses: list[Pose] = []
    while len(poses) < n:
        p = rng.uniform(-4.9, 4.9, size=2)
        t = np.clip(((p - a) * e).sum(axis=1) / length_sq, 0.0, 1.0)
        if np.hypot(*(a + t[:, None] * e - p).T).min() >= clearance_m:
            poses.append(Pose(float(p[0]), float(p[1]), float(rng.uniform(-math.pi, math.pi))))
    return poses


def reset_rate(env_id: str, seed: int, repeats: int, **kwargs: Any) -> tuple[float, float]:
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

    median, _ = median_rate(resets, repeats)
    return median, 1e3 * statistics.median(times)


class TwoRobotRun:
    """`steps` two-robot steps (`pico_gym.multi`) of fixed random actions, as one timed run."""

    def __init__(self, steps: int, seed: int, env_id: str, **kwargs: Any) -> None:
        from pico_gym.multi import parallel_env

        self.env = parallel_env(env_id, **kwargs)
        self.env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        space = self.env.robots["pico"].action_space
        self.actions = rng.uniform(space.low, space.high, size=(steps, 2, len(space.low))).astype(np.float32)
        self.resets = 0

    def __call__(self) -> int:
        env = self.env
        names = env.possible_agents
        for pair in self.actions:
            env.step({a: pair[names.index(a)] for a in env.agents})
            if not env.agents:
                env.reset()
                self.resets += 1
        return len(self.actions)


def _two_robot_row(env_id: str, steps: int, seed: int, repeats: int, rows: list[tuple[str, dict[str, Any]]]) -> None:
    """Two robots in one world against one robot, on the task's first row's settings, interleaved."""
    from pico_gym.extras import missing

    if not rows or missing("pettingzoo"):
        return
    from pico_gym.multi import PLAYS

    if env_id not in PLAYS:
        return
    # (the course's two-robot world when the task has it: the 2021 hospital)
    label, kwargs = next(((lb, kw) for lb, kw in rows if kw.get("map") == "hospital_2021"), rows[0])
    one, two = EnvRun(steps, seed, env_id, **kwargs), TwoRobotRun(steps, seed, env_id, **kwargs)
    a, b = interleaved([one, two], repeats)
    ratio = statistics.median(y / x for x, y in zip(a, b, strict=True))
    print(
        f"{'two robots (pico_gym.multi), ' + label.split(', ', 1)[1]:<66} {statistics.median(b):9,.0f} steps/s   "
        f"{ratio:5.2f}x one robot's steps there ({statistics.median(a):,.0f}/s; a step moves both robots)"
    )


def bench_task(env_id: str, steps: int, seed: int, repeats: int) -> None:
    """A task's rows (`TaskInfo.bench_rows`), with PicoEscape-v0's default row measured in the same
    run as the reference; then the task's resets, and the scan rate on its `lrf_maps`."""
    import gymnasium as gym

    from pico_gym.registry import task_info

    info = task_info(env_id)
    print(f"machine : {machine()}")
    print(f"versions: {versions()}")
    print(
        f"method  : {repeats} rounds, each running every row once (interleaved, so a slow spell of a shared "
        "machine hits all rows alike); random actions, one process; steps/s: median over the rounds; ratio: median "
        "of each round's ratio to escape's row in that round\n"
    )
    rows = [(f"{env_id}, {row.label}", dict(row.env_kwargs)) for row in info.bench_rows]
    runs = [EnvRun(steps, seed)] + [EnvRun(steps, seed, env_id, **kwargs) for _, kwargs in rows]
    rates = interleaved(runs, repeats)
    labels = ["PicoEscape-v0, 1000 beams, defaults (reference)"] + [label for label, _ in rows]
    for k, (label, run) in enumerate(zip(labels, runs, strict=True)):
        ratios = [r / e for r, e in zip(rates[k], rates[0], strict=True)]
        ratio = f"   {statistics.median(ratios):5.2f}x escape" if k else " " * 16
        print(
            f"{label:<66} {statistics.median(rates[k]):9,.0f} steps/s{ratio}   (runs: "
            f"{', '.join(f'{r:,.0f}' for r in rates[k])}; {run.resets} episode ends per {steps:,} steps)"
        )
    _two_robot_row(env_id, steps, seed, repeats, rows)
    print()
    for label, kwargs in rows:
        rate, ms = reset_rate(env_id, seed, repeats, **kwargs)
        print(f"{'reset, ' + label.split(', ', 1)[1]:<66} {rate:9,.0f} resets/s   ({ms:.1f} ms median)")
    print()
    lrf = Lrf(LrfConfig())
    for name in info.lrf_maps:
        env = gym.make(env_id, map=name)
        env.reset(seed=seed)
        scene = pico_env(env).scene
        pose = pico_env(env).pose
        lrf.exact(pose, scene.lrf_static, scene.mover_segments, scene.static_one_sided)

        def scans(scene: Any = scene, pose: Any = pose) -> int:
            for _ in range(1000):  # the env's own path: the grid on large maps, plus the movers
                lrf.exact(pose, scene.lrf_static, scene.mover_segments, scene.static_one_sided)
            return 1000

        median, _ = median_rate(scans, repeats)
        n = len(scene.static_seen) + len(scene.mover_segments)
        print(f"{f'LRF, 1000 beams, {name} at its start ({n} segments)':<66} {median:9,.0f} scans/s")


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
    lrf = Lrf(LrfConfig())
    scenes = _lrf_scenes(seed)
    _lrf_exact_rows(lrf, scenes, repeats, scans)
    _lrf_noisy_rows(lrf, scenes, repeats, scans, seed)
    _lrf_moving_rows(lrf, scenes, repeats, scans, seed)
    noise_rng = np.random.default_rng(seed)
    unit = np.empty(lrf.config.n_beams)

    def draws() -> int:
        for _ in range(scans):
            noise_rng.random(out=unit)
        return scans

    median, _ = median_rate(draws, repeats)
    print(f"{'noise draw (1000 uniforms)':<48} {median:9,.0f} draws/s")


_LrfScene = tuple[str, np.ndarray, np.ndarray | None, Pose]


def _lrf_scenes(seed: int) -> list[_LrfScene]:
    """Rooms of 20 to 2000 segments, and the 2021 hospital as shipped."""
    import gymnasium as gym

    scenes: list[_LrfScene] = []
    for n in (20, 100, 400, 1000, 2000):
        scenes.append(
            (f"{n:>4} segments (10 x 10 m room with boxes)", clutter_scene(n, seed), None, Pose(0.1, 0.05, 0.3))
        )
    env = gym.make("PicoHospital-v0", map="hospital_2021")
    env.reset(seed=seed)
    scene = pico_env(env).scene
    scenes.append(
        (
            f"hospital_2021 as shipped ({len(scene.static_seen)} segments)",
            scene.static_seen,
            scene.static_one_sided,
            pico_env(env).pose,
        )
    )
    env.close()
    return scenes


def _lrf_exact_rows(lrf: Lrf, scenes: list[_LrfScene], repeats: int, scans: int) -> None:
    """The exact cast: the env path, lrf_ranges on arrays and as the env scans, f1tenth's marcher."""
    from pico_gym.sensors.raymarch import RayMarchScanner
    from pico_gym.world.segment_grid import GRID_MIN_SEGMENTS, SegmentGrid

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

        a, b, b2, c = interleaved([ours, pure, pure_as_env, theirs], repeats)
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


def _lrf_noisy_rows(lrf: Lrf, scenes: list[_LrfScene], repeats: int, scans: int, seed: int) -> None:
    from pico_gym.sensors.raymarch import RayMarchScanner
    from pico_gym.world.segment_grid import GRID_MIN_SEGMENTS, SegmentGrid

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
        a, c = interleaved([ours_noisy, theirs_noisy], repeats)
        ratio = statistics.median(x / y for x, y in zip(a, c, strict=True))
        print(f"{label:<48} {statistics.median(a):9,.0f} {'':>11} {'':>11} {statistics.median(c):9,.0f} {ratio:6.2f}x")


def _lrf_moving_rows(lrf: Lrf, scenes: list[_LrfScene], repeats: int, scans: int, seed: int) -> None:
    from pico_gym.sensors.raymarch import RayMarchScanner
    from pico_gym.world.segment_grid import GRID_MIN_SEGMENTS, SegmentGrid

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
        a, c = interleaved([ours_moving, theirs_moving], repeats)
        ratio = statistics.median(x / y for x, y in zip(a, c, strict=True))
        print(f"{label:<48} {statistics.median(a):9,.0f} {'':>11} {'':>11} {statistics.median(c):9,.0f} {ratio:6.2f}x")


def bench_escape(steps: int, seed: int, repeats: int) -> None:
    """PicoEscape-v0's rows: steps/s at several settings, against the toy ceiling env, resets, the
    LRF rows (`bench_lrf`) and the vector envs."""
    import gymnasium as gym

    print(f"machine : {machine()}")
    print(f"versions: {versions()}")
    print(f"method  : median of {repeats} runs; random actions, one process, a generated room per episode\n")

    rows: list[tuple[str, dict[str, Any]]] = [
        ("PicoEscape-v0, 1000 beams, defaults (collision=terminate)", {}),
        ("PicoEscape-v0, 1000 beams, collision=continue", {"collision": "continue"}),
        ("PicoEscape-v0, 64 beams, collision=continue", {"collision": "continue", "n_beams": 64}),
        ("PicoEscape-v0, 1000 beams, pymunk sub-steps on every step", {"free_space_shortcut": False}),
    ]
    for label, kwargs in rows:
        run = EnvRun(steps, seed, **kwargs)
        median, rates = median_rate(run, repeats)
        print(
            f"{label:<60} {median:9,.0f} steps/s   (runs: {', '.join(f'{r:,.0f}' for r in rates)}; "
            f"{run.resets} episode ends per {steps:,} steps)"
        )

    # The toy ceiling (a pymunk body + an exact numba scan of all 20 segments per step, nothing
    # else), interleaved with PicoEscape-v0 through gym.make and unwrapped: the same load for all.
    from pico_gym.envs.toy import ToyCeilingEnv

    toy = EnvRun(steps, seed, env=ToyCeilingEnv())
    made = EnvRun(steps, seed)
    bare = EnvRun(steps, seed, env=gym.make("PicoEscape-v0").unwrapped)
    toy_rates = interleaved([toy, made, bare], repeats)
    for label, r in zip(("toy ceiling (pymunk body + exact scan, 20 segments)", "PicoEscape-v0 through gym.make",
                         "PicoEscape-v0 unwrapped"), toy_rates, strict=True):  # fmt: skip
        ratio = statistics.median(x / t for x, t in zip(r, toy_rates[0], strict=True))
        print(f"{label:<60} {statistics.median(r):9,.0f} steps/s   {ratio:5.2f}x the toy (median of per-round ratios)")

    env = gym.make("PicoEscape-v0")
    env.reset(seed=seed)

    def resets() -> int:
        for _ in range(50):
            env.reset()
        return 50

    median, _ = median_rate(resets, repeats)
    print(f"{'PicoEscape-v0 reset (new room, geodesic field, space)':<60} {median:9,.0f} resets/s")

    print()
    bench_lrf(repeats, seed)
    print()

    # Vector envs: N robots per call, aggregate env steps/s, interleaved with the single env.
    def vec_rate(mode: str, n: int) -> Callable[[], int]:
        venv = gym.make_vec("PicoEscape-v0", num_envs=n, vectorization_mode=mode)
        venv.reset(seed=seed)
        venv.action_space.seed(seed)
        batch = [venv.action_space.sample() for _ in range(max(steps // n, 1))]
        for a in batch[:20]:
            venv.step(a)

        def run(venv: gym.vector.VectorEnv = venv, batch: list = batch) -> int:
            for a in batch:
                venv.step(a)
            return n * len(batch)

        return run

    single = EnvRun(steps, seed)
    vec_rows = [("vector_entry_point", 16), ("sync", 16), ("vector_entry_point", 2), ("async", 2)]
    vec_rates = interleaved([single] + [vec_rate(mode, n) for mode, n in vec_rows], repeats)
    print(f"{'PicoEscape-v0, one env (gym.make)':<60} {statistics.median(vec_rates[0]):9,.0f} steps/s")
    for (mode, n), r in zip(vec_rows, vec_rates[1:], strict=True):
        ratio = statistics.median(x / s for x, s in zip(r, vec_rates[0], strict=True))
        label = f"gymnasium.make_vec, {n} envs, {mode}"
        print(f"{label:<60} {statistics.median(r):9,.0f} env steps/s  {ratio:5.2f}x one env (aggregate)")


def bench_walls(steps_total: int, seed: int, env_id: str = DEFAULT_ENV_ID) -> int:
    """Adversarial driving: full speed, spinning, into walls, corners, boxes, closed doors and
    people, and standing still while people walk into the robot; counts the steps after which the
    true footprint overlaps anything solid, people included (there must be none: everything solid
    stays so at every accepted setting)."""
    import gymnasium as gym

    import pico_gym  # noqa: F401
    from pico_gym.physics import PhysicsConfig
    from pico_gym.registry import task_info
    from pico_gym.robot import RobotConfig
    from pico_gym.world.catalog import shipped_maps

    rng = np.random.default_rng(seed)
    info = task_info(env_id)
    settings = [(row.label, dict(row.env_kwargs)) for row in info.walls_rows]
    if not settings:
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
    tally = _WallsTally()
    t0 = time.perf_counter()
    per_setting = max(1, steps_total // (len(settings) * len(speeds)))
    print(f"machine : {machine()}")
    for _name, options in settings:
        for speed in speeds:
            kwargs: dict[str, Any] = {
                "collision": "continue", "max_speed_mps": speed, "time_limit_s": 1e5, "idle_time_s": 1e5,
            }  # fmt: skip
            kwargs.update(options)
            env = gym.make(env_id, **kwargs)
            env.reset(seed=int(rng.integers(1 << 30)))
            _drive_adversarially(env, rng, per_setting, tally)
            env.close()
    rate = tally.steps / (time.perf_counter() - t0)
    print(
        f"adversarial driving ({env_id}): {tally.steps:,} steps over {len(settings)} worlds x speeds "
        f"{', '.join(map(str, speeds))} m/s at the full turn rate ({rate:,.0f} steps/s)"
    )
    print(
        f"steps in contact: {tally.contact_steps:,}; sub-steps undone because the footprint would have touched: "
        f"{tally.held:,}; mover sub-steps undone because a person would have walked into the robot: "
        f"{tally.movers_held:,}"
    )
    print(f"nearest the true footprint came to anything solid: {tally.nearest * 1000:.2f} mm")
    print(f"true footprint overlapping something solid: {tally.overlaps} steps (people: {tally.mover_overlaps})")
    return 0 if tally.overlaps == 0 else 1


class _WallsTally:
    def __init__(self) -> None:
        self.steps = self.overlaps = self.mover_overlaps = self.held = self.movers_held = self.contact_steps = 0
        self.nearest = math.inf


def _drive_adversarially(env: Any, rng: np.random.Generator, n_steps: int, tally: _WallsTally) -> None:
    """`n_steps` of full-speed commands held for 0.5-3 s (drive and spin, into whatever is there),
    a fifth of them standing still (people walk up to the robot), checking the footprint after each."""
    from pico_gym.world.geometry import footprint_clearance

    u = pico_env(env)
    outline = u.config.robot.outline
    high = u.action_space.high
    done = 0
    while done < n_steps:
        action = high * rng.choice([-1.0, 1.0], size=high.shape) * rng.choice([0.0, 1.0], size=high.shape, p=[0.2, 0.8])
        if rng.random() < 0.2:
            action = np.zeros_like(high)
        if len(high) > 3:
            action[3:] = -1.0  # (never announce)
        for _ in range(int(rng.integers(5, 30))):
            _, _, terminated, truncated, _info = env.step(action.astype(np.float32))
            u = pico_env(env)
            pose = u.pose
            scene = u.scene
            clearance = footprint_clearance(pose.x, pose.y, pose.theta, outline, scene.static_solid, 0.05)
            people = footprint_clearance(pose.x, pose.y, pose.theta, outline, scene.mover_segments, 0.05)
            tally.steps += 1
            done += 1
            tally.overlaps += min(clearance, people) <= 0.0
            tally.mover_overlaps += people <= 0.0
            tally.contact_steps += u.physics.in_contact
            tally.nearest = min(tally.nearest, clearance, people)
            if terminated or truncated:
                tally.held += u.physics.held
                tally.movers_held += u.physics.movers_held
                env.reset(seed=int(rng.integers(1 << 30)))
                break
    tally.held += pico_env(env).physics.held
    tally.movers_held += pico_env(env).physics.movers_held
