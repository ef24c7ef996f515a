"""The learning wrappers: shapes, bounds, min-pooling, action rescaling, and the one-pass pipeline
equal to the chain of standard wrappers."""

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import FlattenObservation, FrameStackObservation, RescaleAction

import pico_gym  # noqa: F401
from pico_gym.wrappers import (
    POINT_GOAL_RANGE_M,
    POINT_GOAL_SIZE,
    LearningConfig,
    LrfMemory,
    MinPoolLrf,
    OdometryTrail,
    OdomVelocity,
    PicoLearningWrapper,
    PrivilegedPointGoal,
    RangeMemory,
    encode_goal,
    min_pool,
    point_goal,
    rescale_action,
    scale_ranges,
    sector_starts,
    unit_action,
)


def test_sector_starts_cover_every_beam_once():
    for n_beams, n_sectors in [(1000, 64), (1000, 90), (1000, 1000), (7, 3), (1000, 1)]:
        starts = sector_starts(n_beams, n_sectors)
        sizes = np.diff(np.append(starts, n_beams))
        assert len(starts) == n_sectors and starts[0] == 0
        assert sizes.sum() == n_beams and sizes.min() >= 1 and sizes.max() - sizes.min() <= 1
    with pytest.raises(ValueError, match="n_sectors"):
        sector_starts(10, 11)


def test_min_pool_is_the_sector_minimum():
    rng = np.random.default_rng(0)
    ranges = rng.uniform(0.1, 10.0, 1000)
    starts = sector_starts(1000, 64)
    pooled = min_pool(ranges, starts, 10.0, normalize=False)
    bounds = np.append(starts, 1000)
    expected = [ranges[a:b].min() for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    np.testing.assert_allclose(pooled, expected, rtol=1e-6)
    # A single close beam makes its whole sector read close: conservative.
    ranges = np.full(1000, 8.0)
    ranges[500] = 0.3
    pooled = min_pool(ranges, starts, 10.0)
    assert pooled.min() == pytest.approx(0.03) and np.sum(pooled < 0.5) == 1
    # Max-pooling shows what min-pooling hides: a far gap inside a sector of near beams.
    assert min_pool(ranges, starts, 10.0, reduce=np.maximum).max() == pytest.approx(0.8)
    # The legacy "0 = no hit" reads as range_max, not as an obstacle at 0 m.
    assert min_pool(np.zeros(10), np.array([0, 5]), 10.0).tolist() == [1.0, 1.0]


def test_action_rescaling_round_trip():
    low, high = np.array([-0.5, -0.5, -1.2]), np.array([0.5, 0.5, 1.2])
    for unit in ([-1, -1, -1], [1, 1, 1], [0, 0, 0], [0.3, -0.7, 0.5]):
        twist = rescale_action(np.array(unit, float), low, high)
        assert np.all(twist >= low) and np.all(twist <= high)
        np.testing.assert_allclose((twist - low) / (high - low) * 2 - 1, unit, atol=1e-12)
        np.testing.assert_allclose(unit_action(twist, low, high), unit, atol=1e-12)
    np.testing.assert_allclose(rescale_action(np.array([5.0, -5, 0]), low, high), [0.5, -0.5, 0.0])
    # And through the wrapper: unit action 1 on vx drives at 0.5 m/s.
    env = PicoLearningWrapper(gym.make("PicoEscape-v0", map="escape_2019"), n_sectors=16)
    env.reset(seed=0)
    before = env.unwrapped.pose
    env.step(np.array([1.0, 0.0, 0.0], np.float32))
    after = env.unwrapped.pose
    assert np.hypot(after.x - before.x, after.y - before.y) == pytest.approx(0.05, abs=2e-3)


@pytest.mark.parametrize("n_sectors,frame_stack", [(64, 1), (90, 3)])
def test_learning_wrapper_shapes_and_bounds(n_sectors, frame_stack):
    env = PicoLearningWrapper(gym.make("PicoEscape-v0"), n_sectors=n_sectors, frame_stack=frame_stack)
    size = (n_sectors + 3) * frame_stack
    assert env.observation_space.shape == (size,)
    assert env.action_space.shape == (3,)
    np.testing.assert_array_equal(env.action_space.low, -1)
    np.testing.assert_array_equal(env.action_space.high, 1)
    obs, _ = env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(60):
        assert obs.shape == (size,) and obs.dtype == np.float32
        assert env.observation_space.contains(obs)
        obs, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, 3).astype(np.float32))
        if terminated or truncated:
            obs, _ = env.reset()


