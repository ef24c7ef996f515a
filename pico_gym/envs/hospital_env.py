"""PicoHospital-v0: visit cabinets in a given order on a given map."""

from __future__ import annotations

from typing import Any

from pico_gym.envs.base import EnvConfig, PicoMapEnv
from pico_gym.tasks.hospital import FAMILIES, HospitalTask, HospitalTaskConfig, HospitalTaskSpec
from pico_gym.world.map import Map


class PicoHospitalEnv(PicoMapEnv):
    """The hospital challenge (2019-2021) of TU/e's Embedded Motion Control course.

    ## Description
    PICO is given the hospital's map and starts somewhere in a 1 x 1 m start area with an unknown
    heading; its odometry starts at (0, 0, 0), so it must localise itself on the map. It must
    visit cabinets in a given order, standing in front of each (its centre in the square in front
    of the cabinet's front, side = the front's length) and facing it, while some doors turn out to
    be closed, boxes that are not on the map stand in the way and people walk through the building.
    Without a map every reset draws a new hospital (2019 rules, `pico_gym.world.hospital`).

    ## What the agent is given (public)
    At reset, `info["task"]` (also `env.unwrapped.task_spec`) is a frozen `HospitalTaskSpec` with
    exactly what the course gave the teams: `map` (a `Map`: walls, cabinets with their fronts
    first and numbered by index, the start area, and `doors` = the door openings, indexed as
    `closed_doors` indexes them), `cabinet_order` (a tuple), the arrival rule (`arrival`,
    `dwell_s`, `facing_tolerance_rad`) and the limits (`time_limit_s`, `idle_time_s`). The given
    map never contains the episode's closed doors, boxes or movers. Every other `info` key is
    privileged: for metrics and rewards, never an agent's input.

    ## Observation Space
    As PicoEscape-v0: `Dict(lrf=Box(0, range_max_m, (n_beams,)), odom=Box(3))`, so an escape
    agent's sensor code works unchanged. The LRF sees walls, cabinets, closed doors, boxes and
    movers (0.3 m above the floor; heightmap obstacles lower than that are solid but unseen).

    ## Action Space
    `arrival="dwell"` (default): the body-frame twist `Box([-0.5, -0.5, -1.2], [0.5, 0.5, 1.2])`,
    clipped and capped at 0.5 m/s as in escape. `arrival="announce"`: a fourth component in
    [-1, 1]; a positive value announces arrival (the course's `io.speak`). A NaN or infinite
    component raises ValueError naming it.

    ## Rewards
    Named terms (`info["reward_terms"]`, weights `rewards=`): `progress` (metres of decrease of the
    geodesic distance to the next arrival square; one field per target, computed at reset on the
    true static world with the episode's closed doors and boxes), `cabinet` (+10 per cabinet
    counted), `bump` (-10 per bump), `time` (-0.1 per second), `false_announce` (-1 each), and
    `facing` (weight 0 by default: potential-based shaping of turning to face the cabinet while
    in its square, see `HospitalRewardWeights`). `info["cost"]` (Safety Gym's convention): 1 per
    bump plus 1 per second within 0.1 m of anything.

    ## Arrival
    The robot's centre in the cabinet's arrival square and its heading within
    `facing_tolerance_rad` (0.26 rad) of facing the front. With `arrival="dwell"` a cabinet counts
    once the robot has stood there nearly still (true speed < `dwell_speed_mps`, turn rate <
    `dwell_turn_rate_radps`) for `dwell_s` (0.5 s); with "announce", when it announces there. An
    announcement anywhere else is a false announcement (counted in `info["false_announcements"]`;
    `false_announcement="terminate"` also ends the episode). Cabinets count only in order.

    ## Starting State
    Uniform in the map's start area with any heading and at least `start_clearance_m` (0.05 m)
    footprint clearance. `reset(options=...)`: `cabinet_order` (cabinet indices), `closed_doors`
    (door indices; `[]` = all open), `start_pose` (x, y, theta). Without them the episode draws
    from the seed: an order of `n_cabinets` (3) cabinets, `n_closed_doors` (0-1) closed doors (never
    one that cuts the start or a target off; an explicit `closed_doors` that does is refused with
    an error naming the door), `n_boxes` (0-2) boxes of 0.2-0.6 m (never in a doorway, on an
    arrival square, in the start area or in a wall, never cutting a target off), the map's movers,
    or `n_movers` (0-1) walking people when the map has none. Unknown option keys are refused.

    ## Movers
    Exactly the course simulator's moving objects (`pico_gym.world.movers`): they start when the
    robot comes within `trigger_radius`, pause while it is within half their diagonal + 0.3 m,
    ping-pong when `repeat`. Seen by the LRF, solid, their contacts counted as `mover` bumps.

    ## Episode End
    Terminated: `done` (every cabinet of the order counted, success), `bump` (with
    `collision="terminate"`, the default), `false_announcement` (if so configured), `idle` (30 s
    standing still). Truncated: `timeout` at `time_limit_s` = 600 s of simulated time. No official
    hospital time limit was found; 600 s is the 10 minutes of a 2019 team's requirements
    (docs/facts/hospital-facts.md 1.9). Stepping an ended episode raises RuntimeError.

    ## Info (privileged)
    `pose`, `cabinets_done` (count, in order), `next_cabinet` (its index, None when done),
    `is_success`, `termination_reason`, `bumps`, `bumps_by_kind` (wall, cabinet, door, box, mover),
    `sim_time`, `path_length`, `shortest_path_length` (the oracle's chain start -> c1 -> ... -> cn
    through the arrival squares), `geodesic_to_next`, `clearance`, `min_clearance`,
    `false_announcements`, `movers` ((n, 3) true poses), `arrival` (the predicate's parts for the
    next cabinet: `in_square`, `distance_to_square`, `heading_error`), `dwell_s`, `odom_error`,
    `reward_terms`, `cost`; at reset also `task` (public, above).

    ## Arguments
    `gym.make("PicoHospital-v0", map=None, map_path=None, config=None, render_mode=None, **options)`:
    `map` names a shipped map (`pico-gym maps`), `map_path` a map file; any config field by name,
    e.g. `n_cabinets=4`, `n_boxes=(2, 2)`, `n_closed_doors=(1, 1)`, `n_movers=(1, 1)`,
    `arrival="announce"`, `noise_m=0.02`, `random_start=True` (odometry at a random pose).

    ## Families
    `gym.make("PicoHospital-v0", family=NAME)`: `"narrow"`, a hallway 1.0-1.2 m and doors
    0.55-0.7 m wide with 1-2 people walking the hallway towards the start; `"crowded"`, 2-3 people
    and 2-3 boxes. Each is a suite of `pico-gym bench` and `compare` with fixed dev and test
    seeds (docs/benchmarks.md). The counts an episode draws (people, boxes, closed doors) are met:
    a generated hospital that cannot hold them is drawn again, and on a fixed map a request that
    cannot be met after 20 draws raises ValueError naming the option.

    ## Version History
    - v0: initial version; `family=` added; `n_closed_doors` names the count (`closed_doors`
      stays the reset option's list); counts drawn are met or refused, which redrew the ~3 % of
      default generated-hospital episodes that used to get fewer people, boxes or doors than drawn.
    """

    env_id = "PicoHospital-v0"
    task_config = HospitalTaskConfig
    families = FAMILIES

    @classmethod
    def check_options(cls, options: dict[str, Any]) -> None:
        if "closed_doors" in options:
            raise TypeError(
                "closed_doors is a reset option naming the doors to close (reset(options={'closed_doors': [1]})); "
                f"the number of doors drawn closed per episode is n_closed_doors=(lo, hi), got closed_doors="
                f"{options['closed_doors']!r}"
            )

    @classmethod
    def make_task(cls, config: EnvConfig, fixed: Map | None) -> HospitalTask:
        return HospitalTask(config.task, config.robot, fixed)

    @property
    def task_spec(self) -> HospitalTaskSpec:
        """What the agent is given for the current episode (public)."""
        if self.episode is None:
            raise RuntimeError("call reset() first: the task (order, closed doors) is drawn per episode")
        return self.episode.public
