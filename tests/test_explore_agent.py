"""The classic explore agent: public information only, its map, parking by touch, finding."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import pico_gym  # noqa: F401
from pico_gym.agents import make_agent
from pico_gym.agents.classic.explore import ExploreAgent, State
from pico_gym.agents.classic.explore.config import ExploreAgentConfig
from pico_gym.agents.classic.explore.pose import wall_directions
from pico_gym.agents.classic.explore.regions import (
    component_sizes,
    components,
    distance_transform,
    opening,
    room_depths,
)
from pico_gym.agents.classic.explore.search import free_standing
from pico_gym.sensors.lrf import lrf_ranges
from pico_gym.tasks.explore import OccupancyBelief
from pico_gym.types import Pose
from pico_gym.world.geometry import compose, point_clearance


def explore_env(**kwargs: object) -> gym.Env:
    return gym.make("PicoExplore-v0", **kwargs)


def test_make_agent_gives_the_explore_agent_and_it_acts_in_the_action_space() -> None:
    env = explore_env()
    agent = make_agent("classic", env)
    assert isinstance(agent, ExploreAgent)
    assert not any(isinstance(v, gym.Env) for v in vars(agent).values())
    obs, info = env.reset(seed=0)
    agent.reset(obs, {"task": info["task"]})  # nothing of the building: the rules only
    for _ in range(30):
        action = agent.act(obs)
        assert env.action_space.contains(action)
        obs, *_ = env.step(action)


def test_the_map_after_looking_around_matches_the_building() -> None:
    env = explore_env()
    agent = make_agent("classic", env)
    obs, info = env.reset(seed=3)
    agent.reset(obs, {"task": info["task"]})
    while agent.state is State.LOOK:
        obs, *_ = env.step(agent.act(obs))
    belief = agent.map_belief()
    assert isinstance(belief, OccupancyBelief)
    assert env.unwrapped.belief_iou(belief) > 0.2
    # Cells it calls free are free in truth, and cells it calls occupied lie on walls (within
    # 10 cm of the true geometry): the pose is good after a turn in place.
    g = agent.occupancy.grid
    frame = env.unwrapped.map_from_odom
    c, s = math.cos(frame.theta), math.sin(frame.theta)
    building = env.unwrapped.episode.extra["building"]
    walls = env.unwrapped.scene.static_solid
    for value, check in ((0, "free"), (1, "wall")):
        rows, cols = np.nonzero(belief.cells == value)
        xs, ys = g.x0 + (cols + 0.5) * g.resolution, g.y0 + (rows + 0.5) * g.resolution
        mx, my = frame.x + c * xs - s * ys, frame.y + s * xs + c * ys
        if check == "free":
            b = building.grid
            r = np.floor((my - b.y0) / b.resolution).astype(int)
            k = np.floor((mx - b.x0) / b.resolution).astype(int)
            inside = (r >= 0) & (r < b.shape[0]) & (k >= 0) & (k < b.shape[1])
            ok = np.zeros(len(r), dtype=bool)
            ok[inside] = building.region[r[inside], k[inside]] >= -1  # inside the building's free area
            # (cells of the free area's rim, within half a coverage cell of a wall, count too)
            rim = np.array(
                [point_clearance(float(x), float(y), walls) < 0.08 for x, y in zip(mx[~ok], my[~ok], strict=True)]
            )
            assert len(ok) > 1000 and (ok.sum() + rim.sum()) / len(ok) > 0.97
        else:
            near = [point_clearance(float(x), float(y), walls) < 0.1 for x, y in zip(mx, my, strict=True)]
            assert len(near) > 100 and np.mean(near) > 0.95


def test_it_parks_backwards_by_touch_without_a_bump() -> None:
    env = explore_env()
    agent = make_agent("classic", env)
    obs, info = env.reset(seed=1, options={"start_pose": (0.7, 0.6, 0.1)})
    agent.reset(obs, {"task": info["task"]})
    while agent.state is State.LOOK:
        obs, *_ = env.step(agent.act(obs))
    agent._go(State.PARK)  # skip the exploration
    for _ in range(400):
        obs, _, terminated, _, info = env.step(agent.act(obs))
        if info["parked"] or terminated:
            break
    assert info["parked"] and info["bumps"] == 0
    assert info["parking_error"]["heading_rad"] < math.radians(10)
    assert agent.state in (State.REVERSE, State.PARKED)


def run_episode(
    seed: int, options: dict | None = None, steps: int = 6000, family: str | None = None, **config: Any
) -> dict:
    """The classic explore agent (settings changed by `config`) through one episode (at most
    `steps`) of the generator's `family`: its last info."""
    env = explore_env(**({"family": family} if family else {}))
    agent = make_agent("classic", env, config=ExploreAgentConfig(**config))
    obs, info = env.reset(seed=seed, options=options)
    agent.reset(obs, {"task": info["task"]})
    for _ in range(steps):
        obs, _, terminated, truncated, info = env.step(agent.act(obs))
        if terminated or truncated:
            break
    return info