@pytest.mark.parametrize(
    "max_pool,memory,scale", [(False, 0, "linear"), (True, 0, "linear"), (False, 24, "linear"), (True, 24, "log")]
)
def test_learning_wrapper_equals_the_chain_of_standard_wrappers(max_pool, memory, scale):
    def chain():
        env = gym.make("PicoEscape-v0", noise_m=0.02, slip_std=0.05)
        if memory:
            env = LrfMemory(env, memory, scale=scale)
        env = FlattenObservation(OdomVelocity(MinPoolLrf(env, n_sectors=32, max_pool=max_pool, scale=scale)))
        env = FlattenObservation(FrameStackObservation(env, 3))
        return RescaleAction(env, -1.0, 1.0)

    env = gym.make("PicoEscape-v0", noise_m=0.02, slip_std=0.05)
    a, b = chain(), PicoLearningWrapper(env, 32, 3, max_pool=max_pool, memory_sectors=memory, range_scale=scale)
    assert a.observation_space.shape == b.observation_space.shape
    oa, _ = a.reset(seed=11)
    ob, _ = b.reset(seed=11)
    rng = np.random.default_rng(1)
    for _ in range(40):
        np.testing.assert_allclose(oa, ob, atol=1e-6)
        action = rng.uniform(-1, 1, 3).astype(np.float32)
        oa, ra, ta, _, _ = a.step(action)
        ob, rb, tb, _, _ = b.step(action)
        assert ra == rb and ta == tb
        if ta:
            break


def test_odom_velocity_reads_the_commanded_twist():
    env = OdomVelocity(gym.make("PicoEscape-v0", map="escape_2019"))
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(obs["odom"], 0)
    obs, *_ = env.step(np.array([0.25, -0.1, 0.6]))
    # Odometry integrates the commanded twist: vx/vmax, vy/vmax, w/wmax.
    np.testing.assert_allclose(obs["odom"], [0.5, -0.2, 0.5], atol=0.02)


def test_bad_settings_are_named():
    with pytest.raises(ValueError, match="frame_stack"):
        LearningConfig(frame_stack=0)
    with pytest.raises(ValueError, match="odometry"):
        LearningConfig(odometry="pose")
    with pytest.raises(TypeError, match="not a pico-gym env"):
        MinPoolLrf(gym.make("CartPole-v1"))
    with pytest.raises(ValueError, match="range_scale"):
        LearningConfig(range_scale="sqrt")
    with pytest.raises(ValueError, match="range scale"):
        MinPoolLrf(gym.make("PicoEscape-v0"), scale="sqrt")


def test_log_range_scale_resolves_the_near_field():
    r = np.array([0.0, 0.05, 0.1, 0.2, 0.5, 1.0, 5.0, 10.0, 30.0])
    log = scale_ranges(r, 10.0, "log")
    lin = scale_ranges(r, 10.0, "linear")
    assert np.all((0.0 <= log) & (log <= 1.0)) and np.all(np.diff(log) >= 0.0)  # monotone, in [0, 1]
    np.testing.assert_allclose(log[[2, 5, 7]], [0.0, 0.5, 1.0])
    np.testing.assert_allclose(lin, np.clip(r / 10.0, 0.0, 1.0))
    # Between touching (0.2 m from the LRF to the side) and 0.5 m: 7x the linear scale's spread.
    assert (log[4] - log[3]) > 6.0 * (lin[4] - lin[3])
    # min_pool normalises with the same scale
    pooled = min_pool(np.array([0.3, 0.2, 4.0, 0.0]), np.array([0, 2]), 10.0, scale="log")
    np.testing.assert_allclose(pooled, scale_ranges(np.array([0.2, 4.0]), 10.0, "log"), rtol=1e-6)
    # and so does the range memory
    angles = np.linspace(-2.0, 2.0, 1000)
    ranges = np.random.default_rng(3).uniform(0.05, 12.0, 1000)
    linear = RangeMemory(angles, 36, 10.0).update(ranges, 0.4)
    logged = RangeMemory(angles, 36, 10.0, "log").update(ranges, 0.4)
    np.testing.assert_allclose(logged, scale_ranges(linear.astype(np.float64) * 10.0, 10.0, "log"), atol=1e-5)


