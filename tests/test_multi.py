"""Two robots in one world (PettingZoo ParallelEnv): the API tests, seeding, rendering, solid
robot-robot contacts, each robot's own task, and the classic agent driving both."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pettingzoo")

import pico_gym  # noqa: E402
from pico_gym.agents import make_agent  # noqa: E402
from pico_gym.multi import robot_env  # noqa: E402
from pico_gym.world.geometry import footprint_clearance, transform_points  # noqa: E402

TACO = Path(__file__).parent / "data" / "emc_simulator" / "2021_hospitalconfig_taco.json"


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (PettingZoo's API test passes a reset option of its own)
        yield


@pytest.mark.parametrize(("env_id", "options"), [("PicoHospital-v0", {"map": "hospital_2019"}), ("PicoEscape-v0", {})])
def test_pettingzoo_parallel_api_and_seed_tests(env_id: str, options: dict) -> None:
    from pettingzoo.test import parallel_api_test, parallel_seed_test

    # Both raise on a violation of the PettingZoo API or on seeds not reproducing.
    parallel_api_test(pico_gym.parallel_env(env_id, **options), num_cycles=100)
    parallel_seed_test(lambda: pico_gym.parallel_env(env_id, **options), num_cycles=60)
    env = pico_gym.parallel_env(env_id, **options)
    obs, infos = env.reset(seed=0)
    assert env.agents == ["pico", "taco"] and set(obs) == set(infos) == {"pico", "taco"}
    assert all(env.observation_space(a).contains(obs[a]) for a in env.agents)


def test_pettingzoo_render_test() -> None:
    from pettingzoo.test.render_test import render_test
    from pettingzoo.utils.conversions import parallel_to_aec

    render_test(  # raises if a render mode misbehaves
        lambda render_mode=None: parallel_to_aec(
            pico_gym.parallel_env("PicoHospital-v0", map="hospital_2019", render_mode=render_mode)
        )
    )
    env = pico_gym.parallel_env("PicoHospital-v0", map="hospital_2019", render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert isinstance(frame, np.ndarray) and frame.ndim == 3 and frame.shape[2] == 3 and frame.any()


def _rollout(seed: int, steps: int = 80) -> list[bytes]:
    env = pico_gym.parallel_env("PicoHospital-v0", map="hospital_2021", sim_config=TACO)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    out = [obs["pico"]["lrf"].tobytes() + obs["taco"]["lrf"].tobytes()]
    for _ in range(steps):
        if not env.agents:
            break
        actions = {a: rng.uniform(-1, 1, 3).astype(np.float32) for a in env.agents}
        obs, rewards, _, _, infos = env.step(actions)
        out += [obs[a]["lrf"].tobytes() + np.array([rewards[a]]).tobytes() for a in obs]
        out += [np.array(infos[a]["pose"]).tobytes() for a in infos]
    return out


@pytest.mark.slow
def test_same_seed_same_two_robot_episode_bit_for_bit() -> None:
    assert _rollout(3) == _rollout(3)
    assert _rollout(3) != _rollout(4)


def test_each_robot_sees_the_other_and_has_its_own_task() -> None:
    env = pico_gym.parallel_env("PicoHospital-v0", map="hospital_2019")
    obs, infos = env.reset(seed=0, options={"pico": {"cabinet_order": [0, 1]}, "taco": {"cabinet_order": [3, 2]}})
    assert infos["pico"]["task"].cabinet_order == (0, 1) and infos["taco"]["task"].cabinet_order == (3, 2)
    pico, taco = robot_env(env, "pico"), robot_env(env, "taco")
    assert pico.episode.scene is taco.episode.scene  # one world: the same walls, doors, boxes, people
    # taco's LRF sees pico's footprint: the beam towards pico reads about the distance to it
    dx, dy = pico.pose.x - taco.pose.x, pico.pose.y - taco.pose.y
    bearing = np.arctan2(dy, dx) - taco.pose.theta
    bearing = (bearing + np.pi) % (2 * np.pi) - np.pi
    if abs(bearing) < 1.9:
        beam = int(np.argmin(np.abs(taco.lrf.beam_angles - bearing)))
        assert obs["taco"]["lrf"][beam] <= np.hypot(dx, dy) + 0.05


def test_robots_driving_into_each_other_stay_apart_and_count_robot_bumps() -> None:
    env = pico_gym.parallel_env("PicoEscape-v0", collision="continue", map="escape_2018")
    obs, _ = env.reset(
        seed=0, options={"pico": {"start_pose": (1.5, 2.0, 0.0)}, "taco": {"start_pose": (2.5, 2.0, 3.14159)}}
    )
    pico, taco = robot_env(env, "pico"), robot_env(env, "taco")
    outline = pico.config.robot.outline
    for _ in range(40):  # head on, full speed
        _, _, _, _, infos = env.step({a: np.array([0.5, 0.0, 0.0], dtype=np.float32) for a in env.agents})
        placed = transform_points(taco.pose, outline)
        edges = np.hstack([placed, np.roll(placed, -1, axis=0)])
        assert footprint_clearance(pico.pose.x, pico.pose.y, pico.pose.theta, outline, edges, 0.05) > 0.0
    assert infos["pico"]["bumps_by_kind"]["robot"] + infos["taco"]["bumps_by_kind"]["robot"] >= 1


@pytest.mark.slow
def test_the_classic_agent_drives_both_robots_of_the_courses_taco_config() -> None:
    env = pico_gym.parallel_env("PicoHospital-v0", map="hospital_2021", sim_config=TACO)
    obs, infos = env.reset(seed=0)
    agents = {n: make_agent("classic", robot_env(env, n)) for n in env.possible_agents}
    for n, agent in agents.items():
        agent.reset(obs[n], infos[n])
    last = dict(infos)
    while env.agents:
        obs, _, _, _, infos = env.step({n: agents[n].act(obs[n]) for n in env.agents})
        last.update(infos)
    assert all(last[n]["is_success"] for n in ("pico", "taco"))
    assert all(last[n]["bumps_by_kind"]["robot"] == 0 for n in ("pico", "taco"))


def test_bad_two_robot_input_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match="two robots play PicoHospital-v0 and PicoEscape-v0"):
        pico_gym.parallel_env("PicoExplore-v0")
    with pytest.raises(ValueError, match="n_robots must be 1 or 2"):
        pico_gym.parallel_env("PicoHospital-v0", n_robots=3)
    env = pico_gym.parallel_env("PicoHospital-v0", map="hospital_2019")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="missing \\['taco'\\]"):
        env.step({"pico": np.zeros(3, dtype=np.float32)})


def test_compare_reports_both_robots_of_every_agent(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from pico_gym.cli import main

    out = tmp_path / "cmp"
    args = ["compare", "--robots", "2", "--env", "PicoEscape-v0", "--agents", "wall-follow,random"]
    assert main([*args, "--episodes", "1", "--seed", "0", "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "| agent | episodes | both done | pico success" in printed and "taco success" in printed
    assert "| wall-follow | 1 |" in printed and "| random | 1 |" in printed
    saved = json.loads((out / "results.json").read_text())
    assert set(saved["records"]) == {"wall-follow", "random"} and len(saved["records"]["random"]) == 1
    assert "robot-robot bump" in (out / "results.md").read_text()