@pytest.mark.slow
def test_it_finds_the_object_from_a_parked_start() -> None:
    info = run_episode(5, {"phase": "find"}, steps=3000)
    assert info["termination_reason"] == "done" and info["bumps"] == 0


@pytest.mark.slow
def test_the_search_enters_a_deep_room_seen_only_through_its_door() -> None:
    """Dev seed 112: the object's room (the deepest) was seen while exploring only through its
    0.65 m door, so its frontier there is two or three cells, shorter than exploring's minimum;
    the search skipped it and looked at the hallway for 400 s. Any frontier of a large unseen
    part counts in the search: it goes in and finds the object. (Without the wedge turn: with
    it, the default, this seed is a known regression, the next test.)"""
    info = run_episode(112, wedge_turn_s=0.0)
    assert info["termination_reason"] == "done" and info["bumps"] == 0
    assert info["time_to_find"] < 300.0


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="a known regression of wedge_turn_s (docs/agents/classic-explore.md): at the deep room's "
    "door the robot creeps at 2-3 cm/s, under the still count's 3 mm a step, and the turn in place "
    "interrupts the creep; it times out",
)
def test_the_default_enters_the_deep_room_of_dev_seed_112() -> None:
    info = run_episode(112)
    assert info["termination_reason"] == "done" and info["bumps"] == 0


@pytest.mark.slow
def test_the_search_tries_again_a_room_it_once_gave_up_on() -> None:
    """Comb dev seed 550047: parked at 169 s, the search made no progress through the door of
    the object's room for 10 s (the potential field's minimum in the doorway) and gave the place
    up; it then went round the other rooms until 600 s, the given-up place never tried again.
    With `search_retry`, once it has looked everywhere it tries the places it gave up on."""
    assert run_episode(550047, family="comb", search_retry=False)["termination_reason"] == "timeout"
    info = run_episode(550047, family="comb")
    assert info["termination_reason"] == "done" and info["bumps"] == 0


@pytest.mark.slow
def test_a_creep_held_by_a_jamb_hands_back_to_the_planner() -> None:
    """Deep-L dev seed 560008: the planner brought the robot to 0.88 m of the object with a door
    jamb between, and the final creep, straight at the object, was held by the safety filter
    until 600 s. With `creep_held_s` (3 s by default), a creep held for 3 s plans round the jamb
    to 0.45 m and creeps again from there. (The held creep is in a doorway: turning free there,
    `wedge_turn_s`, mends it too, so that is off to see the creep's own part.)"""
    off = {"creep_held_s": 0.0, "wedge_turn_s": 0.0}
    assert run_episode(560008, family="deep-L", **off)["termination_reason"] == "timeout"
    info = run_episode(560008, family="deep-L", wedge_turn_s=0.0)
    assert info["termination_reason"] == "done" and info["bumps"] == 0


@pytest.mark.slow
def test_a_robot_wedged_askew_in_a_door_turns_free() -> None:
    """Deep-L dev seed 560028: on its way back to park, the robot went sideways into a door of a
    thick wall 35 deg askew and stood wedged between the jambs, a corner against each, from 330 s
    to 600 s (the follower turned one step a second; the filters let through at most a creep of
    2 cm/s against the jambs). With
    `wedge_turn_s` (1 s by default), held 1 s in a doorway it turns in place for 1 s the way that
    frees the corners, and drives on."""
    assert run_episode(560028, family="deep-L", wedge_turn_s=0.0)["termination_reason"] == "timeout"
    info = run_episode(560028, family="deep-L")
    assert info["termination_reason"] == "done" and info["bumps"] == 0


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_wedged_askew_between_two_jambs_the_turn_that_frees_both_corners_is_chosen(side: float) -> None:
    """Nested dev seed 570006, as the filters saw it: the front face 4 cm off one jamb, the rear
    corner of the other side 1.3 cm off the other jamb (PICO 0.2 m deep, 0.4 m wide, askew in
    a door). Turning one way moves both off the footprint; the other way swings the corners in."""
    env = explore_env()
    agent = make_agent("classic", env)
    agent.reset(*env.reset(seed=0))
    near = np.array([[0.14, 0.13 * side], [0.14, 0.12 * side], [-0.11, -0.21 * side]])
    w = agent.follower._freeing_turn(near)
    assert w == pytest.approx(0.3 * side)
    # Pressed against one wall along its side, no turn moves it off: none is chosen.
    assert agent.follower._freeing_turn(np.array([[x, 0.22] for x in np.linspace(-0.3, 0.3, 13)])) == 0.0


