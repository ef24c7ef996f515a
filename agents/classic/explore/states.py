"""The classic explore agent's state machine: one function per state, each the command for a step.

LOOK      turn a full circle in place; facing back, fit the parking wall behind the start
EXPLORE   frontier exploration until no frontier is left (or the budget is spent)
PARK      drive to the stand-off point in front of the parking wall (the last 1.5 m with the pose
          put at the distance the scan sees the wall), turn to point away
REVERSE   back up with the heading held until odometry keeps counting while the scan stops
          moving (the wall is touched)
PARKED    stand still, then off the wall
SEARCH    look for what the map stored at parking does not explain, going into the rooms
          not looked into since parking
APPROACH  drive to 0.5 m from the object, face it, creep in until the LRF reads 0.3 m
FOUND     stand still (the env counts the find after 1 s)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

from pico_gym.agents.classic.explore.motion import Command, filtered
from pico_gym.agents.classic.explore.parking import dock, fit_wall, parking_spot
from pico_gym.agents.classic.explore.regions import component_sizes
from pico_gym.agents.classic.potential_field import attract_and_repel, heading_rate, safe_turn
from pico_gym.types import FloatArray, Pose
from pico_gym.world.geometry import wrap_angle

if TYPE_CHECKING:
    from pico_gym.agents.classic.explore.agent import ExploreAgent


class State(Enum):
    LOOK = "look"
    EXPLORE = "explore"
    PARK = "park"
    REVERSE = "reverse"
    PARKED = "parked"
    SEARCH = "search"
    APPROACH = "approach"
    FOUND = "found"


def _follow(agent: ExploreAgent, near: FloatArray) -> Command:
    return agent.follower.follow(agent.planner, agent.pose, near, agent.steps, agent.still_steps)


def look(agent: ExploreAgent, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> Command:
    """Turn a full circle; facing back, fit the parking wall; then explore (or, started parked
    in "find", search)."""
    find = agent.phase == "find"
    if find and agent.state_steps <= agent._steps(3.0):
        return 0.1, 0.0, 0.0  # started parked: off the wall before turning (0.3 m)
    agent.turned += abs(delta.theta)
    start = agent.odometry.start
    behind = abs(wrap_angle(agent.pose.theta - start.theta - math.pi))
    if agent.wall is None and behind < 0.1 and not find:
        agent.wall = fit_wall(ranges, agent.angles, agent.pose, start)
    if safe_turn(near, 1.0, agent.motion) < 0.5:
        # Too close to something to turn: away from it first (the start may be near a wall).
        away = dataclasses.replace(agent.follow, repulsion_range=0.4, repulsion_gain=0.02)
        v = attract_and_repel(near, np.zeros(2), away, speed=0.1)
        return float(v[0]), float(v[1]), 0.0
    if agent.turned >= 2 * math.pi + 0.2:
        if agent.wall is None:  # nothing seen behind: assume the wall 0.6 m behind the start
            back = np.array([math.cos(start.theta), math.sin(start.theta)])
            agent.wall = (np.array([start.x, start.y]) - 0.7 * back, back)
        agent._go(State.SEARCH if find else State.EXPLORE)
        if (agent.config.relocalise_park_m > 0.0 or agent.config.park_wall_from_start) and not find:
            agent.start_map = agent.occupancy.logodds.copy()  # the hallway's end, before any drift
        if find:
            agent.finder.stored = agent.occupancy.logodds.copy()
            agent.occupancy.checked[:] = False
        return 0.0, 0.0, 0.0
    return 0.0, 0.0, 1.0


def _dithered(agent: ExploreAgent) -> bool:
    """Whether the robot has stayed in one spot for `dither_s` while exploring or searching;
    then its goal is given up. Two goals that take turns (each nearer once the robot heads for
    the other) each restart the progress `give_up_s` counts, and a robot between them stays."""
    cfg, planner = agent.config, agent.planner
    stayed = planner.stayed(np.array([agent.pose.x, agent.pose.y]), agent.steps)
    if cfg.dither_s <= 0.0 or planner.goal is None or stayed < agent._steps(cfg.dither_s):
        return False
    planner.given_up.append(planner.goal.copy())
    planner.goal, planner.path, planner.anchor = None, [], None
    return True


def explore(agent: ExploreAgent, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> Command:
    """To the best frontier; frontiers given up get one more try, then small ones (a door seen
    only at a grazing angle leaves a frontier of a cell or two); none left: PARK."""
    planner, step = agent.planner, agent.steps
    if step * agent.spec.dt_s > agent.config.explore_budget_s:
        agent._go(State.PARK)
        return 0.0, 0.0, 0.0
    if _dithered(agent):
        return 0.0, 0.0, 0.0
    if planner.replan_due(step):
        unknown = agent.occupancy.unknown
        found = planner.plan_to_frontier(agent.pose, step, unknown(step))
        fresh = [q for q in planner.given_up if not any(np.linalg.norm(q - r) < 0.3 for r in planner.retried)]
        if not found and fresh:
            # Only frontiers given up on are left: they may have become reachable since (each
            # gets one more try).
            planner.retried += fresh
            planner.given_up = [q for q in planner.given_up if not any(q is f for f in fresh)]
            found = planner.plan_to_frontier(agent.pose, step, unknown(step))
        planner.small_goal = False
        if not found:
            # Most small frontiers are gaps in a mapped wall: one looked at from within 1 m is
            # done (a door there would have shown the room behind it, a large frontier).
            found = planner.small_goal = planner.plan_to_frontier(agent.pose, step, unknown(step), min_cells=1)
        if not found:
            agent._go(State.PARK)
            return 0.0, 0.0, 0.0
    if planner.small_goal and planner.goal is not None:
        if np.linalg.norm(planner.goal - np.array([agent.pose.x, agent.pose.y])) < 1.0:
            planner.given_up.append(planner.goal.copy())
            planner.goal = None
            planner.path = []
            return 0.0, 0.0, 0.0
    return _follow(agent, near)


def park(agent: ExploreAgent, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> Command:
    """To the stand-off point in front of the parking wall; there, face away from it: REVERSE."""
    cfg = agent.config
    if not agent.at_standoff and (agent.state_steps == 1 or agent.planner.replan_due(agent.steps)):
        logodds = agent.start_map if cfg.park_wall_from_start and agent.start_map is not None else None
        agent.wall, agent.park_foot = parking_spot(
            agent.occupancy, agent.parking_wall(), agent.odometry.start, agent.motion, cfg, logodds
        )
        if agent.wall_seen is not None:  # the wall as the scan saw it, facing it (`park_dock_m`)
            agent.wall = (agent.wall[0], agent.wall_seen)
    point, normal = agent.parking_wall()
    standoff = agent.park_foot + normal * (cfg.park_standoff_m + agent.standoff_extra)
    here = np.array([agent.pose.x, agent.pose.y])
    distance = float(np.linalg.norm(standoff - here))
    if distance < cfg.park_dock_m and not agent.at_standoff:
        seen = dock(ranges, agent.angles, agent.pose, (point, normal), 0.6, heading=cfg.park_dock_heading)
        if seen is not None:
            docked, agent.wall_seen = seen
            moved = math.hypot(docked.x - agent.pose.x, docked.y - agent.pose.y)
            if moved > 0.03 or abs(wrap_angle(docked.theta - agent.pose.theta)) > 0.02:
                agent.blind_from = agent.steps + 1  # this step's scan went into the map before the move
            agent.odometry.pose = docked
            agent.odometry.settle(odom)
            here = np.array([docked.x, docked.y])
            distance = float(np.linalg.norm(standoff - here))
    if (
        agent.start_map is not None
        and distance < cfg.relocalise_park_m
        and not agent.at_standoff
        and agent.state_steps % agent._steps(2.0) == 1
    ):
        if agent.odometry.relocalise(
            ranges, agent.angles, agent.start_map, agent.occupancy, agent.spec.lrf.range_max_m
        ):
            agent.odometry.settle(odom)  # keep the match (the next prediction starts from it)
            agent.planner.path = []  # plan again from where it is
            return 0.0, 0.0, 0.0
    if distance < 0.4:  # (the path ends within 0.2 m of its goal cell)
        return _at_standoff(agent, near, standoff, here, distance, math.atan2(normal[1], normal[0]))
    if agent.planner.replan_due(agent.steps):
        if not agent.planner.plan_to(agent.pose, agent.steps, standoff):
            agent.planner.given_up.clear()
            return 0.0, 0.0, 0.6  # turn and look: the map may open a way
    return _follow(agent, near)


def _at_standoff(
    agent: ExploreAgent, near: FloatArray, standoff: FloatArray, here: FloatArray, distance: float, heading: float
) -> Command:
    """Servo onto the stand-off point facing it (the way there may lie behind the robot, in the
    LRF's blind sector), then turn in place to face away from the wall, then reverse.
    Hysteresis: the turn may shift the centre a few centimetres."""
    settle = agent.config.park_settle_s
    if distance < 0.04 or (settle > 0.0 and distance < 0.12 and agent.still_steps > agent._steps(settle)):
        agent.at_standoff = True
    elif distance > 0.12:
        agent.at_standoff = False
    v = agent.odometry.to_robot(standoff) * 1.5
    speed = float(np.hypot(*v))
    if speed > 0.15:
        v *= 0.15 / speed
    if not agent.at_standoff:
        error = wrap_angle(math.atan2(*(standoff - here)[::-1]) - agent.pose.theta)
        turn = heading_rate(error, agent.motion)
        return (float(v[0]), float(v[1]), turn) if abs(error) < 0.5 else (0.0, 0.0, turn)  # face it first
    error = wrap_angle(heading - agent.pose.theta)
    # A door jamb beside the parking spot may leave no room to turn the last few degrees: within
    # the rule's 15 deg, reverse at the heading it has (the reverse corrects it if it can).
    turn = heading_rate(error, agent.motion)
    blocked = filtered(near, 0.0, 0.0, turn, agent.motion)[2] == 0.0
    cramped = abs(error) < 0.25 and blocked
    # A turn the filter cuts far from the heading: no room to turn here. Stand off farther from
    # the wall (the reverse goes back to it anyway), up to `park_more_m` more.
    agent.turn_blocked = agent.turn_blocked + 1 if blocked and abs(error) >= 0.25 else 0
    if agent.turn_blocked > agent._steps(2.0) and agent.standoff_extra < agent.config.park_more_m - 1e-9:
        agent.standoff_extra += 0.1
        agent.turn_blocked = 0
        agent.at_standoff = False
        return 0.0, 0.0, 0.0
    # Settled (`park_settle_s`): turn in place (the servo's last centimetres, cut by the filter,
    # stopped the turn too), and reverse from where it stands once facing away.
    if settle > 0.0 and not (abs(error) < 0.03 or cramped) and not blocked:
        return 0.0, 0.0, turn
    if (distance < 0.06 or settle > 0.0) and (abs(error) < 0.03 or cramped):
        agent._go(State.REVERSE)
        agent.stuck = 0
        agent.reversed_m = 0.0
        agent.reverse_log = []
        return 0.0, 0.0, 0.0
    if not blocked and filtered(near, float(v[0]), float(v[1]), turn, agent.motion)[2] == 0.0:
        return 0.0, 0.0, turn  # the last millimetres of the servo cut the turn with them: turn alone
    return float(v[0]), float(v[1]), turn


def reverse(agent: ExploreAgent, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> Command:
    """Back up at `reverse_mps`, heading and line held, until touching: over the last second the
    odometry counted at least 3 cm back while the scan straight ahead moved less than a third of
    that, with the wall (as mapped) close behind; then the pose is put back at the wall."""
    cfg = agent.config
    if agent.state_steps == 1:  # its first step
        # The map to store: as it is before the rear touches (the object is placed once the env
        # counts the robot parked, seconds before this agent is sure of the touch).
        agent.finder.before_touch = agent.occupancy.logodds.copy()
    point, normal = agent.parking_wall()
    heading = math.atan2(normal[1], normal[0])
    agent.reversed_m += max(-delta.x, 0.0)  # odometry says the robot moved back this much
    agent.reverse_log.append((agent.reversed_m, ranges[agent._front]))
    pose = agent.pose
    # The rear edge's distance to the wall as the odometry has it (the corners touch first when
    # the heading is off).
    reach = agent.motion.half_depth * math.cos(pose.theta - heading) + agent.motion.half_width * abs(
        math.sin(pose.theta - heading)
    )
    gap = float((np.array([pose.x, pose.y]) - point) @ normal) - reach
    if len(agent.reverse_log) > agent._steps(1.0):
        agent.stuck = agent.stuck + 1 if _touched(agent, ranges, gap) else 0
    # The odometry 8 cm past the wall (refitted to the map, within 2-3 cm): its wheels slip on
    # the spot.
    if agent.stuck >= 2 or gap < -cfg.park_overrun_m or agent.reversed_m > 1.0:
        # Touching: the centre is `reach` off the wall, whatever the odometry counted.
        theta = heading if cfg.touch_sets_heading else pose.theta
        if cfg.touch_sets_heading:  # flush: the centre is half the depth off the wall
            gap = float((np.array([pose.x, pose.y]) - point) @ normal) - agent.motion.half_depth
        here = np.array([pose.x, pose.y]) - normal * gap
        agent.odometry.pose = Pose(float(here[0]), float(here[1]), theta)
        agent.odometry.settle(odom)
        agent._go(State.PARKED)
        return 0.0, 0.0, 0.0
    # Hold the heading and the line through the stand-off point while backing up.
    along = np.array([normal[1], -normal[0]])
    offset = float((np.array([pose.x, pose.y]) - agent.park_foot) @ along)
    correction = -along * float(np.clip(2.0 * offset, -0.03, 0.03))  # map frame
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    vy = -s * correction[0] + c * correction[1]
    w = safe_turn(near, heading_rate(wrap_angle(heading - pose.theta), agent.motion), agent.motion)
    return -cfg.reverse_mps, float(vy), w


def _touched(agent: ExploreAgent, ranges: FloatArray, gap: float) -> bool:
    """Over the last second: odometry counted over 3 cm back, the scan ahead moved less than a
    third of that, and the wall is within 0.2 m as mapped."""
    then_m, then = agent.reverse_log.pop(0)
    counted = agent.reversed_m - then_m
    now = ranges[agent._front]
    far = agent.spec.lrf.range_max_m - 1e-6
    ok = (then < far) & (now < far)
    # Beams ahead that hit something in both scans, along the heading (nothing ahead in range:
    # the odometry's own gap decides).
    ahead = (now[ok] - then[ok]) * np.cos(agent.angles[agent._front][ok])
    seen = float(np.median(ahead)) if ok.sum() >= 3 else counted
    return counted > 0.03 and seen < counted / 3 and gap < 0.2


def parked(agent: ExploreAgent, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> Command:
    """Stand still 1.5 s (the map before the touch becomes the stored one, the rooms are cut from
    it), then off the wall: SEARCH."""
    if agent.state_steps == agent._steps(1.5):
        finder = agent.finder
        finder.stored = finder.before_touch  # PARKED comes only from REVERSE, which took it
        agent.occupancy.checked[:] = False
        finder.evidence[:] = 0.0
        finder.depths = finder.room_depths(agent.steps, agent.odometry.start)
        # What exploring gave up was frontiers; the search's goals are other places.
        agent.planner.given_up.clear()
    if agent.state_steps > agent._steps(1.5):
        # Off the wall before anything turns (a turn against it swings a corner into it).
        point, normal = agent.parking_wall()
        gap = float((np.array([agent.pose.x, agent.pose.y]) - point) @ normal) - agent.motion.half_depth
        if gap > 0.25 or agent.state_steps > agent._steps(6.0):
            agent._go(State.SEARCH)
            agent.blind_from = 0  # the memory of the rooms, for the search (docking cut it)
        return 0.1, 0.0, 0.0
    return 0.0, 0.0, 0.0


def search(agent: ExploreAgent, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> Command:
    """Into the rooms not looked into since parking, the deepest first (the course's hint: the
    object is in the room that needs the most doors to reach); an object seen: APPROACH."""
    finder, planner, occupancy, step = agent.finder, agent.planner, agent.occupancy, agent.steps
    if finder.object is not None:
        agent._go(State.APPROACH)
        return 0.0, 0.0, 0.0
    if _dithered(agent):
        return 0.0, 0.0, 0.0
    if planner.replan_due(step):
        finder.isolated(step, agent.phase == "find", planner.given_up)
        if finder.object is not None:
            return 0.0, 0.0, 0.0
        occupied, free = occupancy.coarse(step)
        r0, r1, c0, c1 = occupancy.view
        # Not looked at since parking; or never seen, for a start in "find".
        unseen = free & ~occupancy.checked[r0:r1, c0:c1]
        if agent.phase == "find":
            unseen |= ~occupied & ~free
        # Large unseen parts first (a room not looked into since parking), by the unseen area.
        large = component_sizes(unseen) >= 30
        if finder.depths is not None:
            depths = finder.depths[r0:r1, c0:c1]
            if _search_next(agent, large, depths, step):
                return _follow(agent, near)
        if not planner.plan_to_frontier(agent.pose, step, large, min_cells=1) and not planner.plan_to_frontier(
            agent.pose, step, unseen
        ):
            occupancy.checked[:] = False  # looked everywhere: look again
            if agent.config.search_retry:  # the places given up too (the false objects stay so)
                planner.given_up = [q.copy() for q in finder.rejected]
            return 0.0, 0.0, 0.8
    return _follow(agent, near)


def _search_next(agent: ExploreAgent, large: np.ndarray, depths: np.ndarray, step: int) -> bool:
    """Plan to the next room not looked into since parking (`ExploreAgentConfig.search_depth_m`):
    the nearest by path less a bonus per door on the way, or strictly the deepest first. Any
    frontier of a large unseen part counts, however short (a room glimpsed through its door leaves
    a frontier of two or three cells there)."""
    planner, weight = agent.planner, agent.config.search_depth_m
    if weight < 0.0:
        for d in range(int(depths.max()), 0, -1):
            if planner.plan_to_frontier(agent.pose, step, large & (depths == d), min_cells=1):
                return True
        return False
    # Each frontier cell's bonus: the depth of the unseen part it borders (the 3 x 3 maximum).
    unseen_depth = np.where(large, depths, 0)
    padded = np.pad(unseen_depth, 1)
    rows, cols = unseen_depth.shape
    around = np.max([padded[dr : dr + rows, dc : dc + cols] for dr in range(3) for dc in range(3)], axis=0)
    return planner.plan_to_frontier(agent.pose, step, large, min_cells=1, bonus=weight * around)


def approach(agent: ExploreAgent, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> Command:
    """To 0.6 m from the object by the planner; then face it and creep in until the LRF reads
    the stop range towards it: FOUND."""
    obj = agent.finder.object
    assert obj is not None  # (APPROACH comes only with an object)
    pose = agent.pose
    here = np.array([pose.x, pose.y])
    distance = float(np.linalg.norm(obj - here))
    error = wrap_angle(math.atan2(obj[1] - here[1], obj[0] - here[0]) - pose.theta)
    if agent.round_from and distance < agent.round_from - 0.15:
        agent.round_from = 0.0  # round the jamb, nearer: creep again from here
    if distance < 0.9 and not agent.round_from:
        rel = np.abs(np.array([wrap_angle(a - error) for a in agent.angles[::5]])) < 0.3
        ahead = ranges[::5][rel]
        closest = float(ahead.min()) if len(ahead) else math.inf
        if closest <= agent.config.stop_range_m and abs(error) < agent.motion.visible_bearing:
            agent._go(State.FOUND)
            return 0.0, 0.0, 0.0
        held_s = agent.config.creep_held_s
        if not (held_s > 0.0 and agent.still_steps > agent._steps(held_s)):
            # Towards it as it turns (holonomic; a turn a jamb refuses must not stop the creep).
            forward = 0.1 if abs(error) < agent.motion.visible_bearing else 0.0
            return forward * math.cos(error), forward * math.sin(error), heading_rate(error, agent.motion)
        agent.round_from = distance  # the filter holds the creep (a jamb between): plan round it
        agent.planner.clear(agent.steps)
    if agent.planner.replan_due(agent.steps):
        nearer = bool(agent.round_from) and agent.planner.plan_to(pose, agent.steps, obj, stop_m=0.45)
        if not nearer:
            agent.round_from = 0.0
            if not agent.planner.plan_to(pose, agent.steps, obj, stop_m=0.6):
                agent.finder.object = None
                agent._go(State.SEARCH)
                return 0.0, 0.0, 0.0
    return _follow(agent, near)


def found(agent: ExploreAgent, ranges: FloatArray, near: FloatArray, odom: Pose, delta: Pose) -> Command:
    """Stand still; not counted within 5 s (a false object): give it up, SEARCH on."""
    if agent.state_steps > agent._steps(5.0):
        finder = agent.finder
        assert finder.object is not None  # (FOUND comes only with an object)
        agent.planner.given_up.append(finder.object.copy())
        finder.rejected.append(finder.object.copy())
        finder.evidence[:] = 0.0
        finder.object = None
        agent._go(State.SEARCH)
    return 0.0, 0.0, 0.0


HANDLERS: dict[State, Callable[[ExploreAgent, FloatArray, FloatArray, Pose, Pose], Command]] = {
    State.LOOK: look,
    State.EXPLORE: explore,
    State.PARK: park,
    State.REVERSE: reverse,
    State.PARKED: parked,
    State.SEARCH: search,
    State.APPROACH: approach,
    State.FOUND: found,
}
