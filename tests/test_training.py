"""Training smoke tests: a few thousand PPO steps run, save, load, act, resume; configs are checked."""

import json
import pickle
import threading
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")

import pico_gym  # noqa: E402,F401
from pico_gym.agents import make_agent  # noqa: E402
from pico_gym.agents.evaluation import run_episode  # noqa: E402
from pico_gym.train.checkpoints import latest_checkpoint  # noqa: E402
from pico_gym.train.cli import DEFAULT_CONFIG  # noqa: E402
from pico_gym.train.config import TRAIN_SEED_MIN, ConfigError, load_config  # noqa: E402
from pico_gym.train.envs import EpisodeSeeds  # noqa: E402
from pico_gym.train.ppo import train  # noqa: E402

TINY = """
PicoEscape-v0:
  n_envs: 2
  n_timesteps: 2048
  policy: 'MlpPolicy'
  normalize: true
  env_wrapper:
    - pico_gym.wrappers.PicoLearningWrapper:
        n_sectors: 16
        frame_stack: 2
  n_steps: 256
  batch_size: 128
  n_epochs: 2
  policy_kwargs: "dict(net_arch=[32, 32])"
pico-gym:
  env_kwargs: {n_beams: 200, time_limit_s: 15}
  checkpoint_freq: 1024
  eval_freq: 1024
  eval_episodes: 2
"""


@pytest.fixture
def tiny_config(tmp_path):
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY)
    return load_config(path)


@pytest.mark.slow
def test_train_save_load_act_and_resume(tiny_config, tmp_path):
    run = tmp_path / "run"
    model_path = train(tiny_config, run, seed=0, progress_bar=False)
    for name in (
        "config.yaml",
        "model.zip",
        "model.json",
        "best.zip",
        "eval.csv",
        "progress.csv",
        "learning_curve.png",
    ):
        assert (run / name).is_file(), name
    assert any((run / "tb").glob("events.out.tfevents.*"))
    resolved = yaml.safe_load((run / "config.yaml").read_text())
    assert resolved["PicoEscape-v0"]["n_timesteps"] == 2048 and resolved["run"]["seed"] == 0
    assert latest_checkpoint(run)[1] == 2048
    header = (run / "progress.csv").read_text().splitlines()[0]
    assert "escape/success_rate" in header and "escape/bump_rate" in header

    env = gym.make("PicoEscape-v0", n_beams=200, time_limit_s=15)
    agent = make_agent("ppo", env, path=model_path)
    record = run_episode(env, agent, seed=5)
    assert record.time_s > 0 and record.termination_reason in ("escaped", "bump", "idle", "timeout")
    obs, info = env.reset(seed=1)
    agent.reset(obs, info)
    action = agent.act(obs)
    assert env.action_space.contains(action.astype(np.float32))

    # Resuming continues from the last checkpoint (and its VecNormalize statistics) to the new total.
    train(tiny_config, run, timesteps=3072, seed=0, progress_bar=False)
    assert latest_checkpoint(run)[1] == 3072
    assert '"timesteps": 3072' in (run / "done.json").read_text()

    # The policy carries the observation statistics it was trained with; the agent applies them.
    meta = json.loads((run / "model.json").read_text())
    with (run / "checkpoints" / "ppo_vecnormalize_3072_steps.pkl").open("rb") as f:
        stats = pickle.load(f)  # SB3's own VecNormalize save
    np.testing.assert_allclose(meta["obs_norm"]["mean"], stats.obs_rms.mean)
    np.testing.assert_allclose(meta["obs_norm"]["var"], stats.obs_rms.var)


def test_a_policy_for_another_robot_is_refused(tiny_config, tmp_path):
    model_path = train(tiny_config, tmp_path / "run", timesteps=512, progress_bar=False)
    env = gym.make("PicoEscape-v0", n_beams=10)  # 10 beams cannot give 16 sectors
    with pytest.raises(ValueError, match="n_sectors"):
        make_agent("ppo", env, path=model_path)
    with pytest.raises(FileNotFoundError, match="no PPO policy"):
        make_agent("ppo", gym.make("PicoEscape-v0"), path=tmp_path / "nothing.zip")


def test_training_seeds_are_disjoint_from_evaluation_seeds():
    env = EpisodeSeeds(gym.make("PicoEscape-v0", n_beams=10), np.random.default_rng(0))
    seeds = []
    for _ in range(5):
        env.reset(seed=3)  # an explicit seed is replaced by a training seed
        seeds.append(env.unwrapped.np_random_seed)
    assert all(s >= TRAIN_SEED_MIN for s in seeds) and len(set(seeds)) == 5


