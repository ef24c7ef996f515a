"""Benchmarks as Ray tasks: same seeds, same records as the local process pool (needs the ray extra;
CI runs it in the RLlib venv)."""

from __future__ import annotations

import dataclasses

import pytest

ray = pytest.importorskip("ray")

from pico_gym.agents.evaluation import run_episodes  # noqa: E402


def test_episodes_on_a_local_ray_instance_match_the_local_pool() -> None:
    seeds = range(1000, 1006)
    local = run_episodes("classic", seeds, {}, workers=1)
    try:
        remote = run_episodes("classic", seeds, {}, ray_address="local")
    finally:
        ray.shutdown()

    def strip(records: list) -> list:
        return [dataclasses.replace(r, act_ms=0.0) for r in records]

    assert strip(remote) == strip(local)
    assert [r.seed for r in remote] == list(seeds)