@pytest.mark.slow
def test_the_stored_map_is_the_one_from_before_the_touch_so_an_object_in_view_is_unexplained() -> None:
    """Dev seed 466: the object stands 2 m from the parking spot, in view of it. The env places it
    0.5 s after the touch; the map was stored 1.5 s after the agent was sure of the touch, with
    the object in it, so nothing there was ever unexplained (the robot passed within 0.15 m of it
    and searched until the time ran out). Stored as it was before reversing, it is found."""
    info = run_episode(466)
    assert info["termination_reason"] == "done" and info["bumps"] == 0
    assert info["time_to_find"] < 300.0


def test_the_pose_estimate_stays_within_10_cm_while_exploring() -> None:
    env = explore_env()
    agent = make_agent("classic", env)
    obs, info = env.reset(seed=2)
    agent.reset(obs, {"task": info["task"]})
    worst = 0.0
    for _ in range(600):
        action = agent.act(obs)
        truth = compose(env.unwrapped._odom_from_map, env.unwrapped.pose)  # before the step: as the agent's
        worst = max(worst, math.hypot(agent.pose.x - truth.x, agent.pose.y - truth.y))
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    assert worst < 0.1


def test_distance_transform_is_the_chamfer_distance() -> None:
    blocked = np.zeros((5, 5), dtype=bool)
    blocked[2, 2] = True
    d = distance_transform(blocked, 0.1, 1.0)
    assert d[2, 2] == 0.0 and d[2, 3] == 0.1 and abs(d[3, 3] - 0.1 * math.sqrt(2)) < 1e-12 and d[2, 4] == 0.2


def run_until_parked(seed: int) -> tuple[Any, Any, dict]:
    """The classic explore agent from a reset until it parks or the episode ends: (env, agent, last info)."""
    env = explore_env()
    agent = make_agent("classic", env)
    obs, info = env.reset(seed=seed)
    agent.reset(obs, {"task": info["task"]})
    for _ in range(6000):
        obs, _, terminated, truncated, info = env.step(agent.act(obs))
        if agent.state is State.PARKED or terminated or truncated:
            break
    return env, agent, info


@pytest.mark.slow
def test_parking_puts_the_pose_back_at_the_wall_when_the_wheels_slip() -> None:
    """Dev seed 102: nothing straight ahead in range, so the scan cannot tell the robot stopped at
    the wall; the odometry counting 8 cm past the (refitted) wall ends the reverse, and the pose
    is put back at the wall (it used to count 0.7 m against it and search with that error)."""
    env, agent, info = run_until_parked(102)
    assert agent.state is State.PARKED and info["parked"] and info["bumps"] == 0
    truth = compose(env.unwrapped._odom_from_map, env.unwrapped.pose)
    error = np.array([agent.pose.x - truth.x, agent.pose.y - truth.y])
    _, normal = agent.wall
    assert abs(float(error @ normal)) < 0.03  # off the wall: as touched
    assert float(np.hypot(*error)) < 0.15  # along it: the odometry's own drift (it was 0.7 m)


@pytest.mark.slow
def test_a_robot_wedged_across_a_door_turns_its_way_through() -> None:
    """Dev seed 107: the robot entered a 0.6 m door at 33 deg and the filters stopped every
    translation (it stood still 45 s, then idle ended the episode); turning slowly towards the way
    once stopped in the doorway takes it through, and it explores on and parks."""
    env, agent, info = run_until_parked(107)
    assert agent.state is State.PARKED and info["parked"] and info["bumps"] == 0, info["termination_reason"]
    assert min(info["room_coverage"]) >= 0.95


