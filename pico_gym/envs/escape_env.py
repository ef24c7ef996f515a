"""PicoEscape-v0: escape an unknown room through its corridor."""

from __future__ import annotations

from pico_gym.envs.base import EnvConfig, PicoMapEnv
from pico_gym.tasks.escape import FAMILIES, EscapeTask, EscapeTaskConfig
from pico_gym.world.map import Map


class PicoEscapeEnv(PicoMapEnv):
    """The escape-room challenge of TU/e's Embedded Motion Control course.

    ## Description
    PICO, a holonomic robot with a 1000-beam laser range finder and drifting wheel odometry,
    starts somewhere in a rectangular room it has never seen, not necessarily facing the exit. It
    must leave through the one corridor (0.5-1.5 m wide, perpendicular to a wall, possibly flush
    with a room corner) and cross the finish line more than 3 m down the corridor, without bumping
    into anything. Without a fixed map every reset draws a new room from `self.np_random`.

    ## Observation Space
    `Dict`:

    | key  | shape        | meaning                                   | bounds              |
    |------|--------------|-------------------------------------------|---------------------|
    | lrf  | (n_beams,)   | ranges, metres; beam 0 at -2 rad (right)  | [0, range_max_m]    |
    | odom | (3,)         | x [m], y [m], theta [rad], odometry frame | theta in [-pi, pi]  |

    A beam that hits nothing reads range_max_m (`no_hit="zero"` gives the PICO-era 0). Odometry
    starts at (0, 0, 0) (`random_start=True`: a random pose) and drifts.

    ## Action Space
    `Box([-0.5, -0.5, -1.2], [0.5, 0.5, 1.2])`: body-frame twist (vx [m/s], vy [m/s], w [rad/s]).
    Values outside are clipped and (vx, vy) is scaled to a norm of at most 0.5 m/s (the
    competition's rule). A NaN or infinite component raises ValueError naming it.

    ## Rewards
    A sum of named terms, each weighted (`rewards=` / `RewardWeights`) and reported in
    `info["reward_terms"]`: `progress` (metres of decrease of the geodesic distance to the finish
    line, weight 1), `success` (10 on escape), `bump` (-10 per bump), `time` (-0.1 per second),
    `proximity` (off by default: with weight k, -k per second times max(0, 1 - clearance /
    proximity_m), a dense warning before a bump), and `approach` (off by default: with weight k,
    k times the step's change of max(0, 1 - clearance / approach_m), negative while closing in on
    a wall; potential-based shaping, so it cannot be farmed and does not tax a corridor).
    The geodesic field is computed once per reset from the true map; it shapes the reward only.

    ## Starting State
    Uniform over the free room with at least `start_clearance_m` (0.05 m) between footprint and
    walls, any heading; only poses from which the robot can reach the exit are used. A fixed map
    uses its `start_pose`, else its `start_area`; `reset(options={"start_pose": (x, y, theta)})`
    overrides both.

    ## Episode End
    Terminated: `escaped` (the whole footprint past the finish line), `bump` (first bump, with
    `collision="terminate"`, the default; `"continue"` counts and goes on), `idle` (30 s of true
    speed below `idle_speed_mps` and turn rate below `idle_turn_rate_radps`). Truncated:
    `timeout` at 300 s of simulated time. `info["termination_reason"]` says which.

    ## Info
    `pose` (true x, y, theta, map frame), `odom_error` (odometry minus truth in the odometry
    frame), `bumps`, `clearance` and `min_clearance` (footprint to nearest wall now / over the
    episode, metres, capped at 2 m), `sim_time`, `path_length`, `geodesic_to_finish`,
    `shortest_path_length` (the oracle's path length from the start, for SPL/SCT), `is_success`,
    `termination_reason` (None until the end), `reward_terms`.

    ## Arguments
    `gym.make("PicoEscape-v0", map=None, map_path=None, config=None, render_mode=None, **options)`:
    `map` names a shipped map (`pico-gym maps`), `map_path` a map file (JSON or heightmap image);
    `config` is an `EnvConfig`; any field of it or of its parts can be given by name, e.g.
    `n_beams=64`, `collision="continue"`, `dt_s=0.05`, `noise_m=0.02`, `slip_std=0.05`,
    `n_obstacles=3`, `rewards={"time": 0.2}`.

    ## Notes
    The time limit is enforced by the env on simulated time (300 s whatever `dt_s` is), so the
    registered spec has no `max_episode_steps`. A bump is the footprint coming within the 1 cm
    contact skin of something (see `PhysicsConfig.contact_skin_m`).

    `reset(options=...)` accepts `start_pose` only; an unknown key raises ValueError.
    Stepping an episode that has ended raises RuntimeError (call reset).

    ## Families
    `gym.make("PicoEscape-v0", family=NAME)` draws from a harder generator setting (options given
    explicitly still win): `"cluttered"`, rooms with 3-5 boxes; `"narrow"`, corridors 0.5-0.6 m
    wide. Each is a suite of `pico-gym bench` and `compare` with fixed dev and test seeds
    (docs/benchmarks.md).

    ## Version History
    - v0: initial version; `family=` added (default episodes unchanged).
    """

    env_id = "PicoEscape-v0"
    task_config = EscapeTaskConfig
    families = FAMILIES

    @classmethod
    def make_task(cls, config: EnvConfig, fixed: Map | None) -> EscapeTask:
        return EscapeTask(config.task, config.robot, fixed)
