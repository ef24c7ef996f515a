"""The classic explore agent's settings (SI units; times in seconds, turned into steps with the
control period). How each default was measured is in docs/agents/classic-explore.md."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ExploreAgentConfig:
    """Settings of the classic explore agent.

    Attributes:
        cell_m: the occupancy grid's cell [m]; plan_cell_m: the planning grid's (2 x 2 cells).
        size_m: the side of the square the occupancy grid covers, centred on the start [m]: a
            2018 building fits with room to spare whichever way it lies.
        map_range_m: beams mark free space up to this range [m]; farther, the pose's angular
            error smears the map.
        beam_stride: every this-many-th beam updates the map (a third keeps a step under 1 ms).
        hit, miss, clamp: log-odds added at an end point, along a beam, and their bound.
        occupied, free: log-odds above which a cell is occupied, below which it is free.
        inflate_m: cells closer than this to an occupied cell are blocked for planning [m]: the
            robot's half depth (it crosses doors sideways) plus a margin.
        comfort_m: cells closer than this cost more, so paths keep off the walls [m].
        narrow_m: where the path's clearance is below this, the robot drives sideways [m].
        cruise_mps: the speed in open space [m/s].
        frontier_min_cells: smaller frontiers are ignored unless they open into the unknown.
        replan_s: how often the plan is remade, as the map grows.
        give_up_s: a target approached by less than 0.2 m in this long is given up.
        explore_budget_s: exploring stops after this long, leaving time to park and find.
        park_standoff_m: the centre's distance to the parking wall before reversing [m].
        reverse_mps: the reversing speed [m/s]; the rule allows 0.1 m/s at contact.
        object_hits: evidence needed for an unexplained cluster to be the object.
        object_max_m: only runs of beams this short, standing free, count as evidence [m]: the
            object is small; a wall seen off its mapped place (pose drift) is a long run.
        room_join_m, room_middle_m: the room/door graph's cut (`regions.room_depths`): free
            cells farther than `room_join_m` from the walls, grouped, are a room's middle where
            the walls are `room_middle_m` away somewhere in them (a 2018 room is 2.0 m or wider,
            a hallway 1.8 m or narrower, a door 1.5 m or narrower) [m].
        stop_range_m: the final creep stops when the LRF reads this towards the object [m].
        scan_matching: correct the odometry by correlative scan-to-map matching. Off: its
            corrections random-walk the heading faster than the course's odometry drifts.
        search_align: after parking, correct the odometry's heading by the same matching against
            the map stored at parking (a finished map that no longer moves with the pose; the
            position is left alone: along a hallway it slides). On: measured on the families'
            dev splits, found-of-parked 92-97 % -> 97-100 %.
        search_align_explained: `search_align` takes a match only where the stored map explains
            at least this fraction of the scan (its score against the most the scan's points could
            score): in a room the stored map holds poorly, a gain of a few points is noise and the
            heading walked off by 10-30 deg (0: any match). 0.35: measured on the families' dev splits
            (docs/agents/classic-explore.md).
        search_retry: once the search has looked everywhere and starts again, the places it gave
            up on (no progress towards them for `give_up_s`) are tried again; without, a room
            whose door the robot once failed to pass stayed out of the search for good. On: measured
            with `search_align_explained` and `dither_s` (docs/agents/classic-explore.md).
        dither_s: exploring or searching, a robot that has stayed within 0.5 m of one spot this
            long gives its goal up [s] (0: never; `give_up_s` alone restarts with each new goal,
            and two goals taking turns held a robot in place for 8 minutes).
        creep_held_s: approaching the object, a final creep the safety filter has held still this
            long (a door jamb between) hands back to the planner, to within 0.45 m instead of
            0.6 m, and creeps again once 0.15 m nearer [s] (0: the creep waits).
        wedge_turn_s: in a doorway, held still 1 s by the filters, turn in place this long, as
            the filters let it: towards the heading the follower wants, or, where that is
            reached or refused (wedged askew between the jambs, a corner against each), the way
            that moves the nearest points off the footprint; then drive on [s] (0: off, one
            step's turn towards the heading per second held). On: measured on the families' dev
            splits, timeouts with the building explored 8 -> 2 in 340 episodes
            (docs/agents/classic-explore.md).
        safety_floor_m: the safety filter lets nothing closer to the footprint than this plus
            twice the LRF's noise, and tries a command without its turn before scaling it down
            (0: the plain filter).
        blind_memory_s: the blind sector is covered by the cells the LRF hit within this long
            (0: ever): odometry drifts over minutes, so an old hit stands where a jamb was, not
            where it is now relative to the pose.
        search_depth_m: how the search after parking orders the rooms not looked into since: the
            next is the one whose frontier is nearest by path, less this much per door on the way
            to it from the start (the course's hint: the object is in the deepest room), so the
            tour stays short and still leans deep [m]; a negative value: strictly the deepest
            first (one room at a time by door depth).
        park_more_m: when the turn to face away at the stand-off point is cut for 2 s (no room to
            turn there), the stand-off moves 0.1 m farther from the wall, up to this much [m]
            (0: off).
        park_turn_margin_m: the stand-off point keeps the footprint's circumradius plus this from
            everything mapped, so the turn to face away from the wall has room [m] (0: off).
        relocalise_park_m: on the way back to park, within this of the stand-off point, match the
            scan against the map as it was after the first look round (the parking wall and the
            hallway's end, mapped before any drift) within 1.2 m and 11 deg, and take the match:
            odometry drifts up to a metre over the minutes of a long exploration [m] (0: off).
        park_wall_from_start: refit the parking wall (and choose the stand-off's foot) on the map
            as it was after the first look round, not the map at parking time: scans of the
            hallway's end taken on the way back carry the exploration's drift, and a wall refitted
            on them tilted the reverse by up to 5 deg.
        touch_sets_heading: at the touch the heading becomes the parking wall's normal (the
            contact turns the rear flush with the wall): a corner touching first turns the robot
            without the odometry seeing it, and the search after parking then drifts by that.
        park_overrun_m: the reverse ends as touching once the odometry counts this far past the
            wall as mapped (wheels slipping against it), without waiting for the scan's evidence
            of the touch; a drifted pose reached it short of the wall [m].
        park_dock_m: on the way to park, within this of the stand-off point, and while facing
            the parking wall, put the pose at the distance from it the scan sees, and take the
            wall's direction as seen (`parking.dock`): a pose drifted 0.2-0.5 m over minutes of
            exploring stood the robot where it could not turn, or ended the reverse short of the
            wall, and the wall refitted on the drifted map tilted by up to 20 deg [m] (0: off).
            `park_dock_heading`: put the heading square to the wall as refitted instead of
            keeping it (off: the refitted wall tilts, and the search then runs on a heading off
            the map). Measured in docs/agents/classic-explore.md.
        park_settle_s: near the stand-off point (within 0.12 m) but held still this long (the
            safety filter cuts the last few centimetres: a drifted pose put the point close to
            a side wall), take where it stands as the stand-off point and turn there; and turn in
            place there (the servo's last centimetres, cut by the filter, stopped the turn too)
            [s] (0: off).
        square_gain, square_min, square_window_deg: pull the heading towards the building's axes
            (a 2018 hospital is rectilinear): where the scan's pieces of wall agree (their mean
            resultant of 4a is `square_min` or more) within `square_window_deg` of the start's
            axes, the heading moves `square_gain` of the way per step. Off (0): it straightens
            the map but did not raise the successes.
    """

    cell_m: float = 0.05
    plan_cell_m: float = 0.1
    size_m: float = 48.0
    map_range_m: float = 5.0
    beam_stride: int = 3
    hit: float = 0.9
    miss: float = 0.4
    clamp: float = 6.0
    occupied: float = 1.0
    free: float = -1.0
    inflate_m: float = 0.13
    comfort_m: float = 0.4
    narrow_m: float = 0.33
    cruise_mps: float = 0.4
    frontier_min_cells: int = 5
    replan_s: float = 1.0
    give_up_s: float = 10.0
    explore_budget_s: float = 420.0
    park_standoff_m: float = 0.4
    reverse_mps: float = 0.06
    object_hits: float = 8.0
    object_max_m: float = 0.8
    room_join_m: float = 0.92
    room_middle_m: float = 1.02
    stop_range_m: float = 0.3
    scan_matching: bool = False
    search_align: bool = True
    search_align_explained: float = 0.35
    search_retry: bool = True
    dither_s: float = 20.0
    creep_held_s: float = 3.0
    wedge_turn_s: float = 1.0
    square_gain: float = 0.0
    square_min: float = 0.6
    square_window_deg: float = 5.0
    safety_floor_m: float = 0.015
    blind_memory_s: float = 240.0
    search_depth_m: float = -1.0
    relocalise_park_m: float = 0.0
    park_turn_margin_m: float = 0.0
    park_more_m: float = 0.0
    park_wall_from_start: bool = False
    touch_sets_heading: bool = False
    park_overrun_m: float = 0.08
    park_settle_s: float = 0.0
    park_dock_m: float = 1.5
    park_dock_heading: bool = False

    def __post_init__(self) -> None:
        # (The search's settings; the older fields are not checked yet.)
        if not isinstance(self.search_retry, bool):
            raise ValueError(f"ExploreAgentConfig.search_retry must be true or false, got {self.search_retry!r}")
        for name, top in (
            ("search_align_explained", 1.0),
            ("dither_s", 600.0),
            ("creep_held_s", 60.0),
            ("wedge_turn_s", 10.0),
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= top:
                raise ValueError(f"ExploreAgentConfig.{name} must be a number in [0, {top:g}], got {value!r}")