def test_train_env_variants_randomise_the_envs_of_the_vector_env(tmp_path):
    from pico_gym.train.envs import make_training_vec_env

    path = tmp_path / "variants.yaml"
    path.write_text(TINY + "  train_env_variants: [{}, {n_obstacles: 2, noise_m: 0.02}]\n")
    vec = make_training_vec_env(load_config(path), seed=0)
    configs = [env.unwrapped.config for env in vec.envs]
    assert [c.task.room.n_obstacles for c in configs] == [0, 2]
    assert [c.lrf.noise_m for c in configs] == [0.01, 0.02]
    assert all(c.lrf.n_beams == 200 for c in configs)  # env_kwargs still apply to every env
    vec.close()
    robust = load_config(Path(DEFAULT_CONFIG).with_name("ppo_escape_robust.yaml"))
    assert len(robust.pico["train_env_variants"]) == robust.zoo["n_envs"]


def test_shipped_config_loads_in_rl_zoo_layout():
    config = load_config(DEFAULT_CONFIG)
    assert config.env_id == "PicoEscape-v0"
    assert config.learning.n_sectors > 0
    raw = yaml.safe_load(Path(DEFAULT_CONFIG).read_text())
    block = raw["PicoEscape-v0"]
    assert {"n_envs", "n_timesteps", "policy", "env_wrapper"} <= set(block)
    assert isinstance(block["policy_kwargs"], str)  # rl-zoo3 evaluates it as Python


@pytest.mark.parametrize(
    "text,match",
    [
        ("Other-v0: {}\n", "'Other-v0' is not a registered env id"),
        ("PicoEscape-v0: {n_envs: 1, n_timesteps: 1, policy: MlpPolicy}\n", "env_wrapper is missing"),
        (TINY + "  surprise: 1\n", "unknown key"),
        ("PicoEscape-v0: [\n", "not valid YAML"),
        (TINY + "  train_env_variants: {n_obstacles: 2}\n", "train_env_variants must be a list"),
    ],
)
def test_bad_configs_name_file_and_key(tmp_path, text, match):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=match) as err:
        load_config(path)
    assert "bad.yaml" in str(err.value)


def test_behaviour_cloning_warm_start(tmp_path):
    path = tmp_path / "bc.yaml"
    path.write_text(TINY.replace("  eval_episodes: 2\n", "  eval_episodes: 1\n  bc_episodes: 2\n  bc_epochs: 3\n"))
    config = load_config(path)
    train(config, tmp_path / "run", timesteps=512, progress_bar=False)
    report = json.loads((tmp_path / "run" / "behaviour_cloning.json").read_text())
    assert report["samples"] > 50 and len(report["mse_per_epoch"]) == 3
    assert report["mse_per_epoch"][-1] < report["mse_per_epoch"][0]


def test_a_stop_file_ends_a_run_cleanly(tiny_config, tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "STOP").touch()  # a STOP left from before is removed when a run (re)starts

    def stop_once_learning():
        while not (run / "checkpoints" / "ppo_1024_steps.zip").exists():
            time.sleep(0.05)
        (run / "STOP").touch()

    threading.Thread(target=stop_once_learning, daemon=True).start()
    train(tiny_config, run, timesteps=100_000, progress_bar=False)
    steps = json.loads((run / "done.json").read_text())["timesteps"]
    assert 1024 <= steps < 100_000 and (run / "model.zip").is_file()


@pytest.mark.slow
def test_init_from_another_runs_checkpoint(tiny_config, tmp_path):
    train(tiny_config, tmp_path / "a", timesteps=1024, progress_bar=False)
    checkpoint = tmp_path / "a" / "checkpoints" / "ppo_1024_steps.zip"
    # A fine-tune: a lower learning rate and a proximity penalty, which the new run must use.
    fine = tmp_path / "fine.yaml"
    fine.write_text(
        TINY.replace("  n_epochs: 2\n", "  n_epochs: 2\n  learning_rate: !!float 3e-5\n").replace(
            "time_limit_s: 15}", "time_limit_s: 15, rewards: {proximity: 1.0}}"
        )
    )
    train(load_config(fine), tmp_path / "b", timesteps=2048, progress_bar=False, init_from=checkpoint)
    assert json.loads((tmp_path / "b" / "init_from.json").read_text())["timesteps"] == 1024
    assert json.loads((tmp_path / "b" / "done.json").read_text())["timesteps"] == 2048
    from stable_baselines3 import PPO

    tuned = PPO.load(tmp_path / "b" / "checkpoints" / "ppo_2048_steps.zip", device="cpu")
    assert tuned.learning_rate == pytest.approx(3e-5)
    assert "proximity: 1.0" in (tmp_path / "b" / "config.yaml").read_text()


@pytest.mark.slow
def test_init_from_a_policy_zip_carries_its_own_step_count(tiny_config, tmp_path):
    """A policy zip without the count in its name (a run's model.zip, a shipped policy) carries
    on from the count it holds; asking for no more steps than that is refused, not a silent no-op."""
    train(tiny_config, tmp_path / "a", timesteps=1024, progress_bar=False)
    policy = tmp_path / "shipped.zip"
    policy.write_bytes((tmp_path / "a" / "model.zip").read_bytes())
    with pytest.raises(ConfigError, match=r"has 1,024 steps already .*--timesteps 1,024 trains nothing"):
        train(tiny_config, tmp_path / "b", timesteps=1024, progress_bar=False, init_from=policy)
    assert not (tmp_path / "b").exists()  # refused before anything is written
    train(tiny_config, tmp_path / "c", timesteps=2048, progress_bar=False, init_from=policy)
    assert json.loads((tmp_path / "c" / "init_from.json").read_text())["timesteps"] == 1024
    assert json.loads((tmp_path / "c" / "done.json").read_text())["timesteps"] == 2048
    not_a_policy = tmp_path / "notes.zip"
    not_a_policy.write_bytes(b"PK not a zip")
    with pytest.raises(ConfigError, match="not a stable-baselines3 policy zip"):
        train(tiny_config, tmp_path / "d", timesteps=2048, progress_bar=False, init_from=not_a_policy)