def test_a_small_frontier_counts_when_it_opens_into_the_unknown_not_at_a_gap_in_a_wall() -> None:
    """A door seen at a grazing angle leaves a frontier of a cell or two: looked at when the
    unknown beside it is open across the way in, not when it is a hole in a mapped wall."""
    n = 20
    unknown = np.zeros((n, n), dtype=bool)
    occupied = np.zeros((n, n), dtype=bool)
    occupied[10, :] = True  # a wall along row 10; free below, unknown above
    unknown[11:, :] = True
    occupied[10, 8] = False  # a one-cell hole in the mapped wall
    unknown[10, 8] = True
    assert not opening(np.array([[9, 8]]), unknown, occupied)
    occupied[10, 5:12] = False  # a door 0.7 m wide, seen only through its near edge
    unknown[10, 5:12] = True
    assert opening(np.array([[9, 8]]), unknown, occupied)


def test_component_sizes_are_those_of_the_components() -> None:
    """The compiled labelling the search uses gives each cell its 8-connected component's size."""
    rng = np.random.default_rng(0)
    for _ in range(30):
        mask = rng.random((30, 40)) < rng.uniform(0.2, 0.7)
        expected = np.zeros(mask.shape, dtype=np.int64)
        for cells in components(mask):
            expected[cells[:, 0], cells[:, 1]] = len(cells)
        assert np.array_equal(component_sizes(mask), expected)


def test_room_depths_count_the_rooms_on_the_way_through_doors() -> None:
    """A 1.2 m hallway (the start at its end), room A off it through a 0.9 m door, room B behind A
    through a 1.4 m door, room C off the hallway through a 0.6 m door; 0.2 m walls, 0.1 m cells."""
    walls = np.ones((70, 120), dtype=bool)
    walls[2:14, 2:118] = False  # hallway, rows 2-13
    walls[16:46, 10:45] = False  # room A (3.0 x 3.5 m)
    walls[14:16, 22:31] = False  # door hallway -> A
    walls[48:68, 10:45] = False  # room B (2.0 x 3.5 m) behind A
    walls[46:48, 15:29] = False  # door A -> B
    walls[16:40, 60:100] = False  # room C
    walls[14:16, 75:81] = False  # door hallway -> C
    free = ~walls
    depths = room_depths(free, walls, (8, 4), 0.1, 0.92, 1.02)
    assert depths[8, 60] == 0  # the hallway
    assert depths[30, 27] == 1 and depths[30, 80] == 1  # A and C
    assert depths[58, 27] == 2  # B
    assert depths[walls].max() == 0
    # A stray hit in the middle of a room is not a wall (the agent keeps groups of four or more):
    # with it counted, B's middle is gone and B is no room of its own.
    assert (
        room_depths(
            free, walls | (np.arange(120) == 27)[None, :] & (np.arange(70) == 58)[:, None], (8, 4), 0.1, 0.92, 1.02
        )[58, 20]
        < 2
    )


def test_free_standing_marks_a_box_before_a_wall_and_not_the_wall() -> None:
    angles = np.linspace(-2.0, 2.0, 1000)
    wall = 3.0 / np.maximum(np.cos(angles), 0.3)  # a wall 3 m ahead (capped at the sides)
    box = np.abs(np.arctan2(np.sin(angles), np.cos(angles)) - 0.2) < 0.15  # about 0.45 m across at 1.5 m
    ranges = np.where(box, 1.5, wall)
    standing = free_standing(ranges, angles, 0.8)
    assert standing[box].all()
    assert not standing[~box].any()
    # The same run against the wall (no background behind it) is not standing free; nor a long one.
    assert not free_standing(np.where(box, wall - 0.05, wall), angles, 0.8)[box].all()
    assert not free_standing(ranges, angles, 0.3)[box].any()


def test_the_blind_sector_holds_recent_hits_only() -> None:
    """A cell hit long ago (the odometry has drifted since: a phantom jamb) is not put into the
    blind sector; the same cell hit moments ago is, where it lies relative to the robot."""
    env = explore_env()
    agent = make_agent("classic", env)
    obs, info = env.reset(seed=0)
    agent.reset(obs, {"task": info["task"]})
    g, p = agent.occupancy.grid, agent.pose
    x, y = p.x - 0.4 * math.cos(p.theta), p.y - 0.4 * math.sin(p.theta)  # 0.4 m behind
    row, col = int((y - g.y0) / g.resolution), int((x - g.x0) / g.resolution)
    agent.steps = 100_000
    occupancy = agent.occupancy
    occupancy.hits[row, col] = 5
    occupancy.last_hit[row, col] = agent.steps - agent._steps(agent.config.blind_memory_s) - 1
    assert len(occupancy.mapped_near(agent.pose, 0.7, agent._blind_since())) == 0
    occupancy.last_hit[row, col] = agent.steps - 10
    points = occupancy.mapped_near(agent.pose, 0.7, agent._blind_since())
    nearest = points[np.argmin(np.hypot(points[:, 0] + 0.4, points[:, 1]))]
    assert np.hypot(nearest[0] + 0.4, nearest[1]) < 0.05


