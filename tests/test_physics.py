"""Physics: walls are solid at any speed and heading, bumps are counted once per contact."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import pico_gym  # noqa: F401
from pico_gym.physics import Physics, PhysicsConfig
from pico_gym.robot import RobotConfig
from pico_gym.types import Pose
from pico_gym.world import geometry

ROBOT = RobotConfig()


def wall_of_thickness(thickness: float) -> np.ndarray:
    """A long wall whose near face is the line x = 1 (zero thickness: a single segment)."""
    if thickness == 0.0:
        return np.array([[1.0, -20.0, 1.0, 20.0]])
    return geometry.polygon_to_segments(
        np.array([[1.0, -20.0], [1.0 + thickness, -20.0], [1.0 + thickness, 20.0], [1.0, 20.0]])
    )


def drive(physics: Physics, world_direction: float, turn: float, steps: int) -> None:
    for k in range(steps):
        angle = physics.body.angle
        wx, wy = 0.5 * math.cos(world_direction), 0.5 * math.sin(world_direction)
        c, s = math.cos(angle), math.sin(angle)
        w = turn if (k // 10) % 2 == 0 else -turn
        physics.step(c * wx + s * wy, -s * wx + c * wy, w, 0.1)
        yield physics


@pytest.mark.parametrize("thickness", [0.0, 0.02, 0.2])
def test_no_tunnelling_at_full_speed(thickness: float) -> None:
    segments = wall_of_thickness(thickness)
    for heading in np.linspace(-math.pi, math.pi, 12, endpoint=False):
        for direction in (-1.2, -0.6, 0.0, 0.6, 1.2):
            for turn in (0.0, 1.2):
                physics = Physics(segments, ROBOT, PhysicsConfig(), Pose(0.0, 0.0, float(heading)))
                for p in drive(physics, direction, turn, 80):
                    pose = p.pose
                    footprint = geometry.transform_points(pose, ROBOT.outline)
                    assert footprint[:, 0].max() < 1.0, f"crossed into the wall at {pose}"
                    assert geometry.polygon_clearance(footprint, segments) > 0.0


def test_no_tunnelling_into_a_concave_corner() -> None:
    corner = np.array([[1.0, -5.0, 1.0, 1.0], [1.0, 1.0, -5.0, 1.0]])
    for heading in np.linspace(-math.pi, math.pi, 8, endpoint=False):
        physics = Physics(corner, ROBOT, PhysicsConfig(), Pose(0.0, 0.0, float(heading)))
        for p in drive(physics, math.pi / 4, 1.2, 80):
            footprint = geometry.transform_points(p.pose, ROBOT.outline)
            assert footprint[:, 0].max() < 1.0 and footprint[:, 1].max() < 1.0
            assert geometry.polygon_clearance(footprint, corner) > 0.0


def test_bump_counted_once_per_contact() -> None:
    segments = wall_of_thickness(0.0)
    physics = Physics(segments, ROBOT, PhysicsConfig(), Pose(0.0, 0.0, 0.0))
    for _ in range(60):  # reach the wall, then keep pushing for seconds
        physics.step(0.5, 0.0, 0.0, 0.1)
    assert physics.bumps == 1
    for _ in range(60):  # slide along it while pushing
        physics.step(0.3, 0.4, 0.0, 0.1)
    assert physics.bumps == 1
    for _ in range(10):  # back off
        physics.step(-0.5, 0.0, 0.0, 0.1)
    assert not physics.in_contact
    for _ in range(20):  # and hit it again
        physics.step(0.5, 0.0, 0.0, 0.1)
    assert physics.bumps == 2


def test_free_space_follows_the_command_exactly() -> None:
    physics = Physics(np.zeros((0, 4)), ROBOT, PhysicsConfig(), Pose(1.0, 2.0, 0.5))
    physics.step(0.3, -0.2, 0.8, 0.1, clearance_m=10.0)
    from pico_gym.sensors.odometry import integrate_twist

    expected = integrate_twist(Pose(1.0, 2.0, 0.5), 0.3, -0.2, 0.8, 0.1)
    assert physics.pose == pytest.approx(expected, abs=1e-12)


def test_substeps_and_fast_path_agree() -> None:
    """The free-space shortcut lands where pymunk's sub-steps do (within the drive's lag)."""
    a = Physics(np.zeros((0, 4)), ROBOT, PhysicsConfig(), Pose(0.0, 0.0, 0.0))
    b = Physics(np.zeros((0, 4)), ROBOT, PhysicsConfig(), Pose(0.0, 0.0, 0.0))
    for _ in range(20):
        a.step(0.4, 0.1, 0.6, 0.1, clearance_m=0.0)
        b.step(0.4, 0.1, 0.6, 0.1, clearance_m=10.0)
    assert a.pose == pytest.approx(b.pose, abs=0.01)


def test_acceleration_limit_ramps_the_speed() -> None:
    robot = RobotConfig(max_accel_mps2=1.0)
    physics = Physics(np.zeros((0, 4)), robot, PhysicsConfig(), Pose(0.0, 0.0, 0.0))
    physics.step(0.5, 0.0, 0.0, 0.1)
    assert physics.body.velocity.x == pytest.approx(0.1, abs=0.02)  # 1 m/s^2 for 0.1 s


def adversarial_episode(seed: int, map_name: str | None, speed: float, steps: int = 400, **options: float):
    """Full-speed commands (drive and spin) held for 0.5-3 s into whatever is there, as
    `pico-gym bench-walls` drives; yields (env, pose before, pose after) per step."""
    import gymnasium as gym

    kwargs = {"collision": "continue", "max_speed_mps": speed, "time_limit_s": 1e5, "idle_time_s": 1e5}
    if map_name:
        kwargs.update(map=map_name, sample_start=True)
    kwargs.update(options)
    env = gym.make("PicoEscape-v0", **kwargs)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    high = env.action_space.high
    t = 0
    previous = env.unwrapped.pose
    while t < steps:
        action = high * rng.choice([-1.0, 1.0], size=3) * rng.choice([0.0, 1.0], size=3, p=[0.2, 0.8])
        for _ in range(int(rng.integers(5, 30))):
            _, _, terminated, truncated, _ = env.step(action)
            t += 1
            pose = env.unwrapped.pose
            yield env, previous, pose
            previous = pose
            if terminated or truncated:
                return


# Episodes in which, before sub-steps were guarded, the true footprint overlapped a wall (found by
# driving 3,000 such episodes: 91 overlaps, 10 of them at 0.6 m/s, the rest at 0.7-0.73 m/s).
OVERLAPPED_BEFORE = [
    (40, "escape_small", 0.7),
    (64, "escape_small", 0.7),
    (345, "escape_2020_corner", 0.6),
    (491, "escape_student_2019", 0.6),
    (162, None, 0.73),
]


@pytest.mark.parametrize(("seed", "map_name", "speed"), OVERLAPPED_BEFORE)
def test_true_footprint_never_touches_a_wall_when_driven_into_it(seed: int, map_name: str | None, speed: float) -> None:
    for env, _, pose in adversarial_episode(seed, map_name, speed):
        outline = env.unwrapped.config.robot.outline
        clearance = geometry.footprint_clearance(
            pose.x, pose.y, pose.theta, outline, env.unwrapped.scene.static_solid, 0.05
        )
        assert clearance > 0.0, f"the true footprint touches a wall at {pose}"


def test_a_contact_never_turns_or_moves_the_robot_past_its_caps() -> None:
    # Before the caps were kept, contacts spun the robot up to 4.4x its turn cap in one step. (The
    # wheels' calibration error and slip may make the ground's twist exceed the caps: both off.)
    robot = RobotConfig()
    for seed, map_name, speed in OVERLAPPED_BEFORE + [(302, "escape_2018", 0.7), (386, None, 0.73)]:
        for env, before, after in adversarial_episode(seed, map_name, speed, steps=300, slip_std=0.0, wheel_noise=0.0):
            dt = env.unwrapped.config.dt_s
            turn = abs(math.remainder(after.theta - before.theta, 2.0 * math.pi))
            assert turn <= robot.max_turn_rate_radps * dt * (1.0 + 1e-6), (seed, turn)
            assert math.hypot(after.x - before.x, after.y - before.y) <= speed * dt * (1.0 + 1e-6), seed


@pytest.mark.parametrize("kwargs", [{"map": "hospital_2019", "n_boxes": (2, 2), "n_movers": (1, 1)}, {}])
def test_an_env_reusing_its_static_shapes_plays_as_a_fresh_one(kwargs: dict) -> None:
    """The env hands its physics' static shapes to the next episode's (StaticShapePool): an
    episode after others on the same env is bit for bit the episode of a fresh env."""
    import gymnasium as gym

    def play(env: gym.Env, seed: int) -> list[bytes]:
        env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        out = []
        for _ in range(120):
            action = rng.uniform(-1.0, 1.0, 3) * [0.5, 0.5, 1.2]
            obs, _, terminated, truncated, info = env.step(action)
            out += [obs["lrf"].tobytes(), np.array(info["pose"]).tobytes(), bytes([info["bumps"]])]
            if terminated or truncated:
                break
        return out

    used = gym.make("PicoHospital-v0", **kwargs)
    for seed in (1, 2, 3):
        play(used, seed)
    pooled = used.unwrapped._shape_pool
    assert pooled is not None
    assert play(used, 4) == play(gym.make("PicoHospital-v0", **kwargs), 4)


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("PicoEscape-v0", {"noise_m": 0.02, "slip_std": 0.05}),
        ("PicoHospital-v0", {"map": "hospital_2019", "n_movers": (2, 2), "n_boxes": (2, 2)}),
    ],
)
@pytest.mark.slow
def test_the_steps_compiled_motion_is_the_physics_own_step(env_id: str, kwargs: dict) -> None:
    """The env moves the robot in one compiled call (`_drive`); stepping a copy through the
    Python parts it replaces (clip, true twist, `Physics.step`, odometry) gives the same state,
    bit for bit, whether the step glides or pymunk takes it."""
    import copy

    import gymnasium as gym

    from pico_gym.robot import clip_twist

    env = gym.make(env_id, **kwargs).unwrapped
    env.reset(seed=3)
    rng = np.random.default_rng(3)
    glided = stepped = 0
    for _ in range(400):
        action = rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32)
        twin = copy.deepcopy(env)
        env.step(action)
        # The same step, the Python way, on the copy.
        dt = twin.config.dt_s
        vx, vy, w = clip_twist(action[:3], twin.config.robot)
        true = twin.odometry.true_twist(vx, vy, w, dt, twin.np_random)
        free = twin.physics.contacts == 0 and twin._room > twin.physics.sweep_m(*true, dt) + twin.physics._glide_margin
        twin.physics.step(*true, dt, twin._room)
        twin.odometry.advance(vx, vy, w, dt)
        assert tuple(env.pose) == tuple(twin.physics.pose)
        assert tuple(env.odometry.pose) == tuple(twin.odometry.pose)
        assert env.physics._pending == twin.physics._pending
        assert env.physics.time_s == twin.physics.time_s
        if env.scene.has_movers:
            assert np.array_equal(env.scene.movers.state, twin.scene.movers.state)
            assert np.array_equal(env.scene.mover_segments, twin.scene.mover_segments)
        glided += free
        stepped += not free
        if env._finished:
            env.reset(seed=int(rng.integers(1000)))
    assert glided > 50 and stepped > 5  # both paths were taken


@pytest.mark.slow
def test_people_and_carts_are_as_solid_as_walls() -> None:
    """Adversarial driving among walking people (into them, and standing while they walk up):
    the true footprint never overlaps a mover after a step, as it never overlaps a wall."""
    from pico_gym.bench import _drive_adversarially, _WallsTally

    rng = np.random.default_rng(7)
    tally = _WallsTally()
    for options in ({"map": "hospital_2019", "n_movers": (2, 2), "n_boxes": (1, 1)}, {"family": "crowded"}):
        env = gym.make(
            "PicoHospital-v0", collision="continue", max_speed_mps=0.7, time_limit_s=1e5, idle_time_s=1e5, **options
        )
        env.reset(seed=3)
        _drive_adversarially(env, rng, 3000, tally)
    assert tally.steps >= 6000 and tally.contact_steps > 0
    assert tally.overlaps == 0 and tally.mover_overlaps == 0
