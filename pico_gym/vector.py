"""N robots in one process: pico-gym's vector env (`gymnasium.make_vec(..., vectorization_mode="vector_entry_point")`).

`PicoVectorEnv` holds N pico-gym envs and steps them together. PicoEscape-v0 robots step in one
compiled call for all of them (`pico_gym.batched.EscapeBatch`: motion, scan, the task's verdict
and the info values, with the robots' state kept in arrays; a step the physics must take, an
episode's end and a reset go through the robot's own env). Other robots step env by env: each
robot's action, physics and odometry (`PicoEnv.begin_step`), then the scans of every robot whose scene
is a plain segment array in one compiled call (cast and noise; robots on large maps or with movers
scan on their own), then each task's verdict (`PicoEnv.finish_step`). Infos are batched per key as
gymnasium's `SyncVectorEnv` batches them (a value array and a `_key` mask per key, nested dicts
alike), built once per step rather than env by env. `envs` hands out the robots' own envs, brought
up to date first.

Same seeds, same episodes: sub-env i is an ordinary env seeded as `SyncVectorEnv` seeds it
(`seed + i`), every random draw still comes from its own `np_random`, and the scan of a robot is
the one its own env would compute, so observations, rewards, terminations and infos equal those of
`gymnasium.make_vec(..., vectorization_mode="sync")` bit for bit (tested). Autoreset follows
gymnasium's modes: NEXT_STEP (the default, as `SyncVectorEnv`) or SAME_STEP (the final observation
and info in `info["final_obs"]`, `info["final_info"]`; what Stable-Baselines3's `VecEnv` expects).

It steps each robot through the step's declared parts (`PicoEnv.begin_step`, `take_scan`,
`finish_step`) and reads what the single step hands its LRF (`PicoEnv.scan_inputs`) and the LRF's
kept constants (`Lrf.beams`, `reading`), so that a scan in the batch is the scan the env itself
would take.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import partial
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from pico_gym.batched import N_INFO, REASONS, REWARD_TERMS, EscapeBatch, escape_infos
from pico_gym.envs.base import _NO_EXTRAS, pico_env
from pico_gym.jit import njit
from pico_gym.sensors.lrf import _cast, _noisy
from pico_gym.tasks.escape import EscapeTask
from pico_gym.types import FloatArray, Segments

Obs = dict[str, np.ndarray]
Finals = dict[int, tuple[Obs, dict[str, Any]]]  # robot -> (final observation, final info)


@njit
def _scan_batch(
    rows: np.ndarray,
    poses: FloatArray,
    segments: Segments,
    bounds: np.ndarray,
    flags: np.ndarray,
    beam_angles: FloatArray,
    beam_cos: FloatArray,
    beam_sin: FloatArray,
    units: FloatArray,
    reading: tuple[float, float, float, float],
    exact: FloatArray,
    out: np.ndarray,
) -> None:
    """The scans of robots rows[j] at poses[j] into out[rows[j]]: each robot's own segments are
    segments[bounds[i, 0]:bounds[i, 1]] with back-face flags flags[bounds[i, 2]:bounds[i, 3]]
    (empty: none), as `Lrf.scan` casts and adds noise for one."""
    noise, rmin, rmax, no_hit = reading
    for j in range(rows.shape[0]):
        i = rows[j]
        _cast(
            poses[j, 0],
            poses[j, 1],
            poses[j, 2],
            segments[bounds[i, 0] : bounds[i, 1]],
            beam_angles,
            beam_cos,
            beam_sin,
            rmax,
            exact,
            True,
            flags[bounds[i, 2] : bounds[i, 3]],
        )
        _noisy(exact, units[i], noise, rmin, rmax, no_hit, out[i])


class PicoVectorEnv(VectorEnv):
    """`num_envs` copies of a pico-gym env stepped together in one process.

    Args:
        env_id: a pico-gym env id ("PicoEscape-v0", "PicoHospital-v0", "PicoExplore-v0").
        num_envs: how many robots.
        autoreset_mode: gymnasium's `AutoresetMode` (or its value): NEXT_STEP or SAME_STEP.
        **kwargs: the options every sub-env is made with (as `gymnasium.make(env_id, **kwargs)`).
    """

    def __init__(
        self,
        env_id: str,
        num_envs: int,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        **kwargs: Any,
    ) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise ValueError(f"autoreset_mode must be 'NextStep' or 'SameStep', got {autoreset_mode!r}") from None
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(f"autoreset_mode must be 'NextStep' or 'SameStep', got {autoreset_mode!r}")
        kwargs.pop("max_episode_steps", None)  # gymnasium passes the spec's (None: pico-gym envs time out themselves)
        self._envs = [pico_env(gym.make(env_id, **kwargs)) for _ in range(num_envs)]
        first = self._envs[0]
        self.num_envs = num_envs
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.render_mode = first.render_mode
        self.metadata = dict(first.metadata, autoreset_mode=mode)
        self.autoreset_mode = mode
        self._autoreset = np.zeros(num_envs, dtype=np.bool_)
        lrf = first.lrf
        self._lrf = lrf
        self._units = np.empty((num_envs, lrf.config.n_beams))
        if not lrf.draws_noise:
            self._units.fill(0.5)
        self._exact = np.empty(lrf.config.n_beams)
        self._scenes: list[Any] = [None] * num_envs  # the static segments the batch arrays were built from
        self._bounds = np.zeros((num_envs, 4), dtype=np.int64)
        self._segments = np.zeros((0, 4))
        self._flags = np.zeros(0, dtype=np.bool_)
        self._batchable = [False] * num_envs  # scanned in the batch call (a plain segment array, no movers)
        # Escape robots step in one compiled call (`pico_gym.batched`).
        self._batch = (
            EscapeBatch(self._envs) if isinstance(first.task, EscapeTask) and first.n_action_extras == 0 else None
        )
        self._all = np.arange(num_envs)
        self._batch_shape = (num_envs, 3)

    @property
    def batch_steps(self) -> int:
        """Robot steps taken in the compiled escape batch so far (0 for robots it cannot take)."""
        return self._batch.stepped if self._batch is not None else 0

    @property
    def envs(self) -> list[Any]:
        """The robots' own envs, up to date (what the batch holds for them is handed back first)."""
        self._hand_back()
        return self._envs

    def _hand_back(self) -> None:
        """Bring every robot's env up to date from the batch's rows."""
        if self._batch is not None:
            for i in range(self.num_envs):
                self._batch.sync_out(i)

    # --- the batch's scene arrays ----------------------------------------------------------
    def _refresh_scenes(self) -> None:
        """Rebuild the joined segment arrays when a robot's static scene changed (a reset, or a
        task's new scene)."""
        seen = [env.scan_inputs()[1] for env in self._envs]
        if all(a is b for a, b in zip(seen, self._scenes, strict=True)):
            return
        self._scenes = seen
        segments: list[np.ndarray] = []
        flags: list[np.ndarray] = []
        n_seg = n_flag = 0
        for i, env in enumerate(self._envs):
            _, static, movers, one_sided = env.scan_inputs()
            ok = isinstance(static, np.ndarray) and movers is None
            self._batchable[i] = ok
            if not ok:
                self._bounds[i] = (n_seg, n_seg, n_flag, n_flag)
                continue
            k = 0 if one_sided is None else len(one_sided)
            self._bounds[i] = (n_seg, n_seg + len(static), n_flag, n_flag + k)
            segments.append(static)
            if one_sided is not None and k:
                flags.append(one_sided)
            n_seg += len(static)
            n_flag += k
        self._segments = np.ascontiguousarray(np.concatenate(segments)) if segments else np.zeros((0, 4))
        self._flags = np.ascontiguousarray(np.concatenate(flags), dtype=np.bool_) if flags else np.zeros(0, np.bool_)

    def _scan(self, stepped: list[int], out: np.ndarray) -> None:
        """The scans of the robots just stepped, into their rows of `out` (and into each env)."""
        self._refresh_scenes()
        envs, batchable = self._envs, self._batchable
        batch = [i for i in stepped if batchable[i]]
        lrf = self._lrf
        if batch:
            if lrf.draws_noise:
                units = self._units
                for i in batch:
                    envs[i].np_random.random(out=units[i])  # the draws its own scan would take
            _scan_batch(
                np.array(batch, dtype=np.int64), np.array([envs[i].scan_inputs()[0] for i in batch]), self._segments,
                self._bounds, self._flags, *lrf.beams, self._units, lrf.reading,
                self._exact, out,
            )  # fmt: skip
        for i in stepped:
            env = envs[i]
            if not batchable[i]:
                out[i] = env.lrf.scan(*_scan_args(env), env.np_random, *_scan_extras(env))
            env.take_scan(out[i])

    # --- the VectorEnv interface -----------------------------------------------------------
    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Reset the robots (all, or those of `options["reset_mask"]`); seeds as `SyncVectorEnv`."""
        obs, infos = self.reset_each(seed=seed, options=options)
        return obs, self._batch_infos(infos)

    def reset_each(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], list[dict[str, Any] | None]]:
        """`reset` with each robot's info as its own dict (None for a robot the mask left alone)."""
        n = self.num_envs
        if seed is None:
            seeds: list[int | None] = [None] * n
        elif isinstance(seed, int):
            seeds = [seed + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ValueError(f"seed: a list of {n} seeds (one per env) is needed, got {len(seeds)}")
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        if mask is not None:
            if not (isinstance(mask, np.ndarray) and mask.dtype == np.bool_ and mask.shape == (n,)):
                raise ValueError(f"options['reset_mask'] must be a bool array of shape ({n},), got {mask!r}")
            if not mask.any():
                raise ValueError("options['reset_mask'] must reset at least one env")
        which = range(n) if mask is None else np.flatnonzero(mask).tolist()
        infos: list[dict[str, Any] | None] = [None] * n
        envs = self.envs
        for i in which:
            _, infos[i] = envs[i].reset(seed=seeds[i], options=options or None)
            self._autoreset[i] = False
        return self._observations(), infos

    def autoreset_seed(self, i: int) -> int | None:
        """The seed robot i's next autoreset passes to its env's `reset` (None: its generator goes
        on, as gymnasium's vector envs do). A subclass may hand each episode its own seed."""
        return None

    def step_finals(self, actions: np.ndarray) -> tuple[Obs, np.ndarray, np.ndarray, np.ndarray, Finals]:
        """`step` in SAME_STEP mode for a learner that reads only the infos of the episodes that
        ended: observations, rewards, terminations, truncations and {robot: (final observation,
        final info)}, without the step's batched infos (what they cost is saved)."""
        if self.autoreset_mode != AutoresetMode.SAME_STEP:
            raise ValueError("step_finals needs autoreset_mode SAME_STEP (the final observations it returns)")
        actions = np.asarray(actions)
        if self._batch is not None and actions.shape == self._batch_shape and math.isfinite(actions.sum()):
            obs, rewards, terminated, truncated, _, final = self._step_batch(actions, with_infos=False)
        else:
            obs, rewards, terminated, truncated, _, final = self.step_each(actions)
        return obs, rewards, terminated, truncated, final

    def step(
        self, actions: np.ndarray
    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every robot with its row of `actions` (an (num_envs, action size) array)."""
        actions = np.asarray(actions)
        if self._batch is not None and actions.shape == self._batch_shape and math.isfinite(actions.sum()):
            obs, rewards, terminated, truncated, batched, final = self._step_batch(actions)
        else:
            obs, rewards, terminated, truncated, infos, final = self.step_each(actions)
            batched = self._batch_infos(infos)
        if final:
            n = self.num_envs
            objects = np.full(n, None, dtype=object)
            final_infos: list[dict[str, Any] | None] = [None] * n
            for i, (final_obs, final_info) in final.items():
                objects[i], final_infos[i] = final_obs, final_info
            mask = np.zeros(n, dtype=np.bool_)
            mask[list(final)] = True
            batched["final_obs"], batched["_final_obs"] = objects, mask
            batched["final_info"], batched["_final_info"] = self._batch_infos(final_infos), mask.copy()
        return obs, rewards, terminated, truncated, batched

    def _step_batch(
        self, actions: np.ndarray, with_infos: bool = True
    ) -> tuple[Obs, np.ndarray, np.ndarray, np.ndarray, dict[str, Any], Finals]:
        """`step` with the escape robots in one compiled call (`pico_gym.batched`); robots the
        batch does not take, and steps it hands back (a possible contact), go through their envs.
        `with_infos=False`: the batched infos are left out (an empty dict)."""
        n = self.num_envs
        batch, envs = self._batch, self._envs
        assert batch is not None
        rewards = np.zeros(n)
        terminated = np.zeros(n, dtype=np.bool_)
        truncated = np.zeros(n, dtype=np.bool_)
        scans = np.empty((n, self._lrf.config.n_beams), dtype=np.float32)
        odom = np.empty((n, 3), dtype=np.float32)
        values = np.zeros((N_INFO, n))  # the kernel's info values: one row per value
        patches: dict[int, dict[str, Any]] = {}
        next_step = self.autoreset_mode == AutoresetMode.NEXT_STEP
        others: list[int]
        # (count_nonzero: a fifth of what any() and all() cost on arrays this small)
        everyone = not np.count_nonzero(self._autoreset) and np.count_nonzero(batch.live) == n
        if everyone:
            rows, others = self._all, []  # the common step: every robot in the batch
        else:
            rows, others = self._rows_to_batch(scans, odom, patches, next_step)
        final: Finals = {}
        ends = batch.ends
        events: list[int] = []
        if len(rows):
            batch.prepare(rows, everyone)
            if batch.step(rows, actions, scans, odom, values, rewards, terminated, truncated):
                events = np.flatnonzero(ends[:, 0] | ends[:, 1]).tolist()
        else:
            ends[:] = 0
        if others:
            ends[others] = 0  # not stepped by the batch: no verdict of its (a row may hold an old one)
        for i in events + others:
            env = envs[i]
            self._finish_outside(i, actions, scans, odom, values, rewards, terminated, truncated, patches)
            if (terminated[i] or truncated[i]) and not next_step:
                final[i] = ({"lrf": scans[i].copy(), "odom": odom[i].copy()}, patches[i])
                obs, patches[i] = env.reset(seed=self.autoreset_seed(i))
                scans[i], odom[i] = obs["lrf"], obs["odom"]
            elif terminated[i] or truncated[i]:
                self._autoreset[i] = True
            batch.sync_in(i)
        if not with_infos:
            return {"lrf": scans, "odom": odom}, rewards, terminated, truncated, {}, final
        batched = escape_infos(values, ends, batch, patches)
        if batched is None:  # some robot's info has other keys: batch every robot's own
            kernel = escape_infos(values, ends, batch, {})
            assert kernel is not None
            batched = self._batch_infos([patches[i] if i in patches else _row(kernel, i) for i in range(n)])
        return {"lrf": scans, "odom": odom}, rewards, terminated, truncated, batched, final

    def _rows_to_batch(
        self, scans: np.ndarray, odom: np.ndarray, patches: dict[int, dict[str, Any]], next_step: bool
    ) -> tuple[np.ndarray, list[int]]:
        """Before a step where not every robot is the batch's: resets the robots this step resets
        (NEXT_STEP mode), brings rows up to their envs; (rows the batch steps, robots it does not)."""
        batch, envs = self._batch, self._envs
        assert batch is not None
        n = self.num_envs
        stepping = np.ones(n, dtype=np.bool_)
        others: list[int] = []
        for i in range(n):
            if next_step and self._autoreset[i]:  # this step resets it (and steps it not)
                obs, patches[i] = envs[i].reset(seed=self.autoreset_seed(i))
                scans[i], odom[i] = obs["lrf"], obs["odom"]
                self._autoreset[i] = False
                batch.sync_in(i)
                stepping[i] = False
                continue
            batch.sync_in(i)  # (if its env is ahead of its row)
            if not batch.live[i]:
                others.append(i)
        return np.flatnonzero(batch.live & stepping), others

    def _finish_outside(
        self,
        i: int,
        actions: np.ndarray,
        scans: np.ndarray,
        odom: np.ndarray,
        values: np.ndarray,
        rewards: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        patches: dict[int, dict[str, Any]],
    ) -> None:
        """Robot i's step where the batch did not finish it: an episode the batch ended, a
        possible contact (the physics steps it, in the robot's own env), or a robot not the batch's."""
        batch = self._batch
        assert batch is not None
        env = self._envs[i]
        ends = batch.ends
        code = int(ends[i, 0])
        if code > 0 or ends[i, 1]:  # the episode ended in the batch
            batch.sync_out(i)
            terms = dict(zip(REWARD_TERMS, values[10:16, i].tolist(), strict=True))
            reason = REASONS[code] if code > 0 else None
            reason = "timeout" if reason is None else reason
            patches[i] = env.end_stepped_elsewhere(terms, reason, bool(ends[i, 2]), float(values[16, i]))
            return
        if code < 0:  # a contact is possible: the physics steps it, in the robot's own env
            batch.sync_out(i)
            moved = env.apply_motion(tuple(batch.motions[i].tolist()), _NO_EXTRAS)
            scans[i] = env.lrf.read(*_scan_args(env), batch.unit_row(i), *_scan_extras(env))
            ends[i] = 0
        else:  # not the batch's: as `step_each` steps it
            moved = env.begin_step(actions[i])
            scans[i] = env.lrf.scan(*_scan_args(env), env.np_random, *_scan_extras(env))
        env.take_scan(scans[i])
        obs, rewards[i], terminated[i], truncated[i], patches[i] = env.finish_step(moved)
        odom[i] = obs["odom"]

    def step_each(
        self, actions: np.ndarray
    ) -> tuple[Obs, np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]], Finals]:
        """`step` with each robot's info as its own dict (what Stable-Baselines3's VecEnv hands
        on), and, in SAME_STEP mode, {robot: (final observation, final info)} of the episodes
        that ended (the batch holds the next episode's first observation)."""
        actions = np.asarray(actions)
        n = self.num_envs
        if actions.shape[:1] != (n,):
            raise ValueError(f"actions must have one row per env: shape ({n}, ...), got {actions.shape}")
        rewards = np.zeros(n)
        terminated = np.zeros(n, dtype=np.bool_)
        truncated = np.zeros(n, dtype=np.bool_)
        infos: list[Any] = [None] * n
        scans = np.empty((n, self._lrf.config.n_beams), dtype=np.float32)
        stepped, moves = [], []
        next_step = self.autoreset_mode == AutoresetMode.NEXT_STEP
        for i, env in enumerate(self.envs):
            if next_step and self._autoreset[i]:
                obs, infos[i] = env.reset(seed=self.autoreset_seed(i))
                scans[i] = obs["lrf"]
                self._autoreset[i] = False
                continue
            stepped.append(i)
            moves.append(env.begin_step(actions[i]))
        self._scan(stepped, scans)
        final: Finals = {}
        for i, moved in zip(stepped, moves, strict=True):
            env = self._envs[i]
            obs, rewards[i], terminated[i], truncated[i], infos[i] = env.finish_step(moved)
            if terminated[i] or truncated[i]:
                if next_step:
                    self._autoreset[i] = True
                else:
                    # (its scan is a row of the batch, which the reset's scan overwrites)
                    final[i] = ({**obs, "lrf": obs["lrf"].copy()}, infos[i])
                    obs, infos[i] = env.reset(seed=self.autoreset_seed(i))
                    scans[i] = obs["lrf"]
        return {"lrf": scans, "odom": self._odometry()}, rewards, terminated, truncated, infos, final

    def _observations(self) -> dict[str, np.ndarray]:
        return {"lrf": np.stack([env.last_scan for env in self._envs]), "odom": self._odometry()}

    def _odometry(self) -> np.ndarray:
        return np.array([env.odometry.pose for env in self._envs], dtype=np.float32)

    def _batch_infos(self, infos: Sequence[dict[str, Any] | None]) -> dict[str, Any]:
        """Per key, one array over the envs and a `_key` mask of the envs that have it: what
        `VectorEnv._add_info` builds env by env, built key by key. Arrays whose shape differs
        between envs (the hospital's `movers`, one row per person) go in an object array, where
        `_add_info` fails."""
        n = self.num_envs
        first_info = infos[0]
        if first_info is not None and all(info is not None and info.keys() == first_info.keys() for info in infos):
            return self._batch_alike(infos)  # type: ignore[arg-type]
        keys: dict[str, None] = {}
        for info in infos:
            if info:
                keys.update(dict.fromkeys(info))
        out: dict[str, Any] = {}
        for key in keys:
            present = [i for i, info in enumerate(infos) if info is not None and key in info]
            values = [infos[i][key] for i in present]  # type: ignore[index]
            first = values[0]
            if isinstance(first, dict):
                nested: list[dict[str, Any] | None] = [None] * n
                for i, value in zip(present, values, strict=True):
                    nested[i] = value
                array: Any = self._batch_infos(nested)
            else:
                if type(first) in (int, float, bool) or isinstance(first, np.number):
                    array = np.zeros(n, dtype=type(first))
                elif isinstance(first, np.ndarray) and all(
                    isinstance(v, np.ndarray) and v.shape == first.shape for v in values
                ):
                    array = np.zeros((n, *first.shape), dtype=first.dtype)
                else:
                    array = np.full(n, None, dtype=object)
                if array.ndim == 1 and array.dtype != object:
                    array[present] = values  # scalars: one assignment
                else:
                    for i, value in zip(present, values, strict=True):
                        array[i] = value  # as gymnasium assigns (broadcasting included)
            mask = np.zeros(n, dtype=np.bool_)
            mask[present] = True
            out[key], out[f"_{key}"] = array, mask
        return out

    def _batch_alike(self, infos: list[dict[str, Any]]) -> dict[str, Any]:
        """`_batch_infos` when every env has the same keys (the common step): no masks to work out."""
        n = self.num_envs
        everyone = np.ones(n, dtype=np.bool_)
        out: dict[str, Any] = {}
        for key, first in infos[0].items():
            values = [info[key] for info in infos]
            if isinstance(first, dict):
                array: Any = self._batch_infos(values)
            elif type(first) in (int, float, bool) or isinstance(first, np.number):
                array = np.array(values, dtype=type(first))
            elif isinstance(first, np.ndarray) and all(
                isinstance(v, np.ndarray) and v.shape == first.shape for v in values
            ):
                array = np.empty((n, *first.shape), dtype=first.dtype)
                array[:] = values
            else:
                array = np.empty(n, dtype=object)
                for i, value in enumerate(values):
                    array[i] = value
            out[key], out[f"_{key}"] = array, everyone.copy()
        return out

    def render(self) -> tuple[Any, ...] | None:
        """Each robot's frame (as `SyncVectorEnv.render`)."""
        return tuple(env.render() for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        for env in self._envs:
            env.close()


def _scan_args(env: Any) -> tuple[Any, Any]:
    """The pose and static geometry a robot's scan reads (`PicoEnv.scan_inputs`)."""
    pose, seen, _, _ = env.scan_inputs()
    return pose, seen


def _scan_extras(env: Any) -> tuple[Any, Any]:
    """The movers and one-sided flags a robot's scan reads (`PicoEnv.scan_inputs`)."""
    _, _, movers, one_sided = env.scan_inputs()
    return movers, one_sided


def _row(batched: dict[str, Any], i: int) -> dict[str, Any]:
    """Robot i's own info dict from batched infos (the values as an env hands them out)."""
    row: dict[str, Any] = {}
    for key, value in batched.items():
        if key.startswith("_"):
            continue
        if isinstance(value, dict):
            row[key] = _row(value, i)
        elif value.ndim > 1:
            row[key] = value[i].copy()
        else:
            item = value[i]
            row[key] = item.item() if isinstance(item, np.generic) else item
    return row


# The creators `gymnasium.make_vec` calls (registered by name, so that specs pickle):
# creator(num_envs=..., **options).
escape_vector_env = partial(PicoVectorEnv, "PicoEscape-v0")
hospital_vector_env = partial(PicoVectorEnv, "PicoHospital-v0")
explore_vector_env = partial(PicoVectorEnv, "PicoExplore-v0")