def test_wall_directions_give_a_rectilinear_rooms_axes_modulo_90_degrees() -> None:
    """A scan of a 4 x 3 m room rotated by 20 deg, from off its centre: the straight pieces of wall
    agree on one direction modulo 90 deg, 20 deg in the robot frame (a corner is no piece)."""
    room = np.array([[-2, -1.5, 2, -1.5], [2, -1.5, 2, 1.5], [2, 1.5, -2, 1.5], [-2, 1.5, -2, -1.5]], float)
    angles = np.linspace(-0.75 * math.pi, 0.75 * math.pi, 1000)
    for heading in (0.0, 0.3, -1.2):
        ranges = lrf_ranges(Pose(0.4, -0.3, heading - math.radians(20)), room, angles)
        c4, s4, n = wall_directions(ranges, angles, 8, 4, 4.0)
        assert n > 100 and math.hypot(c4, s4) > 0.99 * n  # every piece agrees
        axis = math.atan2(s4, c4) / 4.0  # the walls' direction in the robot frame, modulo 90 deg
        expected = math.radians(20) - heading
        assert abs(math.remainder(4.0 * (axis - expected), 2 * math.pi)) / 4.0 < math.radians(0.1)


def _hallway_ranges(pose: Pose, angles: np.ndarray, half_width: float = 0.9) -> np.ndarray:
    """A scan from `pose` in an endless hallway along x (walls at y = +-half_width)."""
    a = pose.theta + angles
    s = np.sin(a)
    with np.errstate(divide="ignore"):
        r = np.where(s > 0, (half_width - pose.y) / s, np.where(s < 0, (-half_width - pose.y) / s, np.inf))
    return np.minimum(r, 10.0)


def test_search_align_turns_the_heading_onto_the_stored_map_and_leaves_the_position() -> None:
    """`search_align`: matched against the map stored at parking, the heading comes back (in a
    hallway the walls fix it) and the position is left alone (along a hallway it would slide)."""
    from pico_gym.agents.classic.explore.config import ExploreAgentConfig
    from pico_gym.agents.classic.explore.occupancy import OccupancyMap
    from pico_gym.agents.classic.explore.pose import OdometryPose

    cfg = ExploreAgentConfig()
    occupancy = OccupancyMap(cfg, Pose(0.0, 0.0, 0.0))
    angles = np.linspace(-2.0, 2.0, 1000)
    for x in np.arange(-3.0, 3.01, 0.5):  # map the hallway from its middle
        occupancy.integrate(
            Pose(float(x), 0.0, 0.0), angles, _hallway_ranges(Pose(float(x), 0.0, 0.0), angles), 10.0, 1
        )
    stored = occupancy.logodds.copy()
    truth = Pose(0.4, 0.1, 0.0)
    pose = OdometryPose(cfg, truth)
    pose.pose = Pose(0.4, 0.1, math.radians(2.0))  # the estimate 2 degrees off
    ranges = _hallway_ranges(truth, angles)
    for _ in range(5):
        pose.align(ranges, angles, occupancy, 10.0, stored, heading_only=True)
    assert (pose.pose.x, pose.pose.y) == (0.4, 0.1)
    assert abs(pose.pose.theta) < math.radians(0.5)