def test_range_memory_remembers_what_turned_out_of_view():
    angles = np.linspace(-2.0, 2.0, 1000)
    memory = RangeMemory(angles, 36, 10.0)
    ranges = np.full(1000, 2.0)
    ranges[490:510] = 10.0  # a far gap straight ahead (heading 0)
    body = memory.update(ranges, heading=0.0)
    ahead = np.argmin(np.abs(memory.centres))
    assert body[ahead] == pytest.approx(1.0) or body[ahead + 1] == pytest.approx(1.0)
    behind = [0, 35]  # never seen: 0
    assert body[behind].tolist() == [0.0, 0.0]
    # Turn around (heading pi): the LRF now sees only 2 m walls, but the gap is remembered behind.
    body = memory.update(np.full(1000, 2.0), heading=np.pi)
    assert max(body[0], body[35]) == pytest.approx(1.0)
    assert body[ahead] == pytest.approx(0.2)
    with pytest.raises(ValueError, match="memory_sectors"):
        RangeMemory(angles, 2, 10.0)


def _memory_by_definition(memory: np.ndarray, ranges: np.ndarray, angles: np.ndarray, heading: float, n: int) -> None:
    """RangeMemory's store, beam by beam: bin int((heading mod 2 pi + angle + 4 pi) * n / 2 pi) mod n
    keeps the farthest range of this scan (no hit: the range limit, 10 m)."""
    inv_width = n / (2.0 * math.pi)
    h = heading % (2.0 * math.pi)
    current = np.full(n, -1.0)
    for r, a in zip(ranges.tolist(), angles.tolist(), strict=True):
        b = int((h + a + 4.0 * math.pi) * inv_width) % n
        current[b] = max(current[b], r if r > 0.0 else 10.0)
    memory[current >= 0.0] = current[current >= 0.0]


@pytest.mark.parametrize("n_bins", [4, 13, 36, 1500])
def test_range_memory_bins_every_beam_as_its_definition(n_bins: int):
    # 229-degree and full-circle beam fans; scans with no-hit zeros; headings on bin edges too.
    rng = np.random.default_rng(n_bins)
    for angles in (np.linspace(-2.0, 2.0, 1000), np.linspace(-math.pi, math.pi, 721)):
        memory = RangeMemory(angles, n_bins, 10.0)
        expected = np.zeros(n_bins)
        for k in range(40):
            ranges = rng.uniform(0.05, 12.0, len(angles)).astype(np.float32 if k % 2 else np.float64)
            ranges[rng.random(len(angles)) < 0.2] = 0.0
            heading = rng.uniform(-20.0, 20.0) if k % 3 else int(rng.integers(-9, 9)) * 2.0 * math.pi / n_bins
            memory.update(ranges, heading)
            _memory_by_definition(expected, ranges, angles, heading, n_bins)
            np.testing.assert_array_equal(memory.memory, expected)


# --- the privileged point goal (end-to-end hospital baseline) ------------------------------------
def test_point_goal_reads_the_next_cabinet_from_the_true_pose():
    env = PrivilegedPointGoal(gym.make("PicoHospital-v0", map="hospital_2019", n_cabinets=2))
    assert env.observation_space["point_goal"].shape == (POINT_GOAL_SIZE,)
    obs, info = env.reset(seed=3, options={"cabinet_order": [1, 0]})
    task = env.unwrapped.task
    target = task.next_target
    assert target.index == 1
    pose = env.unwrapped.pose
    goal = target.dock_point(0.5 * target.side_m)
    d = float(np.hypot(*(goal - [pose.x, pose.y])))
    r, sb, cb, se, ce = obs["point_goal"]
    assert r == pytest.approx(np.log1p(d / 0.1) / np.log1p(POINT_GOAL_RANGE_M / 0.1), rel=1e-5)
    bearing = np.arctan2(goal[1] - pose.y, goal[0] - pose.x) - pose.theta
    assert (sb, cb) == pytest.approx((np.sin(bearing), np.cos(bearing)), abs=1e-6)
    error = target.facing_rad - pose.theta
    assert (se, ce) == pytest.approx((np.sin(error), np.cos(error)), abs=1e-6)
    assert env.observation_space.contains(obs)
    obs, *_ = env.step(np.zeros(3))
    assert env.observation_space.contains(obs)
    # It is privileged: the agent-facing info["task"] is unchanged, the point goal is not in it.
    assert not hasattr(info["task"], "point_goal")


