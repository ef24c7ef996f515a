"""The shipped PPO policy loads and reproduces its model card's check episodes."""

import json

import gymnasium as gym
import pytest

pytest.importorskip("stable_baselines3")

import pico_gym  # noqa: E402,F401
from pico_gym.agents import make_agent  # noqa: E402
from pico_gym.agents.evaluation import run_episode  # noqa: E402
from pico_gym.agents.ppo import SHIPPED_MODEL, policy_metadata_path  # noqa: E402


def test_shipped_model_is_small_and_documented():
    assert SHIPPED_MODEL.is_file(), "the PPO agent's policy is not shipped"
    assert SHIPPED_MODEL.stat().st_size < 5e6
    card = (SHIPPED_MODEL.parent / "MODEL_CARD.md").read_text()
    meta = json.loads(policy_metadata_path(SHIPPED_MODEL).read_text())
    generated = meta["evaluation"]["generated"]
    assert f"{100 * generated['success_rate']:.1f} %" in card
    assert "pico-gym train" in card


@pytest.mark.slow
def test_shipped_model_reproduces_its_card():
    meta = json.loads(policy_metadata_path(SHIPPED_MODEL).read_text())
    check = meta["check"]
    env = gym.make("PicoEscape-v0", **check.get("env_kwargs", meta.get("env_kwargs") or {}))
    agent = make_agent("ppo", env)
    records = [run_episode(env, agent, seed, "ppo") for seed in check["seeds"]]
    successes = sum(r.success for r in records)
    # Same seeds, same episodes; the tolerance covers float differences of other CPUs/torch builds.
    assert abs(successes - sum(check["success"])) <= max(1, len(records) // 10)
    assert abs(sum(r.bumps > 0 for r in records) - sum(b > 0 for b in check["bumps"])) <= max(1, len(records) // 10)


@pytest.mark.slow
def test_the_shipped_hybrid_policy_reproduces_its_card():
    from pico_gym.agents.hybrid import SHIPPED_HYBRID_POLICY

    card = (SHIPPED_HYBRID_POLICY.parent / "HOSPITAL_HYBRID_CARD.md").read_text()
    meta = json.loads(policy_metadata_path(SHIPPED_HYBRID_POLICY).read_text())
    assert SHIPPED_HYBRID_POLICY.stat().st_size < 1e6
    assert f"{100 * meta['evaluation']['generated']['success_rate']:.1f} %" in card
    check = meta["check"]
    env = gym.make("PicoHospital-v0", **check.get("env_kwargs", meta.get("env_kwargs") or {}))
    agent = make_agent("hybrid", env)
    records = [run_episode(env, agent, seed, "hybrid") for seed in check["seeds"]]
    assert abs(sum(r.success for r in records) - sum(check["success"])) <= max(1, len(records) // 10)
    assert abs(sum(r.bumps > 0 for r in records) - sum(b > 0 for b in check["bumps"])) <= max(1, len(records) // 10)
