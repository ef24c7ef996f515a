"""The classic hospital agent's state machine: one function per state, each the command for a step.

    LOCALISE   turn in place until the pose on the start area is certain (`pose.MapPose.search`)
    RELOCALISE the same over the whole map, after the pose was lost
    NAVIGATE   follow the planned path to the next cabinet's dock point: forward where there is
               room, sideways where it is narrow (the robot's 0.2 m depth across the way)
    DOCK       servo into the arrival square facing the front (`docking.fit_front`)
    DWELL      stand still for the dwell time, or announce once; then the next cabinet
    YIELD      no path with something unexplained close (a person crossing, one paused because
               the robot is near): keep out of its pause radius, watch it, plan again every half
               second; what does not move while watched is a box: RECOVER
    RECOVER    no path or no progress: back off, fade the evidence, plan again
    DONE       every cabinet visited

LOCALISE and RELOCALISE are the agent's own (`HospitalAgent._localise`); the others are here. A
state function reads and writes the agent's parts (its pose, evidence, route) and its state, and
changes state with `agent._go`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

from pico_gym.agents.classic.hospital.docking import fit_front
from pico_gym.agents.classic.potential_field import attract_and_repel, heading_rate
from pico_gym.types import FloatArray
from pico_gym.world.geometry import wrap_angle

if TYPE_CHECKING:
    from pico_gym.agents.classic.hospital.agent import HospitalAgent

Command = tuple[float, float, float]


class State(Enum):
    LOCALISE = "localise"
    RELOCALISE = "relocalise"
    NAVIGATE = "navigate"
    DOCK = "dock"
    DWELL = "dwell"
    YIELD = "yield"
    RECOVER = "recover"
    DONE = "done"


# --- progress -----------------------------------------------------------------------------------
def progress(agent: HospitalAgent, distance: float) -> bool:
    """Track progress to the goal; True when there was none for `stuck_s`."""
    if distance < agent.best_distance - 0.1:
        agent.best_distance = distance
        agent.progress_step = agent.steps
    return agent.steps - agent.progress_step > agent._steps(agent.config.stuck_s)


def going_nowhere(agent: HospitalAgent, here: FloatArray) -> bool:
    """True when the robot has stayed within 0.3 m of one spot for twice `stuck_s`."""
    if agent._anchor is None or float(np.linalg.norm(here - agent._anchor[0])) > 0.3:
        agent._anchor = (here.copy(), agent.steps)
    return agent.steps - agent._anchor[1] > agent._steps(2.0 * agent.config.stuck_s)


# --- people and what is in the way ----------------------------------------------------------
def blocker(agent: HospitalAgent) -> FloatArray | None:
    """The nearest point within `yield_range_m` that the map does not explain (robot frame)."""
    pts = agent._unexplained_near(agent.config.yield_range_m)
    if len(pts) == 0:
        return None
    return pts[int(np.argmin(np.hypot(pts[:, 0], pts[:, 1])))]


def holding_a_person(agent: HospitalAgent) -> bool:
    """Whether the robot is inside a moving track's pause radius (+ 0.1 m): the simulator's
    person or cart waits there until the robot leaves (docs/facts/hospital-facts.md 1.6)."""
    if not agent.config.track_people:
        return False
    pose = agent.pose
    return any(
        math.hypot(t.position[0] - pose.x, t.position[1] - pose.y) < t.pause_radius_m + 0.1
        for t in agent.world.tracker.moving()
    )


def moved(agent: HospitalAgent) -> bool:
    """Whether something the map does not explain is where nothing was at the last check
    (map frame, 0.15 m apart): a person walking, not a box seen again."""
    here = agent._to_map(agent._unexplained_near(agent.config.yield_range_m))
    before, agent._yield_seen = agent._yield_seen, here
    if len(before) == 0 or len(here) == 0:
        return False
    gaps = np.hypot(here[:, None, 0] - before[None, :, 0], here[:, None, 1] - before[None, :, 1]).min(axis=1)
    return bool((gaps > 0.15).any())


def escape_spot(agent: HospitalAgent, unexplained: FloatArray) -> FloatArray:
    """Where to back off to (map frame): of the spots 0.6 and 0.9 m away in 16 directions that
    the map and the evidence leave room for the robot's centre, the one farthest from what the
    map does not explain."""
    pose = agent.pose
    here = np.array([pose.x, pose.y])
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    others = here + unexplained @ np.array([[c, s], [-s, c]])  # robot frame -> map frame
    best, best_score = here, -math.inf
    for a, reach in ((a, r) for r in (0.6, 0.9) for a in np.linspace(0.0, 2.0 * math.pi, 16, endpoint=False)):
        spot = here + reach * np.array([math.cos(a), math.sin(a)])
        # Room for the robot's centre (beside a wall too: wedged between a wall and a paused
        # person, the way out is along the wall).
        if not agent.route.roomy(spot, agent.config.inflate_m) or not agent.route.straight_way(here, spot):
            continue
        if any(np.hypot(*(spot - bad)) < 0.3 for bad in agent._blocked_spots):
            continue
        score = float(np.hypot(*(others - spot).T).min()) if len(others) else 0.0
        if score > best_score:
            best, best_score = spot, score
    if agent.still_steps >= agent._steps(1.0) and best is not here:
        # The safety filter has held the robot still on the way there: another way out.
        agent._blocked_spots.append(best)
        agent.still_steps = 0
    return best


# --- the states ---------------------------------------------------------------------------------
def navigate(agent: HospitalAgent, near: FloatArray) -> Command:
    """Follow the path to the dock point; plan again when due or blocked; no progress: RECOVER
    (and a no-go disc where it got stuck); no path: YIELD or RECOVER."""
    cfg, route = agent.config, agent.route
    goal = agent.dock_point()
    pose = agent.pose
    here = np.array([pose.x, pose.y])
    distance = float(np.linalg.norm(goal - here))
    if distance < cfg.dock_radius_m:
        agent._go(State.DOCK)
        return 0.0, 0.0, 0.0
    if not route.path or agent.steps - route.plan_step >= agent._steps(cfg.replan_s) or route.path_blocked(pose):
        if not route.plan(pose, goal, agent.steps):
            yielding = blocker(agent) is not None and agent.steps >= agent._static_until
            agent._go(State.YIELD if yielding else State.RECOVER)
            return 0.0, 0.0, 0.0
        remaining = route.remaining(here)
        if remaining > agent.best_distance + 0.5:  # a new, longer way round: progress counts anew
            agent.best_distance = remaining
            agent.progress_step = agent.steps
    while len(route.path) > 1 and np.linalg.norm(route.path[0] - here) < cfg.lookahead_m:
        route.path.pop(0)
    # Progress along the way, not as the crow flies; and, since plans that alternate between
    # two ways round each restart that count, the robot must also get somewhere at all.
    if progress(agent, route.remaining(here)) or going_nowhere(agent, here):
        ahead = route.path[0] - here
        gap = float(np.hypot(*ahead))
        spot = here + ahead * min(1.0, (cfg.nogo_m + 0.1) / gap) if gap > 1e-6 else here
        if float(np.linalg.norm(goal - spot)) > cfg.nogo_m + 0.3:  # never the goal itself
            route.nogo.append((float(spot[0]), float(spot[1]), agent.steps + agent._steps(cfg.nogo_s)))
        agent._go(State.RECOVER)
        return 0.0, 0.0, 0.0
    if agent.still_steps >= agent._steps(1.0) and holding_a_person(agent):
        # Stopped inside a person's pause radius: it waits for the robot, the robot for it.
        agent._go(State.YIELD)
        return 0.0, 0.0, 0.0
    target = route.path[0]
    agent.target = target
    v = attract_and_repel(near, agent._to_robot(target), agent.follow)
    travel = math.atan2(target[1] - here[1], target[0] - here[0])
    if distance < cfg.face_within_m and route.clear_way(here, goal):
        heading = agent.cabinet().facing_rad
    elif route.roomy(here) and route.roomy(target):
        heading = travel  # forward: the LRF sees the way ahead and both sides
    else:
        heading = travel - _sideways(agent, here, travel) * math.pi / 2
    return float(v[0]), float(v[1]), heading_rate(heading - pose.theta, agent.motion)


def _sideways(agent: HospitalAgent, here: FloatArray, travel: float) -> float:
    """The side (+1: the robot's +y) the direction of travel is kept at where it is narrow: the
    more open side faces out (the LRF sees what may come from there; the blind back is to the
    nearer wall), else the nearer turn; something the map does not explain close by is kept in
    view first. Decided afresh every 2 s."""
    unexplained = agent._unexplained_near()
    if agent.side == 0.0 or agent.state_steps % agent._steps(2.0) == 0 or len(unexplained):
        towards = None
        if len(unexplained):
            mx, my = unexplained.mean(axis=0)
            towards = agent.pose.theta + math.atan2(my, mx)
        scores = []
        for side in (1.0, -1.0):
            h = travel - side * math.pi / 2
            ahead = here + 0.6 * np.array([math.cos(h), math.sin(h)])
            turn = abs(wrap_angle(h - agent.pose.theta))
            watch = 0.0 if towards is None else round(math.cos(h - towards), 1)
            scores.append((watch, round(float(agent.given.clearance[agent.given.cell(ahead)]), 1), -turn, side))
        agent.side = max(scores)[3]
    return agent.side


def dock(agent: HospitalAgent, near: FloatArray) -> Command:
    """Servo into the arrival square facing the front: on the front as the LRF sees it
    (`fit_front`) once it is in view, else on the pose estimate."""
    cfg = agent.config
    cab = agent.cabinet()
    goal = agent.dock_point()
    pose = agent.pose
    here = np.array([pose.x, pose.y])
    if float(np.linalg.norm(goal - here)) > cfg.dock_radius_m + 0.4 or agent.state_steps > agent._steps(15.0):
        agent._go(State.NAVIGATE)
        return 0.0, 0.0, 0.0
    fit = fit_front(agent._scan_robot, np.array([agent._to_robot(p) for p in cab.front]), cfg.dock_depth_m)
    agent.front_fit = fit
    if fit is not None:
        error, heading_error = fit.goal, fit.heading_error
        arrived = True  # the fit's errors decide (the square is around its goal)
    else:
        error = agent._to_robot(goal)
        heading_error = wrap_angle(cab.facing_rad - pose.theta)
        arrived = cab.arrival(pose, math.radians(4.0))[0]
    distance = float(np.hypot(*error))
    if arrived and distance < 0.06 and abs(heading_error) < math.radians(4.0):
        agent._go(State.DWELL)
        return 0.0, 0.0, 0.0
    v = error * min(1.5, cfg.dock_speed / max(distance, 1e-9))
    return float(v[0]), float(v[1]), heading_rate(heading_error, agent.motion)


def dwell(agent: HospitalAgent, near: FloatArray) -> Command:
    """Stand still for the dwell (arrival="dwell"), or announce the arrival once and go on
    (arrival="announce"). Not while the scan fits the map poorly without a check against the
    whole map (the pose may be lost in a look-alike spot: that arrival would count for nothing)."""
    loc = agent.localisation
    if agent.state_steps == 1 and loc.health < agent.config.doubt_health and loc.localised:
        if loc.check_elsewhere(agent._odom, agent._fixed):  # a look-alike spot while lost?
            agent._lost()
        if agent.state is not State.DWELL:
            return 0.0, 0.0, 0.0
    if agent.announce:
        agent._announcing = True
        agent.done += 1
        agent._go(State.DONE if agent.done >= len(agent.order) else State.NAVIGATE)
        return 0.0, 0.0, 0.0
    if agent.state_steps * agent.spec.dt_s >= agent.dwell_s + agent.config.dwell_margin_s:
        agent.done += 1
        agent._go(State.DONE if agent.done >= len(agent.order) else State.NAVIGATE)
    return 0.0, 0.0, 0.0


def yield_to(agent: HospitalAgent, near: FloatArray) -> Command:
    """Keep out of the blocker's pause radius and watch it: a person walking across the way
    moves on (a paused one resumes once the robot is far enough), the beams clear the cells it
    leaves, and a plan goes through again. No fading: what is really there stays."""
    cfg = agent.config
    if agent.state_steps * agent.spec.dt_s >= cfg.yield_max_s:
        agent._go(State.RECOVER)
        return 0.0, 0.0, 0.0
    if agent.state_steps % agent._steps(0.5) == 0:
        if not holding_a_person(agent) and agent.route.plan(agent.pose, agent.dock_point(), agent.steps):
            path = agent.route.path
            agent._go(State.NAVIGATE)
            agent.route.path, agent.route.plan_step = path, agent.steps
            return 0.0, 0.0, 0.0
        if moved(agent):
            agent._moved_step = agent.steps
    if agent.steps - max(agent._moved_step, agent.steps - agent.state_steps) >= agent._steps(cfg.yield_static_s):
        # Nothing moved: a box (or a cart at the end of its run). Watching it again would only
        # renew its evidence: RECOVER (which fades it) from now on, for a while.
        agent._static_until = agent.steps + agent._steps(cfg.yield_static_memory_s)
        agent._go(State.RECOVER)
        return 0.0, 0.0, 0.0
    nearest = blocker(agent)
    if nearest is None:
        return 0.0, 0.0, 0.3  # it left the view: look round (never idle)
    w = heading_rate(math.atan2(nearest[1], nearest[0]), agent.motion)
    if float(np.hypot(*nearest)) < cfg.yield_keep_m:
        spot = escape_spot(agent, agent._unexplained_near())
        v = attract_and_repel(near, agent._to_robot(spot), agent.motion, speed=0.2)
        return float(v[0]), float(v[1]), w
    return 0.0, 0.0, w


def recover(agent: HospitalAgent, near: FloatArray) -> Command:
    """Back away from what the map does not explain (a person waits while the robot is within
    half its diagonal + 0.3 m, so a robot that waits close by waits forever), to `clear_m`
    from it or for `recover_s`, then wait a little for it to move on, then plan again."""
    cfg = agent.config
    if agent.state_steps == 1:
        agent.world.fade()  # fade, never wipe: what is really there is seen again
    t = agent.state_steps * agent.spec.dt_s
    unexplained = agent._unexplained_near()
    far = len(unexplained) == 0 or float(np.hypot(unexplained[:, 0], unexplained[:, 1]).min()) > cfg.clear_m
    if t >= cfg.recover_s + cfg.recover_wait_s:
        agent._go(State.NAVIGATE)
        return 0.0, 0.0, 0.0
    if t >= cfg.recover_s or far:
        if len(near) and float(np.hypot(near[:, 0], near[:, 1]).min()) < 0.35:
            v = attract_and_repel(near, np.zeros(2), agent.motion, speed=0.15)  # room to turn first
            return float(v[0]), float(v[1]), 0.0
        return 0.0, 0.0, 0.3  # wait, turning slowly (the LRF looks round; never idle)
    v = attract_and_repel(near, agent._to_robot(escape_spot(agent, unexplained)), agent.motion, speed=0.25)
    return float(v[0]), float(v[1]), 0.0


# The state functions of the states past localisation (DONE: stand still).
HANDLERS: dict[State, Callable[[HospitalAgent, FloatArray], Command]] = {
    State.NAVIGATE: navigate,
    State.DOCK: dock,
    State.DWELL: dwell,
    State.YIELD: yield_to,
    State.RECOVER: recover,
}