@pytest.mark.slow
def test_a_run_killed_while_saving_resumes_from_the_last_whole_checkpoint(tiny_config, tmp_path, capsys):
    run = tmp_path / "run"
    train(tiny_config, run, timesteps=1024, seed=0, progress_bar=False)
    ckpt = run / "checkpoints"
    assert latest_checkpoint(run, needs_stats=True)[1] == 1024
    assert not list(ckpt.glob(".*"))  # no temporary files left behind
    # A kill while writing the next checkpoint: a partial zip, and an empty one after it.
    (ckpt / "ppo_2048_steps.zip").write_bytes((ckpt / "ppo_1024_steps.zip").read_bytes()[:3000])
    (ckpt / "ppo_3072_steps.zip").write_bytes(b"")
    assert latest_checkpoint(run) == (ckpt / "ppo_1024_steps.zip", 1024)
    assert "skipping ppo_3072_steps.zip" in capsys.readouterr().out
    # A checkpoint whose VecNormalize statistics are cut off is skipped too (not fresh statistics).
    (ckpt / "ppo_2048_steps.zip").write_bytes((ckpt / "ppo_1024_steps.zip").read_bytes())
    (ckpt / "ppo_vecnormalize_2048_steps.pkl").write_bytes(b"\x80\x04")
    assert latest_checkpoint(run, needs_stats=True)[1] == 1024
    (ckpt / "ppo_2048_steps.zip").unlink()
    (ckpt / "ppo_vecnormalize_2048_steps.pkl").unlink()
    (ckpt / "ppo_3072_steps.zip").unlink()
    train(tiny_config, run, timesteps=2048, seed=0, progress_bar=False)
    out = capsys.readouterr().out
    assert "resuming" in out and "ppo_1024_steps.zip" in out
    assert latest_checkpoint(run)[1] == 2048


def test_resuming_with_another_model_config_is_refused_naming_the_keys(tiny_config, tmp_path):
    run = tmp_path / "run"
    train(tiny_config, run, timesteps=1024, seed=0, progress_bar=False)
    other = tmp_path / "other.yaml"
    other.write_text(TINY.replace("net_arch=[32, 32]", "net_arch=[64, 64]").replace("n_beams: 200", "n_beams: 100"))
    with pytest.raises(ConfigError, match="resuming .* with other policy_kwargs, pico-gym.env_kwargs .*--init-from"):
        train(load_config(other), run, timesteps=2048, seed=0, progress_bar=False)


@pytest.mark.slow
def test_progress_and_eval_records_continue_across_a_resume(tiny_config, tmp_path):
    import csv

    run = tmp_path / "run"
    train(tiny_config, run, timesteps=1024, seed=0, progress_bar=False)
    first = list(csv.DictReader((run / "progress.csv").open()))
    first_evals = list(csv.DictReader((run / "eval.csv").open()))
    assert first and first_evals
    # The session after a kill: its rows past the checkpoint it resumes from are redone.
    train(tiny_config, run, timesteps=2048, seed=0, progress_bar=False)
    rows = list(csv.DictReader((run / "progress.csv").open()))
    steps = [int(float(r["time/total_timesteps"])) for r in rows]
    elapsed = [float(r["time/time_elapsed"]) for r in rows]
    assert len(rows) > len(first) and rows[: len(first)] == first  # the first session's rows kept
    assert steps == sorted(steps) and len(set(steps)) == len(steps) and steps[-1] == 2048
    assert elapsed == sorted(elapsed)  # the clock continues, it does not restart
    assert elapsed[len(first)] >= elapsed[len(first) - 1]
    evals = list(csv.DictReader((run / "eval.csv").open()))
    assert evals[: len(first_evals)] == first_evals and len(evals) > len(first_evals)
    clocks = [float(r["wall_clock_s"]) for r in evals]
    assert clocks == sorted(clocks)
    eval_steps = [int(r["timesteps"]) for r in evals]
    assert eval_steps == sorted(eval_steps) and len(set(eval_steps)) == len(eval_steps)
    done = json.loads((run / "done.json").read_text())
    assert done["wall_clock_s"] >= clocks[-1] - 1.0