def test_point_goal_learning_pipeline_and_its_errors():
    base = gym.make("PicoHospital-v0", n_cabinets=2)
    env = PicoLearningWrapper(PrivilegedPointGoal(base), n_sectors=16, frame_stack=2, point_goal=True)
    plain = PicoLearningWrapper(gym.make("PicoHospital-v0", n_cabinets=2), n_sectors=16, frame_stack=2)
    assert env.observation_space.shape[0] == plain.observation_space.shape[0] + 2 * POINT_GOAL_SIZE
    x, _ = env.reset(seed=1)
    assert env.observation_space.contains(x)
    # the goal sits between the LRF sectors and the velocity in each frame
    raw = point_goal(env)
    frame = env.observation_space.shape[0] // 2
    np.testing.assert_array_equal(x[frame + 16 : frame + 16 + POINT_GOAL_SIZE], raw)
    with pytest.raises(ValueError, match="PrivilegedPointGoal first"):
        PicoLearningWrapper(gym.make("PicoHospital-v0"), point_goal=True)
    with pytest.raises(ValueError, match="PicoHospital-v0"):
        PrivilegedPointGoal(gym.make("PicoEscape-v0"))
    with pytest.raises(ValueError, match="point_goal"):
        LearningConfig(point_goal="yes")  # type: ignore[arg-type]


def test_odometry_trail_bins_where_the_robot_has_been():
    """A position kept each second, read in the body frame: bin 0 straight behind, counter-clockwise,
    each bin the closeness (1 - distance / 2 m) of its nearest kept position."""
    trail = OdometryTrail(16, dt_s=0.1)
    assert not trail.update(np.array([0.0, 0.0, 0.0])).any()  # nothing kept before: all zero
    for _ in range(9):  # within the second: the origin is the only kept position
        trail.update(np.array([1.0, 0.0, 0.0]))
    behind = trail.update(np.array([1.0, 0.0, 0.0]))  # the 11th call (kept): the origin 1 m straight behind
    assert behind[0] == pytest.approx(0.5) and np.count_nonzero(behind) == 1
    left = trail.update(np.array([0.0, -1.0, 0.0]))  # the origin 1 m to the left (bin 12), (1, 0) at 45 deg
    assert left[12] == pytest.approx(0.5) and left[10] == pytest.approx(1 - math.sqrt(0.5))
    assert np.count_nonzero(left) == 2
    ahead = trail.update(np.array([0.0, -1.0, math.pi / 2]))  # turned to face it: straight ahead, bin 8
    assert ahead[8] == pytest.approx(0.5)
    assert not trail.update(np.array([5.0, 5.0, 0.0])).any()  # farther than 2 m from every position
    trail.reset()
    assert not trail.update(np.array([1.0, 0.0, 0.0])).any()
    with pytest.raises(ValueError, match="trail_sectors must be >= 4"):
        OdometryTrail(3, dt_s=0.1)


def test_the_trail_sits_before_the_point_goal_and_needs_the_per_robot_encoder():
    base = PrivilegedPointGoal(gym.make("PicoHospital-v0", n_cabinets=2))
    env = PicoLearningWrapper(base, n_sectors=16, frame_stack=2, point_goal=True, trail_sectors=8)
    x, _ = env.reset(seed=1)
    frame = env.observation_space.shape[0] // 2
    assert frame == 16 + 8 + POINT_GOAL_SIZE + 3 and env.observation_space.contains(x)
    np.testing.assert_array_equal(x[frame + 16 : frame + 24], 0.0)  # nothing kept yet
    np.testing.assert_array_equal(x[frame + 24 : frame + 24 + POINT_GOAL_SIZE], point_goal(env))
    for _ in range(30):
        x, *_ = env.step(np.array([0.3, 0.0, 0.0]))
    assert x[frame + 16 : frame + 24].max() > 0.0  # where it came from
    from pico_gym.agents.base import RobotSpec
    from pico_gym.wrappers import BatchedLearningEncoder

    spec = RobotSpec.of(base)
    with pytest.raises(ValueError, match="odometry trail"):
        BatchedLearningEncoder(spec.lrf, spec.robot, spec.dt_s, LearningConfig(trail_sectors=8), 2)
    with pytest.raises(ValueError, match="trail_sectors must be an integer"):
        LearningConfig(trail_sectors=2.5)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "settings",
    [
        {"n_sectors": 64, "frame_stack": 2, "memory_sectors": 36, "range_scale": "log"},
        {"n_sectors": 16, "frame_stack": 3, "max_pool": True},
        {"n_sectors": 8, "odometry": "none", "memory_sectors": 12},
    ],
)
def test_the_batched_encoder_encodes_what_the_encoder_does(settings):
    """BatchedLearningEncoder over 3 robots, with resets in the middle, against one
    LearningEncoder per robot: the same inputs, bit for bit (odometry noise and heading wrap included)."""
    from pico_gym.agents.base import RobotSpec
    from pico_gym.wrappers import BatchedLearningEncoder, LearningEncoder

    envs = [gym.make("PicoEscape-v0", noise_m=0.02, slip_std=0.05, time_limit_s=6) for _ in range(3)]
    spec = RobotSpec.of(envs[0])
    config = LearningConfig(**settings)
    ones = [LearningEncoder(spec.lrf, spec.robot, spec.dt_s, config) for _ in envs]
    batch = BatchedLearningEncoder(spec.lrf, spec.robot, spec.dt_s, config, len(envs))
    obs = [env.reset(seed=20 + i)[0] for i, env in enumerate(envs)]
    rows = np.arange(3)
    batch.reset(rows, np.stack([o["lrf"] for o in obs]), np.stack([o["odom"] for o in obs]))
    expected = [e.reset(o) for e, o in zip(ones, obs, strict=True)]
    assert np.array_equal(batch.stacks, np.stack(expected))
    rng = np.random.default_rng(1)
    resets = 0
    for _ in range(150):
        fresh = []
        for i, env in enumerate(envs):
            obs[i], _, terminated, truncated, _ = env.step(rng.uniform(env.action_space.low, env.action_space.high))
            if terminated or truncated:
                obs[i] = env.reset()[0]
                fresh.append(i)
        stepped = [i for i in range(3) if i not in fresh]
        if stepped:
            batch.encode(
                np.array(stepped),
                np.stack([obs[i]["lrf"] for i in stepped]),
                np.stack([obs[i]["odom"] for i in stepped]),
            )
        if fresh:
            batch.reset(
                np.array(fresh), np.stack([obs[i]["lrf"] for i in fresh]), np.stack([obs[i]["odom"] for i in fresh])
            )
        resets += len(fresh)
        for i in range(3):
            x = ones[i].reset(obs[i]) if i in fresh else ones[i].encode(obs[i])
            assert np.array_equal(batch.stacks[i], x)
    assert resets >= 3
    with pytest.raises(ValueError, match="point goal"):
        BatchedLearningEncoder(spec.lrf, spec.robot, spec.dt_s, LearningConfig(point_goal=True), 2)


