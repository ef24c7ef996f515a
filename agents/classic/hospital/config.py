"""The classic hospital agent's settings (SI units; times in seconds, turned into steps with the
control period). How each default was measured is in docs/agents/classic-hospital.md."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from pico_gym.agents.classic.tracking import TrackerConfig


@dataclass(frozen=True)
class HospitalAgentConfig:
    """Parameters of the classic hospital agent.

    Attributes:
        cell_m: the planning and evidence grid's cell [m]; 5 cm resolves a 0.5 m door.
        inflate_m: the centre keeps this far from the map's walls when planning [m]: the robot's
            half depth (0.1 m, it drives sideways where narrow) plus a 5 cm margin.
        replan_s: plan again at least this often, as the evidence changes.
        lookahead_m: the path point this far ahead is the set-point [m].
        dock_depth_m: the dock point's distance from the cabinet's front [m]; the best poses in
            the course's squares are 0.3-0.4 m deep.
        dock_radius_m: within this of the dock point, navigating hands over to docking [m].
        dock_speed: the speed limit while docking [m/s], slow enough for the front fit to follow.
        dwell_margin_s: stand still this much longer than the task's dwell time, so that it
            counts whatever the rounding of the steps.
        face_within_m: turn to face the cabinet once this close to the dock point [m], so that
            docking needs no turn in the square.
        roomy_m: drive forward where walls and evidence are at least this far from the centre
            (here and at the set-point), else sideways [m]: the robot is 0.4 m wide, 0.2 m deep.
        door_approach_m: a path through a door passes waypoints this far before and after it
            on its centre line [m], so the footprint crosses it square.
        unexplained_m: an end point farther than this from every wall of the map is evidence of
            something the map does not show [m]; above the LRF's noise and the pose's error.
        evidence_hit, evidence_miss, evidence_block, evidence_max: the evidence grid's counts: a
            hit adds, a beam passing through subtracts, a cell at `evidence_block` or more is an
            obstacle, none exceeds `evidence_max` (two hits make an obstacle, six misses clear it).
        localise_turn_rad: while localising, search again after turning this much [rad].
        health_min: below this fraction of explained beams the registration is not trusted.
        lost_after: after this many local relocalisations (one per 3 s of poor health) that did
            not restore the health, the pose is lost and the whole map is searched.
        doubt_health, doubt_s, doubt_scans, doubt_gain: a health under `doubt_health` for
            `doubt_s` checks the pose against the whole map with `doubt_scans` scans of the last
            seconds; lost when a pose elsewhere scores `doubt_gain` more per point (mean
            log-likelihood, nats: about a fifth more of the points explained). A hospital's rooms
            look alike: a wrong pose can explain most beams.
        registration_prior: how strongly the scan-to-map registration holds to the odometry
            prediction (per m^2 and rad^2 against unit-weight residuals).
        stuck_s: no progress for this long (or within 0.3 m of one spot for twice this long)
            means recovering.
        recover_s, clear_m, recover_wait_s: recovering backs off for at most `recover_s` or until
            what the map does not explain is `clear_m` away, then waits `recover_wait_s` before
            planning again (a paused person walks on once the robot is away).
        max_still_s: standing still this long (not dwelling) means recovering: the challenge ends
            a run after 30 s without movement.
        turn_keep_m: turning is cut so that half a second of it keeps every point this far off
            the footprint [m]: a turn next to a cabinet swings a corner into it (0: no cut).
        safety_floor_m: the safety filter lets nothing closer to the footprint than this plus
            twice the LRF's noise [m].
        yield_range_m: no path with something the map does not explain this close means
            yielding, not recovering [m].
        yield_keep_m: yielding backs away to keep this far from it [m]: outside the course
            simulator's pause radii (0.86 m for its cart, 0.52 m for a person).
        yield_max_s: a yield that has found no path after this long hands over to recovering.
        yield_static_s, yield_static_memory_s: a yield that has seen nothing move for
            `yield_static_s` is facing a box: recover, and do not yield for
            `yield_static_memory_s`.
        unexplained_margin_m: the safety filter keeps this much more room from points the map
            does not explain (boxes, people, seen late or moving) than from its walls [m].
        nogo_m, nogo_s: where navigating made no progress, a disc of this radius just ahead is
            kept out of the plan for this long [m, s], so the next plan tries another way.
        squeeze_m: with no plan otherwise, the evidence is inflated by only this much and the
            safety filter drops `unexplained_margin_m` on that plan [m]: the robot's half depth,
            for a gap beside a box it can pass sideways only so.
        beams: beams per scan the localiser uses (every k-th); 90 keep a registration under 1 ms.
        track_beams: beams per scan the people tracker clusters.
        track_people: track clusters the map does not explain; the points of moving ones are
            left out of the registration (a person beside a jamb dragged the pose onto it).
        clear_trails: the cells a moving track walked through are cleared (a person leaves no
            wall behind).
        escape_people: what recovering and yielding back away from and watch is the last scan's
            unexplained points and also where the tracker last saw each person walking (a person
            paused just behind the robot is in no scan). Off: measured no gain on this agent.
        blind_memory_s: the safety filter's blind sector also holds the near end points of the
            last this many seconds of scans, kept with odometry (0: the map and the evidence
            only). Off: measured no gain on this agent.
        people_cuts_m: while a person tracked walking is this near, no translation or turn may
            sweep the footprint's rear into space no recent scan saw free [m] (0: off; needs
            `blind_memory_s` > 0). Off: measured no gain on this agent.
        ghost_people_s: a person tracked walking who went out of the LRF's view near the robot
            is kept, where it would have paused for the robot, among the points the safety filter
            keeps the footprint off, until a scan sees that space free or for this long [s]
            (0: off; `agents/classic/hospital/ghosts.py`). Off: measured on the narrow family,
            fewer of this agent's bumps, within the noise, and more of the hybrid's.
        back_guard_mps: recovering and yielding, the robot backs only where a scan of the last
            4 s saw the strip just behind its footprint free, what it saw taken back at this
            speed (a walking person's) [m/s] (0: off): a person who walked up behind a robot
            is in no scan, and recovering backs away from what is in front. Off: measured, it
            boxes the robot in (docs/agents/hybrid.md).
        tracker: the people tracker's settings.
    """

    cell_m: float = 0.05
    inflate_m: float = 0.15
    replan_s: float = 1.0
    lookahead_m: float = 0.4
    dock_depth_m: float = 0.33
    dock_radius_m: float = 0.5
    dock_speed: float = 0.25
    dwell_margin_s: float = 0.3
    face_within_m: float = 1.0
    roomy_m: float = 0.4
    door_approach_m: float = 0.4
    unexplained_m: float = 0.15
    evidence_hit: float = 1.0
    evidence_miss: float = 0.34
    evidence_block: float = 2.0
    evidence_max: float = 6.0
    localise_turn_rad: float = 0.6
    health_min: float = 0.4
    lost_after: int = 2
    doubt_health: float = 0.7
    doubt_s: float = 1.0
    doubt_scans: int = 4
    doubt_gain: float = 0.6
    registration_prior: float = 4.0
    stuck_s: float = 8.0
    recover_s: float = 4.0
    recover_wait_s: float = 2.5
    clear_m: float = 0.9
    max_still_s: float = 20.0
    turn_keep_m: float = 0.05
    safety_floor_m: float = 0.015
    yield_range_m: float = 2.0
    yield_keep_m: float = 1.0
    yield_max_s: float = 15.0
    yield_static_s: float = 3.0
    yield_static_memory_s: float = 30.0
    unexplained_margin_m: float = 0.08
    nogo_m: float = 0.3
    nogo_s: float = 60.0
    squeeze_m: float = 0.1
    beams: int = 90
    track_beams: int = 250
    track_people: bool = True
    clear_trails: bool = True
    escape_people: bool = False
    blind_memory_s: float = 0.0
    people_cuts_m: float = 0.0
    ghost_people_s: float = 0.0
    back_guard_mps: float = 0.0
    tracker: TrackerConfig = dataclasses.field(default_factory=TrackerConfig)

    def __post_init__(self) -> None:
        if not isinstance(self.escape_people, bool):
            raise ValueError(f"HospitalAgentConfig.escape_people must be true or false, got {self.escape_people!r}")
        for name, top in (
            ("blind_memory_s", 60.0),
            ("people_cuts_m", 10.0),
            ("ghost_people_s", 600.0),
            ("back_guard_mps", 5.0),
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= top:
                raise ValueError(f"HospitalAgentConfig.{name} must be a number in [0, {top:g}], got {value!r}")
        if self.people_cuts_m > 0.0 and self.blind_memory_s <= 0.0:
            raise ValueError(
                "HospitalAgentConfig.people_cuts_m needs blind_memory_s > 0 (the scans that vouch for free space)"
            )