def test_the_hospital_point_goal_config_trains_evaluates_and_acts(tmp_path):
    """The end-to-end hospital config: its env block is found without naming it, the eval and
    demonstration envs get the privileged point goal, and the result plays as ppo-pointgoal."""
    shipped = Path(DEFAULT_CONFIG).with_name("ppo_hospital_pointgoal.yaml")
    config = load_config(shipped)
    assert config.env_id == "PicoHospital-v0" and config.learning.point_goal
    config.zoo.update(n_envs=2, n_steps=128, batch_size=128, n_epochs=1, policy_kwargs="dict(net_arch=[32, 32])")
    config.pico.update(bc_episodes=1, bc_epochs=1, eval_freq=256, eval_episodes=1, checkpoint_freq=256)
    config.pico["env_kwargs"] = {"n_cabinets": 1, "time_limit_s": 10}
    path = train(config, tmp_path / "run", timesteps=512, progress_bar=False)
    env = gym.make("PicoHospital-v0", n_cabinets=1, time_limit_s=10)
    agent = make_agent("ppo-pointgoal", env, path=path)
    record = run_episode(env, agent, 3, "ppo-pointgoal")
    assert record.time_s > 0
    with pytest.raises(ValueError, match="PicoHospital-v0 only"):
        make_agent("ppo-pointgoal", gym.make("PicoEscape-v0"), path=path)
    # shipping it writes the arrays, the metadata and a card that says what it sees
    from dataclasses import replace

    from pico_gym.train.ship import TARGETS, ship

    target = replace(
        TARGETS["hospital-pointgoal"], policy=tmp_path / "models" / "pg.npz", card=tmp_path / "models" / "CARD.md"
    )
    (tmp_path / "models").mkdir()
    ship(path, episodes=2, seed=5, target=target)
    card = target.card.read_text()
    assert "PRIVILEGED" in card and "ppo-pointgoal" in card and "success >= 80 %" in card
    shipped = make_agent("ppo-pointgoal", env, path=target.policy)
    assert run_episode(env, shipped, 3, "ppo-pointgoal").time_s == record.time_s


def test_a_config_with_two_env_blocks_is_refused(tmp_path):
    path = tmp_path / "two.yaml"
    path.write_text(TINY + TINY.split("pico-gym:")[0].replace("PicoEscape-v0", "PicoHospital-v0"))
    with pytest.raises(ConfigError, match="expected one env block"):
        load_config(path)


@pytest.mark.slow
def test_the_shipped_point_goal_policy_plays_shielded_and_its_absence_is_named(monkeypatch):
    import pico_gym.agents.ppo as ppo_module

    env = gym.make("PicoHospital-v0", n_cabinets=2, arrival="announce", false_announcement="terminate")
    agent = make_agent("ppo-pointgoal", env)  # the shipped arrays: numpy only
    assert agent.shield and agent.encoder.config.trail_sectors == 16
    assert run_episode(env, agent, 67000, "ppo-pointgoal").time_s > 0
    monkeypatch.setattr(
        ppo_module, "SHIPPED_POINTGOAL_POLICY", ppo_module.SHIPPED_POINTGOAL_POLICY.with_name("none.npz")
    )
    with pytest.raises(FileNotFoundError, match="no ppo-pointgoal policy is shipped"):
        make_agent("ppo-pointgoal", gym.make("PicoHospital-v0"))


def test_demonstrations_cover_the_training_variants(tmp_path, monkeypatch):
    """The teacher's episodes are spread over `train_env_variants` as the training envs are."""
    import pico_gym.train.cloning as ppo

    path = tmp_path / "c.yaml"
    path.write_text(TINY + "  train_env_variants: [{}, {n_obstacles: 2}]\n")
    made = []
    real = ppo.make_plain_env

    def spy(config, **kwargs):
        env = real(config, **kwargs)
        made.append(kwargs.get("n_obstacles", 0))
        return env

    monkeypatch.setattr(ppo, "make_plain_env", spy)
    xs, ys, report = ppo.collect_demonstrations(load_config(path), 4)
    assert made == [0, 2] and len(xs) == len(ys) > 0 and 0.0 <= report["teacher_success"] <= 1.0


def test_ship_counts_a_checkpoint_between_evaluations_and_a_start_from_a_shipped_policy(tmp_path):
    """The card's wall clock for a checkpoint between two evaluations is interpolated; a run
    started (--init-from) from a policy that is not a run directory adds nothing and is named."""
    from pico_gym.train.ship import history, wall_clock

    run = tmp_path / "run"
    run.mkdir()
    (run / "config.yaml").write_text(yaml.safe_dump({"run": {"command": "pico-gym train --config x.yaml"}}))
    (run / "eval.csv").write_text("timesteps,wall_clock_s\n5500000,60.0\n6000000,180.0\n")
    (run / "init_from.json").write_text(json.dumps({"checkpoint": "agents/models/ppo_escape.zip", "timesteps": 0}))
    assert wall_clock(run, 5750000) == pytest.approx(120.0)
    assert wall_clock(run, 6000000) == pytest.approx(180.0)
    assert wall_clock(run, 7000000) is None  # after the last evaluation: unknown
    (run / "done.json").write_text(json.dumps({"timesteps": 7000000, "wall_clock_s": 420.0}))
    assert wall_clock(run, 6500000) == pytest.approx(300.0)  # ... unless the run's end says
    lines = history(run)
    assert "agents/models/ppo_escape.zip" in lines[0] and "not a run directory" in lines[0]
    assert lines[-1] == "`pico-gym train --config x.yaml`"