def test_search_align_takes_no_match_where_the_stored_map_explains_little_of_the_scan() -> None:
    """`search_align_explained`: with most of the scan on what the stored map does not hold
    (here clutter 0.6 m off in every beam but those 11-46 deg off the heading, which reach the
    hallway's walls), the points on its walls still move the heading (here the right way), but
    a match on under 35 % of what the scan could score is not taken, right or wrong."""
    from pico_gym.agents.classic.explore.config import ExploreAgentConfig
    from pico_gym.agents.classic.explore.occupancy import OccupancyMap
    from pico_gym.agents.classic.explore.pose import OdometryPose

    cfg = ExploreAgentConfig()
    occupancy = OccupancyMap(cfg, Pose(0.0, 0.0, 0.0))
    angles = np.linspace(-2.0, 2.0, 1000)
    for x in np.arange(-3.0, 3.01, 0.5):
        occupancy.integrate(
            Pose(float(x), 0.0, 0.0), angles, _hallway_ranges(Pose(float(x), 0.0, 0.0), angles), 10.0, 1
        )
    stored = occupancy.logodds.copy()
    truth = Pose(0.4, 0.1, 0.0)
    ranges = np.where((np.abs(angles) > 0.2) & (np.abs(angles) < 0.8), _hallway_ranges(truth, angles), 0.6)
    moved = {}
    for explained in (0.0, 0.35):
        pose = OdometryPose(cfg, truth)
        pose.pose = Pose(0.4, 0.1, math.radians(2.0))
        for _ in range(5):
            pose.align(ranges, angles, occupancy, 10.0, stored, heading_only=True, explained=explained)
        moved[explained] = pose.pose.theta != math.radians(2.0)
    assert moved == {0.0: True, 0.35: False}


def test_dock_puts_the_pose_at_the_distance_the_scan_sees_the_parking_wall() -> None:
    """`parking.dock`: facing the parking wall (x = 0, the end of a 1.8 m hallway), the scan gives
    the distance to it (and, if asked, the heading against it) whatever the drifted pose says;
    the position along the wall is left alone. Kept, the heading turns the wall seen into the
    map (a wall refitted on a drifted map tilted). A wall seen that is not the parking wall as
    the pose has it (a side wall, or one farther off than `max_shift_m`) leaves the pose alone."""
    from pico_gym.agents.classic.explore.parking import dock

    end = np.array([[0, -0.9, 0, 0.9], [0, 0.9, 6, 0.9], [6, -0.9, 0, -0.9]], float)
    angles = np.linspace(-2.0, 2.0, 1000)
    wall = (np.array([0.0, 0.0]), np.array([1.0, 0.0]))
    truth = Pose(0.62, 0.2, math.pi + 0.05)
    ranges = lrf_ranges(truth, end, angles)
    drifted = Pose(0.9, 0.05, math.pi - 0.08)  # 0.28 m too far off the wall, 7.4 deg off
    seen = dock(ranges, angles, drifted, wall, max_shift_m=0.6, heading=True)
    assert seen is not None
    docked, normal = seen
    assert abs(docked.x - truth.x) < 0.01 and docked.y == drifted.y  # along the wall: not measured
    assert abs(math.remainder(docked.theta - truth.theta, 2 * math.pi)) < math.radians(0.5)
    assert normal @ wall[1] == 1.0
    # The distance only (the default): the heading kept, the wall seen turned by it.
    seen = dock(ranges, angles, drifted, wall, max_shift_m=0.6, heading=False)
    assert seen is not None
    docked, normal = seen
    assert docked.theta == drifted.theta
    tilt = math.atan2(normal[1], normal[0])  # the wall as this heading sees it: 7.4 deg tilted
    assert abs(tilt - (drifted.theta - truth.theta)) < math.radians(0.5)
    wall_distance = float((np.array([docked.x, docked.y]) - wall[0]) @ normal)
    assert abs(wall_distance - truth.x) < 0.01
    assert dock(ranges, angles, Pose(1.5, 0.05, math.pi), wall, max_shift_m=0.6, heading=False) is None  # 0.88 m off
    side = lrf_ranges(Pose(2.0, 0.2, math.pi / 2), end, angles)  # facing a side wall
    assert dock(side, angles, Pose(2.0, 0.2, math.pi / 2), wall, max_shift_m=0.6, heading=False) is None


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"search_align_explained": 1.5}, "search_align_explained"),
        ({"search_align_explained": float("nan")}, "search_align_explained"),
        ({"dither_s": -1.0}, "dither_s"),
        ({"dither_s": True}, "dither_s"),
        ({"search_retry": 1}, "search_retry"),
        ({"creep_held_s": -3.0}, "creep_held_s"),
        ({"wedge_turn_s": 20.0}, "wedge_turn_s"),
        ({"wedge_turn_s": True}, "wedge_turn_s"),
    ],
)
def test_the_config_refuses_bad_search_settings(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        ExploreAgentConfig(**kwargs)