def test_mirror_maps_reflect_the_learning_input() -> None:
    """The reflection is an involution that reverses each block and flips vy and w; the encoding
    of a reflected world (the scan reversed, odometry y and heading negated) is the reflected
    encoding to within the sectors' one-beam asymmetry."""
    from pico_gym.agents.base import RobotSpec
    from pico_gym.wrappers import LearningConfig, LearningEncoder, mirror_maps

    config = LearningConfig(n_sectors=64, frame_stack=2, memory_sectors=36, range_scale="log", trail_sectors=16)
    index, sign = mirror_maps(config)
    assert np.array_equal(index[index], np.arange(len(index)))
    frame = 64 + 36 + 16 + 3
    assert index[:64].tolist() == list(range(63, -1, -1)) and index[frame - 3 : frame].tolist() == [
        frame - 3,
        frame - 2,
        frame - 1,
    ]
    assert sign[frame - 3 : frame].tolist() == [1.0, -1.0, -1.0] and len(index) == 2 * frame
    # The point goal (before the velocity): range kept, the sines of bearing and heading error negated,
    # which is encode_goal's answer in the reflected world.
    goal_config = LearningConfig(n_sectors=8, frame_stack=1, point_goal=True)
    g_index, g_sign = mirror_maps(goal_config)
    assert g_index[8:13].tolist() == list(range(8, 13)) and g_sign[8:13].tolist() == [1.0, -1.0, 1.0, -1.0, 1.0]
    assert g_sign[13:].tolist() == [1.0, -1.0, -1.0]
    goal = encode_goal(0.3, 0.2, 0.4, 1.5, -0.7, 2.0)
    assert encode_goal(0.3, -0.2, -0.4, 1.5, 0.7, -2.0) == pytest.approx(goal * g_sign[8:13], abs=1e-6)

    env = gym.make("PicoEscape-v0")
    obs, _ = env.reset(seed=3)
    spec = RobotSpec.of(env)
    plain, mirrored = (LearningEncoder(spec.lrf, spec.robot, spec.dt_s, config) for _ in range(2))

    def reflect(o):  # noqa: ANN001, ANN202
        odom = np.array(o["odom"])
        return {**o, "lrf": o["lrf"][::-1].copy(), "odom": np.array([odom[0], -odom[1], -odom[2]], odom.dtype)}

    errors = [np.abs(mirrored.reset(reflect(obs)) - plain.reset(obs)[index] * sign)]
    rng = np.random.default_rng(0)
    for _ in range(200):
        obs, *_ = env.step(rng.uniform(-0.5, 0.5, 3))
        errors.append(np.abs(mirrored.encode(reflect(obs)) - plain.encode(obs)[index] * sign))
    errors = np.concatenate(errors)
    assert np.median(errors) < 0.02 and np.mean(errors < 0.05) > 0.95