def test_the_training_vec_env_returns_what_dummy_vec_env_returns(tiny_config):
    """make_training_vec_env's in-process VecEnv skips DummyVecEnv's deep copy of the infos, nothing else:
    observations, rewards, dones and infos (terminal observations included) are DummyVecEnv's."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    from pico_gym.train.envs import make_training_env, make_training_vec_env

    ours = make_training_vec_env(tiny_config, seed=4)
    theirs = DummyVecEnv(
        [lambda i=i: make_training_env(tiny_config, np.random.default_rng([4, i, 0]), i) for i in range(2)]
    )
    assert np.array_equal(ours.reset(), theirs.reset())
    rng = np.random.default_rng(0)
    dones = 0
    for _ in range(400):
        actions = rng.uniform(-1.0, 1.0, size=(2, 3)).astype(np.float32)
        (o1, r1, d1, i1), (o2, r2, d2, i2) = ours.step(actions), theirs.step(actions)
        assert np.array_equal(o1, o2) and np.array_equal(r1, r2) and np.array_equal(d1, d2)
        for a, b in zip(i1, i2, strict=True):
            assert a.keys() == b.keys()
            if "terminal_observation" in a:
                assert np.array_equal(a["terminal_observation"], b["terminal_observation"])
            assert a["sim_time"] == b["sim_time"] and a["termination_reason"] == b["termination_reason"]
        dones += int(d1.sum())
    assert dones >= 2
    ours.close()
    theirs.close()


@pytest.mark.slow
def test_bench_train_prints_its_rows(capsys):
    from pico_gym.cli import main

    assert main(["bench-train", "--rounds", "1", "--rollouts", "1"]) == 0
    out = capsys.readouterr().out
    for row in ("toy env (206-float Box observation)", "x the toy", "leaves", "the wrapper tax", "x DummyVecEnv"):
        assert row in out


def _announce_config(tmp_path):
    config = load_config(Path(DEFAULT_CONFIG).with_name("ppo_hospital_pointgoal_announce.yaml"))
    config.zoo.update(n_envs=2, n_steps=128, batch_size=128, n_epochs=1, policy_kwargs="dict(net_arch=[32, 32])")
    config.pico.update(bc_episodes=1, bc_epochs=1, eval_freq=256, eval_episodes=1, checkpoint_freq=256)
    return config


def test_the_announcing_point_goal_policy_plays_the_announce_mode_only(tmp_path):
    """The explicit-STOP variant: its policy has a fourth output, acts in arrival='announce'
    envs, and a dwell env (three action components) is refused with the reason."""
    config = _announce_config(tmp_path)
    assert config.env_id == "PicoHospital-v0" and config.pico["bc_announce"] == "arrival"
    kwargs = {"n_cabinets": 1, "time_limit_s": 10, "arrival": "announce", "false_announcement": "terminate"}
    config.pico["env_kwargs"] = kwargs
    path = train(config, tmp_path / "run", timesteps=512, progress_bar=False)
    env = gym.make("PicoHospital-v0", **kwargs)
    agent = make_agent("ppo-pointgoal", env, path=path)
    obs, info = env.reset(seed=3)
    agent.reset(obs, info)
    action = agent.act(obs)
    assert action.shape == (4,) and env.action_space.contains(action)
    assert run_episode(env, agent, 3, "ppo-pointgoal").time_s > 0
    with pytest.raises(ValueError, match="4 action outputs .*arrival='announce'"):
        make_agent("ppo-pointgoal", gym.make("PicoHospital-v0", n_cabinets=1), path=path)


def test_behaviour_cloning_labels_the_announcement_where_the_robot_stands(tmp_path):
    """bc_announce 'arrival': +1 on the steps in the next square facing its cabinet, -1 elsewhere."""
    from pico_gym.train.cloning import ANNOUNCE_LABEL_MARGIN, collect_demonstrations

    config = _announce_config(tmp_path)
    config.pico["env_kwargs"] = {"n_cabinets": 1, "arrival": "announce"}
    config.pico["train_env_kwargs"] = {}
    xs, ys, report = collect_demonstrations(config, 2)
    assert report["teacher_success"] == 1.0 and ys.shape == (len(xs), 4)
    assert set(np.unique(ys[:, 3])) == {-1.0, 1.0}  # both labels occur; nothing in between
    assert 0 < ANNOUNCE_LABEL_MARGIN <= 1


@pytest.mark.parametrize(
    "extra,match",
    [
        ("  bc_announce: sometimes\n", r"bc_announce must be one of \('teacher', 'arrival'\), got 'sometimes'"),
        ("  bc_announce: arrival\n", "needs arrival: announce"),
    ],
)
def test_bad_announcement_labels_are_refused(tmp_path, extra, match):
    path = tmp_path / "bad.yaml"
    path.write_text(TINY + extra)
    with pytest.raises(ConfigError, match=match):
        load_config(path)


def test_the_vector_training_env_hands_sb3_what_the_dummy_path_does(tiny_config):
    """vec_env: vector (one vector env, the batched learning encoder) against vec_env: dummy
    (wrapped single envs): the same observations, rewards, dones, terminal observations and final
    infos, bit for bit, over episodes that end by bumps and time limits."""
    import copy

    from pico_gym.train.envs import make_training_vec_env

    tiny_config.pico["env_kwargs"] = {"n_beams": 200, "time_limit_s": 4}
    vector = copy.deepcopy(tiny_config)
    vector.pico["vec_env"] = "vector"
    ours, theirs = make_training_vec_env(vector, seed=4), make_training_vec_env(tiny_config, seed=4)
    assert ours.observation_space == theirs.observation_space and ours.action_space == theirs.action_space
    assert np.array_equal(ours.reset(), theirs.reset())
    rng = np.random.default_rng(0)
    reasons = set()
    for _ in range(300):
        actions = rng.uniform(-1.0, 1.0, size=(2, 3)).astype(np.float32)
        (o1, r1, d1, i1), (o2, r2, d2, i2) = ours.step(actions), theirs.step(actions)
        assert np.array_equal(o1, o2) and np.array_equal(r1, r2) and np.array_equal(d1, d2)
        assert r1.dtype == r2.dtype and o1.dtype == o2.dtype
        for a, b, done in zip(i1, i2, d1, strict=True):
            if not done:
                continue
            assert np.array_equal(a["terminal_observation"], b["terminal_observation"])
            for key in ("sim_time", "termination_reason", "is_success", "bumps", "pose", "TimeLimit.truncated"):
                assert np.array_equal(a[key], b[key]), key
            assert a["episode"]["l"] == b["episode"]["l"]  # (VecMonitor sums returns in float32)
            assert a["episode"]["r"] == pytest.approx(b["episode"]["r"], abs=1e-4)
            reasons.add(a["termination_reason"])
    assert {"bump", "timeout"} <= reasons
    assert ours.venv.venv.batch_steps >= 0.6 * 2 * 300  # the compiled escape batch took the steps
    ours.close()
    theirs.close()


def test_training_with_the_vector_env_learns_what_the_dummy_path_learns(tiny_config, tmp_path):
    """Same seed, same rollouts: the two paths end with the same policy weights."""
    import copy

    vector = copy.deepcopy(tiny_config)
    vector.pico["vec_env"] = "vector"
    tiny_config.pico.update(eval_freq=10**9, checkpoint_freq=10**9)
    vector.pico.update(eval_freq=10**9, checkpoint_freq=10**9)
    a = np.load(Path(train(tiny_config, tmp_path / "dummy", timesteps=1024, progress_bar=False)).with_suffix(".npz"))
    b = np.load(Path(train(vector, tmp_path / "vector", timesteps=1024, progress_bar=False)).with_suffix(".npz"))
    assert sorted(a.files) == sorted(b.files)
    for name in a.files:
        assert np.array_equal(a[name], b[name]), name


@pytest.mark.parametrize(
    "extra,wrapper,match",
    [
        ("  vec_env: vectorised\n", "", "vec_env must be one of"),
        (
            "  vec_env: vector\n  train_env_variants: [{n_obstacles: 1}]\n",
            "",
            "1 train_env_variants: use vec_env: dummy",
        ),
        ("  vec_env: vector\n", "        trail_sectors: 8\n", "trail_sectors: use vec_env: dummy"),
    ],
)
def test_vector_training_configs_it_cannot_run_are_refused(tmp_path, extra, wrapper, match):
    path = tmp_path / "bad.yaml"
    path.write_text(TINY.replace("        frame_stack: 2\n", "        frame_stack: 2\n" + wrapper) + extra)
    with pytest.raises(ConfigError, match=match):
        load_config(path)


def test_every_shipped_config_loads():
    configs = sorted(Path(DEFAULT_CONFIG).parent.glob("*.yaml"))
    assert len(configs) >= 5
    for path in configs:
        load_config(path)  # raises ConfigError naming the file and key


def test_the_trail_point_goal_policy_acts_with_its_trail(tmp_path):
    """The point goal with an odometry trail: trained, it plays as ppo-pointgoal, whose encoder
    keeps the same trail (its input has the trail's 16 values per frame)."""
    config = load_config(Path(DEFAULT_CONFIG).with_name("ppo_hospital_pointgoal_trail.yaml"))
    assert config.learning.trail_sectors == 16 and config.learning.point_goal
    config.zoo.update(n_envs=2, n_steps=128, batch_size=128, n_epochs=1, policy_kwargs="dict(net_arch=[32, 32])")
    config.pico.update(bc_episodes=1, bc_epochs=1, eval_freq=256, eval_episodes=1, checkpoint_freq=256)
    kwargs = {"n_cabinets": 1, "time_limit_s": 10, "arrival": "announce", "false_announcement": "terminate"}
    config.pico["env_kwargs"] = kwargs
    path = train(config, tmp_path / "run", timesteps=512, progress_bar=False)
    env = gym.make("PicoHospital-v0", **kwargs)
    agent = make_agent("ppo-pointgoal", env, path=path)
    assert agent.encoder.config.trail_sectors == 16 and not agent.shield
    assert run_episode(env, agent, 3, "ppo-pointgoal").time_s > 0
    # Shipped shielded: its agent is shielded unless told otherwise, and its card says so.
    from dataclasses import replace

    from pico_gym.train.ship import TARGETS, ship

    models = tmp_path / "models"
    models.mkdir()
    target = replace(TARGETS["hospital-pointgoal"], policy=models / "pg.npz", card=models / "CARD.md")
    ship(path, episodes=1, seed=5, target=target, shield=True)
    assert "Shielded" in target.card.read_text()
    assert make_agent("ppo-pointgoal", env, path=target.policy).shield
    assert not make_agent("ppo-pointgoal", env, path=target.policy, shield=False).shield
    with pytest.raises(ValueError, match="shield"):
        make_agent("ppo-pointgoal", env, path=target.policy, shield="yes")


MIRRORED = (
    TINY.replace("policy: 'MlpPolicy'", "policy: 'MirrorMlpPolicy'")
    .replace("  normalize: true\n", "")
    .replace(
        "        frame_stack: 2\n", "        frame_stack: 2\n        memory_sectors: 8\n        trail_sectors: 4\n"
    )
    .replace("  eval_episodes: 2\n", "  eval_episodes: 1\n  bc_episodes: 2\n  bc_epochs: 2\n")
)


def test_a_mirrored_policy_trains_exports_and_plays_mirror_symmetric(tmp_path):
    """MirrorMlpPolicy: the SB3 policy's mean for a reflected input is the reflected mean, the
    exported numpy actor computes the same (and keeps the reflection through its file), and
    behaviour cloning saw the reflected demonstrations too."""
    import torch

    from pico_gym.agents.mlp import MlpActor, export_actor
    from pico_gym.wrappers import MIRROR_ACTION_SIGN, mirror_maps

    path = tmp_path / "mirror.yaml"
    path.write_text(MIRRORED)
    config = load_config(path)
    model_path = train(config, tmp_path / "run", timesteps=512, progress_bar=False)
    report = json.loads((tmp_path / "run" / "behaviour_cloning.json").read_text())
    steps = report["samples"]
    assert steps > 50
    from pico_gym.train.mirror import mirrored_demonstrations

    xs = np.random.default_rng(1).uniform(0.0, 1.0, (4, 2 * (16 + 8 + 4 + 3))).astype(np.float32)
    ys = np.random.default_rng(2).uniform(-1.0, 1.0, (4, 3)).astype(np.float32)
    both_x, both_y = mirrored_demonstrations(xs, ys, config.learning)
    index, sign = mirror_maps(config.learning)
    assert np.array_equal(both_x[:4], xs) and np.array_equal(both_x[4:], xs[:, index] * sign)
    assert np.array_equal(both_y[4:], ys * np.array([1.0, -1.0, -1.0], np.float32))
    from stable_baselines3 import PPO

    model = PPO.load(model_path, device="cpu")
    index, sign = mirror_maps(config.learning)
    x = np.random.default_rng(0).uniform(0.0, 1.0, (5, len(index))).astype(np.float32)
    with torch.no_grad():
        mean = model.policy.mean_actions(torch.as_tensor(x)).numpy()
        reflected = model.policy.mean_actions(torch.as_tensor(x[:, index] * sign)).numpy()
        plain = model.policy.action_net(
            model.policy.mlp_extractor.forward_actor(model.policy.extract_features(torch.as_tensor(x)))
        ).numpy()
    assert reflected == pytest.approx(mean * MIRROR_ACTION_SIGN[:3], abs=1e-6)
    assert not np.allclose(plain, mean, atol=1e-4)  # the symmetrisation is on: the raw net is not symmetric
    actor = export_actor(model)
    assert np.allclose([actor.mean_action(row) for row in x], mean, atol=1e-5)
    again = MlpActor.load(actor.save(tmp_path / "actor.npz"))
    assert np.array_equal(again.mirror_index, actor.mirror_index)
    assert np.allclose([again.mean_action(row) for row in x], mean, atol=1e-5)
    agent = make_agent("ppo", gym.make("PicoEscape-v0", n_beams=200), path=str(model_path.with_suffix(".npz")))
    assert agent.actor.mirror_index is not None


def test_mirrored_policy_configs_it_cannot_reflect_are_refused(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text(MIRRORED.replace("  n_steps: 256\n", "  normalize: true\n  n_steps: 256\n"))
    with pytest.raises(ConfigError, match="normalize"):
        load_config(path)
    # A point goal with nothing to fill it: the wrapper its source needs is named.
    path.write_text(
        MIRRORED.replace("        trail_sectors: 4\n", "        trail_sectors: 4\n        point_goal: true\n")
    )
    with pytest.raises(ConfigError, match="PrivilegedPointGoal"):
        load_config(path)
    path.write_text(
        MIRRORED.replace("        trail_sectors: 4\n", "        trail_sectors: 4\n        point_goal: true\n").replace(
            "pico-gym:\n", "pico-gym:\n  point_goal_source: exit\n"
        )
    )
    with pytest.raises(ConfigError, match="ExitGoalObservation"):
        load_config(path)
    path.write_text(MIRRORED.replace("pico-gym:\n", "pico-gym:\n  point_goal_source: oracle\n"))
    with pytest.raises(ConfigError, match="point_goal_source"):
        load_config(path)


class _Recorder(gym.Wrapper):
    """Records the actions the env under it is stepped with."""

    def __init__(self, env):
        super().__init__(env)
        self.actions = []

    def step(self, action):
        self.actions.append(np.array(action))
        return self.env.step(action)


def test_shielded_actions_step_the_env_with_what_the_shielded_agent_plays():
    """The training env steps the twist `PpoAgent(shield=True)` would play for the same command on
    the same scan (a command into the wall is cut, one into open space is not), and a fourth
    component (the announcement) passes unchanged."""
    from pico_gym.agents.base import RobotSpec
    from pico_gym.agents.shield import ScanShield
    from pico_gym.train.shielded import ShieldedActions

    env = gym.make("PicoEscape-v0")
    recorder = _Recorder(env)
    shielded = ShieldedActions(recorder)
    shield = ScanShield(RobotSpec.of(env))
    obs, _ = shielded.reset(seed=3)
    rng = np.random.default_rng(0)
    low, high = env.action_space.low, env.action_space.high
    cut = 0
    for _ in range(200):
        command = np.array([high[0], rng.uniform(low[1], high[1]), rng.uniform(low[2], high[2]) / 4], np.float32)
        expected = shield(obs["lrf"], command).astype(np.float32)
        obs, _, terminated, truncated, _ = shielded.step(command)
        assert np.array_equal(recorder.actions[-1], expected)
        cut += not np.array_equal(expected, command)
        if terminated or truncated:
            obs, _ = shielded.reset()
    assert 0 < cut < 200  # the filter acted on some commands and let others through

    hospital = gym.make("PicoHospital-v0", arrival="announce")
    recorder = _Recorder(hospital)
    shielded = ShieldedActions(recorder)
    shielded.reset(seed=0)
    shielded.step(np.array([0.1, 0.0, 0.2, 0.7], np.float32))
    assert recorder.actions[-1].shape == (4,) and recorder.actions[-1][3] == np.float32(0.7)


def test_shielded_actions_after_the_learning_wrapper_are_refused(tmp_path):
    path = tmp_path / "shielded.yaml"
    after = "        frame_stack: 2\n    - pico_gym.train.shielded.ShieldedActions\n"
    path.write_text(TINY.replace("        frame_stack: 2\n", after))
    config = load_config(path)
    from pico_gym.train.envs import make_training_env

    with pytest.raises(ValueError, match="list it before PicoLearningWrapper"):
        make_training_env(config, np.random.default_rng(0))


def test_a_config_with_shielded_actions_trains(tmp_path):
    path = tmp_path / "shielded.yaml"
    path.write_text(TINY.replace("  env_wrapper:\n", "  env_wrapper:\n    - pico_gym.train.shielded.ShieldedActions\n"))
    config = load_config(path)
    model_path = train(config, tmp_path / "run", seed=0, timesteps=1024, progress_bar=False)
    assert model_path.exists()


@pytest.mark.slow
def test_a_resume_never_unpickles_a_file_it_did_not_write(tiny_config, tmp_path, capsys):
    """A VecNormalize pickle or a checkpoint zip put into a run folder by anyone else is refused
    on a resume without being loaded (pickles run code); the trainer's own files are in the
    folder's manifest with their sha256."""
    import pickle

    run = tmp_path / "run"
    train(tiny_config, run, timesteps=1024, seed=0, progress_bar=False)
    ckpt = run / "checkpoints"
    assert latest_checkpoint(run, needs_stats=True)[1] == 1024
    marker = tmp_path / "ran"

    class Evil:
        def __reduce__(self):
            return (open, (str(marker), "w"))

    # A newer checkpoint planted with a pickle that would run code when loaded.
    (ckpt / "ppo_2048_steps.zip").write_bytes((ckpt / "ppo_1024_steps.zip").read_bytes())
    (ckpt / "ppo_vecnormalize_2048_steps.pkl").write_bytes(pickle.dumps(Evil()))
    assert latest_checkpoint(run, needs_stats=True) == (ckpt / "ppo_1024_steps.zip", 1024)
    assert "not written by this run" in capsys.readouterr().out
    # The trainer's own pickle, replaced: refused the same way.
    (ckpt / "ppo_vecnormalize_1024_steps.pkl").write_bytes(pickle.dumps(Evil()))
    assert latest_checkpoint(run, needs_stats=True) is None
    assert not marker.exists()
